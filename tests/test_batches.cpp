// The brute-force renderer's batches (many_light.h): a batch stopped
// anywhere changes nothing, so rendering it again gives the same images as
// an uninterrupted render, bit for bit, whatever the thread count (batch
// buffers are reused from batch to batch, films are merged and read in
// parallel).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <thread>

#include "core/many_light.h"
#include "core/parallel.h"
#include "support.h"

using namespace vsl;
using namespace vsl::test;

namespace {

bool sameBits(const Image& a, const Image& b) {
  return a.width == b.width && a.height == b.height && a.rgb.size() == b.rgb.size() &&
         std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0;
}

}  // namespace

TEST(ManyLightBatches, StoppedBatchesRenderedAgainMatchAnUninterruptedRender) {
  Loaded l = loadAsset("cornell-glossy", 40);
  ManyLightSettings s;
  s.lights = 400;
  s.seed = 3;
  s.width = l.width;
  s.height = l.height;
  s.batches = 5;
  s.directSamples = 8;
  ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);

  // One thread, never stopped: the reference order of every sum.
  setThreadCount(1);
  ManyLightRenderer serial(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
  for (int b = 0; b < serial.batchCount(); ++b) ASSERT_TRUE(serial.renderBatch(b));
  const ManyLightImages want = serial.images();
  setThreadCount(0);

  // Every thread; each batch first stopped after a growing delay (so at
  // different points of its tiles and light blocks), then rendered whole.
  ManyLightRenderer resumed(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
  int stoppedBatches = 0;
  for (int b = 0; b < resumed.batchCount(); ++b) {
    std::atomic<bool> stop{false};
    std::thread stopper([&stop, b] {
      std::this_thread::sleep_for(std::chrono::milliseconds(5 << b));
      stop.store(true);
    });
    const size_t before = resumed.lightsProcessed();
    const bool completed = resumed.renderBatch(b, &stop);
    stopper.join();
    if (!completed) {
      ++stoppedBatches;
      EXPECT_EQ(resumed.lightsProcessed(), before) << "batch " << b;
      ASSERT_TRUE(resumed.renderBatch(b)) << "batch " << b;
    }
  }
  const ManyLightImages got = resumed.images();
  EXPECT_TRUE(sameBits(got.direct, want.direct));
  EXPECT_TRUE(sameBits(got.vsl, want.vsl));
  EXPECT_TRUE(sameBits(got.vpl, want.vpl));
  EXPECT_TRUE(sameBits(got.vplUnclamped, want.vplUnclamped));
  EXPECT_TRUE(sameBits(got.vplDiffuse, want.vplDiffuse));
  EXPECT_TRUE(sameBits(got.lostToClamping, want.lostToClamping));
  EXPECT_TRUE(sameBits(got.lostToDiffuse, want.lostToDiffuse));
  // The timing decides how many were stopped; report it.
  RecordProperty("stoppedBatches", stoppedBatches);
}
