// The studio's background session: restart storms (run under TSan),
// generation numbers, no stale snapshot, failed loads keep the scene.
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <thread>

#include "core/session.h"

using namespace vsl;
using namespace std::chrono_literals;

namespace {

std::string asset(const char* name) { return std::string(VSL_SOURCE_DIR) + "/assets/scenes/" + name + ".gltf"; }

StudioSettings small(const char* scene, uint32_t lights, int size) {
  StudioSettings s;
  s.scene = asset(scene);
  s.many.lights = lights;
  s.many.width = s.many.height = size;
  s.many.batches = 4;
  s.many.directSamples = 4;
  s.maxReferenceSpp = 8;
  return s;
}

// Polls until pred(snapshot) holds for a snapshot of generation g (bounded).
std::shared_ptr<const Snapshot> waitFor(const Session& session, uint64_t g,
                                        const std::function<bool(const Snapshot&)>& pred) {
  uint64_t serial = 0;
  for (int i = 0; i < 6000; ++i) {  // at most ~60 s, far beyond need
    if (auto s = session.latest(serial)) {
      serial = s->serial;
      if (s->generation == g && pred(*s)) return s;
    }
    std::this_thread::sleep_for(10ms);
  }
  return nullptr;
}

}  // namespace

TEST(Session, RendersToCompletionWithAllLayers) {
  Session session;
  uint64_t g = session.restart(small("cornell-glossy", 200, 16));
  ASSERT_GT(g, 0u);
  auto snap = waitFor(session, g, [](const Snapshot& s) { return s.manyLightDone && s.referenceDone; });
  ASSERT_TRUE(snap);
  EXPECT_EQ(snap->width, 16);
  EXPECT_EQ(snap->lightsProcessed, snap->lightsTotal);
  EXPECT_GE(snap->lightsTotal, 200u);
  EXPECT_EQ(snap->ptSpp, 8);
  EXPECT_EQ(snap->batchesDone, snap->batchCount);
  EXPECT_FALSE(snap->history.empty());
  EXPECT_EQ(snap->nonFinite, 0u);
  double sum = 0;
  for (float v : snap->many.vsl.rgb) sum += v;
  EXPECT_GT(sum, 0.0);
  // Time axes only move forward.
  for (size_t i = 1; i < snap->history.size(); ++i) {
    EXPECT_GE(snap->history[i].manySeconds, snap->history[i - 1].manySeconds);
    EXPECT_GE(snap->history[i].ptSeconds, snap->history[i - 1].ptSeconds);
  }
}

// A storm of restarts from one thread while another polls: generations only
// grow, every snapshot carries its own generation's settings, and none is
// older than a restart that already returned.
TEST(Session, RestartStormNeverShowsStaleSnapshots) {
  Session session;
  std::mutex m;
  std::map<uint64_t, uint32_t> lightsOfGeneration;
  std::atomic<bool> done{false};
  std::atomic<int> seen{0}, violations{0};
  std::thread reader([&] {
    uint64_t serial = 0, lastGen = 0;
    while (!done.load()) {
      uint64_t before = session.generation();
      if (auto s = session.latest(serial)) {
        serial = s->serial;
        ++seen;
        if (s->generation < before || s->generation < lastGen) ++violations;
        lastGen = s->generation;
        std::lock_guard<std::mutex> lock(m);
        auto it = lightsOfGeneration.find(s->generation);
        if (it == lightsOfGeneration.end() || it->second != s->settings.many.lights) ++violations;
      }
      std::this_thread::yield();
    }
  });
  uint64_t last = 0;
  for (int i = 0; i < 300; ++i) {
    StudioSettings s = small(i % 3 == 0 ? "furnace" : "cornell-glossy", 20 + i % 50, 8 + i % 9);
    {
      std::lock_guard<std::mutex> lock(m);
      // Record before restart() so the reader never sees an unknown generation.
      lightsOfGeneration[session.generation() + 1] = s.many.lights;
    }
    uint64_t g = session.restart(s);
    ASSERT_EQ(g, last + 1);
    last = g;
    if (i % 37 == 0) std::this_thread::sleep_for(5ms);
  }
  auto final = waitFor(session, last, [](const Snapshot& s) { return s.manyLightDone; });
  done.store(true);
  reader.join();
  ASSERT_TRUE(final);
  EXPECT_EQ(violations.load(), 0);
  EXPECT_GT(seen.load(), 0);
}

TEST(Session, FailedLoadKeepsThePreviousScene) {
  Session session;
  uint64_t g1 = session.restart(small("furnace", 50, 8));
  ASSERT_TRUE(waitFor(session, g1, [](const Snapshot& s) { return s.batchesDone > 0; }));
  StudioSettings bad = small("furnace", 60, 8);
  bad.scene = std::string(VSL_SOURCE_DIR) + "/does-not-exist.gltf";
  uint64_t g2 = session.restart(bad);
  auto snap = waitFor(session, g2, [](const Snapshot& s) { return s.batchesDone > 0; });
  ASSERT_TRUE(snap);
  EXPECT_EQ(snap->settings.scene, asset("furnace"));
  EXPECT_EQ(snap->settings.many.lights, 60u) << "the other new settings still apply";
  Session::Status st = session.status();
  EXPECT_NE(st.loadError.find("does-not-exist.gltf"), std::string::npos) << st.loadError;
  EXPECT_EQ(st.scene, asset("furnace"));
  EXPECT_GT(st.loadErrorSerial, 0u);
}

TEST(Session, InvalidSettingsAreRejected) {
  Session session;
  StudioSettings s = small("furnace", 0, 8);
  std::string err;
  EXPECT_EQ(session.restart(s, &err), 0u);
  EXPECT_NE(err.find("lights"), std::string::npos) << err;
  s = small("furnace", 10, 8);
  s.many.radiusScale = -1;
  EXPECT_EQ(session.restart(s, &err), 0u);
  EXPECT_EQ(session.generation(), 0u);
}

TEST(Session, DestroyedWhileRenderingStopsPromptly) {
  for (int i = 0; i < 3; ++i) {
    Session session;
    session.restart(small("kitchen", 200000, 64));
    std::this_thread::sleep_for(std::chrono::milliseconds(20 * i));
  }  // the destructor cancels between tiles and joins; a hang fails by timeout
  SUCCEED();
}
