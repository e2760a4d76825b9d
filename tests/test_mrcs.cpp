// Matrix row-column sampling: the representative estimator is unbiased for
// any clustering, and renders agree with brute force, better with more
// clusters.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <tuple>

#include "core/estimator.h"
#include "core/estimator_registry.h"
#include "core/estimators/mrcs/mrcs_estimator.h"
#include "core/mrcs.h"
#include "core/rng.h"

using namespace vsl;

namespace {
// An estimator's statistic by key (ManyLightEstimator::statistics); NaN if absent.
double statistic(const ManyLightEstimator& est, const std::string& key) {
  for (const auto& [k, v] : est.statistics())
    if (k == key) return v;
  return NAN;
}

double mean(const Image& img) {
  double s = 0;
  for (float v : img.rgb) s += v;
  return s / double(img.rgb.size());
}
double relMse(const Image& a, const Image& b) {
  double s = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) {
    double d = double(a.rgb[i]) - b.rgb[i];
    s += d * d / (double(b.rgb[i]) * b.rgb[i] + 1e-2);
  }
  return s / double(a.rgb.size());
}
// The small render the seam and progress tests share: cornell-glossy at
// 16x16 with 400 lights and 2 direct samples.
ManyLightSettings smallRender() {
  ManyLightSettings s;
  s.lights = 400;
  s.width = s.height = 16;
  s.directSamples = 2;
  s.seed = 7;
  return s;
}

// cornell-glossy loaded; null (and a test failure) if it cannot be.
std::unique_ptr<RenderContext> cornellGlossy() {
  Result<std::unique_ptr<RenderContext>> ctx =
      RenderContext::load(std::string(VSL_SOURCE_DIR) + "/assets/scenes/cornell-glossy.gltf");
  if (!ctx) {
    ADD_FAILURE() << ctx.error();
    return nullptr;
  }
  return std::move(*ctx);
}

// cornell-glossy with smallRender()'s light set traced, and MRCS at 24 rows
// and 60 clusters (MIX 3), the VSL spread on or off.
struct SmallMrcs {
  std::unique_ptr<RenderContext> ctx;
  ManyLightSettings s = smallRender();
  MrcsSettings m{24, 60, 3};
  ManyLightRun run;
};
SmallMrcs smallMrcs(bool spread) {
  SmallMrcs r;
  r.ctx = cornellGlossy();
  if (!r.ctx) return r;
  r.m.spreadVslRadius = spread;
  r.run = prepareManyLights(*r.ctx, r.s);
  return r;
}
}  // namespace

TEST(MrcsClustering, FewColumnsAreTheirOwnClusters) {
  const int rows = 4;
  std::vector<float> cols = {1, 0, 0, 0, 0, 0, 0, 0, 0.5f, 0.5f, 0, 0, 0, 0, 0, 2};
  size_t zero = 0;
  auto reps = clusterColumns(cols, 4, rows, 10, 1, &zero);
  EXPECT_EQ(zero, 1u);
  ASSERT_EQ(reps.size(), 3u);
  for (const auto& r : reps) EXPECT_DOUBLE_EQ(r.weight, 1.0);
}

