// Bidirectional path tracing (Veach 1997, chapter 10); see core/bdpt.h.
//
// Sections: [1] the pinhole camera as an endpoint, [2] densities,
// [3] subpaths, [4] connections, [5] MIS weights, [6] passes.
#include "core/bdpt.h"

#include <cmath>

#include "core/check.h"
#include "core/parallel.h"
#include "core/path.h"

namespace vsl {

namespace {

inline Vec2 u2(Rng& r) { return {r.uniform(), r.uniform()}; }

// The tile edge of parallelForTiles (core/parallel.cpp): splats are kept per
// tile and summed in tile order.
constexpr int kTile = 16;

// Veach's adjoint BSDF for shading normals (1997, section 5.3, eq. 5.17): a
// light subpath arriving from wPrev and leaving along wNext (world) carries
// f |wPrev.ns| |wNext.ng| / |wPrev.ng|, so that its throughput measures the
// same path contribution as a camera path through the same vertices.
float shadingCorrection(const SurfaceHit& h, const Vec3& wPrev, const Vec3& wNext) {
  const float num = std::abs(dot(wPrev, h.shading.n)) * std::abs(dot(wNext, h.ng));
  const float den = std::abs(dot(wPrev, h.ng)) * std::abs(dot(wNext, h.shading.n));
  return den > 0 ? num / den : 0.0f;
}

}  // namespace

BdptRenderer::BdptRenderer(const Scene& scene, const Accel& accel, const LightSampler& lights,
                           const RenderSettings& settings, const BdptOptions& options)
    : scene_(scene), accel_(accel), lights_(lights), settings_(settings), options_(options) {
  width_ = settings.width;
  height_ = settings.height;
  resolveResolution(scene, width_, height_);
  tanHalf_ = std::tan(0.5f * scene.camera.yfov);
  aspect_ = float(width_) / float(height_);
  filmArea_ = 4 * tanHalf_ * tanHalf_ * aspect_;
  sceneRadius_ = std::max(scene.boundingRadius(), 1e-6f);  // as LightSampler's directional beam
}

// ---- [1] The pinhole camera -------------------------------------------------------------

// Camera::generateRay inverted: w = normalize(forward + right sx + up sy),
// sx = (2 px / W - 1) tan(fov/2) aspect, sy = (1 - 2 py / H) tan(fov/2).
bool BdptRenderer::raster(const Vec3& w, float& px, float& py) const {
  const Camera& c = scene_.camera;
  const float cosC = dot(w, c.forward);
  if (!(cosC > 0)) return false;
  const float sx = dot(w, c.right) / cosC, sy = dot(w, c.up) / cosC;
  px = (sx / (tanHalf_ * aspect_) + 1) * 0.5f * width_;
  py = (1 - sy / tanHalf_) * 0.5f * height_;
  return px >= 0 && px < width_ && py >= 0 && py < height_;
}

// A uniform point on the image plane at distance 1 (area filmArea_) seen
// from the pinhole: solid-angle density 1 / (A cos^3) (pbrt-v3, 16.1.1). The
// importance is W = 1 / (A cos^4), so that W cos / pdf = 1 for camera rays.
double BdptRenderer::cameraPdfDir(const Vec3& w) const {
  float px, py;
  if (!raster(w, px, py)) return 0;
  const double cosC = dot(w, scene_.camera.forward);
  return 1.0 / (double(filmArea_) * cosC * cosC * cosC);
}

// ---- [2] Densities ------------------------------------------------------------------------

namespace {
// A solid-angle density at `from` turned into an area density at `to`:
// pdf |cos_to| / d^2. Zero at the camera and at punctual lights (no
// direction reaches a point); unchanged toward the environment, whose
// vertices are directions (core/bdpt.h).
double toArea(double pdf, const Vec3& from, const BdptVertex& to, bool toPunctual) {
  if (to.infinite) return pdf;
  if (to.kind == BdptVertex::Kind::Camera || toPunctual) return 0;
  const Vec3 d = to.p - from;
  const double d2 = lengthSquared(d);
  if (!(d2 > 0)) return 0;
  return pdf * std::abs(dot(to.ng, d)) / (d2 * std::sqrt(d2));
}
}  // namespace

double BdptRenderer::originDensity(const BdptVertex& v) const {
  if (v.infinite) return lights_.pdfEnvironment(-v.ng);
  if (v.kind == BdptVertex::Kind::Light && isPunctual(v.light)) return lights_.pmf(v.light);
  const uint32_t tri = v.kind == BdptVertex::Kind::Light ? lights_.emissiveTriangle(v.light) : v.hit.triangle;
  const int32_t light = lights_.lightOfTriangle(tri);
  if (light < 0) return 0;
  return double(lights_.pmf(size_t(light))) / scene_.triangleArea(tri);
}

// The density of LightSampler::sampleLe's direction from light vertex v
// (a light, or a surface on an emitter) toward `to`, as area density at `to`.
double BdptRenderer::emissionDensity(const BdptVertex& v, const BdptVertex& to) const {
  const Vec3 w = normalize(to.p - v.p);
  if (v.infinite) {
    // A beam through the disk of the bounding sphere (LightSampler's
    // environmentLe), as a directional light's.
    const bool toPunctual = to.kind == BdptVertex::Kind::Light && isPunctual(to.light);
    if (to.kind == BdptVertex::Kind::Camera || toPunctual || to.infinite) return 0;
    return std::abs(dot(to.ng, v.ng)) / (kPi * sceneRadius_ * sceneRadius_);
  }
  if (v.kind == BdptVertex::Kind::Light && isPunctual(v.light)) {
    const PunctualLight& L = punctual(v.light);
    const bool toPunctual = to.kind == BdptVertex::Kind::Light && isPunctual(to.light);
    if (L.type == PunctualLight::Type::Directional) {
      // A beam through the disk of the bounding sphere: density 1 / (pi R^2)
      // across the beam, times the cosine at the receiver.
      if (to.kind == BdptVertex::Kind::Camera || toPunctual) return 0;
      return std::abs(dot(to.ng, L.direction)) / (kPi * sceneRadius_ * sceneRadius_);
    }
    double pdf = uniformSpherePdf();
    if (L.type == PunctualLight::Type::Spot) pdf = dot(L.direction, w) >= L.cosOuter ? uniformConePdf(L.cosOuter) : 0;
    return toArea(pdf, v.p, to, toPunctual);
  }
  const uint32_t tri = v.kind == BdptVertex::Kind::Light ? lights_.emissiveTriangle(v.light) : v.hit.triangle;
  const float c = dot(scene_.triangleNormal(tri), w);
  const bool twoSided = scene_.materials[scene_.triMaterial[tri]].doubleSided;
  // Cosine-weighted about the emitting side's normal; a double-sided
  // emitter first picks its side with probability 1/2.
  const double pdf = twoSided ? std::abs(c) * kInvPi * 0.5 : (c > 0 ? c * kInvPi : 0.0);
  return toArea(pdf, v.p, to, false);
}

double BdptRenderer::density(const BdptVertex& v, const BdptVertex* prev, const BdptVertex& to) const {
  const bool toPunctual = to.kind == BdptVertex::Kind::Light && isPunctual(to.light);
  switch (v.kind) {
    case BdptVertex::Kind::Camera:
      return toArea(cameraPdfDir(normalize(to.p - v.p)), v.p, to, toPunctual);
    case BdptVertex::Kind::Light:
      return emissionDensity(v, to);
    case BdptVertex::Kind::Surface:
      break;
  }
  if (!prev) return 0;
  const Frame& fr = v.hit.shading;
  const Vec3 wIn = fr.toLocal(normalize(prev->p - v.p)), wOut = fr.toLocal(normalize(to.p - v.p));
  return toArea(BrdfAt(v.f.brdf(), wIn).pdf(wOut), v.p, to, toPunctual);
}

// ---- [3] Subpaths -------------------------------------------------------------------------

int BdptRenderer::cameraSubpath(int x, int y, Rng& rng, BdptVertex* path, uint64_t& rays) const {
  BdptVertex& c = path[0];
  c = BdptVertex{};
  c.kind = BdptVertex::Kind::Camera;
  c.p = scene_.camera.position;
  c.ng = Vec3(0.0f);
  c.beta = Vec3(1.0f);  // W cos / pdf = 1 for a pinhole
  c.pdfFwd = 1;         // the pinhole's position is fixed
  Ray ray = scene_.camera.generateRay(x + rng.uniform(), y + rng.uniform(), width_, height_);
  return walk(ray, Vec3(1.0f), false, rng, path, 1, maxCameraVertices(), rays);
}

int BdptRenderer::lightSubpath(Rng& rng, BdptVertex* path, uint64_t& rays) const {
  if (lights_.empty()) return 0;
  const float uLight = rng.uniform();
  const Vec2 uPos = u2(rng), uDir = u2(rng);
  std::optional<EmissionSample> e = lights_.sampleLe(uLight, uPos, uDir);
  if (!e) return 0;
  BdptVertex& l = path[0];
  l = BdptVertex{};
  l.kind = BdptVertex::Kind::Light;
  l.p = e->p;
  l.ng = e->n;
  l.light = e->light;
  l.infinite = isEnvironment(l.light);
  if (l.infinite) l.ng = e->w;
  l.pdfFwd = originDensity(l);
  l.beta = e->beta;
  if (!isPunctual(l.light) && !l.infinite) {
    // Le / pL(x0), for joining the origin to the camera (s = 1, t = 1):
    // sampleLe's beta is Le pi A sides / pmf.
    const uint32_t tri = lights_.emissiveTriangle(l.light);
    l.beta = e->beta / (kPi * (scene_.materials[scene_.triMaterial[tri]].doubleSided ? 2.0f : 1.0f));
  }
  Ray ray;
  ray.o = offsetRayOrigin(e->p, e->n, e->w);
  ray.d = e->w;
  return walk(ray, e->beta, true, rng, path, 1, maxLightVertices(), rays);
}

// Extends a subpath of `count` vertices by BRDF sampling until it leaves the
// scene, Russian roulette ends it (after rrDepth bounces, as the path
// tracer) or it has maxCount vertices. Sets each new vertex's pdfFwd and
// the pdfRev of the vertex two before it.
int BdptRenderer::walk(Ray ray, Vec3 beta, bool fromLight, Rng& rng, BdptVertex* path, int count, int maxCount,
                       uint64_t& rays) const {
  // Light subpaths carry flux: roulette on the throughput relative to the start.
  const float rrScale = fromLight ? 1.0f / std::max(maxComponent(beta), 1e-30f) : 1.0f;
  while (count < maxCount) {
    ++rays;
    std::optional<Hit> hit = accel_.intersect(ray);
    if (!hit) {
      if (!fromLight && lights_.environment()) escape(ray, beta, path, count++);
      break;
    }
    BdptVertex& prev = path[count - 1];
    BdptVertex& v = path[count];
    v.kind = BdptVertex::Kind::Surface;
    v.infinite = false;  // the slot may have held an escaped vertex
    v.hit = scene_.surfaceHit(hit->triangle, hit->u, hit->v, ray.d);
    v.p = v.hit.p;
    v.ng = v.hit.ng;
    v.beta = beta;
    v.light = 0;
    const Vec3 wPrev = -ray.d;
    v.f = BrdfAt(scene_.brdf(v.hit), v.hit.shading.toLocal(wPrev));
    // Densities from the vertices' positions (not the sampled direction), as
    // misWeight recomputes them at a connection, so that the weights of a
    // path's strategies agree to rounding.
    v.pdfFwd = density(prev, count >= 2 ? &path[count - 2] : nullptr, v);
    v.pdfRev = 0;
    if (count >= 2) path[count - 2].pdfRev = density(prev, &v, path[count - 2]);
    if (++count >= maxCount) break;

    // Continue by sampling the BRDF.
    std::optional<BrdfSample> bs = continuePath(v.f, v.hit, rng.uniform(), u2(rng), beta, ray);
    if (!bs) break;
    if (fromLight) beta *= shadingCorrection(v.hit, wPrev, ray.d);
    if (!isFinite(beta) || isBlack(beta)) break;
    if (count - 1 >= settings_.rrDepth) {
      const float q = std::min(0.95f, maxComponent(beta) * rrScale);
      if (rng.uniform() >= q) break;
      beta /= q;
    }
  }
  return count;
}

void BdptRenderer::escape(const Ray& ray, const Vec3& beta, BdptVertex* path, int count) const {
  const BdptVertex& prev = path[count - 1];
  BdptVertex& v = path[count];
  v = BdptVertex{};
  v.kind = BdptVertex::Kind::Light;
  v.infinite = true;
  v.light = lights_.lightCount() - 1;
  // A point along the ray beyond the bounding sphere: only its direction
  // from prev is read.
  v.p = prev.p + ray.d * (length(prev.p - scene_.center()) + 2 * sceneRadius_);
  v.ng = -ray.d;
  v.beta = beta;
  v.pdfFwd = density(prev, count >= 2 ? &path[count - 2] : nullptr, v);
  if (count >= 2) path[count - 2].pdfRev = density(prev, &v, path[count - 2]);
}

// ---- [4] Connections ----------------------------------------------------------------------

Vec3 BdptRenderer::scatter(const BdptVertex& v, const Vec3& w, bool lightSide) const {
  if (v.kind != BdptVertex::Kind::Surface || !(dot(w, v.ng) > 0)) return Vec3(0.0f);
  const Vec3 wl = v.hit.shading.toLocal(w);
  const Vec3 f = v.f.eval(wl);
  if (!lightSide) return f * std::abs(wl.z);
  return f * (std::abs(wl.z) * shadingCorrection(v.hit, v.hit.shading.toWorld(v.f.w()), w));
}

// s = 0: the camera subpath's last vertex lies on an emitter.
Vec3 BdptRenderer::connectEmitterHit(const BdptVertex* camera, int t) const {
  const BdptVertex& c = camera[t - 1];
  if (c.infinite) return c.beta * lights_.environment()->radiance(-c.ng);
  if (c.kind != BdptVertex::Kind::Surface) return Vec3(0.0f);
  return c.beta * scene_.emitted(c.hit, normalize(camera[t - 2].p - c.p));
}

// s = 1, t >= 2: a light point sampled from the camera vertex (as the path
// tracer's next-event estimation); `sampled` receives it for the MIS weight.
Vec3 BdptRenderer::connectSampledLight(const BdptVertex& c, Rng& rng, BdptVertex& sampled, uint64_t& rays) const {
  const float uLight = rng.uniform();
  const Vec2 u = u2(rng);
  if (c.kind != BdptVertex::Kind::Surface) return Vec3(0.0f);
  std::optional<LightSample> ls = lights_.sampleLi(c.p, uLight, u);
  if (!ls) return Vec3(0.0f);
  const Vec3 f = scatter(c, ls->wi, false);
  if (isBlack(f)) return Vec3(0.0f);
  Ray shadow;
  ++rays;
  if (!segmentRay(c.p, c.ng, ls->pLight, ls->nLight, shadow) || accel_.occluded(shadow)) return Vec3(0.0f);
  sampled = BdptVertex{};
  sampled.kind = BdptVertex::Kind::Light;
  sampled.p = ls->pLight;
  sampled.ng = ls->nLight;
  sampled.light = ls->light;
  sampled.infinite = isEnvironment(ls->light);
  if (sampled.infinite) sampled.ng = -ls->wi;
  sampled.pdfFwd = originDensity(sampled);
  return c.beta * f * ls->Li / ls->pdf;
}

// t = 1: light vertex q (the light's own point when origin) seen by the
// camera: beta f cos_q W cos_c / d^2 with W = 1 / (A cos_c^4). (px, py) is
// where it lands.
Vec3 BdptRenderer::connectCamera(const BdptVertex& q, bool origin, float& px, float& py, uint64_t& rays) const {
  const Vec3 cam = scene_.camera.position;
  const Vec3 d = cam - q.p;
  const float d2 = lengthSquared(d);
  if (!(d2 > 0)) return Vec3(0.0f);
  const Vec3 w = d / std::sqrt(d2);  // from q toward the camera
  if (!raster(-w, px, py)) return Vec3(0.0f);
  Vec3 value, nLit = q.ng;
  if (origin) {
    if (isPunctual(q.light) || q.infinite) return Vec3(0.0f);  // a point or a direction: the pinhole cannot see it
    const uint32_t tri = lights_.emissiveTriangle(q.light);
    const Vec3 n = scene_.triangleNormal(tri);
    const float c = dot(n, w);
    if (!(c > 0) && !scene_.materials[scene_.triMaterial[tri]].doubleSided) return Vec3(0.0f);
    value = q.beta * std::abs(c);
    nLit = c > 0 ? n : -n;
  } else {
    value = q.beta * scatter(q, w, true);
  }
  if (isBlack(value)) return Vec3(0.0f);
  const float cosC = dot(-w, scene_.camera.forward);
  value *= 1.0f / (filmArea_ * cosC * cosC * cosC * d2);
  Ray shadow;
  ++rays;
  if (!segmentRay(q.p, nLit, cam, Vec3(0.0f), shadow) || accel_.occluded(shadow)) return Vec3(0.0f);
  return value;
}

// s >= 2, t >= 2: light vertex q joined to camera vertex c.
Vec3 BdptRenderer::connectInner(const BdptVertex& q, const BdptVertex& c, uint64_t& rays) const {
  const Vec3 d = c.p - q.p;
  const float d2 = lengthSquared(d);
  if (!(d2 > 0)) return Vec3(0.0f);
  const Vec3 w = d / std::sqrt(d2);  // from q toward c
  const Vec3 fq = scatter(q, w, true);
  if (isBlack(fq)) return Vec3(0.0f);
  const Vec3 fc = scatter(c, -w, false);
  if (isBlack(fc)) return Vec3(0.0f);
  Ray shadow;
  ++rays;
  if (!segmentRay(q.p, q.ng, c.p, c.ng, shadow) || accel_.occluded(shadow)) return Vec3(0.0f);
  return q.beta * fq * fc * c.beta / d2;
}

// ---- [5] MIS weights ----------------------------------------------------------------------

// The joined path x0 .. x(n-1), x0 on the light, x(n-1) the camera. Strategy
// s generates x0..x(s-1) from the light and the rest from the camera, with
// density p_s = prod_{i<s} pL(x_i) prod_{i>=s} pE(x_i), so that
// p_{s+1} / p_s = pL(x_s) / pE(x_s) (Veach 1997, section 10.2). The weight
// is p_s^b / sum_k p_k^b (b = 2: power heuristic; b = 1: balance), over the
// strategies k with t >= 1; impossible ones have a zero density.
double BdptRenderer::misWeight(const BdptVertex* light, int s, const BdptVertex* camera, int t,
                               const BdptVertex* sampled) const {
  const int n = s + t;
  thread_local std::vector<double> pL, pE;
  pL.assign(size_t(n), 0);
  pE.assign(size_t(n), 0);
  auto X = [&](int i) -> const BdptVertex& {
    if (i < s) return (i == 0 && sampled) ? *sampled : light[i];
    return camera[n - 1 - i];
  };
  // The environment seen by the camera has one strategy, s = 0 (it cannot
  // be joined to the pinhole).
  if (n == 2 && X(0).infinite) return 1;
  for (int i = 0; i < n; ++i) {
    const BdptVertex& v = X(i);
    pL[i] = i < s ? v.pdfFwd : v.pdfRev;
    pE[i] = i < s ? v.pdfRev : v.pdfFwd;
  }
  // The densities the connection changes.
  if (s == 0) {
    pL[0] = originDensity(X(0));
    pL[1] = emissionDensity(X(0), X(1));
  } else {
    if (t >= 2) {
      pL[s] = s == 1 ? emissionDensity(X(0), X(1)) : density(X(s - 1), &X(s - 2), X(s));
      if (t >= 3) pL[s + 1] = density(X(s), &X(s - 1), X(s + 1));
    }
    pE[s - 1] = t == 1 ? density(X(n - 1), nullptr, X(s - 1)) : density(X(s), &X(s + 1), X(s - 1));
    if (s >= 2) pE[s - 2] = density(X(s - 1), &X(s), X(s - 2));
  }
  const bool power = options_.heuristic == MisHeuristic::Power;
  double sum = 1, r = 1;
  for (int i = s; i < n - 1; ++i) {  // strategies s + 1 .. n - 1
    if (!(pE[i] > 0)) break;
    r *= pL[i] / pE[i];
    sum += power ? r * r : r;
  }
  r = 1;
  for (int i = s - 1; i >= 0; --i) {  // strategies s - 1 .. 0
    if (!(pL[i] > 0)) break;
    r *= pE[i] / pL[i];
    sum += power ? r * r : r;
  }
  const double w = 1 / sum;
  return std::isfinite(w) ? w : 0.0;
}

// ---- [6] Passes ---------------------------------------------------------------------------

struct BdptRenderer::Work {
  std::vector<BdptVertex> camera, light;
  std::vector<Splat> splats;
  Rng rng;
  uint64_t rays = 0, nonFinite = 0;
  Work(int maxCamera, int maxLight) : camera(size_t(maxCamera)), light(size_t(maxLight)) {}
};

void BdptRenderer::connectAll(const BdptVertex* light, int nL, const BdptVertex* camera, int t, Work& w, Vec3& Ld,
                              Vec3& Lind) const {
  const int sMax = std::max(nL, lights_.empty() ? 0 : 1);
  for (int s = 0; s <= sMax; ++s) {
    const int n = s + t;
    if (n < 2 || n - 2 > settings_.maxDepth || (t == 1 && s > nL)) continue;
    if (options_.onlyS >= 0 && (s != options_.onlyS || t != options_.onlyT)) continue;
    BdptVertex sampled;
    float px = 0, py = 0;
    Vec3 L(0.0f);
    if (s == 0)
      L = connectEmitterHit(camera, t);
    else if (t == 1)
      L = connectCamera(light[s - 1], s == 1, px, py, w.rays);
    else if (s == 1)
      L = connectSampledLight(camera[t - 1], w.rng, sampled, w.rays);
    else
      L = connectInner(light[s - 1], camera[t - 1], w.rays);
    if (isBlack(L)) continue;
    const double mis =
        options_.unweighted ? 1.0 : misWeight(light, s, camera, t, (s == 1 && t > 1) ? &sampled : nullptr);
    const Vec3 c = L * float(mis);
    if (!isFinite(c)) {
      ++w.nonFinite;
      continue;
    }
    const bool direct = n <= 3;  // at most one scattering event
    if (t == 1)
      w.splats.push_back({uint32_t(int(py) * width_ + int(px)), direct, c});
    else
      (direct ? Ld : Lind) += c;
  }
}

void BdptRenderer::samplePixel(int x, int y, int pass, Work& w, Vec3& Ld, Vec3& Lind) const {
  w.rng = Rng::forItem(uint64_t(y) * width_ + x, uint64_t(pass), kBdptStream, settings_.seed);
  const int nC = cameraSubpath(x, y, w.rng, w.camera.data(), w.rays);
  const int nL = lightSubpath(w.rng, w.light.data(), w.rays);
  Ld = Vec3(0.0f);
  Lind = Vec3(0.0f);
  for (int t = 1; t <= nC; ++t) connectAll(w.light.data(), nL, w.camera.data(), t, w, Ld, Lind);
}

bool BdptRenderer::renderPass(int pass, Film& direct, Film& indirect, PtCounters& counters,
                              const std::atomic<bool>* stop) const {
  VSL_CHECK_EQ(direct.width(), width_);
  VSL_CHECK_EQ(direct.height(), height_);
  VSL_CHECK_EQ(indirect.width(), width_);
  VSL_CHECK_EQ(indirect.height(), height_);
  const size_t npix = size_t(width_) * height_;
  // This pass's estimates per pixel: the camera subpaths' own, then the
  // splats of every tile's light subpaths, summed in tile order.
  std::vector<Vec3> sums[2] = {std::vector<Vec3>(npix, Vec3(0.0f)), std::vector<Vec3>(npix, Vec3(0.0f))};
  const int tilesX = (width_ + kTile - 1) / kTile, tilesY = (height_ + kTile - 1) / kTile;
  std::vector<std::vector<Splat>> splats(size_t(tilesX) * tilesY);
  const bool done = parallelForTiles(width_, height_, stop, [&](int x0, int y0, int x1, int y1) {
    VSL_CHECK(x0 % kTile == 0 && y0 % kTile == 0);
    Work w(maxCameraVertices(), maxLightVertices());
    uint64_t paths = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const size_t i = size_t(y) * width_ + x;
        samplePixel(x, y, pass, w, sums[0][i], sums[1][i]);
        ++paths;
      }
    splats[size_t(y0 / kTile) * tilesX + x0 / kTile] = std::move(w.splats);
    counters.rays.fetch_add(w.rays, std::memory_order_relaxed);
    counters.nonFinite.fetch_add(w.nonFinite, std::memory_order_relaxed);
    counters.paths.fetch_add(paths, std::memory_order_relaxed);
  });
  if (!done) return false;
  for (const std::vector<Splat>& tile : splats)
    for (const Splat& s : tile) sums[s.direct ? 0 : 1][s.pixel] += s.value;
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      const size_t i = size_t(y) * width_ + x;
      direct.add(x, y, sums[0][i]);
      indirect.add(x, y, sums[1][i]);
    }
  return true;
}

}  // namespace vsl
