#include "core/lights.h"

namespace vsl {

LightSampler::LightSampler(const Scene& scene, std::shared_ptr<const Environment> env)
    : scene_(scene), env_(std::move(env)) {
  std::vector<double> power;
  lightOfTriangle_.assign(scene.triangleCount(), -1);
  for (uint32_t t = 0; t < scene.triangleCount(); ++t) {
    const Material& m = scene.materials[scene.triMaterial[t]];
    if (!m.isEmissive()) continue;
    float area = scene.triangleArea(t);
    if (!(area > 0)) continue;
    lightOfTriangle_[t] = int32_t(emissiveTris_.size());
    emissiveTris_.push_back(t);
    // Power of a Lambertian emitter: pi * L * area, per emitting side.
    power.push_back(double(luminance(m.emission)) * area * kPi * (m.doubleSided ? 2 : 1));
  }
  for (const PunctualLight& L : scene.punctualLights) power.push_back(L.power(sceneRadius()));
  // The environment's power: what crosses the disk of the bounding sphere
  // facing each direction, as for a directional light.
  if (env_) power.push_back(kPi * sqr(double(sceneRadius())) * env_->powerPerArea());
  dist_ = DiscreteDistribution(power);
}

TrianglePoint sampleTrianglePoint(const Scene& scene, uint32_t tri, Vec2 u) {
  Vec2 b = sampleUniformTriangle(u);
  const Vec3& p0 = scene.positions[scene.indices[3 * tri]];
  const Vec3& p1 = scene.positions[scene.indices[3 * tri + 1]];
  const Vec3& p2 = scene.positions[scene.indices[3 * tri + 2]];
  // sampleUniformTriangle's (b0, b1) weigh p0 and p1; Embree's (b1, b2) weigh p1 and p2.
  Vec2 bary{b.y, 1 - b.x - b.y};
  return {p0 * b.x + p1 * bary.x + p2 * bary.y, bary};
}

std::optional<SampledLight> LightSampler::sample(float uLight) const {
  if (empty()) return std::nullopt;
  SampledLight l;
  l.light = dist_.sample(uLight, &l.pmf, &l.uRemapped);
  if (!(l.pmf > 0)) return std::nullopt;
  return l;
}

std::optional<LightSample> LightSampler::sampleLi(const Vec3& p, float uLight, Vec2 u) const {
  std::optional<SampledLight> picked = sample(uLight);
  if (!picked) return std::nullopt;
  const size_t i = picked->light;
  const float pmf = picked->pmf;
  if (env_ && i == environmentIndex()) return environmentLi(p, *picked, u);
  LightSample s;
  if (i < emissiveTris_.size()) {
    uint32_t tri = emissiveTris_[i];
    TrianglePoint y = sampleTrianglePoint(scene_, tri, u);
    s.pLight = y.p;
    Vec3 d = s.pLight - p;
    float d2 = lengthSquared(d);
    if (!(d2 > 0)) return std::nullopt;
    s.dist = std::sqrt(d2);
    s.wi = d / s.dist;
    Vec3 n = scene_.triangleNormal(tri);
    float cosL = -dot(n, s.wi);  // > 0 when the front face sees p
    const Material& m = scene_.materials[scene_.triMaterial[tri]];
    if (cosL <= 0 && !m.doubleSided) return std::nullopt;
    s.nLight = cosL > 0 ? n : -n;
    cosL = std::abs(cosL);
    if (!(cosL > 0)) return std::nullopt;
    s.Li = scene_.emission(tri, y.bary);
    s.pdf = pmf / scene_.triangleArea(tri) * d2 / cosL;
    s.delta = false;
  } else {
    const PunctualLight& L = scene_.punctualLights[i - emissiveTris_.size()];
    if (L.type == PunctualLight::Type::Directional) {
      std::optional<LightSample> d = directionalLi(L, p, pmf);
      if (d) d->light = i;
      return d;
    }
    Vec3 d = L.position - p;
    float d2 = lengthSquared(d);
    if (!(d2 > 0)) return std::nullopt;
    s.dist = std::sqrt(d2);
    s.wi = d / s.dist;
    s.pLight = L.position;
    s.nLight = Vec3(0.0f);
    s.Li = L.intensity * (L.falloff(-s.wi) / d2);
    s.pdf = pmf;
    s.delta = true;
  }
  if (isBlack(s.Li)) return std::nullopt;
  s.light = i;
  return s;
}

std::optional<EmissionSample> LightSampler::sampleLe(float uLight, Vec2 uPos, Vec2 uDir) const {
  std::optional<SampledLight> picked = sample(uLight);
  if (!picked) return std::nullopt;
  const size_t i = picked->light;
  const float pmf = picked->pmf;
  if (env_ && i == environmentIndex()) return environmentLe(*picked, uDir, uPos);
  EmissionSample e;
  if (i < emissiveTris_.size()) {
    uint32_t tri = emissiveTris_[i];
    const Material& m = scene_.materials[scene_.triMaterial[tri]];
    TrianglePoint y = sampleTrianglePoint(scene_, tri, uPos);
    e.p = y.p;
    e.n = scene_.triangleNormal(tri);
    float sides = 1;
    if (m.doubleSided) {  // pick a side with probability 1/2, reusing uDir.x
      sides = 2;
      if (uDir.x < 0.5f) {
        e.n = -e.n;
        uDir.x *= 2;
      } else {
        uDir.x = (uDir.x - 0.5f) * 2;
      }
      uDir.x = std::min(uDir.x, 0.99999994f);
    }
    // Cosine-weighted direction: Le cos / (pmf (1/A) (cos/pi) / sides) = Le pi A sides / pmf.
    e.w = Frame(e.n).toWorld(sampleCosineHemisphere(uDir));
    e.beta = scene_.emission(tri, y.bary) * (kPi * scene_.triangleArea(tri) * sides / pmf);
  } else {
    const PunctualLight& L = scene_.punctualLights[i - emissiveTris_.size()];
    e.p = L.position;
    e.n = Vec3(0.0f);
    if (L.type == PunctualLight::Type::Directional) {
      // A parallel beam through the disk of the bounding sphere facing it,
      // from a point outside the sphere: beta = E pi R^2 / pmf.
      const float R = sceneRadius();
      const Vec2 d = sampleUniformDiskConcentric(uPos);
      const Frame f(L.direction);
      e.p = scene_.center() - L.direction * (1.01f * R) + f.toWorld(Vec3(d.x * R, d.y * R, 0));
      e.w = L.direction;
      e.beta = L.intensity * (kPi * R * R / pmf);
    } else if (L.type == PunctualLight::Type::Point) {
      e.w = sampleUniformSphere(uDir);
      e.beta = L.intensity * (4 * kPi / pmf);
    } else {
      Vec3 local = sampleUniformCone(uDir, L.cosOuter);
      e.w = Frame(L.direction).toWorld(local);
      e.beta = L.intensity * (L.falloff(e.w) / (pmf * uniformConePdf(L.cosOuter)));
    }
  }
  if (isBlack(e.beta) || !isFinite(e.beta)) return std::nullopt;
  e.light = i;
  return e;
}

float LightSampler::sceneRadius() const { return std::max(scene_.boundingRadius(), 1e-6f); }

// A directional light seen from p: irradiance E from -direction, its shadow
// ray ending outside the bounding sphere (docs/REFERENCE.md "Lights").
std::optional<LightSample> LightSampler::directionalLi(const PunctualLight& L, const Vec3& p, float pmf) const {
  LightSample s;
  s.wi = -L.direction;
  s.dist = length(p - scene_.center()) + 2 * sceneRadius();
  s.pLight = p + s.wi * s.dist;
  s.nLight = Vec3(0.0f);
  s.Li = L.intensity;
  s.pdf = pmf;
  s.delta = true;
  if (isBlack(s.Li)) return std::nullopt;
  return s;
}

// The environment seen from p: a direction by the environment's own
// sampling (its part chosen with the remapped uLight), the shadow ray ending
// outside the bounding sphere as a directional light's does.
std::optional<LightSample> LightSampler::environmentLi(const Vec3& p, const SampledLight& picked, Vec2 u) const {
  std::optional<EnvironmentSample> es = env_->sample(picked.uRemapped, u);
  if (!es || isBlack(es->L)) return std::nullopt;
  LightSample s;
  s.wi = es->w;
  s.dist = length(p - scene_.center()) + 2 * sceneRadius();
  s.pLight = p + s.wi * s.dist;
  s.nLight = Vec3(0.0f);
  s.Li = es->L;
  s.pdf = picked.pmf * es->pdf;
  s.delta = false;
  s.light = picked.light;
  return s;
}

// Light entering from the environment: a direction w toward the sky by the
// environment's sampling, then a point on the disk of the bounding sphere
// perpendicular to w, outside the sphere on w's side; the ray travels along
// -w (pbrt-v4's ImageInfiniteLight::SampleLe has this structure). Its
// throughput is L(w) pi R^2 / (pmf pdf(w)).
std::optional<EmissionSample> LightSampler::environmentLe(const SampledLight& picked, Vec2 uDir, Vec2 uPos) const {
  std::optional<EnvironmentSample> es = env_->sample(picked.uRemapped, uDir);
  if (!es || isBlack(es->L)) return std::nullopt;
  const float R = sceneRadius();
  const Vec2 d = sampleUniformDiskConcentric(uPos);
  const Frame f(es->w);
  EmissionSample e;
  e.p = scene_.center() + es->w * (1.01f * R) + f.toWorld(Vec3(d.x * R, d.y * R, 0));
  e.n = Vec3(0.0f);
  e.w = -es->w;
  e.beta = es->L * (kPi * R * R / (picked.pmf * es->pdf));
  if (!isFinite(e.beta)) return std::nullopt;
  e.light = picked.light;
  return e;
}

float LightSampler::pdfEnvironment(const Vec3& w) const {
  if (!env_) return 0;
  return dist_.pmf(environmentIndex()) * env_->pdf(w);
}

float LightSampler::pdfLi(const Vec3& p, uint32_t tri, const Vec3& y) const {
  if (tri >= lightOfTriangle_.size() || lightOfTriangle_[tri] < 0) return 0;
  Vec3 d = y - p;
  float d2 = lengthSquared(d);
  float cosL = std::abs(dot(scene_.triangleNormal(tri), d)) / std::sqrt(d2);
  if (!(cosL > 0)) return 0;
  return dist_.pmf(size_t(lightOfTriangle_[tri])) / scene_.triangleArea(tri) * d2 / cosL;
}

}  // namespace vsl