// For every row, sum over representatives of weight x column equals the row
// sum in expectation (the weights undo the norm-proportional choice, with or
// without a defensive uniform share, which also bounds every weight).
class MrcsMix : public ::testing::TestWithParam<double> {};
INSTANTIATE_TEST_SUITE_P(Clustering, MrcsMix, ::testing::Values(0.0, 0.3));
TEST_P(MrcsMix, RepresentativesAreUnbiasedForEveryRow) {
  const double mix = GetParam();
  const int rows = 12, lights = 600, clusters = 40, trials = 600;
  Rng g(3, 3);
  std::vector<float> cols(size_t(lights) * rows);
  for (int j = 0; j < lights; ++j) {
    float a = g.uniform(), b = g.uniform() * 3;  // a few families of similar columns
    for (int r = 0; r < rows; ++r) cols[size_t(j) * rows + r] = a * (1 + std::sin(b + r)) + 0.1f * g.uniform();
  }
  std::vector<double> exact(rows, 0.0), sum(rows, 0.0), sum2(rows, 0.0);
  for (int j = 0; j < lights; ++j)
    for (int r = 0; r < rows; ++r) exact[r] += cols[size_t(j) * rows + r];
  for (int t = 0; t < trials; ++t) {
    auto reps = clusterColumns(cols, lights, rows, clusters, 100 + t, nullptr, mix);
    EXPECT_LE(reps.size(), size_t(clusters));
    // A cluster holds at most all lights, so 1/p <= lights / mix.
    if (mix > 0) {
      for (const auto& rep : reps) ASSERT_LE(rep.weight, lights / mix * (1 + 1e-9));
    }
    for (int r = 0; r < rows; ++r) {
      double e = 0;
      for (const auto& rep : reps) e += rep.weight * cols[size_t(rep.light) * rows + r];
      sum[r] += e;
      sum2[r] += e * e;
    }
  }
  for (int r = 0; r < rows; ++r) {
    double m = sum[r] / trials, se = std::sqrt(std::max(sum2[r] / trials - m * m, 0.0) / trials);
    EXPECT_NEAR(m, exact[r], 4 * se + 1e-9 * exact[r]) << "row " << r;
  }
}

// The paper's estimator (each representative keeps its radius; the default)
// and the optional spread one (a VSL representative's radius grows with
// sqrt(weight)): both approach brute force as clusters grow. The paper's keeps
// brute force's mean within 5%; spreading only ever darkens (large spheres
// lose energy), by less than 10% once weights are ~3 (500 clusters).
class MrcsRender : public ::testing::TestWithParam<bool> {};
INSTANTIATE_TEST_SUITE_P(Spread, MrcsRender, ::testing::Values(false, true));
TEST_P(MrcsRender, AgreesWithBruteForceAndImprovesWithClusters) {
  const bool spread = GetParam();
  const std::unique_ptr<RenderContext> ctx = cornellGlossy();
  ASSERT_TRUE(ctx);
  const Scene& scene = ctx->scene();
  const Accel& accel = ctx->accel();
  const LightSampler& lights = ctx->lights();
  ManyLightSettings s;
  s.lights = 1500;
  s.width = s.height = 24;
  s.batches = 1;
  s.directSamples = 2;
  s.seed = 5;
  ManyLightRun run = prepareManyLights(scene, accel, lights, s);
  ManyLightRenderer brute(scene, accel, lights, run.set, run.radii, s);
  ASSERT_TRUE(brute.renderBatch(0));
  ManyLightImages ref = brute.images();
  std::vector<double> errVsl, errVpl;
  for (int clusters : {20, 100, 500}) {
    double ev = 0, ep = 0, mv = 0;
    const int seeds = 4;
    for (int k = 0; k < seeds; ++k) {
      MrcsSettings m{64, clusters, uint64_t(k)};
      m.spreadVslRadius = spread;
      MrcsResult r = renderMrcs(scene, accel, lights, run.set, run.radii, s, m);
      ASSERT_FALSE(r.stopped);
      EXPECT_EQ(r.images.vsl.width, 24);
      ev += relMse(r.images.vsl, ref.vsl) / seeds;
      ep += relMse(r.images.vpl, ref.vpl) / seeds;
      mv += mean(r.images.vsl) / seeds;
    }
    std::printf("MRCS %4d clusters%s: relMSE vs brute force VSL %.4f VPL %.4f; VSL mean %.5f (brute %.5f)\n", clusters,
                spread ? " (spread)" : "", ev, ep, mv, mean(ref.vsl));
    errVsl.push_back(ev);
    errVpl.push_back(ep);
    if (clusters == 500) {
      EXPECT_NEAR(mv, mean(ref.vsl), (spread ? 0.10 : 0.05) * mean(ref.vsl));
    }
    if (spread) {
      EXPECT_LT(mv, mean(ref.vsl) * 1.02) << clusters << " clusters";
    }
  }
  EXPECT_GT(errVsl[0], errVsl[2]);
  EXPECT_GT(errVpl[0], errVpl[2]);
}

