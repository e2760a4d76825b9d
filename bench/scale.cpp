// vsl_scale: how the cost of each stage grows with geometry and light count
// (docs/RESULTS.md, "Cost growth"). For one scene and a list of light
// counts it times, in one process:
//   load      loadScene (parse, decode, flatten)
//   build     Accel::build (Embree BVH)
//   trace     light tracing of the virtual lights (prepareManyLights)
//   knn       their k-NN radii (prepareManyLights)
//   gather    the brute-force gather (ManyLightRenderer, one batch) on a
//             small image, over every light or, above --gather-lights, over
//             an evenly strided subset of that many (keeping the radii of the
//             full set): its pairs/s is the figure, the full gather costs
//             pixels x lights / (pairs/s)
//   mrcs      MRCS (renderMrcs): rows, clustering, representative columns
// Each stage's wall time and its process CPU time (user + system, all
// threads): on a shared machine the CPU time moves less with the other jobs
// (trace and k-NN share one CPU figure, "prepare").
// Memory: the resident set after load and build, and each stage's peak
// resident set above what was resident when it started (Linux: VmHWM is reset
// through /proc/self/clear_refs before every stage; without it, -1).
// One estimator is evaluated (--estimator, default vpl: the clamped VPL, whose
// pair cost is mostly the shadow ray) and direct light takes one sample per
// pixel, so the gather and MRCS times are the indirect work.
// Prints one CSV row per light count on stdout; progress goes to stderr.
//   vsl_scale SCENE.gltf --lights 1000,10000 [--estimator vpl|vsl]
//             [--gather-size 32] [--gather-lights 20000] [--mrcs-size 128]
//             [--rows 300] [--clusters 900] [--seed 1]
#include <malloc.h>
#include <sys/resource.h>
#include <CLI/CLI.hpp>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "core/accel.h"
#include "core/lights.h"
#include "core/loader.h"
#include "core/many_light.h"
#include "core/mrcs.h"
#include "core/scene.h"
#include "core/stopwatch.h"

using namespace vsl;

namespace {

struct Options {
  std::string scene;
  std::vector<uint32_t> lights;
  bool vsl = false;  // --estimator
  int gatherSize = 32, mrcsSize = 128, rows = 300, clusters = 900;
  uint32_t gatherLights = 20000;
  uint64_t seed = 1;
};

// ---- Memory (Linux /proc; -1 where unavailable) ----------------------------

// A "VmRSS:" or "VmHWM:" line of /proc/self/status, in MB.
double statusMb(const char* key) {
  std::ifstream f("/proc/self/status");
  std::string k;
  while (f >> k) {
    double kb;
    if (k == key && f >> kb) return kb / 1024.0;
    f.ignore(1 << 12, '\n');
  }
  return -1;
}

// CPU seconds (user + system) of the process so far, all threads.
double cpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  auto s = [](const timeval& t) { return double(t.tv_sec) + 1e-6 * double(t.tv_usec); };
  return s(u.ru_utime) + s(u.ru_stime);
}

// Times one stage (wall and CPU) and its peak resident memory above the resident set at its
// start. Freed heap is returned to the system first (malloc_trim), so that
// what an earlier stage freed is not reused unseen.
class StageMeter {
 public:
  StageMeter() {
    malloc_trim(0);
    std::ofstream("/proc/self/clear_refs") << "5";  // resets VmHWM to VmRSS
    startMb_ = statusMb("VmRSS:");
    startCpu_ = cpuSeconds();
    clock_.reset();
  }
  double seconds() const { return clock_.seconds(); }
  double cpu() const { return cpuSeconds() - startCpu_; }
  double peakAboveStartMb() const { return startMb_ < 0 ? -1 : statusMb("VmHWM:") - startMb_; }
  double startMb() const { return startMb_; }

 private:
  double startMb_, startCpu_;
  Stopwatch clock_;
};

double sceneMb(const Scene& s) {
  size_t bytes = s.positions.size() * sizeof(Vec3) + s.normals.size() * sizeof(Vec3) +
                 s.tangents.size() * sizeof(Vec3) + s.tangentSigns.size() * sizeof(float) +
                 s.uvs.size() * sizeof(Vec2) + s.indices.size() * sizeof(uint32_t) +
                 s.triMaterial.size() * sizeof(uint32_t);
  return bytes / (1024.0 * 1024.0);
}

// ---- Stages -----------------------------------------------------------------

// What the scene costs before any light exists.
struct SceneCosts {
  size_t triangles = 0;
  double loadS = 0, buildS = 0, loadCpu = 0, buildCpu = 0;
  double loadPeakMb = 0, sceneMb = 0, rssAfterLoadMb = 0, bvhMb = 0;
};

