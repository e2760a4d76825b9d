#include "core/virtual_lights.h"

#include "core/path.h"

#include <chrono>
#include <sstream>
#include <utility>

#include "core/memory_budget.h"
#include "core/parallel.h"
#include "core/point_tree.h"
#include "core/rng.h"
#include "core/stopwatch.h"

namespace vsl {

// ---- Compact encodings -------------------------------------------------------

namespace {
inline uint16_t toUnorm16(float v) { return uint16_t(std::lround(clamp(v, 0.0f, 1.0f) * 65535.0f)); }
inline float fromUnorm16(uint16_t v) { return v / 65535.0f; }
inline float signNotZero(float v) { return v >= 0 ? 1.0f : -1.0f; }
inline uint16_t toSnorm16(float v) { return uint16_t(std::lround((clamp(v, -1.0f, 1.0f) * 0.5f + 0.5f) * 65535.0f)); }
inline float fromSnorm16(uint16_t v) { return v / 65535.0f * 2.0f - 1.0f; }
}  // namespace

uint32_t encodeUnit(const Vec3& v) {
  float l1 = std::abs(v.x) + std::abs(v.y) + std::abs(v.z);
  if (!(l1 > 0)) return encodeUnit(Vec3(0, 0, 1));
  float x = v.x / l1, y = v.y / l1;
  if (v.z < 0) {
    float ox = (1 - std::abs(y)) * signNotZero(x), oy = (1 - std::abs(x)) * signNotZero(y);
    x = ox;
    y = oy;
  }
  return uint32_t(toSnorm16(x)) | (uint32_t(toSnorm16(y)) << 16);
}

Vec3 decodeUnit(uint32_t e) {
  float x = fromSnorm16(uint16_t(e & 0xffff)), y = fromSnorm16(uint16_t(e >> 16));
  Vec3 v(x, y, 1 - std::abs(x) - std::abs(y));
  if (v.z < 0) {
    float ox = (1 - std::abs(v.y)) * signNotZero(v.x), oy = (1 - std::abs(v.x)) * signNotZero(v.y);
    v.x = ox;
    v.y = oy;
  }
  return normalize(v);
}

Brdf VirtualLight::brdf() const {
  Brdf b;
  b.baseColor = Vec3(fromUnorm16(base[0]), fromUnorm16(base[1]), fromUnorm16(base[2]));
  b.metallic = fromUnorm16(metallic);
  b.specularWeight = fromUnorm16(specular);
  b.ggx.ax = std::max(sqr(fromUnorm16(roughX)), kMinAlpha);
  b.ggx.ay = std::max(sqr(fromUnorm16(roughY)), kMinAlpha);
  if (clearcoat == 0) return b;
  const Vec3 cn = coatN == 0 ? Vec3(0, 0, 1) : frame().toLocal(decodeUnit(coatN));
  return b.withClearcoat(fromUnorm16(clearcoat), fromUnorm16(coatRough), cn);
}

Result<void> LightTracingSettings::validate() const {
  std::ostringstream e;
  if (count < 1 || count > 50'000'000)
    e << "lights: must be in [1,50000000] (got " << count << ")";
  else if (maxDepth < 1 || maxDepth > 1024)
    e << "light max depth: must be in [1,1024] (got " << maxDepth << ")";
  else if (rrDepth < 1)
    e << "light rr depth: must be >= 1 (got " << rrDepth << ")";
  if (std::string m = e.str(); !m.empty()) return Error(m);
  return {};
}

// ---- Light tracing -------------------------------------------------------------

namespace {

struct PathResult {
  std::vector<VirtualLight> lights;
  uint64_t rays = 0, nonFinite = 0;
};

// Light transport with shading normals (Veach 1997, "Robust Monte Carlo
// Methods for Light Transport Simulation", section 5.3). Radiance is
// transported with f(wo, wi) |wi.ns| (what the path tracer does); its
// adjoint, for light (importance transport) arriving from wo and leaving
// along wi, is f(wo, wi) |wo.ns| |wi.ng| / |wo.ng|, i.e. continuePath's
// f |wi.ns| / pdf times |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|) (Veach's
// eq. 5.19). Without it a normal-mapped surface reflects a different amount
// of light in light tracing than in the path tracer. Only where the shading
// normal comes from a normal map, so that interpolated vertex normals keep
// their (uncorrected) transport and existing scenes their renders.
//
// |wo.ns| / |wo.ng|: the factor of the arriving direction. A virtual light
// keeps it in its flux; its emission then uses the geometric cosine.
inline float shadingInFactor(const SurfaceHit& sh, const Vec3& wo) {
  return std::abs(dot(wo, sh.shading.n)) / std::abs(dot(wo, sh.ng));
}
// |wi.ng| / |wi.ns|: the factor of the leaving direction.
inline float shadingOutFactor(const SurfaceHit& sh, const Vec3& wi) {
  return std::abs(dot(wi, sh.ng)) / std::abs(dot(wi, sh.shading.n));
}

// Traces light path `index` into out: its virtual lights (flux not yet
// divided by the path count).
void traceOnePath(const Scene& scene, const Accel& accel, const LightSampler& lights,
                  const LightTracingSettings& settings, uint64_t index, PathResult& out) {
  out.lights.clear();
  out.rays = out.nonFinite = 0;
  Rng rng = Rng::forItem(index, 0, 1, settings.seed);
  float uLight = rng.uniform();
  Vec2 uPos{rng.uniform(), rng.uniform()}, uDir{rng.uniform(), rng.uniform()};
  std::optional<EmissionSample> e = lights.sampleLe(uLight, uPos, uDir);
  if (!e) return;
  Vec3 beta = e->beta;
  Ray ray;
  ray.o = isBlack(e->n) ? e->p : offsetRayOrigin(e->p, e->n, e->w);
  ray.d = e->w;
  for (int depth = 1; depth <= settings.maxDepth; ++depth) {
    ++out.rays;
    std::optional<Hit> hit = accel.intersect(ray);
    if (!hit) break;
    SurfaceHit sh = scene.surfaceHit(hit->triangle, hit->u, hit->v, ray.d);
    Vec3 wo = -ray.d;  // toward the previous vertex
    Brdf brdf = scene.brdf(sh);
    Vec3 woL = sh.shading.toLocal(wo);
    if (woL.z <= 0) break;
    if (!isFinite(beta)) {
      ++out.nonFinite;
      break;
    }
    // Deposit a virtual light.
    VirtualLight v;
    v.p = sh.p;
    v.Phi = sh.normalMapped ? beta * shadingInFactor(sh, wo) : beta;
    v.normalMapped = sh.normalMapped;
    v.n = encodeUnit(sh.shading.n);
    v.s = encodeUnit(sh.shading.s);
    v.wi = encodeUnit(wo);
    v.ng = encodeUnit(sh.ng);
    for (int c = 0; c < 3; ++c) v.base[c] = toUnorm16(brdf.baseColor[c]);
    v.metallic = toUnorm16(brdf.metallic);
    v.roughX = toUnorm16(std::sqrt(brdf.ggx.ax));
    v.roughY = toUnorm16(std::sqrt(brdf.ggx.ay));
    v.specular = toUnorm16(brdf.specularWeight);
    if (brdf.hasCoat()) {
      v.clearcoat = toUnorm16(brdf.clearcoat);
      v.coatRough = toUnorm16(std::sqrt(brdf.coat.ax));
      const Vec3& cn = brdf.coatNormal;
      v.coatN = cn.x == 0 && cn.y == 0 ? 0 : encodeUnit(sh.shading.toWorld(cn));
    }
    v.depth = uint16_t(std::min(depth, 32767));
    out.lights.push_back(v);

    // Continue by BRDF sampling (the adjoint of a reciprocal BRDF is itself,
    // up to the shading-normal correction where a normal map bends n).
    if (!continuePath(BrdfAt(brdf, woL), sh, rng.uniform(), {rng.uniform(), rng.uniform()}, beta, ray)) break;
    if (sh.normalMapped) beta *= shadingInFactor(sh, wo) * shadingOutFactor(sh, ray.d);
    if (depth >= settings.rrDepth) {
      float q = std::min(0.95f, maxComponent(beta) / std::max(maxComponent(e->beta), 1e-30f));
      if (rng.uniform() >= q) break;
      beta /= q;
    }
  }
}

}  // namespace

VirtualLightSet traceVirtualLights(const Scene& scene, const Accel& accel, const LightSampler& lights,
                                   const LightTracingSettings& settings, const std::atomic<bool>* stop) {
  Stopwatch clock;
  VirtualLightSet set;
  if (lights.empty()) return set;
  // Trace chunks of paths in parallel; append whole paths in path order until
  // the target count is reached, so the set does not depend on threads.
  const uint64_t chunk = 16384;
  uint64_t next = 0;
  // Room for the whole set at once (a path's lights can pass the count by up
  // to its depth): growing by doubling copied every light once or twice more.
  reserveHugePages(set.lights, size_t(settings.count) + size_t(settings.maxDepth));
  // Kept across chunks, so that each path's list keeps its capacity.
  std::vector<PathResult> results(chunk);
  // Paths that deposit nothing (they escape) still count; stop if nothing
  // deposits at all (an open scene seen by no light).
  uint64_t emptyChunks = 0;
  while (set.lights.size() < settings.count && emptyChunks < 64) {
    if (stop && stop->load(std::memory_order_relaxed)) {
      set.stopped = true;
      break;
    }
    parallelFor(size_t(chunk), [&](size_t i) { traceOnePath(scene, accel, lights, settings, next + i, results[i]); });
    size_t before = set.lights.size();
    for (uint64_t i = 0; i < chunk && set.lights.size() < settings.count; ++i) {
      set.lights.insert(set.lights.end(), results[i].lights.begin(), results[i].lights.end());
      set.rays += results[i].rays;
      set.nonFiniteRejected += results[i].nonFinite;
      ++set.paths;
    }
    emptyChunks = set.lights.size() == before ? emptyChunks + 1 : 0;
    next += chunk;
  }
  const float inv = set.paths ? 1.0f / float(set.paths) : 0.0f;
  for (VirtualLight& v : set.lights) v.Phi *= inv;
  set.seconds = clock.seconds();
  return set;
}

// ---- k-nearest-neighbour radii -------------------------------------------------

std::vector<float> knnRadii(const std::vector<VirtualLight>& lights, int k, float scale, float fallback,
                            float minRadius, const std::atomic<bool>* stop) {
  std::vector<float> radii = hugePageVector<float>(lights.size());
  std::fill(radii.begin(), radii.end(), std::max(scale * fallback, minRadius));
  if (lights.size() < 2 || k < 1) return radii;
  const size_t n = lights.size();
  const MortonSorted sorted = mortonSorted(packedPositions(lights));
  const size_t want = std::min<size_t>(size_t(k) + 1, n);  // the light itself is its own 0th neighbour
  const std::vector<float> d2 = kthNearestSquared(sorted, want, stop);
  for (size_t o = 0; o < n; ++o) {
    const float r = scale * std::sqrt(d2[o]);
    radii[sorted.order[o]] = std::isfinite(r) && r > minRadius ? r : minRadius;
  }
  return radii;
}

}  // namespace vsl
