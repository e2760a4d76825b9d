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
// heuristic, n samples each (see VslCount for how the counts may differ): uniform directions in C, sampling f_x, and
// sampling f_p about the light's incoming direction (BRDF samples outside C
// contribute zero). Auto sample counts grow with the cone's half-angle theta,
// as in the authors' shader: n = 1 + floor(100 theta / (pi/2)) per strategy,
// so 6 at 5 degrees, 17 at 15 and 101 for a hemisphere. (A count that grows
// with the solid angle instead gives one sample per strategy up to about 15
// degrees, and glossy-to-glossy pairs then have a relative standard deviation
// near 0.8 per estimate.)
//
// Normalisation: by default the light's flux is spread over pi r^2, the
// expected area of surface inside the sphere. With the clipped-disk option
// (from a third-party copy of the authors' shader; off by default) it is
// spread over the part of the disk of radius r around p that lies on the
// receiver's side of the receiver's tangent plane,
//   A(h) = r^2 (pi/2 + asin(h/r)) + h sqrt(r^2 - h^2),
// h = signed distance of p from that plane (A = pi r^2 for h >= r). This
// offsets part of the darkening of surfaces next to a corner. As r -> 0,
// h/r grows and A -> pi r^2, so the VPL limit is unchanged.
//
// Strategy selection: a BRDF strategy whose pdf cannot put more than
// kVslStrategyMass of its samples into C (pdf bound x solid angle of C) is
// dropped for that pair; the cone strategy alone covers C, so the estimate
// stays unbiased. Those BRDF samples would almost never land in C, and their
// cost (a sample, two evaluations, two pdfs) dominates a narrow cone's. Lobes
// that are narrow compared with C (near-mirror surfaces) keep their strategy.
#pragma once

#include <optional>
#include <string>

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
  // A normal-mapped light emits with the geometric cosine max(0, -l.ng)
  // instead of the shading one (Veach 1997, section 5.3; its flux holds the
  // rest of the adjoint factor, core/virtual_lights.cpp). ngLocal: ng in the
  // shading frame.
  bool geometricCosine = false;
  Vec3 ngLocal{0, 0, 1};
  // The emission cosine for a direction lp (local, leaving p).
  float cosine(const Vec3& lp) const { return geometricCosine ? std::max(0.0f, dot(lp, ngLocal)) : lp.z; }
};

// See "Strategy selection" above.
constexpr double kVslStrategyMass = 0.05;

// The automatic sample count, used where VslOptions::samplesPerStrategy <= 0.
enum class VslCount {
  Authors,  // the cone angle's count n, for every strategy (vslAutoSamples)
  Lobe,     // n scaled down where both lobes are broad (vslLobeAwareSamples), for every strategy
  Shares,   // the lobe-aware n, shared out by how well each strategy fits the cone (vslStrategyCounts)
};
constexpr VslCount kVslCounts[] = {VslCount::Authors, VslCount::Lobe, VslCount::Shares};
const char* vslCountName(VslCount c);  // "authors", "lobe", "shares"
// The count of a name vslCountName gives; empty for any other name.
std::optional<VslCount> parseVslCount(const std::string& name);

// How the cone integral is evaluated: the paper's Monte Carlo quadrature
// (this file), or in closed form by spherical Gaussians (core/vsl_sg.h;
// biased, no samples).
enum class VslIntegral { Quadrature, Sg };

struct VslOptions {
  int samplesPerStrategy = 0;  // <= 0: automatic (count)
  bool clippedDisk = false;    // divide by the clipped disk's area instead of pi r^2
  // The authors' rule here, so that the bare quadrature is theirs; the
  // renderers choose their own default (ManyLightSettings::vslCount).
  VslCount count = VslCount::Authors;
  VslIntegral integral = VslIntegral::Quadrature;  // the renderers' choice (ManyLightSettings::vslIntegral)
  // With integral Sg: cones wider than this (1 - cos of the half-angle) use
  // the quadrature (ManyLightSettings::vslSgMaxAngle).
  double sgMaxOneMinusCos = 1.0;
};