// The seam (estimator.h): the MRCS estimator behind the interface is
// renderMrcs itself, bit for bit for the same light set and seeds, in one
// step; every layer has the render's size (black where MRCS computes
// nothing), and a stop flag set beforehand discards the step.
TEST_P(MrcsRender, EstimatorThroughTheSeamEqualsRenderMrcs) {
  const std::unique_ptr<RenderContext> ctx = cornellGlossy();
  ASSERT_TRUE(ctx);
  const RenderContext& c = *ctx;
  ManyLightSettings s = smallRender();
  EstimatorSettings e = mrcsEstimatorSettings(MrcsSettings{24, 60, 3});
  e.values["mrcs-spread"] = GetParam();
  ManyLightRun run = prepareManyLights(c, s);
  MrcsResult direct = renderMrcs(c.scene(), c.accel(), c.lights(), run.set, run.radii, s, mrcsSettings(e));
  StepProgress progress;
  std::unique_ptr<ManyLightEstimator> est = makeEstimator(c, std::move(run), s, e, &progress);
  EXPECT_EQ(est->name(), "mrcs");
  EXPECT_EQ(est->stepCount(), 1);
  std::atomic<bool> stop{true};
  EXPECT_FALSE(est->step(&stop)) << "stopped before it began";
  EXPECT_EQ(est->stepsDone(), 0);
  EXPECT_EQ(est->images().vsl.width, 16) << "black layers of the render's size before the step";
  // MrcsProgress::overall(): 0 when idle, 1 when done.
  EXPECT_EQ(progress.share(), 0.0) << "a render stopped after its rows is no longer shown";
  EXPECT_EQ(progress.text(), "");
  ASSERT_TRUE(est->step());
  EXPECT_EQ(progress.share(), 1.0);
  EXPECT_EQ(progress.text(), "");
  EXPECT_TRUE(est->done());
  EXPECT_FALSE(est->step()) << "nothing left";
  const ManyLightImages im = est->images();
  EXPECT_EQ(im.vsl.rgb, direct.images.vsl.rgb);
  EXPECT_EQ(im.vpl.rgb, direct.images.vpl.rgb);
  EXPECT_EQ(im.direct.rgb, direct.images.direct.rgb);
  EXPECT_EQ(im.lostToClamping.rgb.size(), im.vsl.rgb.size());
  EXPECT_EQ(est->stats().pairs.load(), direct.pairs);
  EXPECT_EQ(est->lightsProcessed(), est->run().set.lights.size());
  EXPECT_EQ(est->width(), 16);
  EXPECT_EQ(statistic(*est, "zeroColumnsVsl"), double(direct.zeroColumnsVsl));
}

