// The studio's background session: restart storms (run under TSan),
// generation numbers, no stale snapshot, failed loads keep the scene.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <map>
#include <thread>

#include <unistd.h>

#include <filesystem>

#include "core/compare.h"
#include "core/estimator_registry.h"
#include "core/estimators/mrcs/mrcs_estimator.h"
#include "core/gather.h"
#include "core/image_io.h"
#include "core/memory_budget.h"
#include "core/mrcs.h"
#include "core/parallel.h"
#include "core/render_context.h"
#include "core/session.h"
#include "core/virtual_lights.h"
#include "support.h"

using namespace vsl;
using namespace std::chrono_literals;

namespace {

std::string asset(const char* name) { return std::string(VSL_SOURCE_DIR) + "/assets/scenes/" + name + ".gltf"; }

// Under the sanitizers work runs 5-20x slower: the tests that need a long
// light set (to restart inside it) take a fifth of the lights there, which
// still lasts seconds per set, and the same checks hold.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr uint32_t kLongSetLights = 4000, kLongLobeGather = 60'000;
#else
constexpr uint32_t kLongSetLights = 20000, kLongLobeGather = 300'000;
#endif

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

// Points the reference cache at a fresh folder for one test.
struct TempCache {
  std::string dir;
  TempCache() {
    dir = (std::filesystem::temp_directory_path() / ("vsl-session-cache-" + std::to_string(getpid()))).string();
    std::filesystem::remove_all(dir);
    setenv("VSL_REFERENCE_CACHE", dir.c_str(), 1);
  }
  ~TempCache() {
    unsetenv("VSL_REFERENCE_CACHE");
    std::filesystem::remove_all(dir);
  }
};

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
  uint64_t g = session.restart(small("cornell-glossy", 200, 16)).value();
  ASSERT_GT(g, 0u);
  auto snap = waitFor(session, g, [](const Snapshot& s) { return s.manyLightDone && s.referenceDone; });
  ASSERT_TRUE(snap);
  EXPECT_EQ(snap->width, 16);
  EXPECT_EQ(snap->lightsProcessed, snap->lightsTotal);
  EXPECT_GE(snap->lightsTotal, 200u);
  // The live path tracer renders its 8 spp and on while it is too noisy to
  // rank the methods (LiveReferenceNoiseIsEstimatedAndSubtracted).
  EXPECT_GE(snap->ptSpp, 8);
  EXPECT_GE(snap->ptSpp, snap->referenceTargetSpp);  // done: the target (as last estimated) reached
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
    uint64_t g = session.restart(s).value();
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
  uint64_t g1 = session.restart(small("furnace", 50, 8)).value();
  ASSERT_TRUE(waitFor(session, g1, [](const Snapshot& s) { return s.batchesDone > 0; }));
  StudioSettings bad = small("furnace", 60, 8);
  bad.scene = std::string(VSL_SOURCE_DIR) + "/does-not-exist.gltf";
  uint64_t g2 = session.restart(bad).value();
  auto snap = waitFor(session, g2, [](const Snapshot& s) { return s.batchesDone > 0; });
  ASSERT_TRUE(snap);
  EXPECT_EQ(snap->settings.scene, asset("furnace"));
  EXPECT_EQ(snap->settings.many.lights, 60u) << "the other new settings still apply";
  Session::Status st = session.status();
  EXPECT_NE(st.loadError.find("does-not-exist.gltf"), std::string::npos) << st.loadError;
  EXPECT_EQ(st.scene, asset("furnace"));
  EXPECT_GT(st.loadErrorSerial, 0u);
}

// An exception on a parallel worker (here injected into the first parallelFor
// the session runs, in light tracing) reaches the session's worker, is reported
// through status() and the log, and the next restart renders normally.
TEST(Session, WorkerExceptionIsReportedAndTheSessionGoesOn) {
  Session session;
  failParallelForTesting(3, "injected worker failure");
  uint64_t g1 = session.restart(small("furnace", 50, 8)).value();
  Session::Status st;
  for (int i = 0; i < 6000 && (st = session.status()).runErrorSerial == 0; ++i) std::this_thread::sleep_for(10ms);
  EXPECT_EQ(st.runError, "the render failed: injected worker failure");
  EXPECT_EQ(st.runErrorSerial, 1u);
  uint64_t g2 = session.restart(small("furnace", 50, 8)).value();
  ASSERT_GT(g2, g1);
  auto snap = waitFor(session, g2, [](const Snapshot& s) { return s.manyLightDone && s.referenceDone; });
  ASSERT_TRUE(snap);
  EXPECT_EQ(snap->lightsProcessed, snap->lightsTotal);
  EXPECT_EQ(session.status().runErrorSerial, 1u);
}

TEST(Session, InvalidSettingsAreRejected) {
  Session session;
  StudioSettings s = small("furnace", 0, 8);
  Result<uint64_t> r = session.restart(s);
  EXPECT_FALSE(r);
  EXPECT_EQ(r.error(), "lights: must be in [1,50000000] (got 0)");
  s = small("furnace", 10, 8);
  s.many.radiusScale = -1;
  r = session.restart(s);
  EXPECT_FALSE(r);
  EXPECT_NE(r.error().find("radius-scale"), std::string::npos) << r.error();
  for (int sets : {0, StudioSettings::kMaxLightSets + 1}) {
    s = small("furnace", 10, 8);
    s.lightSets = sets;
    r = session.restart(s);
    EXPECT_FALSE(r);
    EXPECT_EQ(r.error(), "light sets: must be in [1,64] (got " + std::to_string(sets) + ")");
  }
  EXPECT_EQ(session.generation(), 0u);
}

TEST(Session, DestroyedWhileRenderingStopsPromptly) {
  for (int i = 0; i < 3; ++i) {
    Session session;
    ASSERT_TRUE(session.restart(small("kitchen", 200000, 64)));
    std::this_thread::sleep_for(std::chrono::milliseconds(20 * i));
  }  // the destructor cancels between tiles and joins; a hang fails by timeout
  SUCCEED();
}