// 1 - cos of the cone's half-angle for a sphere of radius r at distance d
// (1 when d <= r). Precise for r << d.
double vslConeOneMinusCos(double r, double d);
// Auto sample count per strategy for a cone: 1 + floor(100 theta / (pi/2)).
int vslAutoSamples(double oneMinusCos);
// The lobe-aware automatic count: where both BRDFs are broad compared with
// the cone, so that neither could put more than kVslStrategyMass of its
// samples into it (mass = the larger pdf bound x the cone's solid angle),
// the integrand hardly varies over the cone and the angle's count n is
// scaled down in proportion, to n x mass / kVslStrategyMass (at least 1);
// otherwise n. Any count gives an unbiased estimate; this one spends the
// samples where a lobe is narrow enough to vary across the cone.
int vslLobeAwareSamples(int n, double mass);
// The shares count (VslCount::Shares): each strategy's samples where they pay.
// A BRDF strategy's samples land in the cone with probability at most its
// mass m (pdf bound x the cone's solid angle), so it gets n x min(1, m): few
// where its lobe is broad compared with the cone (most of its samples would be
// drawn, tested and dropped). The cone strategy gets n x min(1, 1 / M), M the
// larger mass of the BRDF strategies in use: few where a lobe narrower than the
// cone holds the integrand, which that lobe's own samples find. Each at least
// 1 (the cone strategy keeps the estimate unbiased on its own), rounded; the
// balance heuristic weighs the strategies by count x pdf (Veach 1997). Any
// counts give an unbiased estimate. A BRDF strategy whose mass is at most
// kVslStrategyMass is not used (0 samples), as in every count.
struct VslStrategyCounts {
  int cone = 0, x = 0, p = 0;  // 0: strategy not used
};
VslStrategyCounts vslStrategyCounts(int n, double massX, double massP);
// Area of the disk of radius r whose centre lies at signed distance h on the
// kept side of a line (the receiver's tangent plane): pi r^2 for h >= r, 0 for
// h <= -r.
double vslClippedDiskArea(double r, double h);

struct VslResult {
  Vec3 transfer;  // T_VSL (per unit flux), finite
  int evaluations = 0;
};