// The lobe gather with MRCS: the eye paths gather the narrow receivers'
// specular lobes as brute force's do and the VSL image adds them to the
// columns, which gather the rest. With a cluster per light (every weight 1)
// MRCS is the brute-force gather over the same eye paths: bit for bit the
// one-batch brute-force image, with the lobe gather as without it. Clamped VPL
// does not change, and the lobe gather's time is VSL's own.
TEST(MrcsLobeGather, AClusterPerLightIsTheBruteForceImage) {
  const std::unique_ptr<RenderContext> ctx = cornellGlossy();
  ASSERT_TRUE(ctx);
  const RenderContext& c = *ctx;
  ManyLightSettings s = smallRender();
  s.batches = 1;
  s.directSamples = 1;
  s.lobeGather = 3000;
  s.lobeGatherRays = 16;
  // Bit for bit with the quadrature: the closed form's pairs in brute
  // force's lanes round differently from MRCS's one by one (core/vsl_sg.h).
  s.vslIntegral = VslIntegral::Quadrature;
  ManyLightSettings off = s;
  off.lobeGather = 0;
  const ManyLightRun run = prepareManyLights(c, s);
  const MrcsSettings all{64, int(run.set.lights.size()), 1};
  for (uint64_t seed : {100, 101}) {
    s.seed = off.seed = seed;  // the eye paths' seed (the light set stays)
    const MrcsResult a = renderMrcs(c.scene(), c.accel(), c.lights(), run.set, run.radii, s, all);
    const MrcsResult b = renderMrcs(c.scene(), c.accel(), c.lights(), run.set, run.radii, off, all);
    ASSERT_FALSE(a.stopped);
    ASSERT_FALSE(b.stopped);
    EXPECT_EQ(a.nonFinite, 0u);
    ManyLightRenderer r(c.scene(), c.accel(), c.lights(), run.set, run.radii, s);
    ASSERT_TRUE(r.renderBatch(0));
    EXPECT_EQ(a.images.vsl.rgb, r.images().vsl.rgb) << "seed " << seed;
    // Clamped VPL too: MRCS's rows and columns take its transfers in blocks
    // (Gatherer::addConnectedMany) as brute force's tiles do.
    EXPECT_EQ(a.images.vpl.rgb, r.images().vpl.rgb) << "seed " << seed;
    ManyLightRenderer r0(c.scene(), c.accel(), c.lights(), run.set, run.radii, off);
    ASSERT_TRUE(r0.renderBatch(0));
    EXPECT_EQ(b.images.vsl.rgb, r0.images().vsl.rgb) << "seed " << seed;
    EXPECT_NE(a.images.vsl.rgb, b.images.vsl.rgb) << "cornell-glossy has receivers the lobe gather takes";
    EXPECT_EQ(a.images.vpl.rgb, b.images.vpl.rgb) << "clamped VPL does not change";
    EXPECT_GT(a.lobeSeconds, 0.0);
    EXPECT_EQ(b.lobeSeconds, 0.0);
  }
  // Through the seam: VSL's time includes the lobe gather's.
  const EstimatorSettings e = mrcsEstimatorSettings(all);
  std::unique_ptr<ManyLightEstimator> est = makeEstimator(c, prepareManyLights(c, s), s, e);
  ASSERT_TRUE(est->step());
  EXPECT_GT(est->stats().vslSeconds, est->stats().vplSeconds);
  EXPECT_GT(statistic(*est, "lobeGatherSeconds"), 0.0);
}