// Settings whose memory estimate does not fit are refused before anything
// stops: restart() returns an error with the estimate, and the render goes on.
TEST(Session, RefusesSettingsThatDoNotFitInMemory) {
  Session session;
  uint64_t g = session.restart(small("furnace", 50, 8)).value();
  ASSERT_TRUE(waitFor(session, g, [](const Snapshot& s) { return s.batchesDone > 0; }));
  session.setAvailableMemoryForTesting(uint64_t(400) << 20);  // 400 MB
  StudioSettings huge = small("furnace", 50, 8);
  huge.many.width = 16384;
  huge.many.height = 0;  // from the camera: 16384x16384 for the furnace
  Result<uint64_t> r = session.restart(huge);
  ASSERT_FALSE(r);
  const std::string& err = r.error();
  EXPECT_NE(err.find("memory:"), std::string::npos) << err;
  EXPECT_NE(err.find("needs about"), std::string::npos) << err;
  EXPECT_NE(err.find("at most"), std::string::npos) << "offers the largest setting that fits: " << err;
  EXPECT_EQ(session.generation(), g) << "the running render is untouched";
  StudioSettings many = small("furnace", 20'000'000, 8);
  Result<uint64_t> r2 = session.restart(many);
  ASSERT_FALSE(r2);
  EXPECT_NE(r2.error().find("lights fit"), std::string::npos) << r2.error();
  // Each light set keeps its indirect images: a count that does not fit is
  // refused with the count that does (at 256x256, 400 MB: about 10).
  StudioSettings sets = small("furnace", 50, 256);
  sets.lightSets = StudioSettings::kMaxLightSets;
  Result<uint64_t> r3 = session.restart(sets);
  ASSERT_FALSE(r3);
  EXPECT_NE(r3.error().find("light sets fit"), std::string::npos) << r3.error();
  sets.lightSets = 2;
  EXPECT_TRUE(session.restart(sets)) << "two sets fit";
  // The lobe gather's second light set counts too: 50 million of them need
  // about 9 GB, refused with its own reason; off, the same settings fit.
  StudioSettings lobe = small("furnace", 50, 8);
  lobe.many.lobeGather = 50'000'000;
  Result<uint64_t> r4 = session.restart(lobe);
  ASSERT_FALSE(r4);
  EXPECT_NE(r4.error().find("fewer lobe-gather lights"), std::string::npos) << r4.error();
  EXPECT_GT(lobeGatherBytes(50'000'000), uint64_t(400) << 20);
  lobe.many.lobeGather = 0;
  EXPECT_TRUE(session.restart(lobe));
}

TEST(Session, MemoryEstimateIsItemised) {
  MemoryEstimate e = estimateStudioMemory(1000, 100, 50);
  EXPECT_GE(e.bytesPerLight, sizeof(VirtualLight));
  EXPECT_EQ(e.lightBytes, 1000 * e.bytesPerLight);
  EXPECT_EQ(e.pixelBytes, 5000 * e.bytesPerPixel);
  EXPECT_TRUE(checkStudioMemory(1000, 100, 50, 0)) << "unknown availability applies no limit";
  EXPECT_TRUE(checkStudioMemory(1000, 100, 50, e.total() * 2));
  Result<void> tooBig = checkStudioMemory(1000, 100, 50, e.total() / 2);
  EXPECT_FALSE(tooBig);
  EXPECT_NE(tooBig.error(), "");
  // MRCS holds every light decoded and its reduced columns for both
  // estimators (2 x rows floats), and one gather point set per pixel.
  const ExtraMemory rows300 = estimatorMemory(mrcsEstimatorSettings(MrcsSettings{300, 900, 0}), 100 * 50);
  MemoryEstimate m = estimateStudioMemory(1000, 100, 50, rows300);
  EXPECT_GE(m.bytesPerLight, e.bytesPerLight + 2 * 300 * sizeof(float) + sizeof(GatherLight) / 2);
  EXPECT_GE(m.bytesPerPixel, e.bytesPerPixel + sizeof(EyeSample));
  EXPECT_FALSE(checkStudioMemory(1000, 100, 50, e.total() * 4 / 3 + 1, 0.75, rows300))
      << "what fits brute force need not fit MRCS";
}

// The studio refuses an MRCS render whose reduced columns would not fit, and
// names the light count that does.
TEST(Session, MrcsMemoryIsCheckedBeforeRendering) {
  Session session;
  StudioSettings s = small("cornell-glossy", 200000, 64);
  s.estimator.name = "mrcs";
  s.estimator.values["mrcs-rows"] = 2000;
  const uint64_t brute = estimateStudioMemory(200000, 64, 64).total();
  session.setAvailableMemoryForTesting(brute * 2);  // brute force fits in 75% of this; MRCS needs 3.2 GB more
  Result<uint64_t> r = session.restart(s);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("lights fit"), std::string::npos) << r.error();
  s.estimator.name = "brute-force";
  EXPECT_TRUE(session.restart(s)) << "the same settings fit brute force";
}

// Every stage stops promptly on a restart, light tracing and k-NN included
// (generous bound: the machine is shared; the k-d tree build itself cannot be
// interrupted, so the light count keeps it short).
TEST(Session, RestartStopsLightTracingAndKnnPromptly) {
  Session session;
  for (int delayMs : {50, 400, 900}) {
    uint64_t g = session.restart(small("cornell-glossy", 400000, 8)).value();
    std::this_thread::sleep_for(std::chrono::milliseconds(delayMs));
    Session::Status st = session.status();
    auto t0 = std::chrono::steady_clock::now();
    uint64_t g2 = session.restart(small("furnace", 30, 8)).value();
    ASSERT_EQ(g2, g + 1);
    auto snap = waitFor(session, g2, [](const Snapshot& s) { return s.batchesDone > 0; });
    ASSERT_TRUE(snap);
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_LT(seconds, 20.0) << "stage when restarted: " << st.stage;
  }
}

// A failed load (or a scene without emitters) does not restart the render:
// the interrupted job resumes under the new generation with its batches.
TEST(Session, FailedLoadResumesTheRunningRender) {
  Session session;
  StudioSettings s = small("cornell-glossy", 3000, 24);
  s.many.batches = 16;
  s.maxReferenceSpp = 64;
  uint64_t g1 = session.restart(s).value();
  auto before = waitFor(session, g1, [](const Snapshot& x) { return x.batchesDone >= 2; });
  ASSERT_TRUE(before);
  StudioSettings bad = s;
  bad.scene = std::string(VSL_SOURCE_DIR) + "/does-not-exist.gltf";
  uint64_t g2 = session.restart(bad).value();
  auto after = waitFor(session, g2, [](const Snapshot&) { return true; });
  ASSERT_TRUE(after);
  EXPECT_GE(after->batchesDone, before->batchesDone) << "the render went on instead of starting over";
  EXPECT_EQ(after->settings.scene, s.scene);
  EXPECT_FALSE(session.status().noEmitters);
}

TEST(Session, SceneWithoutEmittersIsReportedAndKeepsThePreviousScene) {
  // A single grey triangle and no light.
  std::string path = std::string(VSL_BINARY_DIR) + "/no-emitters.gltf";
  test::writeNoEmitterTriangle(path);
  Session session;
  uint64_t g1 = session.restart(small("furnace", 50, 8)).value();
  ASSERT_TRUE(waitFor(session, g1, [](const Snapshot& s) { return s.batchesDone > 0; }));
  StudioSettings dark = small("furnace", 50, 8);
  dark.scene = path;
  uint64_t g2 = session.restart(dark).value();
  ASSERT_TRUE(waitFor(session, g2, [](const Snapshot& s) { return s.batchesDone > 0; }));
  Session::Status st = session.status();
  EXPECT_TRUE(st.noEmitters);
  EXPECT_NE(st.loadError.find("no emitters"), std::string::npos) << st.loadError;
  EXPECT_EQ(st.scene, asset("furnace"));
}

