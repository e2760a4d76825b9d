// Light tracing into an immutable VirtualLightSet (instant radiosity, step 1),
// and the per-light radii that turn virtual point lights into virtual
// spherical lights.
//
// Paths start on emitters chosen in proportion to power (area lights: uniform
// point, cosine-weighted direction; point lights: uniform sphere; spots:
// uniform cone weighted by the falloff) and continue by BRDF sampling with
// Russian roulette. A virtual light is deposited at every surface vertex a
// path reaches after leaving the emitter (the emitter's own vertex is direct
// light, which every method computes the same way). Its flux is the path
// throughput divided by its pdf and by the number of paths traced, so the sum
// over lights is an unbiased estimate of the light's transport.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "core/accel.h"
#include "core/lights.h"
#include "core/material.h"
#include "core/result.h"

namespace vsl {

// Unit vectors in 32 bits (octahedral map, 16 bits per axis; error < 1e-4 rad).
uint32_t encodeUnit(const Vec3& v);
Vec3 decodeUnit(uint32_t e);

// One virtual light, 64 bytes. The BRDF at the light is stored resolved
// (textures applied) so that gathering never touches the scene's materials.
struct VirtualLight {
  Vec3 p;               // position
  Vec3 Phi;             // flux carried by the light path (W), already divided by the path count
  uint32_t n;           // shading normal (encodeUnit), facing the side the path arrived from
  uint32_t s;           // shading tangent (anisotropy direction)
  uint32_t wi;          // unit direction toward the previous path vertex
  uint32_t ng;          // geometric normal, same side as n
  uint16_t base[3];     // base colour, unorm16
  uint16_t metallic;    // unorm16
  uint16_t roughX;      // sqrt(alpha_x), unorm16
  uint16_t roughY;      // sqrt(alpha_y), unorm16
  uint16_t specular;    // specularWeight, unorm16
  uint16_t depth : 15;  // scattering vertices on the path so far (1 = first hit)
  // The shading normal n comes from a normal map: Phi already holds the
  // adjoint factor |wi.n| / |wi.ng|, and the light emits with the geometric
  // cosine |l.ng| (Veach 1997, section 5.3; docs/REFERENCE.md, "Normal maps
  // and shading normals").
  uint16_t normalMapped : 1;
  // KHR_materials_clearcoat: the coat's weight (0: none) and sqrt(alpha_c),
  // unorm16, and its normal (encodeUnit), or 0 where it is n.
  uint16_t clearcoat = 0;
  uint16_t coatRough = 0;
  uint32_t coatN = 0;

  Brdf brdf() const;
  Frame frame() const { return Frame(decodeUnit(n), decodeUnit(s)); }
};
static_assert(sizeof(VirtualLight) == 64, "VirtualLight should stay 64 bytes");

struct LightTracingSettings {
  uint32_t count = 10000;  // target number of virtual lights (whole paths are kept)
  uint64_t seed = 0;
  int maxDepth = 16;              // maximum scattering vertices per light path
  int rrDepth = 2;                // Russian roulette from this depth on
  Result<void> validate() const;  // the first invalid setting
};

struct VirtualLightSet {
  std::vector<VirtualLight> lights;
  uint64_t paths = 0;  // light paths traced (the flux normaliser)
  uint64_t rays = 0;
  uint64_t nonFiniteRejected = 0;
  double seconds = 0;
  bool stopped = false;
  size_t bytes() const { return lights.size() * sizeof(VirtualLight); }
};

// Traces light paths until at least settings.count virtual lights exist.
// Deterministic for a given seed, independent of thread count. An empty set
// is returned when the scene has no lights.
// If *stop becomes true, tracing ends early (between chunks of paths) and the
// partial set is returned with `stopped` set.
VirtualLightSet traceVirtualLights(const Scene& scene, const Accel& accel, const LightSampler& lights,
                                   const LightTracingSettings& settings, const std::atomic<bool>* stop = nullptr);

// r_i = scale x (distance to the k-th nearest other light), by
// kthNearestSquared (core/point_tree.h).
// With fewer than k+1 lights, k shrinks to what exists; a single light gets
// scale x fallback. Non-finite or zero distances give the smallest positive
// radius `minRadius`.
// If *stop becomes true, the queries end early (between chunks of 1024
// lights) and the radii are incomplete: the caller must discard them.
std::vector<float> knnRadii(const std::vector<VirtualLight>& lights, int k, float scale, float fallback,
                            float minRadius, const std::atomic<bool>* stop = nullptr);

}  // namespace vsl
