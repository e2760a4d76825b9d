// Emitter sampling for next-event estimation: emissive triangles, punctual
// lights and an environment (core/environment.h), chosen in proportion to
// their power.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "core/environment.h"
#include "core/sampling.h"
#include "core/scene.h"

namespace vsl {

struct LightSample {
  Vec3 wi;             // unit direction from the shading point toward the light
  float dist = 0;      // distance to the sampled point
  Vec3 Li;             // incident radiance (area lights) or intensity/d^2 (punctual)
  Vec3 pLight;         // the sampled point on the light
  Vec3 nLight;         // its geometric normal facing the shading point (zero for punctual)
  float pdf = 0;       // solid angle at the shading point; for punctual lights the pmf alone
  bool delta = false;  // punctual: no MIS with BRDF sampling
  size_t light = 0;    // the light's index in sampler order (bidirectional MIS needs it)
};

// A uniformly sampled point on a triangle: pdf = 1/Scene::triangleArea(tri)
// (area measure). bary are the Embree-style barycentrics (b1, b2) of p, with
// p = (1 - b1 - b2) p0 + b1 p1 + b2 p2, as Scene::emission takes them.
struct TrianglePoint {
  Vec3 p;
  Vec2 bary;
};
TrianglePoint sampleTrianglePoint(const Scene& scene, uint32_t tri, Vec2 u);

// A light chosen by the light sampler: its index (emissive triangles first,
// in scene order, then the punctual lights) and the probability of choosing it.
struct SampledLight {
  size_t light = 0;
  float pmf = 0;
  float uRemapped = 0;  // uLight rescaled to [0,1) within the chosen light's bucket
};

// A ray leaving an emitter, for light tracing.
struct EmissionSample {
  Vec3 p;     // origin on the emitter
  Vec3 n;     // emitter's geometric normal on the emitting side (zero for punctual lights)
  Vec3 w;     // unit direction of emission
  Vec3 beta;  // Le cos / (pmf pdf_area pdf_dir): the path's initial throughput (W)
  // The light's index in sampler order (bidirectional MIS needs it).
  size_t light = 0;
};

// Immutable after construction; safe to share between threads.
class LightSampler {
 public:
  // env (optional) lights the scene from infinitely far; it is the last
  // light, its power pi R^2 times its powerPerArea() (R = the bounding radius).
  explicit LightSampler(const Scene& scene, std::shared_ptr<const Environment> env = nullptr);
  bool empty() const { return dist_.size() == 0; }
  double totalPower() const { return dist_.total(); }
  size_t emissiveTriangleCount() const { return emissiveTris_.size(); }
  // Lights in sampler order: emissive triangles, then punctual lights, then
  // the environment if there is one.
  size_t lightCount() const { return emissiveTris_.size() + scene_.punctualLights.size() + (env_ ? 1 : 0); }
  const Environment* environment() const { return env_.get(); }
  // The solid-angle pdf with which sampleLi picks direction w (unit, toward
  // the sky) on the environment; zero without one.
  float pdfEnvironment(const Vec3& w) const;
  // The triangle of light `light` < emissiveTriangleCount().
  uint32_t emissiveTriangle(size_t light) const { return emissiveTris_[light]; }
  // The light index of an emissive triangle; -1 for any other triangle.
  int32_t lightOfTriangle(uint32_t tri) const { return tri < lightOfTriangle_.size() ? lightOfTriangle_[tri] : -1; }

  // Picks a light in proportion to its power. Empty when the scene has no
  // lights. pmf(light) is the probability of picking it (zero past the end).
  std::optional<SampledLight> sample(float uLight) const;
  float pmf(size_t light) const { return dist_.pmf(light); }

  // Picks a light by power (uLight) and a point on it (u) as seen from p.
  // Empty when the scene has no lights or the point faces away.
  std::optional<LightSample> sampleLi(const Vec3& p, float uLight, Vec2 u) const;
  // The solid-angle pdf with which sampleLi picks point y on emissive
  // triangle tri as seen from p (zero for non-emissive triangles).
  float pdfLi(const Vec3& p, uint32_t tri, const Vec3& y) const;
  // Samples a ray leaving a light: the light by power (uLight), a point on it
  // (uPos) and a direction (uDir). Empty when the scene has no lights.
  std::optional<EmissionSample> sampleLe(float uLight, Vec2 uPos, Vec2 uDir) const;

 private:
  const Scene& scene_;
  std::shared_ptr<const Environment> env_;
  std::vector<uint32_t> emissiveTris_;
  std::vector<int32_t> lightOfTriangle_;  // -1 for non-emissive triangles
  DiscreteDistribution dist_;             // over emissive triangles, then punctual lights
  float sceneRadius() const;              // the bounding radius, at least 1e-6
  std::optional<LightSample> directionalLi(const PunctualLight& L, const Vec3& p, float pmf) const;
  std::optional<LightSample> environmentLi(const Vec3& p, const SampledLight& picked, Vec2 u) const;
  std::optional<EmissionSample> environmentLe(const SampledLight& picked, Vec2 uDir, Vec2 uPos) const;
  size_t environmentIndex() const { return emissiveTris_.size() + scene_.punctualLights.size(); }
};

}  // namespace vsl