TEST(Session, EnvironmentLightsADarkSceneAndABadMapKeepsThePreviousOne) {
  // The grey triangle without lights renders once a sky lights it; a map
  // that cannot be read is reported (naming the file) and the sky stays.
  std::string path = std::string(VSL_BINARY_DIR) + "/no-emitters-env.gltf";
  test::writeNoEmitterTriangle(path);
  Session session;
  StudioSettings lit = small("furnace", 50, 8);
  lit.scene = path;
  lit.env.sky = Vec3(0.5f);
  uint64_t g1 = session.restart(lit).value();
  ASSERT_TRUE(waitFor(session, g1, [](const Snapshot& s) { return s.batchesDone > 0; }));
  EXPECT_EQ(session.status().scene, path);
  StudioSettings bad = lit;
  bad.env.map = std::string(VSL_BINARY_DIR) + "/no-such-map.exr";
  uint64_t g2 = session.restart(bad).value();
  ASSERT_TRUE(waitFor(session, g2, [](const Snapshot& s) { return s.batchesDone > 0; }));
  Session::Status st = session.status();
  EXPECT_TRUE(st.environmentFailed);
  EXPECT_NE(st.loadError.find("no-such-map.exr"), std::string::npos) << st.loadError;
  EXPECT_EQ(st.scene, path);
  EXPECT_TRUE(st.env == lit.env) << st.env.describe();
}

// A scene that cannot load with nothing before it: no render, and the UI can
// tell (the headless studio exits with the reason).
TEST(Session, FirstSceneMissingIsReported) {
  Session session;
  StudioSettings s = small("furnace", 50, 8);
  s.scene = std::string(VSL_SOURCE_DIR) + "/missing.gltf";
  ASSERT_TRUE(session.restart(s));
  for (int i = 0; i < 3000 && session.status().loadErrorSerial == 0; ++i) std::this_thread::sleep_for(10ms);
  Session::Status st = session.status();
  EXPECT_GT(st.loadErrorSerial, 0u);
  EXPECT_TRUE(st.scene.empty());
  EXPECT_TRUE(session.shutdown(10));
}

TEST(Session, ProgressCountsLightsAndTime) {
  Session session;
  // Every snapshot the worker publishes (the hook sees each, in order, on
  // the worker thread): the fraction done (in time) within [0, 1], and a
  // time left once a batch has been measured.
  std::vector<std::shared_ptr<const Snapshot>> published;
  session.setPublishHookForTesting(
      [&](const Snapshot& x) { published.push_back(std::make_shared<const Snapshot>(x)); });
  uint64_t g = session.restart(small("cornell-glossy", 500, 16)).value();
  auto snap = waitFor(session, g, [&](const Snapshot& s) { return s.manyLightDone; });
  session.setPublishHookForTesting(nullptr);  // its calls happened before latest() returned the last one
  ASSERT_TRUE(snap);
  int partial = 0;
  for (const auto& p : published) {
    const Snapshot& s = *p;
    EXPECT_GE(s.manyFractionDone, 0.0);
    EXPECT_LE(s.manyFractionDone, 1.0);
    if (!s.manyLightDone && s.batchesDone > 0) {
      ++partial;
      EXPECT_GT(s.manyRemainingSeconds, 0.0) << "batch " << s.batchesDone;
      EXPECT_LT(s.manyFractionDone, 1.0);
    }
  }
  EXPECT_GT(partial, 0) << "no snapshot between the first batch and the last";
  EXPECT_GT(snap->lightsPerSecond, 0);
  EXPECT_EQ(snap->manyRemainingSeconds, 0);
  EXPECT_EQ(snap->manyFractionDone, 1.0);
  EXPECT_GT(snap->clampBound, 0);
  EXPECT_GT(snap->radiusMedian, 0);
  EXPECT_LE(snap->radiusMin, snap->radiusMedian);
  EXPECT_LE(snap->radiusMedian, snap->radiusMax);
  EXPECT_GT(snap->sceneRadius, 0);
}

// ---- Light sets: independent estimates, their mean, bias and noise.

namespace {

// A scene loaded for rendering directly, outside the session.
struct Loaded {
  std::unique_ptr<RenderContext> context;
  const Scene* scene = nullptr;
  const Accel* accel = nullptr;
  const LightSampler* lights = nullptr;
  explicit Loaded(const char* name) {
    Result<std::unique_ptr<RenderContext>> c = RenderContext::load(asset(name));
    EXPECT_TRUE(c) << c.error();
    if (!c) return;
    context = std::move(c).value();
    scene = &context->scene();
    accel = &context->accel();
    lights = &context->lights();
  }
  // One light set rendered to completion with ManyLightRenderer.
  ManyLightImages render(ManyLightSettings m) const {
    ManyLightRun run = prepareManyLights(*scene, *accel, *lights, m);
    ManyLightRenderer r(*scene, *accel, *lights, run.set, run.radii, m);
    for (int b = 0; b < r.batchCount(); ++b) EXPECT_TRUE(r.renderBatch(b));
    return r.images();
  }
  // Light sets 0 .. n - 1 (seeds m.seed + k), each rendered as by render().
  std::vector<ManyLightImages> renderSets(const ManyLightSettings& m, int n) const {
    std::vector<ManyLightImages> out;
    for (int k = 0; k < n; ++k) {
      ManyLightSettings mk = m;
      mk.seed = m.seed + uint64_t(k);
      out.push_back(render(mk));
    }
    return out;
  }
  // One light set rendered with renderMrcs directly.
  ManyLightImages renderWithMrcs(const ManyLightSettings& m, const MrcsSettings& mrcs) const {
    ManyLightRun run = prepareManyLights(*scene, *accel, *lights, m);
    MrcsResult r = vsl::renderMrcs(*scene, *accel, *lights, run.set, run.radii, m, mrcs);
    EXPECT_FALSE(r.stopped);
    return r.images;
  }
};

// Three light sets of 300 lights on cornell-glossy at 16 px, seeds 11-13.
StudioSettings threeSets() {
  StudioSettings s = small("cornell-glossy", 300, 16);
  s.many.seed = 11;
  s.lightSets = 3;
  return s;
}

// The mean of images as biasVariance computes it: a double sum in order, over K.
Image meanOf(const std::vector<const Image*>& images) {
  Image m(images[0]->width, images[0]->height);
  for (size_t i = 0; i < m.rgb.size(); ++i) {
    double sum = 0;
    for (const Image* img : images) sum += img->rgb[i];
    m.rgb[i] = float(sum / double(images.size()));
  }
  return m;
}

}  // namespace

