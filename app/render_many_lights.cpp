// `vsl render --method vsl|vpl|all`: traces one virtual light set, gathers it
// either in progressive light batches (brute force) or with matrix row-column
// sampling (--mrcs), and writes the EXR layers of the chosen method(s), the
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
  json mrcs;  // MRCS statistics; null for the brute-force gather
};

// One MRCS step on a thread of its own while this one shows its stages
// (`mp`, which the estimator reports to) as a share of the whole render
// (MrcsProgress::overall: each stage weighted by its pairs).
void mrcsStepWithProgress(ManyLightEstimator& est, const MrcsProgress& mp, Progress& progress) {
  std::atomic<bool> finished{false};
  std::thread worker([&] {
    est.step();
    finished = true;
  });
  while (!finished) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const int st = mp.stage.load();
    if (st != MrcsProgress::kIdle && st != MrcsProgress::kDone) progress.update(mp.overall(), mp.text());
  }
  worker.join();
}

// Steps the estimator until it is done or the time limit is reached: brute
// force in progressive light batches, MRCS (rows, clustering,
// representative columns) in one step.
void gather(const RenderArgs& a, ManyLightEstimator& est, const MrcsProgress& mp, Gathered& g) {
  const EstimatorSettings& e = a.estimator;
  const size_t n = est.run().set.lights.size();
  if (e.kind == EstimatorKind::Mrcs)
    std::fprintf(stderr, "render: MRCS with %d rows and %d clusters (uniform mix %g) over %zu lights\n", e.mrcs.rows,
                 e.mrcs.clusters, e.mrcs.uniformMix, n);
  Progress progress("render");
  Stopwatch clock;
  if (e.kind == EstimatorKind::Mrcs) {
    mrcsStepWithProgress(est, mp, progress);
    char done[64];
    std::snprintf(done, sizeof done, "MRCS done, %.1f s", clock.seconds());
    progress.update(1.0, done);
  }
  while (!est.done()) {
    est.step();
    double el = clock.seconds();
    // Done in time where the batches' costs predict the rest (a batch's
    // per-pixel work does not scale with its lights), else in lights.
    const std::optional<double> left = est.remainingSeconds();
    char detail[200], eta[48] = "";
    if (left && *left > 0) std::snprintf(eta, sizeof eta, ", ~%.1f s left", *left);
    std::snprintf(detail, sizeof detail, "batch %d/%d, %zu lights, %.2f Mpairs/s, %.1f s%s", est.stepsDone(),
                  est.stepCount(), est.lightsProcessed(), est.stats().pairs / std::max(el, 1e-9) * 1e-6, el, eta);
    progress.update(left ? el / std::max(el + *left, 1e-9) : double(est.lightsProcessed()) / std::max<size_t>(n, 1),
                    detail);
    if (a.settings.timeLimit > 0 && el >= a.settings.timeLimit) break;
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
  if (e.kind != EstimatorKind::Mrcs) return;
  const MrcsStats ms = est.mrcsStats();
  g.mrcs = {{"rows", e.mrcs.rows},
            {"clusters", e.mrcs.clusters},
            {"uniformMix", e.mrcs.uniformMix},
            {"spreadVslRadius", e.mrcs.spreadVslRadius},
            {"rowSeconds", ms.rowSeconds},
            {"clusterSeconds", ms.clusterSeconds},
            {"columnSeconds", ms.columnSeconds},
            {"lobeGatherSeconds", ms.lobeSeconds},
            {"zeroColumnsVsl", ms.zeroColumnsVsl},
            {"zeroColumnsVpl", ms.zeroColumnsVpl},
            {"rowsUsed", ms.rowsUsed},
            {"clustersUsed", ms.clustersUsed}};
  if (ms.rowsUsed < e.mrcs.rows)
    std::fprintf(stderr, "render: warning: %d MRCS rows for %d pixels: %d used (every pixel a row)\n", e.mrcs.rows,
                 g.w * g.h, ms.rowsUsed);
  if (ms.clustersUsed < e.mrcs.clusters)
    std::fprintf(stderr, "render: warning: %d MRCS clusters for %zu lights: a cluster per light\n", e.mrcs.clusters,
                 est.run().set.lights.size());
  std::fprintf(stderr, "render: rows %.2f s, clustering %.2f s, columns %.2f s", ms.rowSeconds, ms.clusterSeconds,
               ms.columnSeconds);
  if (ms.lobeSeconds > 0) std::fprintf(stderr, ", lobe gather %.2f s (in the eye paths)", ms.lobeSeconds);
  std::fprintf(stderr, "\n");
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
    if (a.estimator.kind == EstimatorKind::BruteForce)  // MRCS renders the two methods only
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
  // not rendered, or a VPL variant MRCS never renders, is left out, not 0.
  const bool mrcs = a.estimator.kind == EstimatorKind::Mrcs, vsl = a.method != Method::Vpl,
             vpl = a.method != Method::Vsl;
  json mean = {{"direct", imageMeanJson(im.direct)}};
  if (vsl) mean["vslIndirect"] = imageMeanJson(im.vsl);
  if (vpl) mean["vplIndirect"] = imageMeanJson(im.vpl);
  if (vpl && !mrcs) {
    mean["vplUnclampedIndirect"] = imageMeanJson(im.vplUnclamped);
    mean["vplDiffuseIndirect"] = imageMeanJson(im.vplDiffuse);
    mean["lostToClamping"] = imageMeanJson(im.lostToClamping);
    mean["lostToDiffuse"] = imageMeanJson(im.lostToDiffuse);
  }
  json j = {{"version", VSL_VERSION},
            {"scene", a.scene},
            {"method", a.settings.method},
            {"estimator", estimatorName(a.estimator.kind)},
            {"settings", a.many.describe()},
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
            {"shadowRays", mrcs ? json(nullptr) : json(g.shadowRays)},
            {"vslEvaluations", mrcs || !vsl ? json(nullptr) : json(g.vslEvaluations)},
            {"pairsDroppedByRoulette", g.rouletteDropped},
            {"nonFiniteRejected", rejected},
            {"mean", mean},
            {"warnings", scene.warnings}};
  if (mrcs) j["countsNotKept"] = "MRCS counts its pairs, not its shadow rays or VSL quadrature draws";
  if (!g.mrcs.is_null()) j["mrcs"] = g.mrcs;
  if (Result<void> written = writeTextFile(a.jsonPath, j.dump(2) + "\n"); !written)
    return fail(kExitBadInput, written.error());
  std::fprintf(stderr, "wrote %s\n", a.jsonPath.c_str());
  return 0;
}

}  // namespace

int renderManyLights(RenderArgs& a, const RenderContext& ctx) {
  if (!ctx.hasEmitters())
    return failf(kExitBadInput, "%s: the scene has no lights, so there is nothing to trace virtual lights from",
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
  MrcsProgress mp;
  std::unique_ptr<ManyLightEstimator> est = makeEstimator(ctx, std::move(run), a.many, a.estimator, &mp);
  Gathered g;
  Stopwatch gatherClock;
  gather(a, *est, mp, g);
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
