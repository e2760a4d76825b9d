// The Virtual Spherical Light transfer (Hasan, Krivanek, Walter, Bala 2009).
//
//   T_VSL = 1/(pi r^2) * integral over the cone C of
//           f_x(wo, l) max(0, n_x.l) f_p(w_p, -l) max(0, -n_p.l) dl
//
// C is the cone of directions from x toward the sphere of radius r around p:
// half-angle asin(r/d), 1 - cos = (r/d)^2 / (1 + sqrt(1 - (r/d)^2)) computed
// without cancellation; when d <= r (x inside the sphere) C is the hemisphere
// around the direction to p. The radiance from one light is V * Phi * T_VSL.
// As r -> 0, T_VSL -> f_x cos_x f_p cos_p / d^2, the unclamped VPL transfer.
//
// Quadrature: Monte Carlo with up to three strategies combined by the balance
// heuristic, n samples each: uniform directions in C, sampling f_x, and
// sampling f_p about the light's incoming direction (BRDF samples outside C
// contribute zero). Auto sample counts grow with the cone's solid angle:
// n = max(1, round(33 (1 - cos))), so about 100 evaluations for a hemisphere
// and 3 for a tiny cone.
//
// Strategy selection: a BRDF strategy whose pdf cannot put more than
// kVslStrategyMass of its samples into C (pdf bound x solid angle of C) is
// dropped for that pair; the cone strategy alone covers C, so the estimate
// stays unbiased. Those BRDF samples would almost never land in C, and their
// cost (a sample, two evaluations, two pdfs) dominates a narrow cone's. Lobes
// that are narrow compared with C (near-mirror surfaces) keep their strategy.
#pragma once

#include "core/material.h"
#include "core/rng.h"

namespace vsl {

struct VslReceiver {
  BrdfAt f;     // the receiver's BRDF with wo (toward the viewer, local) fixed
  Frame frame;  // shading frame at x
  Vec3 ng;      // geometric normal at x (directions below it contribute zero)
};

struct VslEmitter {
  BrdfAt f;     // the light's BRDF with its incoming direction (local) fixed
  Frame frame;  // shading frame at p
};

// See "Strategy selection" above.
constexpr double kVslStrategyMass = 0.05;

// 1 - cos of the cone's half-angle for a sphere of radius r at distance d
// (1 when d <= r). Precise for r << d.
double vslConeOneMinusCos(double r, double d);
// Auto sample count per strategy for a cone.
int vslAutoSamples(double oneMinusCos);

struct VslResult {
  Vec3 transfer;  // T_VSL (per unit flux), finite
  int evaluations = 0;
};

// toLight = p - x. samplesPerStrategy <= 0 selects the automatic count.
VslResult vslTransfer(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius,
                      int samplesPerStrategy, Rng& rng);

}  // namespace vsl