// With lightSets = 3 the session renders three independent light sets (seeds
// s, s + 1, s + 2) and shows their mean: bit for bit the mean of three renders
// made with ManyLightRenderer directly. Each method's bias and noise are
// compare.h's biasVariance of those renders against the snapshot's reference
// (equal to the last bit of a double). lightSets = 1 is one set, as before.
TEST(Session, LightSetsAverageIndependentRendersAndMeasureBiasAndNoise) {
  TempCache cache;  // no cached reference: the live path tracer
  StudioSettings s = threeSets();
  Session session;
  uint64_t g = session.restart(s).value();
  auto snap = waitFor(session, g, [](const Snapshot& x) { return x.manyLightDone && x.referenceDone; });
  ASSERT_TRUE(snap);
  EXPECT_EQ(snap->lightSets, 3);
  EXPECT_EQ(snap->lightSetsDone, 3);
  EXPECT_EQ(snap->lightsProcessed, snap->lightsTotal);

  Loaded l("cornell-glossy");
  const std::vector<ManyLightImages> renders = l.renderSets(s.many, 3);
  EXPECT_NE(renders[0].vsl.rgb, renders[1].vsl.rgb) << "independent sets";
  auto layer = [&](Image ManyLightImages::*which) {
    return std::vector<const Image*>{&(renders[0].*which), &(renders[1].*which), &(renders[2].*which)};
  };
  EXPECT_EQ(snap->many.vsl.rgb, meanOf(layer(&ManyLightImages::vsl)).rgb);
  EXPECT_EQ(snap->many.vpl.rgb, meanOf(layer(&ManyLightImages::vpl)).rgb);
  EXPECT_EQ(snap->many.vplUnclamped.rgb, meanOf(layer(&ManyLightImages::vplUnclamped)).rgb);
  EXPECT_EQ(snap->many.direct.rgb, meanOf(layer(&ManyLightImages::direct)).rgb);
  EXPECT_EQ(snap->many.lostToClamping.rgb, meanOf(layer(&ManyLightImages::lostToClamping)).rgb);
  Image ManyLightImages::*rows[4] = {&ManyLightImages::vsl, &ManyLightImages::vpl, &ManyLightImages::vplUnclamped,
                                     &ManyLightImages::vplDiffuse};
  for (int i = 0; i < 4; ++i) {
    BiasVarianceResult want = biasVariance(layer(rows[i]), snap->refIndirect);
    const BiasNoise& got = snap->biasNoise[i];
    EXPECT_EQ(got.renders, 3) << i;
    EXPECT_DOUBLE_EQ(got.bias2, want.average.bias2) << i;
    EXPECT_DOUBLE_EQ(got.variance, want.average.variance) << i;
    EXPECT_DOUBLE_EQ(got.relMse, want.average.relMse) << i;
    EXPECT_GT(got.variance, 0) << i;
  }
  EXPECT_EQ(snap->biasNoise[int(BiasNoiseRow::Pt)].renders, 0) << "the path tracer is the reference here";
  // Each method's own time grows over the sets, and the history's clocks only move forward.
  EXPECT_GE(snap->vslSeconds, snap->lightTracingSeconds + snap->knnSeconds);
  for (size_t i = 1; i < snap->history.size(); ++i) {
    EXPECT_GE(snap->history[i].vslSeconds, snap->history[i - 1].vslSeconds);
    EXPECT_GE(snap->history[i].vplSeconds, snap->history[i - 1].vplSeconds);
  }

  // One set: the first render itself, and no bias or noise.
  s.lightSets = 1;
  g = session.restart(s).value();
  snap = waitFor(session, g, [](const Snapshot& x) { return x.manyLightDone; });
  ASSERT_TRUE(snap);
  EXPECT_EQ(snap->lightSetsDone, 1);
  EXPECT_EQ(snap->many.vsl.rgb, renders[0].vsl.rgb);
  EXPECT_EQ(snap->many.vpl.rgb, renders[0].vpl.rgb);
  EXPECT_EQ(snap->biasNoise[0].renders, 0);
}

// Issue 49, item 3: a change to VSL's parameters only (the radius scale)
// restarts VSL alone. Clamped VPL keeps its picture, its clock and its bias
// and noise from the first moment, gathers nothing more for the kept sets,
// and its kept picture is bit for bit what a fresh render of the new settings
// makes; VSL's is the new settings'. A change to VPL's only (the clamp) keeps
// VSL's sets the same way; one to both (the light count) restarts both.
TEST(Session, RadiusChangeKeepsClampedVplsPictureAndCounters) {
  TempCache cache;  // no cached reference: the live path tracer
  StudioSettings s = threeSets();
  Session session;
  uint64_t g = session.restart(s).value();
  auto before = waitFor(session, g, [](const Snapshot& x) { return x.manyLightDone; });
  ASSERT_TRUE(before);

  s.many.radiusScale = 2.5f;
  g = session.restart(s).value();
  auto first = waitFor(session, g, [](const Snapshot& x) { return x.batchesDone > 0 || x.lightSetsDone > 0; });
  ASSERT_TRUE(first);
  EXPECT_EQ(first->many.vpl.rgb, before->many.vpl.rgb);
  EXPECT_EQ(first->many.vplUnclamped.rgb, before->many.vplUnclamped.rgb);
  EXPECT_EQ(first->many.lostToClamping.rgb, before->many.lostToClamping.rgb);
  EXPECT_EQ(first->vplSeconds, before->vplSeconds) << "VPL's own clock goes on from where it was";
  EXPECT_LT(first->vslSeconds, before->vslSeconds) << "VSL starts over";
  Loaded l("cornell-glossy");
  const std::vector<ManyLightImages> fresh = l.renderSets(s.many, 3);
  // VPL's bias and noise from the kept sets against the reference of now.
  const BiasVarianceResult vplSets = biasVariance({&fresh[0].vpl, &fresh[1].vpl, &fresh[2].vpl}, first->refIndirect);
  EXPECT_EQ(first->biasNoise[int(BiasNoiseRow::Vpl)].renders, 3);
  EXPECT_DOUBLE_EQ(first->biasNoise[int(BiasNoiseRow::Vpl)].variance, vplSets.average.variance);
  ASSERT_FALSE(first->history.empty());
  EXPECT_EQ(first->history.back().vplSeconds, before->vplSeconds);

  auto after = waitFor(session, g, [](const Snapshot& x) { return x.manyLightDone; });
  ASSERT_TRUE(after);
  EXPECT_EQ(after->many.vpl.rgb, before->many.vpl.rgb);
  EXPECT_EQ(after->vplSeconds, before->vplSeconds) << "no VPL work for the kept sets";
  EXPECT_NE(after->many.vsl.rgb, before->many.vsl.rgb);
  auto layer = [&](Image ManyLightImages::*which) {
    return meanOf({&(fresh[0].*which), &(fresh[1].*which), &(fresh[2].*which)}).rgb;
  };
  EXPECT_EQ(after->many.vsl.rgb, layer(&ManyLightImages::vsl));
  EXPECT_EQ(after->many.vpl.rgb, layer(&ManyLightImages::vpl));
  EXPECT_EQ(after->many.vplDiffuse.rgb, layer(&ManyLightImages::vplDiffuse));
  EXPECT_EQ(after->many.lostToDiffuse.rgb, layer(&ManyLightImages::lostToDiffuse));
  EXPECT_EQ(after->many.direct.rgb, layer(&ManyLightImages::direct));

  // The clamp is VPL's: VPL restarts from zero and VSL keeps its sets.
  s.many.clamp = 0.5f * before->clampBound;
  g = session.restart(s).value();
  first = waitFor(session, g, [](const Snapshot& x) { return x.batchesDone > 0 || x.lightSetsDone > 0; });
  ASSERT_TRUE(first);
  EXPECT_EQ(first->many.vsl.rgb, after->many.vsl.rgb);
  EXPECT_EQ(first->vslSeconds, after->vslSeconds);
  EXPECT_LT(first->vplSeconds, after->vplSeconds);
  auto clamped = waitFor(session, g, [](const Snapshot& x) { return x.manyLightDone; });
  ASSERT_TRUE(clamped);
  EXPECT_EQ(clamped->vslSeconds, after->vslSeconds) << "no VSL work for the kept sets";
  const std::vector<ManyLightImages> freshClamped = l.renderSets(s.many, 3);
  EXPECT_EQ(clamped->many.vpl.rgb, meanOf({&freshClamped[0].vpl, &freshClamped[1].vpl, &freshClamped[2].vpl}).rgb);
  EXPECT_EQ(clamped->many.vsl.rgb, meanOf({&freshClamped[0].vsl, &freshClamped[1].vsl, &freshClamped[2].vsl}).rgb);

  // The light count is both methods': both restart.
  s.many.lights = 400;
  g = session.restart(s).value();
  first = waitFor(session, g, [](const Snapshot& x) { return x.batchesDone > 0 || x.lightSetsDone > 0; });
  ASSERT_TRUE(first);
  EXPECT_LT(first->vslSeconds, clamped->vslSeconds);
  EXPECT_LT(first->vplSeconds, clamped->vplSeconds);
}

