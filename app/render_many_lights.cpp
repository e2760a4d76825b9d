// `vsl render --method vsl|vpl|all`: traces one virtual light set, gathers it
// with the chosen estimator (--estimator: brute-force batches, MRCS, any
// registered one), and writes the EXR layers of the chosen method(s), the
// optional PNG and --json statistics.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "app/cli.h"
#include "app/render.h"
#include "core/estimator_json.h"
#include "core/image_io.h"
#include "core/log.h"
#include "core/presets.h"

namespace vsl {

namespace {

using json = nlohmann::json;

// What a gather produced, whichever estimator ran.
struct Gathered {
  ManyLightImages im;
  int w = 0, h = 0, batches = 0;
  size_t lightsProcessed = 0;
  uint64_t pairs = 0, shadowRays = 0, vslEvaluations = 0, nonFinite = 0, rouletteDropped = 0;
  double seconds = 0;
  std::vector<std::pair<std::string, double>> statistics;  // the estimator's own
};

// One long step (EstimatorInfo::wholeSetPerStep) on a thread of its own
// while this one shows its stages (`sp`, which the estimator reports to) as
// a share of the step.
void longStepWithProgress(ManyLightEstimator& est, const StepProgress& sp, Progress& progress) {
  std::atomic<bool> finished{false};
  std::thread worker([&] {
    est.step();
    finished = true;
  });
  while (!finished) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (const std::string text = sp.text(); !text.empty()) progress.update(sp.share(), text);
  }
  worker.join();
}

// The progress line after a brute-force batch: done in time where the
// batches' costs predict the rest (a batch's per-pixel work does not scale
// with its lights), else in lights.
void showBatch(const ManyLightEstimator& est, double el, Progress& progress) {
  const std::optional<double> left = est.remainingSeconds();
  char detail[200], eta[48] = "";
  if (left && *left > 0) std::snprintf(eta, sizeof eta, ", ~%.1f s left", *left);
  std::snprintf(detail, sizeof detail, "batch %d/%d, %zu lights, %.2f Mpairs/s, %.1f s%s", est.stepsDone(),
                est.stepCount(), est.lightsProcessed(), est.stats().pairs / std::max(el, 1e-9) * 1e-6, el, eta);
  const size_t n = est.run().set.lights.size();
  progress.update(left ? el / std::max(el + *left, 1e-9) : double(est.lightsProcessed()) / std::max<size_t>(n, 1),
                  detail);
}

// Steps the estimator until it is done or the time limit is reached, then
// prints what its last step has to say (ManyLightEstimator::stepReport).
void gather(const RenderArgs& a, ManyLightEstimator& est, const StepProgress& sp, Gathered& g) {
  const EstimatorInfo& info = *findEstimator(a.estimator.name);
  if (info.wholeSetPerStep)
    std::fprintf(stderr, "render: %s over %zu lights\n", a.estimator.describe().c_str(), est.run().set.lights.size());
  Progress progress("render");
  Stopwatch clock;
  double stepSeconds = 0;
  while (!est.done()) {
    Stopwatch stepClock;
    if (info.wholeSetPerStep) {
      longStepWithProgress(est, sp, progress);
      char done[64];
      std::snprintf(done, sizeof done, "step %d/%d done, %.1f s", est.stepsDone(), est.stepCount(), clock.seconds());
      progress.update(double(est.stepsDone()) / std::max(est.stepCount(), 1), done);
    } else {
      est.step();
      showBatch(est, clock.seconds(), progress);
    }
    stepSeconds = stepClock.seconds();
    if (a.settings.timeLimit > 0 && clock.seconds() >= a.settings.timeLimit) break;
  }
  progress.finish();
  g.im = est.images();
  g.w = est.width();
  g.h = est.height();
  g.batches = est.stepsDone();
  g.lightsProcessed = est.lightsProcessed();
  const ManyLightStats& st = est.stats();
  g.pairs = st.pairs;
  g.shadowRays = st.shadowRays;
  g.vslEvaluations = st.vslEvaluations;
  g.rouletteDropped = st.rouletteDropped;
  g.nonFinite = st.nonFinite;
  g.statistics = est.statistics();
  const StepReport report = est.stepReport(stepSeconds);
  for (const std::string& w : report.warnings) std::fprintf(stderr, "render: warning: %s\n", w.c_str());
  for (const std::string& line : report.info) std::fprintf(stderr, "render: %s\n", line.c_str());
}

// The EXR layers of the method(s), the default layer (index 0) being the
// chosen component.
std::vector<Layer> manyLightLayers(const RenderArgs& a, const ManyLightImages& im) {
  const RenderSettings& s = a.settings;
  auto pick = [&](const Image& ind, const Image& full) -> const Image& {
    return s.component == Component::Direct ? im.direct : s.component == Component::Indirect ? ind : full;
  };
  Image vslFull = addImages(im.direct, im.vsl), vplFull = addImages(im.direct, im.vpl);
  if (a.method == Method::All) {
    std::vector<Layer> layers = {{"", pick(im.vsl, vslFull)}, {"vsl-full", vslFull},    {"vsl-indirect", im.vsl},
                                 {"vpl-full", vplFull},       {"vpl-indirect", im.vpl}, {"direct", im.direct}};
    if (findEstimator(a.estimator.name)->vplVariants)  // else it renders the two methods only
      layers.insert(layers.end(), {{"vpl-unclamped-indirect", im.vplUnclamped},
                                   {"vpl-diffuse-indirect", im.vplDiffuse},
                                   {"lost-to-clamping", im.lostToClamping},
                                   {"lost-to-diffuse", im.lostToDiffuse}});
    return layers;
  }
  const Image& ind = a.method == Method::Vsl ? im.vsl : im.vpl;
  const Image& full = a.method == Method::Vsl ? vslFull : vplFull;
  return {{"", pick(ind, full)}, {"full", full}, {"direct", im.direct}, {"indirect", ind}};
}

// The EXR and the optional PNG (of the default layer).
int writeManyLightImages(const RenderArgs& a, const Gathered& g) {
  const RenderSettings& s = a.settings;
  const std::vector<Layer> layers = manyLightLayers(a, g.im);
  std::map<std::string, std::string> attrs = {{"vsl.version", VSL_VERSION},
                                              {"vsl.scene", a.scene},
                                              {"vsl.method", s.method},
                                              {"vsl.settings", a.many.describe()},
                                              {"vsl.estimator", a.estimator.describe()},
                                              {"vsl.environment", a.env.describe()},
                                              {"vsl.component", componentName(s.component)}};
  if (Result<void> written = writeExr(a.out, layers, attrs); !written) return fail(kExitBadInput, written.error());
  std::string names;
  for (const Layer& l : layers)
    names += (names.empty() ? "" : ", ") + (l.name.empty() ? std::string("default") : l.name);
  std::fprintf(stderr, "wrote %s (%dx%d, %s, layers: %s)\n", a.out.c_str(), g.w, g.h, s.method.c_str(), names.c_str());
  if (!a.png.empty()) {
    if (Result<void> written = writePng(a.png, layers[0].image, a.exposure); !written)
      return fail(kExitBadInput, written.error());
    std::fprintf(stderr, "wrote %s\n", a.png.c_str());
  }
  return 0;
}

// Timings of the stages before and around the gather.
struct ManyLightTimes {
  double load = 0, bvh = 0, total = 0;
};

int writeManyLightJson(const RenderArgs& a, const Scene& scene, const ManyLightRun& run, const Gathered& g,
                       ManyLightTimes t, uint64_t rejected) {
  const ManyLightImages& im = g.im;
  auto q = [&](double f) { return double(percentile(run.radii, f)); };
  // The means of the layers this render computed (manyLightLayers): a method
  // not rendered, or a VPL variant the estimator never renders, is left out,
  // not 0; so are the counts it does not keep.
  const EstimatorInfo& info = *findEstimator(a.estimator.name);
  const bool counted = info.countsNotKept.empty(), vsl = a.method != Method::Vpl, vpl = a.method != Method::Vsl;
  json mean = {{"direct", imageMeanJson(im.direct)}};
  if (vsl) mean["vslIndirect"] = imageMeanJson(im.vsl);
  if (vpl) mean["vplIndirect"] = imageMeanJson(im.vpl);
  if (vpl && info.vplVariants) {
    mean["vplUnclampedIndirect"] = imageMeanJson(im.vplUnclamped);
    mean["vplDiffuseIndirect"] = imageMeanJson(im.vplDiffuse);
    mean["lostToClamping"] = imageMeanJson(im.lostToClamping);
    mean["lostToDiffuse"] = imageMeanJson(im.lostToDiffuse);
  }
  json j = {{"version", VSL_VERSION},
            {"scene", a.scene},
            {"method", a.settings.method},
            {"estimator", a.estimator.name},
            {"estimatorParameters", estimatorValuesJson(a.estimator)},
            {"estimatorStats", estimatorStatsJson(g.statistics)},
            {"settings", a.many.describe()},
            {"environment", a.env.describe()},
            {"preset", matchingPreset(a.many)},
            {"width", g.w},
            {"height", g.h},
            {"component", componentName(a.settings.component)},
            {"lights", run.set.lights.size()},
            {"lightsProcessed", g.lightsProcessed},
            {"batches", g.batches},
            {"lightPaths", run.set.paths},
            {"bytesPerLight", sizeof(VirtualLight)},
            {"clampBound", manyLightClampBound(scene, a.many)},
            {"radius", {{"min", q(0)}, {"median", q(0.5)}, {"max", q(1)}}},
            {"seconds",
             {{"load", t.load},
              {"bvh", t.bvh},
              {"lightTracing", run.set.seconds},
              {"knn", run.knnSeconds},
              {"gather", g.seconds},
              {"total", t.total}}},
            {"pairs", g.pairs},
            {"pairsPerSecond", g.pairs / std::max(g.seconds, 1e-9)},
            {"shadowRays", !counted ? json(nullptr) : json(g.shadowRays)},
            {"vslEvaluations", !counted || !vsl ? json(nullptr) : json(g.vslEvaluations)},
            {"pairsDroppedByRoulette", g.rouletteDropped},
            {"nonFiniteRejected", rejected},
            {"mean", mean},
            {"warnings", scene.warnings}};
  if (!counted) j["countsNotKept"] = info.countsNotKept;
  if (Result<void> written = writeTextFile(a.jsonPath, j.dump(2) + "\n"); !written)
    return fail(kExitBadInput, written.error());
  std::fprintf(stderr, "wrote %s\n", a.jsonPath.c_str());
  return 0;
}

}  // namespace