// The lobe floor (a regularisation of the light's lobe; the renderers turn
// it on by default, ManyLightSettings::lobeFloor): where a GGX axis of the
// light's BRDF is narrower than factor x theta (alpha against the cone's half-angle theta in radians, asin(r/d), pi/2
// inside the sphere; at most kVslLobeFloorMaxAlpha), out is the light with
// that axis widened to it, and the result true; otherwise false and out
// untouched. p.f must be a whole BRDF (an emitter always is): the widened
// one is rebuilt from p.f.brdf() and would lose a lobe restriction. A light
// whose lobe is narrower than the cone lights a receiver like a beam from the
// sphere (all its flux in a few degrees), so its contribution is a rare,
// large spike; with the floor it spreads over about the cone, as a sphere's
// worth of neighbouring lights with their own incoming directions would.
// Biased, like the radius, and consistent like it: theta, and so the floor,
// shrinks to zero with the radius (r -> 0 gives the unchanged light).
// Receivers whose gathered lobe is narrower than kVslLobeFloorMinReceiverAlpha
// on either GGX axis, and lights that are not metal (metallic below
// kVslLobeFloorMinLightMetallic), are left unchanged (see below).
bool vslLobeFloor(const VslReceiver& x, const VslEmitter& p, double radius, double d, double factor, VslEmitter& out);
// vslLobeFloor without its test of the pair (vslLobeFloorApplies, below), for
// a caller that has made that test already.
bool vslWidenLobe(const VslEmitter& p, double radius, double d, double factor, VslEmitter& out);
// The light with each GGX axis of its BRDF at least alpha wide (true), or
// false and out untouched where both already are; p.f must be a whole BRDF,
// as above. The lobe floor's and the lobe gather's (LobeGatherMap) widening.
bool widenLobeTo(const VslEmitter& p, float alpha, VslEmitter& out);
// The floor's bound: GGX without multiple scattering loses energy as alpha
// grows (a white-ish metal reflects 0.90 of its light at alpha 0.02 and 0.70
// at 0.4), so receivers near or inside a sphere, whose cones are wide, would
// see a darkened light; 0.3 covers hall's 17-degree cones.
constexpr float kVslLobeFloorMaxAlpha = 0.3f;
// The floor's receivers: only those whose gathered lobe is at least this wide
// on its narrower GGX axis (a receiver restricted to its diffuse lobe, or
// without a specular lobe, counts as wide; a glossy dielectric gathered whole,
// not split, loses the floor for its diffuse lobe too). A near-mirror receiver
// (a polished table, a brushed panel across its brushing) sees a narrow
// light's beam as the reference does, a caustic of a narrow chain of
// reflections; a widened light sends that chain's light where the reference
// has none (tableau at 10,000 lights: indirect mean +12.8% and median relMSE
// 0.49 -> 0.89 with the floor at every receiver; with this bound, 0.49
// unchanged, while hall keeps its gain, 0.244 -> 0.118;
// docs/notebook/2026-12-03-lobe-floor.md, "The floor's receivers").
constexpr float kVslLobeFloorMinReceiverAlpha = 0.05f;
// The floor's lights: only metals. A pure metal puts all its reflected flux
// into its GGX lobe (at metallic 0.5, half of it), so a narrow one is a beam;
// a dielectric's specular lobe holds a few percent of its flux (Fresnel about 0.04 head-on) beside a diffuse lobe
// that is not narrow, and its glossy bounce (cornell-glossy's polished floor
// lighting the walls) is light the reference has where the floor would blur
// it. Measured at 10,000 lights, 64 px, five light sets
// (docs/notebook/2026-12-03-lobe-floor.md, "The floor's lights"): the floor
// on every light cost cornell-glossy's mean of eight sets 7% (0.0233 ->
// 0.0250); on metal lights only it is even (0.0232), hall keeps all of its
// gain (0.244 -> 0.118) and kitchen 60% of it (0.0505 -> 0.0436, against
// 0.0390 on every light).
constexpr float kVslLobeFloorMinLightMetallic = 0.5f;
// Does the floor apply to this pair: a metal light (above) and a receiver at
// least kVslLobeFloorMinReceiverAlpha wide (or without a specular lobe)?
bool vslLobeFloorApplies(const VslReceiver& x, const VslEmitter& p);
// The floor's sphere: where the floor is on and applies to a pair, the
// light's sphere is this many times its k-NN radius for that receiver, and
// the floor follows that radius. A metal light's flux leaves in its lobe
// alone, so its sphere's error is variance more than blur; the wider sphere
// averages it over more of the surface the light stands for. Consistent like
// the radius (r -> 0 as the light count grows). Measured at 10,000 lights,
// five light sets (docs/notebook/2026-12-03-lobe-floor.md): hall 0.118 -> 0.0997 at
// 64 px (clamped VPL 0.1016) and 0.168 -> 0.146 at 256 px; cornell-glossy,
// kitchen and tableau within 1.5% of the floor alone.
constexpr float kVslLobeFloorRadiusScale = 1.5f;

// The quadrature's integrand along the unit direction l (world), with its
// normalisation: f_x(l) max(0, n_x.l) f_p(-l) cos_p / area where l lies in
// the cone and above both sides' surfaces (VslCone's tests), else zero. Its
// integral over directions is the transfer vslTransfer estimates, so an
// estimator that samples directions itself (stochastic lightcuts' lobe
// strategy, docs/REFERENCE.md "Estimators") gathers the same light.
Vec3 vslIntegrand(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius,
                  const VslOptions& options, const Vec3& l);

// toLight = p - x. The scalar reference form: per round, the cone's sample
// (two uniforms), then the receiver's BRDF's (three: the lobe, then the
// direction) and the light's (three); each strategy's terms summed in the
// order drawn, the three sums then added (cone + receiver, + light).
VslResult vslTransfer(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius,
                      const VslOptions& options, Rng& rng);
// The same quadrature eight samples to a register (AVX2, where the CPU has
// it; else vslTransfer): up to 32 rounds' uniforms drawn at once in the
// scalar form's order (Rng::uniforms), each strategy's directions and tests
// (BrdfAt::sampleDirections, the cone's sampling, VslCone::accept), the
// samples that pass left-packed strategy by strategy, both BRDFs evaluated
// on them (BrdfAt::evalTotals) and their terms added in the scalar order.
// Every operation repeats the scalar one without fused multiply-adds, so the
// result is vslTransfer's bit for bit (tests/test_gather.cpp checks the float
// result; the double sums are added in the same order by construction).
VslResult vslTransferBlock(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius,
                           const VslOptions& options, Rng& rng);

}  // namespace vsl