// The MRCS estimator in the session: each light set k is one MRCS render
// (lights and rows drawn with seed s + k), and the picture is their mean, bit
// for bit the mean of renderMrcs calls made directly with those seeds.
TEST(Session, MrcsLightSetsAverageIndependentMrcsRenders) {
  TempCache cache;
  StudioSettings s = small("cornell-glossy", 300, 16);
  s.many.seed = 11;
  s.lightSets = 2;
  s.estimator.name = "mrcs";
  s.estimator.values["mrcs-rows"] = 12;
  s.estimator.values["mrcs-clusters"] = 40;
  Session session;
  uint64_t g = session.restart(s).value();
  auto snap = waitFor(session, g, [](const Snapshot& x) { return x.manyLightDone; });
  ASSERT_TRUE(snap);
  EXPECT_EQ(snap->lightSetsDone, 2);
  EXPECT_EQ(snap->batchCount, 1) << "one MRCS step per light set";
  EXPECT_EQ(snap->lightsProcessed, snap->lightsTotal);
  EXPECT_GT(snap->pairs, 0u);
  Loaded l("cornell-glossy");
  std::vector<ManyLightImages> renders;
  for (int k = 0; k < 2; ++k) {
    const LightSetSettings set = lightSetSettings(s.many, s.estimator, k, s.lightSets);
    EXPECT_EQ(set.many.seed, s.many.seed + uint64_t(k));
    EXPECT_EQ(set.estimator.seed, set.many.seed);
    EXPECT_EQ(set.many.directSamples, (s.many.directSamples + 1) / 2) << "each set its share of the direct samples";
    renders.push_back(l.renderWithMrcs(set.many, mrcsSettings(set.estimator)));
  }
  EXPECT_NE(renders[0].vsl.rgb, renders[1].vsl.rgb) << "independent sets";
  auto layer = [&](Image ManyLightImages::*which) {
    return std::vector<const Image*>{&(renders[0].*which), &(renders[1].*which)};
  };
  EXPECT_EQ(snap->many.vsl.rgb, meanOf(layer(&ManyLightImages::vsl)).rgb);
  EXPECT_EQ(snap->many.vpl.rgb, meanOf(layer(&ManyLightImages::vpl)).rgb);
  EXPECT_EQ(snap->many.direct.rgb, meanOf(layer(&ManyLightImages::direct)).rgb);
  EXPECT_EQ(snap->biasNoise[int(BiasNoiseRow::Vsl)].renders, 2);

  // Another estimator is another picture: the session starts over.
  StudioSettings brute = s;
  brute.estimator.name = "brute-force";
  EXPECT_FALSE(sameImageSettings(s, brute));
  StudioSettings moreRows = s;
  moreRows.estimator.values["mrcs-rows"] = 13;
  EXPECT_FALSE(sameImageSettings(s, moreRows));
}

// An MRCS light set's VSL image is complete before its VPL columns are
// rendered: the first set's VSL picture is published first (after the one
// reference pass a first picture waits for, and with the VPL layers black),
// the whole picture as soon as the step ends (before the reference's further
// passes), and both are bit for bit a direct renderMrcs call's images. Later
// sets publish no VSL-only picture (the completed sets' mean is shown).
TEST(Session, MrcsPublishesTheVslPictureBeforeTheVplColumns) {
  TempCache cache;  // no cached reference: the live path tracer, which has no samples yet
  StudioSettings s = small("cornell-glossy", 300, 16);
  s.many.seed = 11;
  s.lightSets = 2;
  s.maxReferenceSpp = 64;
  s.estimator.name = "mrcs";
  s.estimator.values["mrcs-rows"] = 12;
  s.estimator.values["mrcs-clusters"] = 40;
  Session session;
  std::vector<std::shared_ptr<const Snapshot>> published;  // every snapshot, in order (worker thread)
  session.setPublishHookForTesting(
      [&](const Snapshot& x) { published.push_back(std::make_shared<const Snapshot>(x)); });
  uint64_t g = session.restart(s).value();
  ASSERT_TRUE(waitFor(session, g, [](const Snapshot& x) { return x.manyLightDone; }));
  session.setPublishHookForTesting(nullptr);  // the worker's publishes happened before latest() returned the last one
  ASSERT_GE(published.size(), 3u);

  Loaded l("cornell-glossy");
  const LightSetSettings set0 = lightSetSettings(s.many, s.estimator, 0, s.lightSets);
  const ManyLightImages want = l.renderWithMrcs(set0.many, mrcsSettings(set0.estimator));
  // The first snapshot: the first set's VSL picture, VPL still to come.
  const Snapshot& first = *published[0];
  EXPECT_EQ(first.generation, g);
  EXPECT_TRUE(first.vplPending);
  EXPECT_EQ(first.many.vsl.rgb, want.vsl.rgb);
  EXPECT_EQ(first.many.direct.rgb, want.direct.rgb);
  EXPECT_EQ(first.many.vpl.rgb, Image(16, 16).rgb) << "VPL is black until its columns are rendered";
  EXPECT_EQ(first.ptSpp, 1) << "one reference pass, so that no error is measured against a black image";
  EXPECT_EQ(first.lightSetsDone, 0);
  EXPECT_TRUE(first.history.empty()) << "no error point while VPL's is unknown";
  // The second: the whole first set, as soon as the step ended.
  const Snapshot& second = *published[1];
  EXPECT_FALSE(second.vplPending);
  EXPECT_EQ(second.lightSetsDone, 1);
  EXPECT_EQ(second.many.vsl.rgb, want.vsl.rgb);
  EXPECT_EQ(second.many.vpl.rgb, want.vpl.rgb);
  EXPECT_EQ(second.ptSpp, 1) << "before the reference catches up with the step";
  EXPECT_EQ(second.history.size(), 1u);
  // Then the reference's further passes; the second set shows no VSL-only picture.
  EXPECT_GT(published[2]->ptSpp, 1);
  for (size_t i = 1; i < published.size(); ++i) EXPECT_FALSE(published[i]->vplPending) << i;
  EXPECT_EQ(published.back()->lightSetsDone, 2);
}