// One light count's row.
struct LightCosts {
  size_t lights = 0;
  double traceS = 0, knnS = 0, prepareCpu = 0, lightsMb = 0, preparePeakMb = 0;
  int gatherPx = 0;
  size_t gatherLights = 0;
  double gatherS = 0, gatherCpu = 0, gatherPeakMb = 0;
  uint64_t gatherPairs = 0;
  int mrcsPx = 0;
  double mrcsS = 0, mrcsCpu = 0, rowsS = 0, clusterS = 0, columnsS = 0, mrcsPeakMb = 0;
};

ManyLightSettings baseSettings(const Options& o, uint32_t lights, int size) {
  ManyLightSettings m;
  m.lights = lights;
  m.seed = o.seed;
  m.width = m.height = size;
  m.batches = 1;
  m.directSamples = 1;
  m.computeVsl = o.vsl;
  m.computeVpl = !o.vsl;
  return m;
}

// Every stride-th light of the run with its radius (stride 1: all of them).
ManyLightRun stridedSubset(const ManyLightRun& run, size_t stride) {
  ManyLightRun sub;
  sub.set.paths = run.set.paths;
  for (size_t i = 0; i < run.set.lights.size(); i += stride) {
    sub.set.lights.push_back(run.set.lights[i]);
    sub.radii.push_back(run.radii[i]);
  }
  return sub;
}

void measureGather(const Options& o, const Scene& scene, const Accel& accel, const LightSampler& sampler,
                   const ManyLightRun& run, LightCosts& c) {
  const size_t n = run.set.lights.size();
  const ManyLightRun sub = stridedSubset(run, (n + o.gatherLights - 1) / o.gatherLights);
  ManyLightSettings m = baseSettings(o, uint32_t(sub.set.lights.size()), o.gatherSize);
  StageMeter meter;
  ManyLightRenderer r(scene, accel, sampler, sub.set, sub.radii, m);
  r.renderBatch(0);
  c.gatherS = meter.seconds();
  c.gatherCpu = meter.cpu();
  c.gatherPeakMb = meter.peakAboveStartMb();
  c.gatherPx = r.width() * r.height();
  c.gatherLights = sub.set.lights.size();
  c.gatherPairs = r.stats().pairs;
}

void measureMrcs(const Options& o, const Scene& scene, const Accel& accel, const LightSampler& sampler,
                 const ManyLightRun& run, LightCosts& c) {
  ManyLightSettings m = baseSettings(o, c.lights, o.mrcsSize);
  MrcsSettings mrcs;
  mrcs.rows = o.rows;
  mrcs.clusters = o.clusters;
  mrcs.seed = o.seed;
  StageMeter meter;
  MrcsResult res = renderMrcs(scene, accel, sampler, run.set, run.radii, m, mrcs);
  c.mrcsS = meter.seconds();
  c.mrcsCpu = meter.cpu();
  c.mrcsPeakMb = meter.peakAboveStartMb();
  c.mrcsPx = res.images.direct.width * res.images.direct.height;
  c.rowsS = res.rowSeconds;
  c.clusterS = res.clusterSeconds;
  c.columnsS = res.columnSeconds;
}

LightCosts measureLights(const Options& o, const Scene& scene, const Accel& accel, const LightSampler& sampler,
                         uint32_t count) {
  LightCosts c;
  ManyLightRun run;
  {
    StageMeter meter;
    run = prepareManyLights(scene, accel, sampler, baseSettings(o, count, o.gatherSize));
    c.preparePeakMb = meter.peakAboveStartMb();
    c.prepareCpu = meter.cpu();
  }
  c.lights = run.set.lights.size();
  c.traceS = run.set.seconds;
  c.knnS = run.knnSeconds;
  c.lightsMb = (run.set.bytes() + run.radii.size() * sizeof(float)) / (1024.0 * 1024.0);
  std::fprintf(stderr, "  %zu lights: trace %.3f s, k-NN %.3f s\n", c.lights, c.traceS, c.knnS);
  measureGather(o, scene, accel, sampler, run, c);
  std::fprintf(stderr, "  gather %d px x %zu lights: %.3f s (%.2f Mpairs/s)\n", c.gatherPx, c.gatherLights, c.gatherS,
               c.gatherPairs / std::max(c.gatherS, 1e-9) * 1e-6);
  measureMrcs(o, scene, accel, sampler, run, c);
  std::fprintf(stderr, "  MRCS %d px: %.3f s (rows %.2f, clusters %.2f, columns %.2f)\n", c.mrcsPx, c.mrcsS, c.rowsS,
               c.clusterS, c.columnsS);
  return c;
}

// ---- Output -----------------------------------------------------------------

