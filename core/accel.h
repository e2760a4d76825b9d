// The ray-tracing kernel behind one header: closest hit and occlusion, single
// and batched. Every Embree call lives in accel.cpp; no Embree type leaks.
// Thread-safety: after build(), all queries are safe from any thread.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <string>

#include "core/result.h"
#include "core/scene.h"

namespace vsl {

struct Hit {
  float t;
  uint32_t triangle;
  float u, v;  // p = (1-u-v) p0 + u p1 + v p2
};

class Accel {
 public:
  // Builds a BVH over the scene's triangles; on failure an error names the
  // Embree error (Embree errors also go to the log). Triangles of Mask and
  // Blend materials are holes where their alpha says so, for every query
  // (docs/REFERENCE.md, "Alpha: MASK and BLEND"); for them the Accel keeps a
  // pointer to the scene, which must outlive it.
  static Result<std::unique_ptr<Accel>> build(const Scene& scene);
  ~Accel();

  std::optional<Hit> intersect(const Ray& ray) const;
  bool occluded(const Ray& ray) const;
  // Batched occlusion for the gather loops (spans of equal size, VSL_CHECK):
  // blocked[i] = 1 if rays[i] hits
  // anything in [tMin, tMax]. Coherent batches (many pixels toward one light,
  // or one pixel toward many lights) run fastest.
  void occluded(std::span<const Ray> rays, std::span<uint8_t> blocked) const;

 private:
  Accel();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Moves p off its surface by an amount relative to the coordinates' magnitude,
// along nLit (unit, or zero for no offset).
inline Vec3 offsetToLitSide(const Vec3& p, const Vec3& nLit) {
  float scale = 1e-4f * std::max(1.0f, std::max(std::abs(p.x), std::max(std::abs(p.y), std::abs(p.z))));
  return p + nLit * scale;
}
// Offsets a ray origin off a surface along its geometric normal, toward the
// side of direction w, by an amount relative to the coordinates' magnitude.
inline Vec3 offsetRayOrigin(const Vec3& p, const Vec3& ng, const Vec3& w) {
  return offsetToLitSide(p, dot(ng, w) >= 0 ? ng : -ng);
}

// A shadow ray between two surface points, each moved off its surface along
// its own geometric normal, which must face that point's lit side: the side
// the viewer or the arriving light path is on (a zero normal, as for a point
// light, means no offset). Moving an end toward the other point instead would
// put it on the far side of a thin wall when the other point lies behind it,
// and light would leak through. tMax stops just short of the target. Returns
// false when the points coincide.
// segmentRay() between ends already moved off their surfaces (the gather
// offsets each gather point and each light once, not once per pair).
inline bool segmentRayBetween(const Vec3& from, const Vec3& to, Ray& ray) {
  ray.o = from;
  Vec3 d = to - from;
  float dist = length(d);
  if (!(dist > 0)) return false;
  ray.d = d / dist;
  ray.tMin = 0;
  ray.tMax = dist * (1 - 1e-4f);
  return true;
}
inline bool segmentRay(const Vec3& from, const Vec3& nFrom, const Vec3& to, const Vec3& nTo, Ray& ray) {
  return segmentRayBetween(offsetToLitSide(from, nFrom), offsetToLitSide(to, nTo), ray);
}

}  // namespace vsl