// The consistent progressive VSL: light set k's radii are scaled by
// progressiveRadiusFactor(k, alpha); the picture is the mean of brute-force
// renders made directly with those radius scales.
TEST(Session, ProgressiveRadiusShrinksTheRadiiPerLightSet) {
  TempCache cache;
  StudioSettings s = small("cornell-glossy", 300, 16);
  s.many.seed = 3;
  s.lightSets = 2;
  s.estimator.progressiveRadius = true;
  s.estimator.alpha = 0.5f;
  Session session;
  uint64_t g = session.restart(s).value();
  auto snap = waitFor(session, g, [](const Snapshot& x) { return x.manyLightDone; });
  ASSERT_TRUE(snap);
  Loaded l("cornell-glossy");
  std::vector<ManyLightImages> renders;
  for (int k = 0; k < 2; ++k) {
    ManyLightSettings m = s.many;
    m.seed = s.many.seed + uint64_t(k);
    m.radiusScale *= progressiveRadiusFactor(k, 0.5f);
    renders.push_back(l.render(m));
  }
  EXPECT_LT(progressiveRadiusFactor(1, 0.5f), 1.0f);
  EXPECT_EQ(snap->many.vsl.rgb, meanOf({&renders[0].vsl, &renders[1].vsl}).rgb);
  // VPL has no radius: only the seeds differ.
  EXPECT_EQ(snap->many.vpl.rgb, meanOf({&renders[0].vpl, &renders[1].vpl}).rgb);
  StudioSettings fixed = s;
  fixed.estimator.progressiveRadius = false;
  EXPECT_FALSE(sameImageSettings(s, fixed));
}

// Invalid estimator settings are refused with the setting's name.
TEST(Session, InvalidEstimatorSettingsAreRejected) {
  Session session;
  StudioSettings s = small("furnace", 30, 8);
  s.estimator.name = "mrcs";
  s.estimator.values["mrcs-rows"] = 0;
  Result<uint64_t> r = session.restart(s);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("mrcs rows"), std::string::npos) << r.error();
  s.estimator.values["mrcs-rows"] = 10;
  s.estimator.progressiveRadius = true;
  s.estimator.alpha = 1.5f;
  r = session.restart(s);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("alpha"), std::string::npos) << r.error();
}

// The lobe gather in the studio: the picture is, bit for bit, the mean of
// brute-force renders with it made directly, it changes VSL's picture and
// not VPL's; with MRCS too.
TEST(Session, LobeGatherEqualsDirectRendersWithEitherEstimator) {
  TempCache cache;
  StudioSettings s = small("cornell-glossy", 300, 16);
  s.many.seed = 5;
  s.many.lobeGather = 2000;
  s.lightSets = 2;
  Session session;
  uint64_t g = session.restart(s).value();
  auto snap = waitFor(session, g, [](const Snapshot& x) { return x.manyLightDone; });
  ASSERT_TRUE(snap);
  Loaded l("cornell-glossy");
  std::vector<ManyLightImages> with, without;
  for (int k = 0; k < 2; ++k) {
    ManyLightSettings m = s.many;
    m.seed = s.many.seed + uint64_t(k);
    with.push_back(l.render(m));
    m.lobeGather = 0;
    without.push_back(l.render(m));
  }
  EXPECT_EQ(snap->many.vsl.rgb, meanOf({&with[0].vsl, &with[1].vsl}).rgb);
  EXPECT_EQ(snap->many.vpl.rgb, meanOf({&with[0].vpl, &with[1].vpl}).rgb);
  EXPECT_NE(with[0].vsl.rgb, without[0].vsl.rgb) << "cornell-glossy has receivers the lobe gather takes";
  EXPECT_EQ(with[0].vpl.rgb, without[0].vpl.rgb) << "clamped VPL does not change";
  StudioSettings other = s;
  other.many.lobeGather = 0;
  EXPECT_FALSE(sameImageSettings(s, other));
  // MRCS: the picture changes VSL's picture and not VPL's (bit for bit
  // against MRCS without it; the images against brute force: test_mrcs).
  s.estimator.name = "mrcs";
  s.estimator.values["mrcs-rows"] = 10;
  s.estimator.values["mrcs-clusters"] = 20;
  s.lightSets = 1;
  std::shared_ptr<const Snapshot> mrcs[2];
  for (uint32_t lobe : {2000u, 0u}) {
    s.many.lobeGather = lobe;
    Result<uint64_t> r = session.restart(s);
    ASSERT_TRUE(r) << r.error();
    mrcs[lobe ? 0 : 1] = waitFor(session, *r, [](const Snapshot& x) { return x.manyLightDone; });
    ASSERT_TRUE(mrcs[lobe ? 0 : 1]);
  }
  EXPECT_NE(mrcs[0]->many.vsl.rgb, mrcs[1]->many.vsl.rgb);
  EXPECT_EQ(mrcs[0]->many.vpl.rgb, mrcs[1]->many.vpl.rgb);
}

// A restart while the lobe gather's second light set is traced takes effect
// promptly, and the set stopped half way is never rendered from.
TEST(Session, RestartWhileTracingTheLobeGatherSetStopsPromptly) {
  Session session;
  StudioSettings s = small("kitchen", 1000, 16);
  s.many.lobeGather = 10'000'000;  // tens of seconds of tracing on two cores
  uint64_t g = session.restart(s, true).value();
  (void)g;
  Session::Status st = session.status();
  for (int i = 0; i < 3000 && st.stage != "tracing lobe-gather lights"; ++i) {
    std::this_thread::sleep_for(10ms);
    st = session.status();
  }
  ASSERT_EQ(st.stage, "tracing lobe-gather lights");
  EXPECT_EQ(st.lightsTarget, 10'000'000u);
  std::this_thread::sleep_for(200ms);
  auto t0 = std::chrono::steady_clock::now();
  StudioSettings next = small("kitchen", 1000, 16);
  next.many.lobeGather = 1000;
  next.lightSets = 1;
  uint64_t g2 = session.restart(next).value();
  auto snap = waitFor(session, g2, [](const Snapshot& x) { return x.manyLightDone; });
  ASSERT_TRUE(snap);
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(seconds, 10.0);
  Loaded l("kitchen");
  EXPECT_EQ(snap->many.vsl.rgb, l.render(next.many).vsl.rgb) << "rendered with its own complete second set";
}

// A restart that keeps the images (here: a background reference asked for)
// while the lobe gather's second light set is traced resumes the job; the
// set stopped half way is traced again, never rendered from: the picture is,
// bit for bit, a direct render's.
TEST(Session, ResumedJobTracesAStoppedLobeGatherSetAgain) {
  TempCache cache;
  StudioSettings s = small("kitchen", 1000, 16);
  s.lightSets = 1;
  s.many.lobeGather = kLongLobeGather;  // a fraction of a second of tracing, seconds under the sanitizers
  Session session;
  ASSERT_TRUE(session.restart(s, true));
  Session::Status st = session.status();
  for (int i = 0; i < 3000 && st.stage != "tracing lobe-gather lights"; ++i) {
    std::this_thread::sleep_for(2ms);
    st = session.status();
  }
  ASSERT_EQ(st.stage, "tracing lobe-gather lights");
  StudioSettings same = s;
  same.backgroundReferenceSpp = 4;
  ASSERT_TRUE(sameImageSettings(s, same));
  uint64_t g2 = session.restart(same).value();
  auto snap = waitFor(session, g2, [](const Snapshot& x) { return x.manyLightDone; });
  ASSERT_TRUE(snap);
  Loaded l("kitchen");
  EXPECT_EQ(snap->many.vsl.rgb, l.render(s.many).vsl.rgb);
}