// A stop raised while the lobe gather's light set is traced, or during the
// eye paths that use it, ends the MRCS render there: stopped, the progress
// idle, no image; the next render goes through.
TEST(MrcsLobeGather, StopsWhileItsLightSetIsTracedAndInTheEyePaths) {
  const std::unique_ptr<RenderContext> ctx = cornellGlossy();
  ASSERT_TRUE(ctx);
  const RenderContext& c = *ctx;
  ManyLightSettings s = smallRender();
  s.width = s.height = 96;  // eye paths of about a second with 1,024 directions
  const ManyLightRun run = prepareManyLights(c, s);
  const MrcsSettings m{24, 60, 1};
  // A large set stopped before it begins and while it is traced; a small one
  // (traced in milliseconds) with many directions stopped in the eye paths.
  for (auto [lobeLights, rays, delayMs] :
       {std::tuple{2'000'000u, 16, 0}, std::tuple{2'000'000u, 16, 30}, std::tuple{20'000u, 1024, 250}}) {
    s.lobeGather = lobeLights;
    s.lobeGatherRays = rays;
    std::atomic<bool> stop{delayMs == 0};
    MrcsProgress progress;
    std::thread stopper([&] {
      std::this_thread::sleep_for(std::chrono::milliseconds(delayMs));
      stop = true;
    });
    const MrcsResult r = renderMrcs(c.scene(), c.accel(), c.lights(), run.set, run.radii, s, m, &stop, &progress);
    stopper.join();
    EXPECT_TRUE(r.stopped) << "stopped after " << delayMs << " ms";
    EXPECT_EQ(progress.stage.load(), MrcsProgress::kIdle) << delayMs << " ms";
  }
  s.lobeGather = 2000;
  s.lobeGatherRays = 16;
  const MrcsResult done = renderMrcs(c.scene(), c.accel(), c.lights(), run.set, run.radii, s, m);
  EXPECT_FALSE(done.stopped);
  EXPECT_GT(done.lobeSeconds, 0.0);
}

// overall() through a real render, polled from a second thread as the CLI
// polls it: it starts at 0, never decreases as the stages follow one
// another, stays in [0, 1] and is 1 once the render is done.
TEST_P(MrcsRender, OverallProgressRisesThroughTheStagesToOne) {
  const SmallMrcs small = smallMrcs(GetParam());
  ASSERT_TRUE(small.ctx);
  const auto& [ctx, s, m, run] = small;
  const RenderContext& c = *ctx;
  MrcsProgress progress;
  EXPECT_EQ(progress.overall(), 0.0) << "idle";
  // The poller keeps every change of (stage, overall) and checks each read
  // against the one before.
  struct Seen {
    int stage;
    double overall;
  };
  std::vector<Seen> seen;
  std::atomic<bool> finished{false};
  std::thread poller([&] {
    Seen last{MrcsProgress::kIdle, 0.0};
    while (!finished.load()) {
      const Seen now{progress.stage.load(), progress.overall()};
      if (now.stage != last.stage || now.overall != last.overall) seen.push_back(now);
      last = now;
      std::this_thread::yield();
    }
  });
  MrcsResult r = renderMrcs(c.scene(), c.accel(), c.lights(), run.set, run.radii, s, m, nullptr, &progress);
  finished = true;
  poller.join();
  ASSERT_FALSE(r.stopped);
  EXPECT_EQ(progress.stage.load(), MrcsProgress::kDone);
  EXPECT_EQ(progress.overall(), 1.0) << "done";
  double before = 0.0;
  int beforeStage = MrcsProgress::kIdle;
  for (const Seen& x : seen) {
    EXPECT_GE(x.stage, beforeStage) << "the stages come in order";
    EXPECT_GE(x.overall, before) << "stage " << x.stage << " after stage " << beforeStage;
    EXPECT_LE(x.overall, 1.0) << "stage " << x.stage;
    before = x.overall;
    beforeStage = x.stage;
  }
}

// With both methods, the VSL image is complete before VPL is clustered and
// its columns rendered: onVslImage sees it halfway through the columns stage,
// bit for bit the render's final VSL and direct images with VPL still black,
// and the render's images equal one made without the hook. It is not called
// for one method alone, and a stop set inside it leaves VPL unrendered.
TEST_P(MrcsRender, VslImageIsHandedOutBeforeTheVplColumns) {
  const SmallMrcs small = smallMrcs(GetParam());
  ASSERT_TRUE(small.ctx);
  const auto& [ctx, s, m, run] = small;
  const RenderContext& c = *ctx;
  const MrcsResult plain = renderMrcs(c.scene(), c.accel(), c.lights(), run.set, run.radii, s, m);
  MrcsProgress progress;
  int calls = 0;
  ManyLightImages seen;
  progress.onVslImage = [&](const ManyLightImages& im) {
    ++calls;
    seen = im;
    EXPECT_EQ(progress.stage.load(), MrcsProgress::kColumns);
    EXPECT_EQ(progress.done.load(), 16u) << "VSL's 16 image rows of the columns";
    EXPECT_EQ(progress.total.load(), 32u) << "both methods' rows";
  };
  const MrcsResult r = renderMrcs(c.scene(), c.accel(), c.lights(), run.set, run.radii, s, m, nullptr, &progress);
  ASSERT_FALSE(r.stopped);
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(seen.vsl.rgb, r.images.vsl.rgb);
  EXPECT_EQ(seen.direct.rgb, r.images.direct.rgb);
  EXPECT_EQ(seen.vpl.rgb, Image(16, 16).rgb) << "VPL is black in the VSL-only picture";
  EXPECT_EQ(r.images.vsl.rgb, plain.images.vsl.rgb);
  EXPECT_EQ(r.images.vpl.rgb, plain.images.vpl.rgb);
  EXPECT_EQ(r.images.direct.rgb, plain.images.direct.rgb);
  EXPECT_EQ(r.pairs, plain.pairs);
  EXPECT_GT(r.vslColumnSeconds, 0.0);
  EXPECT_LE(r.vslColumnSeconds, r.columnSeconds);

  // One method alone: nothing to hand out early.
  ManyLightSettings vslOnly = s;
  vslOnly.computeVpl = false;
  calls = 0;
  ASSERT_FALSE(
      renderMrcs(c.scene(), c.accel(), c.lights(), run.set, run.radii, vslOnly, m, nullptr, &progress).stopped);
  EXPECT_EQ(calls, 0);

  // A restart that arrives while the VSL picture is handed out stops the render there.
  std::atomic<bool> stop{false};
  progress.onVslImage = [&](const ManyLightImages&) { stop = true; };
  const MrcsResult stopped = renderMrcs(c.scene(), c.accel(), c.lights(), run.set, run.radii, s, m, &stop, &progress);
  EXPECT_TRUE(stopped.stopped);
  EXPECT_EQ(stopped.zeroColumnsVpl, 0u);
  EXPECT_TRUE(stopped.images.vpl.rgb.empty()) << "VPL's columns were not rendered";
}

// The stage text a long MRCS render shows while it runs.
TEST(MrcsClustering, ProgressNamesTheStageAndItsShare) {
  MrcsProgress p;
  EXPECT_EQ(p.text(), "") << "idle";
  p.begin(MrcsProgress::kRows, 200);
  p.advance(86);
  EXPECT_EQ(p.text(), "MRCS rows 43%");
  p.advance(500);
  EXPECT_EQ(p.text(), "MRCS rows 100%") << "never above 100%";
  p.begin(MrcsProgress::kClustering, 0);
  EXPECT_EQ(p.text(), "MRCS clustering");
  p.begin(MrcsProgress::kColumns, 16);
  p.advance(4);
  EXPECT_EQ(p.text(), "MRCS columns 25%");
  p.begin(MrcsProgress::kDone, 0);
  EXPECT_EQ(p.text(), "");
}

// The whole render's share, each stage weighted by its pairs. 100 pixels,
// 1000 lights, 10 rows, 20 clusters, both methods, 3 direct samples: eye
// paths 100 x (1 + 3) / 4 = 100, rows 10 x 1000 = 10000, columns
// 2 x 20 x 100 = 4000; 14100 in all.
TEST(MrcsClustering, OverallProgressWeighsTheStagesByTheirPairs) {
  MrcsProgress p;
  EXPECT_EQ(p.overall(), 0.0) << "idle, nothing planned";
  p.plan({.pixels = 100, .lights = 1000, .rows = 10, .clusters = 20, .methods = 2, .directSamples = 3});
  EXPECT_EQ(p.overall(), 0.0) << "planned, not begun";
  p.begin(MrcsProgress::kEyePaths, 10);
  p.advance(5);
  EXPECT_DOUBLE_EQ(p.overall(), 50.0 / 14100);
  p.begin(MrcsProgress::kRows, 1000);
  EXPECT_DOUBLE_EQ(p.overall(), 100.0 / 14100) << "the eye paths done, no rows yet";
  p.advance(250);
  EXPECT_DOUBLE_EQ(p.overall(), (100.0 + 2500) / 14100);
  p.advance(5000);
  EXPECT_DOUBLE_EQ(p.overall(), 10100.0 / 14100) << "a stage never counts above its weight";
  p.begin(MrcsProgress::kClustering, 0);
  EXPECT_DOUBLE_EQ(p.overall(), 10100.0 / 14100) << "clustering counts as no work";
  p.begin(MrcsProgress::kColumns, 10);
  p.advance(3);
  EXPECT_DOUBLE_EQ(p.overall(), (10100.0 + 1200) / 14100);
  EXPECT_EQ(p.text(), "MRCS columns 30%") << "the text keeps the stage's own share";
  p.advance(7);
  EXPECT_EQ(p.overall(), 1.0) << "the last stage complete";
  p.begin(MrcsProgress::kDone, 0);
  EXPECT_EQ(p.overall(), 1.0);
  // One method: its columns weigh half as much (2000 of 12100).
  p.plan({.pixels = 100, .lights = 1000, .rows = 10, .clusters = 20, .methods = 1, .directSamples = 3});
  p.begin(MrcsProgress::kColumns, 4);
  p.advance(1);
  EXPECT_DOUBLE_EQ(p.overall(), (10100.0 + 500) / 12100);
  p.begin(MrcsProgress::kIdle, 0);
  EXPECT_EQ(p.overall(), 0.0) << "a stopped render";
}

// Light set k of a progressive run: seed + k for the lights and MRCS's rows,
// radii scaled by progressiveRadiusFactor(k, alpha) only when asked.
TEST(MrcsClustering, LightSetSettingsSeedAndShrinkEachSet) {
  ManyLightSettings m;
  m.seed = 10;
  m.radiusScale = 2;
  EstimatorSettings e;
  e.name = "mrcs";
  LightSetSettings k0 = lightSetSettings(m, e, 0), k3 = lightSetSettings(m, e, 3);
  EXPECT_EQ(k0.many.seed, 10u);
  EXPECT_EQ(k3.many.seed, 13u);
  EXPECT_EQ(k3.estimator.seed, 13u);
  EXPECT_EQ(mrcsSettings(k3.estimator).seed, 13u);
  EXPECT_EQ(k3.many.radiusScale, 2.0f);
  // MRCS spreads the direct-light samples over the sets (at least one each,
  // at least the asked total); brute force keeps them all in every set.
  m.directSamples = 24;
  EXPECT_EQ(lightSetSettings(m, e, 0).many.directSamples, 24) << "one set";
  m.directSamples = 64;
  EXPECT_EQ(lightSetSettings(m, e, 2, 8).many.directSamples, 8);
  EXPECT_EQ(lightSetSettings(m, e, 2, 6).many.directSamples, 11);
  EXPECT_EQ(lightSetSettings(m, e, 0, 100).many.directSamples, 1);
  EstimatorSettings brute;
  EXPECT_EQ(lightSetSettings(m, brute, 2, 8).many.directSamples, 64);
  e.progressiveRadius = true;
  e.alpha = 0.7f;
  EXPECT_EQ(lightSetSettings(m, e, 0).many.radiusScale, 2.0f);
  EXPECT_EQ(lightSetSettings(m, e, 3).many.radiusScale, 2.0f * progressiveRadiusFactor(3, 0.7f));
  EXPECT_TRUE(e.validate());
  e.alpha = 1.0f;
  EXPECT_FALSE(e.validate());
  // Names round-trip; unknown names are refused.
  for (const EstimatorInfo& info : estimators()) EXPECT_EQ(findEstimator(info.name), &info);
  for (Method x : {Method::Pt, Method::Vsl, Method::Vpl, Method::All}) EXPECT_EQ(parseMethod(methodName(x)), x);
  EXPECT_FALSE(parseMethod("VSL"));
  EXPECT_FALSE(findEstimator("bruteforce"));
}