int renderManyLights(RenderArgs& a, const RenderContext& ctx) {
  if (!ctx.hasEmitters())
    return failf(kExitBadInput,
                 "%s: the scene has no lights, so there is nothing to trace virtual lights from (light it "
                 "with --env, --sky or --sun)",
                 a.scene.c_str());
  // Trace the virtual lights and their radii.
  Stopwatch total;
  ManyLightRun run = prepareManyLights(ctx, a.many);
  std::fprintf(stderr,
               "traced %zu virtual lights from %llu paths in %.2f s (%zu bytes each, %.1f MB); radii in %.2f s\n",
               run.set.lights.size(), (unsigned long long)run.set.paths, run.set.seconds, sizeof(VirtualLight),
               run.set.bytes() / 1e6, run.knnSeconds);
  if (run.set.lights.empty())
    std::fprintf(stderr,
                 "warning: %s: no light path met a surface, so there is no virtual light and no indirect light: "
                 "every many-light image is the direct light alone\n",
                 a.scene.c_str());
  // Gather them, and write what came out.
  StepProgress sp;
  std::unique_ptr<ManyLightEstimator> est = makeEstimator(ctx, std::move(run), a.many, a.estimator, &sp);
  Gathered g;
  Stopwatch gatherClock;
  gather(a, *est, sp, g);
  g.seconds = gatherClock.seconds();
  if (int rc = writeManyLightImages(a, g); rc != 0) return rc;
  const ManyLightRun& lights = est->run();
  uint64_t rejected = g.nonFinite + lights.set.nonFiniteRejected;
  if (rejected > 0) log::warning("rejected " + std::to_string(rejected) + " non-finite contributions");
  if (!a.jsonPath.empty())
    return writeManyLightJson(a, ctx.scene(), lights, g, {ctx.loadSeconds(), ctx.bvhSeconds(), total.seconds()},
                              rejected);
  return 0;
}

}  // namespace vsl