// A restart while a large MRCS set renders takes effect promptly: MRCS
// checks the stop flag between its stages and tiles.
TEST(Session, RestartDuringMrcsStopsPromptly) {
  Session session;
  StudioSettings s = small("kitchen", 20000, 96);
  s.lightSets = 2;
  s.estimator.name = "mrcs";
  s.estimator.values["mrcs-rows"] = 400;
  s.estimator.values["mrcs-clusters"] = 2000;
  uint64_t g = session.restart(s, true).value();
  (void)g;
  // MRCS names its stage only once its step has begun, some time after the
  // session's stage reads "rendering": wait for the name (a loaded machine
  // can take seconds to get there), then restart in the middle.
  Session::Status st = session.status();
  for (int i = 0; i < 3000 && (st.stage != "rendering" || st.stepProgress.empty()); ++i) {
    std::this_thread::sleep_for(10ms);
    st = session.status();
  }
  std::this_thread::sleep_for(200ms);
  st = session.status();
  EXPECT_EQ(st.stage, "rendering") << "the first set's MRCS render is in progress";
  EXPECT_EQ(st.stepProgress.rfind("MRCS ", 0), 0u) << "its stage is shown: '" << st.stepProgress << "'";
  auto t0 = std::chrono::steady_clock::now();
  uint64_t g2 = session.restart(small("furnace", 30, 8)).value();
  auto snap = waitFor(session, g2, [](const Snapshot& x) { return x.batchesDone > 0; });
  ASSERT_TRUE(snap);
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(seconds, 5.0) << "stage when restarted: " << st.stage;
}

// Asking for fewer sets while a later one renders keeps the completed ones:
// the set in progress is dropped, the picture stays the first set's (bit for
// bit one render with the first seed), and the methods' clocks never run
// backwards.
TEST(Session, FewerLightSetsKeepTheCompletedOnes) {
  Session session;
  StudioSettings s = small("cornell-glossy", kLongSetLights, 16);
  s.many.batches = 16;
  s.lightSets = 3;
  uint64_t g = session.restart(s).value();
  auto first = waitFor(session, g, [](const Snapshot& x) { return x.lightSetsDone == 1 && !x.manyLightDone; });
  ASSERT_TRUE(first);
  s.lightSets = 1;
  auto t0 = std::chrono::steady_clock::now();
  g = session.restart(s).value();
  auto snap = waitFor(session, g, [](const Snapshot& x) { return x.manyLightDone; });
  ASSERT_TRUE(snap);
  // Resumed, not rendered again: done far sooner than a set takes.
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(seconds, 0.5 * first->seconds) << "a set takes about " << first->seconds << " s";
  EXPECT_EQ(snap->lightSetsDone, 1);
  EXPECT_EQ(snap->lightsProcessed, snap->lightsTotal);
  EXPECT_GE(snap->vslSeconds, first->vslSeconds);
  EXPECT_GE(snap->vplSeconds, first->vplSeconds);
  for (size_t i = 1; i < snap->history.size(); ++i)
    EXPECT_GE(snap->history[i].vslSeconds, snap->history[i - 1].vslSeconds) << i;
  Loaded l("cornell-glossy");
  EXPECT_EQ(snap->many.vsl.rgb, l.render(s.many).vsl.rgb);
}

// A restart while a later light set is being traced or gathered stops it
// within one step of work (generous bound: the machine is shared).
TEST(Session, RestartDuringALaterLightSetStopsPromptly) {
  Session session;
  StudioSettings s = small("cornell-glossy", kLongSetLights, 24);
  s.many.batches = 16;
  s.lightSets = 4;
  for (int delayMs : {0, 300}) {
    uint64_t g = session.restart(s, true).value();
    ASSERT_TRUE(waitFor(session, g, [](const Snapshot& x) { return x.lightSetsDone >= 1; }));
    std::this_thread::sleep_for(std::chrono::milliseconds(delayMs));
    Session::Status st = session.status();
    auto t0 = std::chrono::steady_clock::now();
    uint64_t g2 = session.restart(small("furnace", 30, 8)).value();
    auto snap = waitFor(session, g2, [](const Snapshot& x) { return x.batchesDone > 0; });
    ASSERT_TRUE(snap);
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_LT(seconds, 5.0) << "stage when restarted: " << st.stage;
  }
}

// ---- References (reference.h): the live path tracer's halves, a converged
// reference from the cache or a file, and one rendered in the background.

// Without a converged reference every error is measured against the live
// path tracer with its own noise, relMSE(A, B) / 4, subtracted; the path
// tracer's own point is that noise estimate. It goes on past its setting
// while that noise is above a fifth of the smallest method error
// (docs/REFERENCE.md, "The live path tracer as the reference"): at 8 spp on
// 16x16 pixels it is far above, so it refines, to at most 64 x 8 spp.
TEST(Session, LiveReferenceNoiseIsEstimatedAndSubtracted) {
  TempCache cache;
  Session session;
  uint64_t g = session.restart(small("cornell-glossy", 200, 16)).value();
  auto snap = waitFor(session, g, [](const Snapshot& s) { return s.manyLightDone && s.referenceDone; });
  ASSERT_TRUE(snap);
  EXPECT_FALSE(snap->convergedReference);
  EXPECT_EQ(snap->referenceSource, "live path tracer");
  ASSERT_GT(snap->referenceNoise, 0);
  const ErrorSample& e = snap->history.back();
  EXPECT_DOUBLE_EQ(e.referenceNoise, snap->referenceNoise);
  EXPECT_DOUBLE_EQ(e.pt, snap->referenceNoise);
  EXPECT_NEAR(e.vsl, compareImages(snap->many.vsl, snap->ptIndirect).average.relMse - snap->referenceNoise, 1e-12);
  // Each method has its own clock, and both include light tracing.
  EXPECT_GE(e.vslSeconds, snap->lightTracingSeconds);
  EXPECT_GE(e.vplSeconds, snap->lightTracingSeconds);
  EXPECT_GT(snap->ptSpp, 8);
  EXPECT_LE(snap->ptSpp, 8 * kLiveReferenceSppFactor);
  EXPECT_GE(snap->ptSpp, snap->referenceTargetSpp);  // done: the target (as last estimated) reached
}

// liveReferenceTarget: the setting until it is reached; then the count at
// which the noise, falling as 1/spp, is a fifth of the smallest error the
// methods showed before the noise was subtracted.
TEST(Session, LiveReferenceTargetFollowsTheSmallestError) {
  ErrorSample e{};
  e.vsl = 0.03;
  e.vpl = 0.04;
  e.referenceNoise = 0.2;                                     // smallest error before subtraction: 0.23
  EXPECT_EQ(liveReferenceTarget(512, 1024, 0.4, {e}), 1024);  // the setting first
  EXPECT_EQ(liveReferenceTarget(1024, 1024, 0.2, {}), 1024);  // no error measured yet
  // 1024 x 0.2 / (0.23 / 5) = 4452.17...
  EXPECT_EQ(liveReferenceTarget(1024, 1024, 0.2, {e}), 4453);
  EXPECT_EQ(liveReferenceTarget(1024, 1024, 0.001, {e}), 1024);                         // quiet enough
  EXPECT_EQ(liveReferenceTarget(1024, 1024, 50, {e}), 1024 * kLiveReferenceSppFactor);  // at most 64x
}

