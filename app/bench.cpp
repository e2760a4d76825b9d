// `vsl bench SCENE`: measures, in one run and on the same scene and threads,
//   raw Embree occlusion throughput for incoherent rays (camera-visible points
//   toward area-uniform random surface points), single and batched, and
//   the path tracer's paths/s and rays/s.
// The ratio of the path tracer's rays/s to raw occlusion rays/s is the number
// to quote: absolute timings on a shared machine are noise.
#include "app/bench.h"

#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "core/image_io.h"
#include "core/many_light.h"
#include "core/mrcs.h"
#include "core/parallel.h"
#include "core/pathtracer.h"
#include "core/rng.h"
#include "core/sampling.h"

namespace vsl {

namespace {
using Clock = std::chrono::steady_clock;

// Runs fn() repeatedly for at least `seconds`; returns (calls, elapsed).
template <typename F>
std::pair<uint64_t, double> timeLoop(double seconds, F&& fn) {
  auto t0 = Clock::now();
  uint64_t calls = 0;
  double el = 0;
  do {
    fn();
    ++calls;
    el = std::chrono::duration<double>(Clock::now() - t0).count();
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
}  // namespace

int runBench(const std::string& scenePath, double seconds, int size, const std::string& jsonPath) {
  SceneResult loaded = loadScene(scenePath);
  if (!loaded) {
    std::fprintf(stderr, "error: %s\n", loaded.error().c_str());
    return 1;
  }
  const Scene& scene = **loaded;
  Result<std::unique_ptr<Accel>> built = Accel::build(scene);
  if (!built) {
    std::fprintf(stderr, "error: %s\n", built.error().c_str());
    return 1;
  }
  const std::unique_ptr<Accel>& accel = *built;
  std::vector<Ray> rays = makeOcclusionRays(scene, *accel, 1 << 20);
  if (rays.empty()) {
    std::fprintf(stderr, "error: %s: the camera sees no geometry; nothing to benchmark\n", scenePath.c_str());
    return 1;
  }
  std::fprintf(stderr, "bench %s: %zu triangles, %zu occlusion rays, %.1f s per measurement\n", scenePath.c_str(),
               scene.triangleCount(), rays.size(), seconds);

  constexpr size_t kChunk = 4096;
  // Raw Embree: one rtcOccluded1 per ray, all threads.
  std::atomic<uint64_t> blocked{0};
  auto measureRaw = [&](double sec) {
    auto [calls, el] = timeLoop(sec, [&] {
      parallelFor((rays.size() + kChunk - 1) / kChunk, [&](size_t c) {
        uint64_t b = 0;
        for (size_t i = c * kChunk; i < std::min(rays.size(), (c + 1) * kChunk); ++i) b += accel->occluded(rays[i]);
        blocked += b;
      });
    });
    return std::pair<double, uint64_t>(double(calls) * rays.size() / el, calls);
  };
  auto [rawRate, rawCalls] = measureRaw(seconds);
  // Raw Embree through the batched entry point (stream API), all threads.
  auto [batchCalls, batchSec] = timeLoop(seconds, [&] {
    parallelFor((rays.size() + kChunk - 1) / kChunk, [&](size_t c) {
      size_t begin = c * kChunk, n = std::min(rays.size(), begin + kChunk) - begin;
      std::vector<uint8_t> out(n);
      accel->occluded(std::span<const Ray>(rays.data() + begin, n), out);
    });
  });
  double batchRate = double(batchCalls) * rays.size() / batchSec;

  // Path tracer.
  LightSampler lights(scene);
  RenderSettings s;
  s.width = size;
  s.height = size;
  PathTracer pt(scene, *accel, lights, s);
  Film d(size, size), ind(size, size);
  PtCounters c;
  int pass = 0;
  auto [ptCalls, ptSec] = timeLoop(seconds, [&] { pt.renderPass(pass++, d, ind, c); });
  double pathsRate = c.paths / ptSec, raysRate = c.rays / ptSec;

  std::printf("scene                      %s\n", scenePath.c_str());
  std::printf("raw Embree occluded rays/s %.3f M  (single calls; %.1f%% blocked)\n", rawRate * 1e-6,
              100.0 * blocked / (double(rawCalls) * rays.size()));
  std::printf("raw Embree batched rays/s  %.3f M  (%.2fx single)\n", batchRate * 1e-6, batchRate / rawRate);
  std::printf("path tracer paths/s        %.3f M  (%d passes at %dx%d)\n", pathsRate * 1e-6, pass, size, size);
  std::printf("path tracer rays/s         %.3f M  (%.2f rays/path)\n", raysRate * 1e-6, double(c.rays) / c.paths);
  std::printf("ratio PT rays/s : raw      %.3f\n", raysRate / rawRate);
  (void)ptCalls;

  // Many-light gather: VPL only and VSL only, one light set, one batch each.
  struct GatherResult {
    std::string name;
    uint32_t lights;
    int width, height;
    double pairsPerSecond, raysPerSecond, seconds, raw;
  };
  std::vector<GatherResult> gathers;
  double rawBefore = rawRate;
  auto gather = [&](const std::string& name, bool vsl, uint32_t n, int sz, int szY = 0) {
    ManyLightSettings m;
    m.lights = n;
    m.width = sz;
    m.height = szY > 0 ? szY : sz;
    m.batches = 1;
    m.directSamples = 1;
    m.computeVsl = vsl;
    m.computeVpl = !vsl;
    ManyLightRun run = prepareManyLights(scene, *accel, lights, m);
    ManyLightRenderer r(scene, *accel, lights, run.set, run.radii, m);
    auto t0 = Clock::now();
    r.renderBatch(0);
    double sec = std::chrono::duration<double>(Clock::now() - t0).count();
    // The machine is shared: raw Embree is measured again right after each
    // gather, and the ratio uses the mean of the two measurements around it.
    double rawAfter = measureRaw(std::min(seconds, 1.0)).first;
    double raw = 0.5 * (rawBefore + rawAfter);
    rawBefore = rawAfter;
    const ManyLightStats& st = r.stats();
    gathers.push_back(
        {name, uint32_t(run.set.lights.size()), m.width, m.height, st.pairs / sec, st.shadowRays / sec, sec, raw});
    std::printf(
        "%-4s gather %7u lights %4dx%-4d %7.3f M pairs/s (%.2fx raw)  %7.3f M shadow rays/s (%.2fx raw)  raw %.3f M  "
        "%.2f s\n",
        name.c_str(), uint32_t(run.set.lights.size()), m.width, m.height, st.pairs / sec * 1e-6, st.pairs / sec / raw,
        st.shadowRays / sec * 1e-6, st.shadowRays / sec / raw, raw * 1e-6, sec);
  };
  // Few lights (wide VSL cones, all in cache), more lights, a larger image,
  // and 100,000 lights (the scale MRCS targets; narrow cones) on a small one
  // (eight 16x16 tiles, so that two threads share the work evenly).
  for (bool vsl : {false, true}) {
    const char* name = vsl ? "VSL" : "VPL";
    gather(name, vsl, 1000, size / 2);
    gather(name, vsl, 4000, size / 2);
    gather(name, vsl, 1000, size);
    gather(name, vsl, 100000, 64, 32);
  }

  // Stages: light tracing and k-NN radii for 100,000 lights; MRCS over them.
  ManyLightSettings big;
  big.lights = 100000;
  big.width = big.height = size / 2;
  big.directSamples = 1;
  ManyLightRun bigRun = prepareManyLights(scene, *accel, lights, big);
  double traceRate = bigRun.set.lights.size() / std::max(bigRun.set.seconds, 1e-9);
  double knnRate = bigRun.set.lights.size() / std::max(bigRun.knnSeconds, 1e-9);
  MrcsResult mr = renderMrcs(scene, *accel, lights, bigRun.set, bigRun.radii, big, MrcsSettings{300, 900, 0});
  double mrcsSeconds = mr.rowSeconds + mr.clusterSeconds + mr.columnSeconds;
  double brutePairs = double(bigRun.set.lights.size()) * big.width * big.height * 2;  // VSL and VPL
  std::printf("light tracing              %.3f M lights/s (%zu lights in %.2f s)\n", traceRate * 1e-6,
              bigRun.set.lights.size(), bigRun.set.seconds);
  std::printf("k-NN radii (k = 10)        %.3f M lights/s (%.2f s)\n", knnRate * 1e-6, bigRun.knnSeconds);
  std::printf(
      "MRCS 300 rows, 900 clusters %.2f s at %dx%d (rows %.2f, clustering %.2f, columns %.2f): %.0fx fewer "
      "pairs than brute force\n",
      mrcsSeconds, big.width, big.height, mr.rowSeconds, mr.clusterSeconds, mr.columnSeconds,
      brutePairs / std::max(double(mr.pairs), 1.0));
  if (!jsonPath.empty()) {
    nlohmann::json j = {{"scene", scenePath},
                        {"triangles", scene.triangleCount()},
                        {"rawOccludedRaysPerSecond", rawRate},
                        {"rawBatchedOccludedRaysPerSecond", batchRate},
                        {"ptPathsPerSecond", pathsRate},
                        {"ptRaysPerSecond", raysRate},
                        {"ptRaysPerPath", double(c.rays) / c.paths},
                        {"ratioPtRaysToRawOccluded", raysRate / rawRate}};
    j["lightTracingLightsPerSecond"] = traceRate;
    j["knnLightsPerSecond"] = knnRate;
    j["mrcs"] = {{"lights", bigRun.set.lights.size()},
                 {"size", big.width},
                 {"seconds", mrcsSeconds},
                 {"rowSeconds", mr.rowSeconds},
                 {"clusterSeconds", mr.clusterSeconds},
                 {"columnSeconds", mr.columnSeconds},
                 {"pairs", mr.pairs},
                 {"bruteForcePairs", brutePairs}};
    for (const auto& g : gathers)
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
    if (Result<void> written = writeTextFile(jsonPath, j.dump(2) + "\n"); !written) {
      std::fprintf(stderr, "error: %s\n", written.error().c_str());
      return 1;
    }
  }
  return 0;
}

}  // namespace vsl
