// The brute-force renderer's batches (many_light.h): a batch stopped
// anywhere changes nothing, so rendering it again gives the same images as
// an uninterrupted render, bit for bit, whatever the thread count (batch
// buffers are reused from batch to batch, films are merged and read in
// parallel).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <thread>
#include <vector>

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

// The settings both tests render with: `lights` lights in `batches` batches
// at the loaded scene's size, eight direct samples.
ManyLightSettings batchSettings(const Loaded& l, uint32_t lights, uint64_t seed, int batches) {
  ManyLightSettings s;
  s.lights = lights;
  s.seed = seed;
  s.width = l.width;
  s.height = l.height;
  s.batches = batches;
  s.directSamples = 8;
  return s;
}

}  // namespace

TEST(ManyLightBatches, StoppedBatchesRenderedAgainMatchAnUninterruptedRender) {
  Loaded l = loadAsset("cornell-glossy", 40);
  const ManyLightSettings s = batchSettings(l, 400, 3, 5);
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

// Sizes double, then stay equal; no batch holds less than one light's share.
// Before 2026-12-05 the doublings ran to batches / 2 whatever the light
// count: 64 batches of 4,003 lights were 30 batches of one light each (eye
// samples that carried almost none of the light set's weight) and 34 of the
// rest, and the sweep's prediction from the last batch's time stopped runs
// at the 31st.
TEST(ManyLightBatches, SizesDoubleThenStayEqualAndNoBatchIsWasted) {
  // The rule as it was where it was sound: the CLI's 8 batches, the studio's
  // 16 over its default 5,000 lights.
  EXPECT_EQ(batchWeights(4003, 8), (std::vector<double>{1, 2, 4, 8, 16, 16, 16, 16}));
  const std::vector<double> studio = batchWeights(5000, 16);
  ASSERT_EQ(studio.size(), 16u);
  for (int b = 0; b < 16; ++b) EXPECT_EQ(studio[size_t(b)], std::ldexp(1.0, std::min(b, 8))) << b;
  // More batches than lights: one light each.
  EXPECT_EQ(batchWeights(3, 8), (std::vector<double>{1, 1, 1}));
  EXPECT_EQ(batchWeights(0, 8).size(), 1u);
  for (int B : {1, 2, 7, 16, 32, 64}) {
    for (size_t N : {size_t(1), size_t(50), size_t(1500), size_t(4003), size_t(15000), size_t(100000)}) {
      const std::vector<double> w = batchWeights(N, B);
      ASSERT_EQ(w.size(), std::min<size_t>(size_t(B), N)) << N << " " << B;
      double total = 0;
      for (size_t b = 0; b < w.size(); ++b) {
        total += w[b];
        if (b > 0) {
          EXPECT_TRUE(w[b] == w[b - 1] || w[b] == 2 * w[b - 1]) << N << " " << B << " " << b;
        }
      }
      EXPECT_GE(double(N) * w[0] / total, 1.0 - 1e-12) << N << " " << B;  // the first batch's share
    }
  }

  // The renderer's batches for 64 over 4,003 lights: every one at least one
  // light, sizes non-decreasing (to rounding), the equal ones within one light of each
  // other, and the effective number of batches (sum n)^2 / sum n^2, what the
  // light set's variance is divided by, at least 90% of 64 (34 before).
  Loaded l = loadAsset("cornell-glossy", 8);
  const ManyLightSettings s = batchSettings(l, 4003, 5, 64);
  ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
  ManyLightRenderer r(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
  ASSERT_EQ(r.batchCount(), 64);
  double sum = 0, sum2 = 0;
  size_t last = r.batchLights(63);
  for (int b = 0; b < 64; ++b) {
    const size_t n = r.batchLights(b);
    EXPECT_GE(n, 1u) << b;
    if (b > 0) {
      EXPECT_GE(n + 1, r.batchLights(b - 1)) << b;  // rounding
    }
    if (n * 2 > last) {
      EXPECT_LE(std::abs(long(last) - long(n)), 1L) << b;
    }
    sum += double(n);
    sum2 += double(n) * double(n);
  }
  EXPECT_EQ(sum, double(run.set.lights.size()));
  EXPECT_GE(sum * sum / sum2, 0.9 * 64);
  RecordProperty("effectiveBatches", std::to_string(sum * sum / sum2));
}

// The lobe gather's directions per batch (ManyLightRenderer::lobeRays): the
// first of several batches takes an eighth (at least one), the others share
// the rest, so that a render still takes lobeGatherRays per batch in all;
// none takes more than kMaxLobeGatherRays (the first takes more where the
// others could not hold the rest); one batch takes them all.
TEST(ManyLightBatches, LobeGatherDirectionsSumToTheSettingsPerBatch) {
  Loaded l = loadAsset("cornell-glossy", 8);
  const int kMax = ManyLightSettings::kMaxLobeGatherRays;
  struct Case {
    int rays, batches, first;
  };
  for (const Case& c : {Case{128, 8, 16}, Case{4, 8, 1}, Case{16, 64, 2}, Case{1, 64, 1}, Case{128, 1, 128},
                        Case{1024, 2, 1024}, Case{1000, 8, 1000 * 8 - kMax * 7}, Case{7, 2, 1}}) {
    ManyLightSettings s = batchSettings(l, 2000, 1, c.batches);
    s.lobeGatherRays = c.rays;
    ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
    ManyLightRenderer r(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
    ASSERT_EQ(r.batchCount(), c.batches);
    long total = 0;
    for (int b = 0; b < r.batchCount(); ++b) {
      EXPECT_GE(r.lobeRays(b), 1) << c.rays << " rays, batch " << b;
      EXPECT_LE(r.lobeRays(b), kMax) << c.rays << " rays, batch " << b;
      total += r.lobeRays(b);
    }
    EXPECT_EQ(r.lobeRays(0), c.first) << c.rays << " rays in " << c.batches << " batches";
    EXPECT_EQ(total, long(c.rays) * c.batches) << c.rays << " rays in " << c.batches << " batches";
  }
}

// The time left is predicted part by part: a first batch of one light and
// every pixel's eye path (16 batches: 1 of 2,303 shares of the lights) costs
// mostly per-pixel work, which the later batches repeat without growing.
TEST(ManyLightBatches, CostModelPredictsEachPartFromItsOwnUnits) {
  using U = BatchCostModel::Units;
  const U perUnit{0.02, 0.25, 0.004};  // seconds per direct sample or eye path, per direction, per light
  auto cost = [&](const U& u) { return U{u.pixel * perUnit.pixel, u.lobe * perUnit.lobe, u.lights * perUnit.lights}; };
  BatchCostModel m;
  EXPECT_FALSE(m.measured());
  EXPECT_EQ(m.predict({10, 10, 10}), 0.0);  // nothing measured counts as free
  const U first{2, 2, 1};
  m.add(cost(first), first);
  ASSERT_TRUE(m.measured());
  const U later{8, 15, 256};
  const double truth = later.pixel * perUnit.pixel + later.lobe * perUnit.lobe + later.lights * perUnit.lights;
  EXPECT_NEAR(m.predict(later), truth, 1e-12);
  // Lights per second over the first batch alone would predict
  // (0.04 + 0.5 + 0.004) / 1 light x 256 lights = 139 s for the 4.9 s left.
  EXPECT_GT((first.pixel * perUnit.pixel + first.lobe * perUnit.lobe + perUnit.lights) * later.lights, 20 * truth);
  // More batches: the costs per unit are pooled (measured noise averages).
  const U second{4, 16, 2};
  U s = cost(second);
  s.lights *= 3;  // this batch's lights cost 3x: the pooled cost is (0.004 + 3 x 0.008) / 3 per light
  m.add(s, second);
  EXPECT_NEAR(m.predict({0, 0, 3}), 0.004 + 3 * 0.008, 1e-12);
  EXPECT_NEAR(m.predict({1, 1, 0}), perUnit.pixel + perUnit.lobe, 1e-12);
}

// The renderer's time left: unknown before a batch, predicted from the
// batches done (positive while any is left), zero when every batch is done;
// the next batch's is part of it.
TEST(ManyLightBatches, TimeLeftIsUnknownThenPredictedThenZero) {
  Loaded l = loadAsset("cornell-glossy", 8);
  ManyLightSettings s = batchSettings(l, 2000, 1, 6);
  s.lobeGather = 2000;
  s.lobeGatherRays = 8;
  ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
  ManyLightRenderer r(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
  ASSERT_TRUE(r.lobeGathering());
  EXPECT_FALSE(r.remainingSeconds().has_value());
  EXPECT_FALSE(r.nextBatchSeconds().has_value());
  for (int b = 0; b < r.batchCount(); ++b) {
    ASSERT_TRUE(r.renderBatch(b));
    const std::optional<double> left = r.remainingSeconds(), next = r.nextBatchSeconds();
    ASSERT_TRUE(left.has_value()) << "batch " << b;
    if (b + 1 < r.batchCount()) {
      EXPECT_GT(*left, 0.0) << "batch " << b;
      // The next batch is part of what is left, and the last of it.
      ASSERT_TRUE(next.has_value()) << "batch " << b;
      EXPECT_GT(*next, 0.0) << "batch " << b;
      EXPECT_LE(*next, *left * (1 + 1e-12)) << "batch " << b;
      if (b + 2 == r.batchCount()) {
        EXPECT_NEAR(*next, *left, 1e-12 * *left);
      }
    } else {
      EXPECT_EQ(*left, 0.0);
      EXPECT_FALSE(next.has_value());
    }
  }
}
