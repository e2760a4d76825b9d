// Emitter sampling for next-event estimation: emissive triangles and punctual
// lights, chosen in proportion to their power.
#pragma once

#include <optional>
#include <vector>

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
};

// A ray leaving an emitter, for light tracing.
struct EmissionSample {
  Vec3 p;     // origin on the emitter
  Vec3 n;     // emitter's geometric normal on the emitting side (zero for punctual lights)
  Vec3 w;     // unit direction of emission
  Vec3 beta;  // Le cos / (pmf pdf_area pdf_dir): the path's initial throughput (W)
};

// Immutable after construction; safe to share between threads.
class LightSampler {
 public:
  explicit LightSampler(const Scene& scene);
  bool empty() const { return dist_.size() == 0; }
  double totalPower() const { return dist_.total(); }
  size_t emissiveTriangleCount() const { return emissiveTris_.size(); }

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
  std::vector<uint32_t> emissiveTris_;
  std::vector<int32_t> lightOfTriangle_;  // -1 for non-emissive triangles
  DiscreteDistribution dist_;             // over emissive triangles, then punctual lights
};

}  // namespace vsl
