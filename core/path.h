// Path construction shared by the path tracer, light tracing and the
// many-light eye paths (after pbrt-v4's SpawnRay): one BRDF-sampled
// continuation of a path at a surface.
#pragma once

#include <optional>

#include "core/accel.h"
#include "core/material.h"
#include "core/scene.h"

namespace vsl {

// Samples f (u1 picks the lobe, u2 samples it), rejects a direction below
// the geometric surface (the shading normal sent the path through it),
// multiplies beta by f cos / pdf and points ray away from the surface along
// the new direction. Returns the sample, or nothing when the path ends
// there (beta and ray are then unchanged).
inline std::optional<BrdfSample> continuePath(const BrdfAt& f, const SurfaceHit& sh, float u1, Vec2 u2, Vec3& beta,
                                              Ray& ray) {
  std::optional<BrdfSample> bs = f.sample(u1, u2);
  if (!bs) return std::nullopt;
  Vec3 wi = sh.shading.toWorld(bs->wi);
  if (dot(wi, sh.ng) <= 0) return std::nullopt;
  beta *= bs->f * (bs->wi.z / bs->pdf);
  ray.o = offsetRayOrigin(sh.p, sh.ng, wi);
  ray.d = wi;
  ray.tMin = 0;
  ray.tMax = kInf;
  return bs;
}

}  // namespace vsl