// The CSV columns after scene, estimator, triangles and lights, in order.
constexpr const char* kColumns =
    "load_s,build_s,trace_s,knn_s,gather_px,gather_lights,gather_s,gather_pairs,mrcs_px,mrcs_s,mrcs_rows_s,"
    "mrcs_cluster_s,mrcs_columns_s,load_peak_mb,scene_mb,rss_after_load_mb,bvh_mb,lights_mb,prepare_peak_mb,"
    "gather_peak_mb,mrcs_peak_mb,load_cpu_s,build_cpu_s,prepare_cpu_s,gather_cpu_s,mrcs_cpu_s";

void printHeader() { std::printf("scene,estimator,triangles,lights,%s\n", kColumns); }

void printRow(const Options& o, const SceneCosts& s, const LightCosts& c) {
  const double values[] = {s.loadS,
                           s.buildS,
                           c.traceS,
                           c.knnS,
                           double(c.gatherPx),
                           double(c.gatherLights),
                           c.gatherS,
                           double(c.gatherPairs),
                           double(c.mrcsPx),
                           c.mrcsS,
                           c.rowsS,
                           c.clusterS,
                           c.columnsS,
                           s.loadPeakMb,
                           s.sceneMb,
                           s.rssAfterLoadMb,
                           s.bvhMb,
                           c.lightsMb,
                           c.preparePeakMb,
                           c.gatherPeakMb,
                           c.mrcsPeakMb,
                           s.loadCpu,
                           s.buildCpu,
                           c.prepareCpu,
                           c.gatherCpu,
                           c.mrcsCpu};
  std::printf("%s,%s,%zu,%zu", o.scene.c_str(), o.vsl ? "vsl" : "vpl", s.triangles, c.lights);
  for (double v : values) std::printf(",%.10g", v);
  std::printf("\n");
  std::fflush(stdout);
}

int run(const Options& o) {
  SceneCosts s;
  StageMeter loadMeter;
  SceneResult loaded = loadScene(o.scene);
  s.loadS = loadMeter.seconds();
  s.loadCpu = loadMeter.cpu();
  s.loadPeakMb = loadMeter.peakAboveStartMb();
  if (!loaded) {
    std::fprintf(stderr, "vsl_scale: %s\n", loaded.error().c_str());
    return 1;
  }
  const Scene& scene = **loaded;
  s.triangles = scene.triangleCount();
  s.sceneMb = sceneMb(scene);
  StageMeter buildMeter;
  s.rssAfterLoadMb = buildMeter.startMb();
  auto accel = Accel::build(scene);
  s.buildS = buildMeter.seconds();
  s.buildCpu = buildMeter.cpu();
  if (!accel) {
    std::fprintf(stderr, "vsl_scale: %s\n", accel.error().c_str());
    return 1;
  }
  s.bvhMb = statusMb("VmRSS:") - s.rssAfterLoadMb;
  std::fprintf(stderr, "%s: %zu triangles, load %.3f s, BVH %.3f s (%.1f MB)\n", o.scene.c_str(), s.triangles, s.loadS,
               s.buildS, s.bvhMb);
  LightSampler sampler(scene);
  // Warm-up, not reported: the first parallel stage pays for first-touch page
  // faults and cold caches (0.23 s against 0.03 s for 1,000 lights).
  prepareManyLights(scene, **accel, sampler, baseSettings(o, 1000, o.gatherSize));
  printHeader();
  for (uint32_t count : o.lights) printRow(o, s, measureLights(o, scene, **accel, sampler, count));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app("vsl_scale: stage times and memory against triangle and light count");
  app.add_option("scene", o.scene, "glTF scene")->required();
  app.add_option("--lights", o.lights, "virtual light counts, e.g. 1000,10000")->delimiter(',')->required();
  app.add_option("--gather-size", o.gatherSize, "square image of the brute-force gather")->check(CLI::Range(16, 4096));
  app.add_option("--mrcs-size", o.mrcsSize, "square image of MRCS")->check(CLI::Range(16, 4096));
  app.add_option("--rows", o.rows, "MRCS rows")->check(CLI::Range(1, 100000));
  app.add_option("--clusters", o.clusters, "MRCS clusters")->check(CLI::Range(1, 1000000));
  app.add_option("--seed", o.seed, "light set and MRCS seed");
  std::string estimator = "vpl";
  app.add_option("--estimator", estimator, "vpl (clamped) or vsl")->check(CLI::IsMember({"vpl", "vsl"}));
  app.add_option("--gather-lights", o.gatherLights, "at most this many lights in the brute-force gather")
      ->check(CLI::Range(1u, 50'000'000u));
  CLI11_PARSE(app, argc, argv);
  o.vsl = estimator == "vsl";
  return run(o);
}
