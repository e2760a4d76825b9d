// `vsl bench SCENE`: measures, in one run and on the same scene and threads,
//   raw Embree occlusion throughput for incoherent rays (camera-visible points
//   toward area-uniform random surface points), single and batched;
//   the path tracer's paths/s and rays/s;
//   the VPL and VSL gathers' pairs/s and shadow rays/s at a few light counts
//   and image sizes, each against raw occlusion measured around it; and
//   what the VSL quadrature's draws cost against the rest of a pair (a line
//   fitted over fixed sample counts), and what the default count's draws
//   leave of the 0.7x-raw budget per pair; and
//   light tracing, k-NN radii and MRCS for 100,000 lights.
// The ratios to raw occlusion rays/s are the numbers to quote: absolute
// timings on a shared machine are noise.
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "app/cli.h"
#include "core/image_io.h"
#include "core/many_light.h"
#include "core/mrcs.h"
#include "core/parallel.h"
#include "core/pathtracer.h"
#include "core/render_context.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/stopwatch.h"

namespace vsl {

namespace {

using json = nlohmann::json;

struct BenchArgs {
  std::string scene, jsonPath;
  double seconds = 3;                // per measurement
  int size = 256;                    // of the path tracer's image
  std::vector<std::string> gathers;  // the gather rows' variants to run (empty: all)
  int repeat = 1;                    // runs of each gather row (its median reported)
};

// Runs fn() repeatedly for at least `seconds`; returns (calls, elapsed).
template <typename F>
std::pair<uint64_t, double> timeLoop(double seconds, F&& fn) {
  Stopwatch clock;
  uint64_t calls = 0;
  double el = 0;
  do {
    fn();
    ++calls;
    el = clock.seconds();
  } while (el < seconds);
  return {calls, el};
}

std::vector<Ray> makeOcclusionRays(const Scene& scene, const Accel& accel, size_t n) {
  std::vector<double> areas(scene.triangleCount());
  for (uint32_t t = 0; t < scene.triangleCount(); ++t) areas[t] = scene.triangleArea(t);
  DiscreteDistribution byArea(areas);
  Rng rng(7, 11);
  std::vector<Ray> rays;
  rays.reserve(n);
  size_t attempts = 0;
  while (rays.size() < n && attempts++ < 20 * n) {
    Ray cam = scene.camera.generateRay(rng.uniform() * 256, rng.uniform() * 256, 256, 256);
    auto hit = accel.intersect(cam);
    if (!hit) continue;
    SurfaceHit sh = scene.surfaceHit(hit->triangle, hit->u, hit->v, cam.d);
    float pmf;
    uint32_t tri = uint32_t(byArea.sample(rng.uniform(), &pmf));
    Vec2 b = sampleUniformTriangle({rng.uniform(), rng.uniform()});
    const Vec3& p0 = scene.positions[scene.indices[3 * tri]];
    const Vec3& p1 = scene.positions[scene.indices[3 * tri + 1]];
    const Vec3& p2 = scene.positions[scene.indices[3 * tri + 2]];
    Vec3 y = p0 * b.x + p1 * b.y + p2 * (1 - b.x - b.y);
    Vec3 d = y - sh.p;
    float dist = length(d);
    if (!(dist > 1e-4f)) continue;
    Ray r;
    r.d = d / dist;
    r.o = offsetRayOrigin(sh.p, sh.ng, r.d);
    r.tMax = dist * (1 - 1e-3f);
    rays.push_back(r);
  }
  return rays;
}

// Raw Embree occlusion over a fixed set of incoherent rays, all threads.
class OcclusionBench {
 public:
  OcclusionBench(const Accel& accel, std::vector<Ray> rays) : accel_(accel), rays_(std::move(rays)) {}
  size_t rays() const { return rays_.size(); }

  // One rtcOccluded1 per ray, for at least `seconds`: rays/s, and how many
  // passes over the rays that took.
  std::pair<double, uint64_t> single(double seconds) {
    auto [calls, el] = timeLoop(seconds, [&] {
      parallelFor(chunks(), [&](size_t c) {
        uint64_t b = 0;
        for (size_t i = c * kChunk; i < std::min(rays_.size(), (c + 1) * kChunk); ++i) b += accel_.occluded(rays_[i]);
        blocked_ += b;
      });
    });
    return {double(calls) * rays_.size() / el, calls};
  }
  // The batched entry point (stream API), for at least `seconds`: rays/s.
  double batched(double seconds) {
    auto [calls, el] = timeLoop(seconds, [&] {
      parallelFor(chunks(), [&](size_t c) {
        size_t begin = c * kChunk, n = std::min(rays_.size(), begin + kChunk) - begin;
        std::vector<uint8_t> out(n);
        accel_.occluded(std::span<const Ray>(rays_.data() + begin, n), out);
      });
    });
    return double(calls) * rays_.size() / el;
  }
  // Blocked rays over all single() calls so far.
  uint64_t blocked() const { return blocked_; }