// A cached reference of the right key is found and used; errors are
// measured against it with its noise subtracted.
TEST(Session, UsesAMatchingCachedReference) {
  TempCache cache;
  Result<std::unique_ptr<RenderContext>> ctx = RenderContext::load(asset("cornell-glossy"));
  ASSERT_TRUE(ctx) << ctx.error();
  const Scene& scene = (*ctx)->scene();
  RenderSettings rs;
  rs.width = rs.height = 16;
  rs.seed = 5;
  ReferenceRenderer rr(scene, (*ctx)->accel(), (*ctx)->lights(), rs);
  while (rr.spp() < 32) ASSERT_TRUE(rr.step());
  vsl::Reference ref = rr.result();
  ref.key = referenceKey(scene, 16, 16, RenderSettings().maxDepth);
  Result<std::string> stored = storeCachedReference(ref, scene.path);
  ASSERT_TRUE(stored) << stored.error();

  Session session;
  uint64_t g = session.restart(small("cornell-glossy", 200, 16)).value();
  auto snap = waitFor(session, g, [](const Snapshot& s) { return s.manyLightDone && s.referenceDone; });
  ASSERT_TRUE(snap);
  EXPECT_TRUE(snap->convergedReference);
  EXPECT_EQ(snap->referenceSource, "cache: " + referenceCachePath(ref.key));
  EXPECT_EQ(snap->referenceSpp, 32);
  EXPECT_EQ(snap->refIndirect.rgb, ref.indirect.rgb);
  EXPECT_NEAR(snap->referenceNoise, ref.indirectNoise(), 1e-12);
  const ErrorSample& e = snap->history.back();
  EXPECT_NEAR(e.vpl, compareImages(snap->many.vpl, ref.indirect).average.relMse - ref.indirectNoise(), 1e-12);
  EXPECT_NEAR(e.pt, compareImages(snap->ptIndirect, ref.indirect).average.relMse - ref.indirectNoise(), 1e-12);
  // The live path tracer is a ReferenceRenderer of seed 0 stepped one pass at
  // a time: its mean, and its bias and noise from its two halves against the
  // converged reference, are those of one made here.
  RenderSettings live = rs;
  live.seed = 0;
  ReferenceRenderer pt(scene, (*ctx)->accel(), (*ctx)->lights(), live);
  while (pt.spp() < snap->ptSpp) ASSERT_TRUE(pt.stepPass());
  EXPECT_EQ(snap->ptIndirect.rgb, pt.meanIndirect().rgb);
  const Image a = pt.halfIndirect(0), b = pt.halfIndirect(1);
  BiasVarianceResult want = biasVariance({&a, &b}, ref.indirect);
  const BiasNoise& got = snap->biasNoise[int(BiasNoiseRow::Pt)];
  EXPECT_EQ(got.renders, 2);
  EXPECT_DOUBLE_EQ(got.bias2, want.average.bias2);
  EXPECT_DOUBLE_EQ(got.variance, want.average.variance);
}

// A reference file of another size is refused with its reason; the render
// goes on against the live path tracer.
TEST(Session, AReferenceOfAnotherSizeIsRefused) {
  TempCache cache;
  std::string path = cache.dir + "-ref.exr";
  Result<void> written = writeExr(path, {{"indirect", Image(20, 16)}});
  ASSERT_TRUE(written) << written.error();
  Session session;
  StudioSettings s = small("cornell-glossy", 200, 16);
  s.referencePath = path;
  uint64_t g = session.restart(s).value();
  auto snap = waitFor(session, g, [](const Snapshot& x) { return x.manyLightDone && x.referenceDone; });
  ASSERT_TRUE(snap);
  EXPECT_FALSE(snap->convergedReference);
  Session::Status st = session.status();
  EXPECT_NE(st.runError.find("20x16"), std::string::npos) << st.runError;
  EXPECT_NE(st.runError.find(path), std::string::npos) << st.runError;
  std::filesystem::remove(path);
}

// "Render reference in background": once the live render is done, a
// reference of the asked samples goes into the cache and is then used.
TEST(Session, BackgroundReferenceFillsTheCacheAndIsUsed) {
  TempCache cache;
  Session session;
  StudioSettings s = small("cornell-glossy", 200, 16);
  s.backgroundReferenceSpp = 16;
  uint64_t g = session.restart(s).value();
  auto snap = waitFor(session, g, [](const Snapshot& x) { return x.convergedReference && x.referenceDone; });
  ASSERT_TRUE(snap);
  EXPECT_EQ(snap->referenceSpp, 16);
  EXPECT_EQ(snap->referenceSource.rfind("cache: ", 0), 0u) << snap->referenceSource;
  SceneResult lr = loadScene(asset("cornell-glossy"));
  ASSERT_TRUE(lr) << lr.error();
  auto cached = findCachedReference(referenceKey(**lr, 16, 16, RenderSettings().maxDepth), 16, 16);
  ASSERT_TRUE(cached);
  EXPECT_EQ(cached->spp, 16);
  EXPECT_EQ(cached->indirect.rgb, snap->refIndirect.rgb);
  // Independent of the live path tracer (another seed): they differ.
  EXPECT_NE(snap->refIndirect.rgb, snap->ptIndirect.rgb);
}

// Equal time: errors interpolated at the same own time for every method.
TEST(Session, ErrorsAtEqualOwnTime) {
  auto sample = [](double tv, double ev, double tp, double ep, double tt, double et) {
    ErrorSample e{};
    e.vslSeconds = tv;
    e.vsl = ev;
    e.vplSeconds = tp;
    e.vpl = ep;
    e.ptSeconds = tt;
    e.pt = et;
    return e;
  };
  std::vector<ErrorSample> h = {sample(1, 0.4, 0.5, 0.3, 1, 0.8), sample(3, 0.2, 1.5, 0.1, 2, 0.4)};
  EXPECT_DOUBLE_EQ(equalTimeBudget(h), 1.5);  // VPL has had the least time
  EXPECT_DOUBLE_EQ(errorAtOwnTime(h, StudioMethod::Vsl, 1.5), 0.35);
  EXPECT_DOUBLE_EQ(errorAtOwnTime(h, StudioMethod::Vpl, 1.5), 0.1);
  EXPECT_DOUBLE_EQ(errorAtOwnTime(h, StudioMethod::Pt, 1.5), 0.6);
  EXPECT_TRUE(std::isnan(errorAtOwnTime(h, StudioMethod::Vsl, 0.5)));  // before its first point
  EXPECT_TRUE(std::isnan(errorAtOwnTime(h, StudioMethod::Pt, 2.5)));   // beyond its last
  EXPECT_EQ(equalTimeBudget({}), 0.0);
}