 private:
  static constexpr size_t kChunk = 4096;
  size_t chunks() const { return (rays_.size() + kChunk - 1) / kChunk; }
  const Accel& accel_;
  std::vector<Ray> rays_;
  std::atomic<uint64_t> blocked_{0};
};

// The path tracer's throughput at size x size.
struct PtBench {
  int passes = 0;
  double pathsRate = 0, raysRate = 0, raysPerPath = 0;
};

PtBench benchPathTracer(const Scene& scene, const Accel& accel, const LightSampler& lights, const BenchArgs& a) {
  RenderSettings s;
  s.width = a.size;
  s.height = a.size;
  PathTracer pt(scene, accel, lights, s);
  Film d(a.size, a.size), ind(a.size, a.size);
  PtCounters c;
  PtBench r;
  double seconds = timeLoop(a.seconds, [&] { pt.renderPass(r.passes++, d, ind, c); }).second;
  r.pathsRate = c.paths / seconds;
  r.raysRate = c.rays / seconds;
  r.raysPerPath = double(c.rays) / c.paths;
  return r;
}

// One many-light gather, with raw occlusion measured around it.
struct GatherBench {
  std::string name;
  uint32_t lights = 0;
  int width = 0, height = 0;
  double pairsPerSecond = 0, raysPerSecond = 0, seconds = 0, raw = 0;
  uint64_t pairs = 0, draws = 0;  // draws: the VSL quadrature's (ManyLightStats::vslEvaluations)
  // One core's nanoseconds per pair (the batch's wall time on every thread).
  double coreNsPerPair() const { return seconds * threadCount() / double(std::max<uint64_t>(pairs, 1)) * 1e9; }
  double drawsPerPair() const { return double(draws) / double(std::max<uint64_t>(pairs, 1)); }
};

// The least-squares line y = slope x + intercept through the points (at
// least two distinct x).
struct Line {
  double slope = 0, intercept = 0;
};
Line fitLine(const std::vector<std::pair<double, double>>& xy) {
  double mx = 0, my = 0;
  for (auto [x, y] : xy) {
    mx += x;
    my += y;
  }
  mx /= double(xy.size());
  my /= double(xy.size());
  double sxy = 0, sxx = 0;
  for (auto [x, y] : xy) {
    sxy += (x - mx) * (y - my);
    sxx += (x - mx) * (x - mx);
  }
  Line l;
  l.slope = sxx > 0 ? sxy / sxx : 0;
  l.intercept = my - l.slope * mx;
  return l;
}

// The target for the VSL gather: pairs/s at least this share of raw
// single-ray occlusion.
constexpr double kVslTargetShareOfRaw = 0.7;

// One light set of m.lights at m.width x m.height, gathered in one batch with
// one direct sample per pixel (VSL alone, VPL alone or both, as m says) and
// timed: everything of a GatherBench but its name and raw rate.
GatherBench timeOneBatch(const Scene& scene, const Accel& accel, const LightSampler& lights, ManyLightSettings m) {
  m.batches = 1;
  m.directSamples = 1;
  ManyLightRun run = prepareManyLights(scene, accel, lights, m);
  ManyLightRenderer r(scene, accel, lights, run.set, run.radii, m);
  Stopwatch clock;
  r.renderBatch(0);
  const double sec = clock.seconds();
  const ManyLightStats& st = r.stats();
  GatherBench g;
  g.lights = uint32_t(run.set.lights.size());
  g.width = m.width;
  g.height = m.height;
  g.pairsPerSecond = st.pairs / sec;
  g.raysPerSecond = st.shadowRays / sec;
  g.seconds = sec;
  g.pairs = st.pairs.load();
  g.draws = st.vslEvaluations.load();
  return g;
}

// The gather rows' variants: VPL, VSL with the default count, then VSL with
// each other automatic count, and VSL at one sample per strategy ("VSL-1",
// --vsl-samples 1: what a pair costs besides its quadrature's count), and VSL
// in closed form ("VSL-SG", --vsl-integral sg, core/vsl_sg.h: cones wider
// than 5 degrees by the quadrature; "VSL-SG90", every pair in closed form).
struct GatherVariant {
  std::string name;
  VslCount count;
  int samples;  // per strategy; 0: the automatic count
  VslIntegral integral = VslIntegral::Quadrature;
  float sgMaxAngle = ManyLightSettings::kDefaultVslSgMaxAngle;
};

const std::vector<GatherVariant>& gatherVariants() {
  static const std::vector<GatherVariant> variants = [] {
    const VslCount dflt = ManyLightSettings().vslCount;
    std::vector<GatherVariant> v = {{"VPL", dflt, 0}, {"VSL", dflt, 0}};
    for (VslCount c : kVslCounts)
      if (c != dflt) v.push_back({std::string("VSL-") + vslCountName(c), c, 0});
    v.push_back({"VSL-1", dflt, 1});
    v.push_back({"VSL-SG", dflt, 0, VslIntegral::Sg});
    v.push_back({"VSL-SG90", dflt, 0, VslIntegral::Sg, 90.0f});
    return v;
  }();
  return variants;
}

std::vector<std::string> gatherVariantNames() {
  std::vector<std::string> names;
  for (const GatherVariant& v : gatherVariants()) names.push_back(v.name);
  return names;
}

// What a closed-form pair costs against a clamped VPL pair: the median over
// the rows both ran of VPL's pairs/s over VSL-SG90's (docs/RESULTS.md,
// "Closed-form VSL by spherical Gaussians"). 0 where either did not run.
double closedFormCostRatio(const std::vector<GatherBench>& gathers) {
  std::vector<double> ratios;
  for (const GatherBench& v : gathers)
    for (const GatherBench& s : gathers)
      if (v.name == "VPL" && s.name == "VSL-SG90" && v.lights == s.lights && v.width == s.width &&
          v.height == s.height && s.pairsPerSecond > 0)
        ratios.push_back(v.pairsPerSecond / s.pairsPerSecond);
  if (ratios.empty()) return 0;
  std::sort(ratios.begin(), ratios.end());
  const size_t n = ratios.size();
  return n % 2 ? ratios[n / 2] : 0.5 * (ratios[n / 2 - 1] + ratios[n / 2]);
}

struct GatherRow {
  const GatherVariant* v;
  uint32_t lights;
  int width, height;
};

GatherBench measureGather(const Scene& scene, const Accel& accel, const LightSampler& lights, OcclusionBench& occlusion,
                          double& rawBefore, const BenchArgs& a, const GatherRow& row) {
  ManyLightSettings m;
  m.vslCount = row.v->count;
  m.vslIntegral = row.v->integral;
  m.vslSgMaxAngle = row.v->sgMaxAngle;
  m.vslSamples = row.v->samples;
  m.lights = row.lights;
  m.width = row.width;
  m.height = row.height;
  m.computeVsl = row.v->name != "VPL";
  m.computeVpl = !m.computeVsl;
  GatherBench g = timeOneBatch(scene, accel, lights, m);
  const double rawAfter = occlusion.single(std::min(a.seconds, 1.0)).first;
  g.name = row.v->name;
  g.raw = 0.5 * (rawBefore + rawAfter);
  rawBefore = rawAfter;
  return g;
}

void printGather(const GatherBench& g) {
  std::printf(
      "%-11s gather %7u lights %4dx%-4d %7.3f M pairs/s (%.2fx raw)  %7.3f M shadow rays/s (%.2fx raw)  raw %.3f M  "
      "%.2f s\n",
      g.name.c_str(), g.lights, g.width, g.height, g.pairsPerSecond * 1e-6, g.pairsPerSecond / g.raw,
      g.raysPerSecond * 1e-6, g.raysPerSecond / g.raw, g.raw * 1e-6, g.seconds);
  std::fflush(stdout);
}

// The many-light gather rows: each variant (gatherVariants), one light set,
// one batch a run. The machine is shared: raw Embree is measured again right
// after each gather, and the ratio uses the mean of the two measurements
// around it.
std::vector<GatherBench> benchGathers(const Scene& scene, const Accel& accel, const LightSampler& lights,
                                      OcclusionBench& occlusion, double rawBefore, const BenchArgs& a) {
  // Few lights (wide VSL cones, all in cache), more lights, a larger image,
  // and 100,000 lights (the scale MRCS targets; narrow cones) on a small one
  // (eight 16x16 tiles, so that two threads share the work evenly), for
  // each variant (gatherVariants) the user asked for.
  std::vector<GatherRow> rows;
  for (const GatherVariant& v : gatherVariants()) {
    if (!a.gathers.empty() && std::find(a.gathers.begin(), a.gathers.end(), v.name) == a.gathers.end()) continue;
    rows.push_back({&v, 1000, a.size / 2, a.size / 2});
    rows.push_back({&v, 4000, a.size / 2, a.size / 2});
    rows.push_back({&v, 1000, a.size, a.size});
    rows.push_back({&v, 100000, 64, 32});
  }
  // --repeat: the rows in turn, again and again (so that a slow spell of the
  // machine falls on every row alike); each row's median run by pairs/s.
  std::vector<std::vector<GatherBench>> runs(rows.size());
  for (int rep = 0; rep < a.repeat; ++rep) {
    if (a.repeat > 1) std::fprintf(stderr, "gather rows: round %d of %d\n", rep + 1, a.repeat);
    for (size_t i = 0; i < rows.size(); ++i) {
      runs[i].push_back(measureGather(scene, accel, lights, occlusion, rawBefore, a, rows[i]));
      if (a.repeat == 1) printGather(runs[i].back());
    }
  }
  std::vector<GatherBench> gathers;
  for (std::vector<GatherBench>& r : runs) {
    std::sort(r.begin(), r.end(),
              [](const GatherBench& x, const GatherBench& y) { return x.pairsPerSecond < y.pairsPerSecond; });
    gathers.push_back(r[r.size() / 2]);
    if (a.repeat > 1) printGather(gathers.back());
  }
  if (const double ratio = closedFormCostRatio(gathers); ratio > 0)
    std::printf(
        "closed form: a VSL-SG90 pair costs %.2fx a VPL pair (median over the rows, VPL's pairs/s over "
        "VSL-SG90's%s)\n",
        ratio, a.repeat > 1 ? ", each row's median run" : "");
  return gathers;
}

// What the VSL quadrature's draws cost against the rest of a pair. The
// 1,000-light set of the gathers at fixed counts per strategy (kCounts), a
// line through (draws per pair, one core's ns per pair): its slope is what a
// draw costs (its direction, both BRDFs, the balance heuristic's term), its
// intercept what a pair costs besides (orientation, its shadow ray, the cone's
// set-up and the quadrature's bookkeeping). The default count's draws at that
// slope, with its shadow rays at raw speed, against the ns per pair that
// kVslTargetShareOfRaw of raw occlusion allows one core: where they exceed
// it, no cut of the rest reaches the target at that count.
json benchVslDrawCost(const Scene& scene, const Accel& accel, const LightSampler& lights, OcclusionBench& occlusion,
                      const std::vector<GatherBench>& gathers, const BenchArgs& a) {
  const int size = a.size / 2;
  auto isDefault = [&](const GatherBench& g) { return g.name == "VSL" && g.width == size && g.lights < 2000; };
  auto dflt = std::find_if(gathers.begin(), gathers.end(), isDefault);
  if (dflt == gathers.end() || dflt->pairs == 0) return json::object();
  static constexpr int kCounts[] = {4, 16, 64};
  std::vector<std::pair<double, double>> points;
  json rows = json::array();
  double raw = 0;
  for (int n : kCounts) {
    ManyLightSettings m;
    m.vslSamples = n;
    m.lights = 1000;
    m.width = m.height = size;
    m.computeVpl = false;
    const GatherBench g = timeOneBatch(scene, accel, lights, m);
    raw += occlusion.single(std::min(a.seconds, 1.0)).first / double(std::size(kCounts));
    if (g.pairs == 0) return json::object();
    points.push_back({g.drawsPerPair(), g.coreNsPerPair()});
    rows.push_back(
        {{"samplesPerStrategy", n}, {"drawsPerPair", g.drawsPerPair()}, {"coreNsPerPair", g.coreNsPerPair()}});
  }
  const Line line = fitLine(points);
  const double coreNsPerRawRay = threadCount() / raw * 1e9;
  const double budget = coreNsPerRawRay / kVslTargetShareOfRaw;
  const double draws = dflt->drawsPerPair(), drawsNs = draws * line.slope;
  const double rays = dflt->raysPerSecond / std::max(dflt->pairsPerSecond, 1e-9), raysNs = rays * coreNsPerRawRay;
  std::printf(
      "VSL draws   %.1f ns per draw and %.0f ns per pair besides (one core; fitted over %d, %d and %d samples per "
      "strategy, %u lights %dx%d)\n",
      line.slope, line.intercept, kCounts[0], kCounts[1], kCounts[2], dflt->lights, size, size);
  std::printf(
      "            the default count: %.1f draws per pair, %.0f ns at that cost, and %.2f shadow rays per pair, %.0f "
      "ns at raw speed: %.0f ns, where %.1fx raw allows %.0f ns per pair (all one core's; raw %.3f M rays/s on %d "
      "threads)\n",
      draws, drawsNs, rays, raysNs, drawsNs + raysNs, kVslTargetShareOfRaw, budget, raw * 1e-6, threadCount());
  return {{"nsPerDraw", line.slope},
          {"nsPerPairBesidesDraws", line.intercept},
          {"fixedCounts", rows},
          {"defaultDrawsPerPair", draws},
          {"defaultDrawsNsPerPair", drawsNs},
          {"defaultShadowRaysPerPair", rays},
          {"defaultShadowRaysNsPerPairAtRawSpeed", raysNs},
          {"targetShareOfRaw", kVslTargetShareOfRaw},
          {"budgetNsPerPair", budget},
          {"rawOccludedRaysPerSecond", raw},
          {"threads", threadCount()}};
}

// Stages: light tracing and k-NN radii for 100,000 lights; MRCS over them.
json benchStages(const Scene& scene, const Accel& accel, const LightSampler& lights, const BenchArgs& a) {
  ManyLightSettings big;
  big.lights = 100000;
  big.width = big.height = a.size / 2;
  big.directSamples = 1;
  ManyLightRun bigRun = prepareManyLights(scene, accel, lights, big);
  double traceRate = bigRun.set.lights.size() / std::max(bigRun.set.seconds, 1e-9);
  double knnRate = bigRun.set.lights.size() / std::max(bigRun.knnSeconds, 1e-9);
  MrcsResult mr = renderMrcs(scene, accel, lights, bigRun.set, bigRun.radii, big, MrcsSettings{300, 900, 0});
  double mrcsSeconds = mr.rowSeconds + mr.clusterSeconds + mr.columnSeconds;
  double brutePairs = double(bigRun.set.lights.size()) * big.width * big.height * 2;  // VSL and VPL
  std::printf("light tracing              %.3f M lights/s (%zu lights in %.2f s)\n", traceRate * 1e-6,
              bigRun.set.lights.size(), bigRun.set.seconds);
  std::printf("k-NN radii (k = 10)        %.3f M lights/s (%.2f s)\n", knnRate * 1e-6, bigRun.knnSeconds);
  std::printf(
      "MRCS 300 rows, 900 clusters %.2f s at %dx%d (rows %.2f, clustering %.2f, columns %.2f): %.3gx fewer "
      "pairs than brute force\n",
      mrcsSeconds, big.width, big.height, mr.rowSeconds, mr.clusterSeconds, mr.columnSeconds,
      brutePairs / std::max(double(mr.pairs), 1.0));
  return {{"lightTracingLightsPerSecond", traceRate},
          {"knnLightsPerSecond", knnRate},
          {"mrcs",
           {{"lights", bigRun.set.lights.size()},
            {"size", big.width},
            {"seconds", mrcsSeconds},
            {"rowSeconds", mr.rowSeconds},
            {"clusterSeconds", mr.clusterSeconds},
            {"columnSeconds", mr.columnSeconds},
            {"pairs", mr.pairs},
            {"bruteForcePairs", brutePairs}}}};
}

int runBench(const BenchArgs& a) {
  Result<std::unique_ptr<RenderContext>> loaded = RenderContext::load(a.scene);
  if (!loaded) return fail(kExitBadInput, loaded.error());
  const Scene& scene = (*loaded)->scene();
  const Accel& accel = (*loaded)->accel();
  const LightSampler& lights = (*loaded)->lights();
  OcclusionBench occlusion(accel, makeOcclusionRays(scene, accel, 1 << 20));
  if (occlusion.rays() == 0)
    return failf(kExitBadInput, "%s: the camera sees no geometry; nothing to benchmark", a.scene.c_str());
  std::fprintf(stderr, "bench %s: %zu triangles, %zu occlusion rays, %.1f s per raw-Embree measurement\n",
               a.scene.c_str(), scene.triangleCount(), occlusion.rays(), a.seconds);

  // Raw Embree, single and batched; then the path tracer.
  auto [rawRate, rawCalls] = occlusion.single(a.seconds);
  const uint64_t blocked = occlusion.blocked();
  double batchRate = occlusion.batched(a.seconds);
  PtBench pt = benchPathTracer(scene, accel, lights, a);
  std::printf("scene                      %s\n", a.scene.c_str());
  std::printf("raw Embree occluded rays/s %.3f M  (single calls; %.1f%% blocked)\n", rawRate * 1e-6,
              100.0 * blocked / (double(rawCalls) * occlusion.rays()));
  std::printf("raw Embree batched rays/s  %.3f M  (%.2fx single)\n", batchRate * 1e-6, batchRate / rawRate);
  std::printf("path tracer paths/s        %.3f M  (%d passes at %dx%d)\n", pt.pathsRate * 1e-6, pt.passes, a.size,
              a.size);
  std::printf("path tracer rays/s         %.3f M  (%.2f rays/path)\n", pt.raysRate * 1e-6, pt.raysPerPath);
  std::printf("ratio PT rays/s : raw      %.3f\n", pt.raysRate / rawRate);

  // The many-light gathers and stages.
  std::vector<GatherBench> gathers = benchGathers(scene, accel, lights, occlusion, rawRate, a);
  const bool all = a.gathers.empty();
  json drawCost = all ? benchVslDrawCost(scene, accel, lights, occlusion, gathers, a) : json::object();
  json stages = all ? benchStages(scene, accel, lights, a) : json::object();
  if (a.jsonPath.empty()) return 0;
  json j = {{"scene", a.scene},
            {"triangles", scene.triangleCount()},
            {"rawOccludedRaysPerSecond", rawRate},
            {"rawBatchedOccludedRaysPerSecond", batchRate},
            {"ptPathsPerSecond", pt.pathsRate},
            {"ptRaysPerSecond", pt.raysRate},
            {"ptRaysPerPath", pt.raysPerPath},
            {"ratioPtRaysToRawOccluded", pt.raysRate / rawRate}};
  j.update(stages);
  j["vslDrawCost"] = drawCost;
  for (const GatherBench& g : gathers)
    j["gather"].push_back({{"method", g.name},
                           {"lights", g.lights},
                           {"width", g.width},
                           {"height", g.height},
                           {"pairsPerSecond", g.pairsPerSecond},
                           {"shadowRaysPerSecond", g.raysPerSecond},
                           {"rawOccludedRaysPerSecond", g.raw},
                           {"ratioPairsToRawOccluded", g.pairsPerSecond / g.raw},
                           {"ratioShadowRaysToRawOccluded", g.raysPerSecond / g.raw},
                           {"secondsPerBatch", g.seconds}});
  if (Result<void> written = writeTextFile(a.jsonPath, j.dump(2) + "\n"); !written)
    return fail(kExitBadInput, written.error());
  return 0;
}

}  // namespace

Subcommand addBenchCommand(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* bench = app.add_subcommand("bench", "Path-tracer throughput against raw Embree occlusion on one scene");
  bench->add_option("scene", args->scene, "Scene file")->required();
  bench
      ->add_option("--seconds", args->seconds,
                   "Seconds per raw-Embree and path-tracer measurement (each gather row is one batch of fixed work, so "
                   "a run takes minutes whatever this is)")
      ->default_str("3")
      ->check(CLI::Range(0.1, 600.0));
  bench->add_option("--size", args->size, "Image size for the path tracer")
      ->default_str("256")
      ->check(CLI::Range(8, 4096));
  bench->add_option("--json", args->jsonPath, "Write results as JSON");
  bench
      ->add_option("--only-gathers", args->gathers,
                   "Run only these gather rows' variants, comma-separated (VPL, VSL, VSL-authors, VSL-shares, VSL-1, "
                   "VSL-SG, VSL-SG90), and neither the VSL draw-cost fit nor the stages after them")
      ->delimiter(',')
      ->check(CLI::IsMember(gatherVariantNames()));
  bench
      ->add_option("--repeat", args->repeat,
                   "Run the gather rows this many times in turn and report each row's median run (by pairs/s)")
      ->default_str("1")
      ->check(CLI::Range(1, 99));
  return {bench, [args] { return runBench(*args); }};
}

}  // namespace vsl
