// The VSL transfer in closed form by spherical Gaussians (--vsl-integral sg).
//
// The quadrature (core/vsl_integral.h) estimates
//   T_VSL = 1/(pi r^2) * integral over the cone C of
//           f_x(wo, l) max(0, n_x.l) f_p(w_p, -l) max(0, -n_p.l) dl
// by Monte Carlo. Here every factor of the integrand becomes a spherical
// Gaussian (SG), G(l; u, lambda) = exp(lambda (u.l - 1)), and the product of
// SGs, itself an SG, is integrated over the sphere exactly:
//   integral of exp(v.l - B) dl = 2 pi exp(|v| - B) (1 - exp(-2|v|)) / |v|   (1)
// with v = sum lambda_k u_k and B = sum lambda_k b_k (Wang et al. 2009,
// "All-frequency rendering of dynamic, spatially-varying reflectance",
// section 4: SG products and integrals; Tokuyoshi 2015, "Virtual Spherical
// Gaussian Lights for Real-time Glossy Indirect Illumination", evaluates
// virtual lights so). No sample is drawn per pair.
//
// The factors, with a = the cone's axis (x toward p), and the approximations
// named:
//  1. The cone C (its indicator) -> G(l; a, lambda_c), lambda_c chosen so
//     that the SG's integral is the cone's solid angle 2 pi (1 - cos theta)
//     (sgSharpnessForSolidAngle). [A1: a soft-edged cone; the SG weighs the
//     cone's centre more than its rim and reaches past it.]
//  2. Each cosine max(0, n.l) -> cos(a) G(l; n, k) / G(a; n, k), k = 2.133,
//     the least-squares SG fit of the clamped cosine over the sphere (our fit
//     gives 2.14, mu 1.176; Tokuyoshi 2015 and Xu et al. 2013 use 2.133 with
//     mu 1.17). Exact at the axis; only the shape across the cone is the
//     SG's. [A2: poor at grazing axes, where the true cosine falls to zero
//     inside the cone and the SG does not.]
//  3. The diffuse lobes are constant over the cone, taken at a. [A3: the
//     albedo-scaling factor of the diffuse lobe (core/material.h) varies.]
//  4. Each GGX specular lobe -> its value at a times a shape. The GGX normal
//     distribution is an SG in the half vector, G(h; n, 2/alpha^2) with
//     amplitude 1/(pi alpha^2) (Wang et al. 2009's NDF fit; this sharpness
//     keeps the NDF's projected integral, 1), warped to the light domain
//     about the mirror direction m = reflect(w) with sharpness
//     2/alpha^2 / (4 w.n) (Wang et al. 2009's spherical warp: the Jacobian
//     of h -> l is 4 w.h). Fresnel, masking and 1/(4 cos cos) are taken at a
//     (exact there). An anisotropic lobe uses alpha = sqrt(alpha_x alpha_y)
//     for the shape [A4: an isotropic shape; anisotropic SGs (Xu et al.
//     2013, "Anisotropic Spherical Gaussians") would keep it, at the price of
//     an approximate product integral], while its value at a (the true
//     anisotropic D) is exact.
//     The lobe relative to its value S(a) blends two SG fits with the same
//     axis u (the warped lobe's) in the log domain, which is again an SG:
//       local    exp(lambda' (u.l - u.a)), lambda' sin(psi) = the slope of
//                log D at a toward u (psi = angle(a, u)): value and slope
//                exact at a. In GGX's tail the slope falls like 1/psi, so
//                this SG's value at u stays within about e^2 of S(a): the
//                tail is not extrapolated into a peak that is not there.
//       global   (D_max / D(h_a)) exp(lambda (u.l - 1)): the NDF fit with its
//                own peak, right where the lobe's peak lies inside the cone
//                and the integral is the lobe's mass, which the fit keeps.
//     The global fit's share is about the part of the lobe's mass inside the
//     cone, the lobe taken as a 2D Gaussian of variance 1/lambda:
//       (1 - exp(-lambda theta_c^2 / 2)) exp(-lambda max(0, psi - theta_c)^2 / 2)
//     (theta_c the cone's half-angle). [A5: GGX's long tail is not an SG,
//     and the share is a heuristic; measured against the quadrature in
//     tests/test_vsl_sg.cpp.]
//  The integrand is then a sum of four SG products (diffuse or specular at
//  each end), each integrated by (1), and divided by pi r^2 (or the clipped
//  disk, as the quadrature). The geometric-normal test of the quadrature
//  (directions below x's geometric normal count zero) is not modelled [A6].
//
// Limits: as r -> 0, lambda_c -> infinity, the global share -> 0 and the
// cone SG's integral -> pi r^2 / d^2 around a where every other factor is
// exact (value and slope), so
// T_SG -> f_x cos_x f_p cos_p / d^2, the unclamped VPL transfer, for every
// lobe (tests/test_vsl_sg.cpp). Inside the sphere (d <= r) the cone is the
// hemisphere about a (lambda_c about 0.797). Zero roughness (alpha 1e-4)
// gives sharpnesses near 1e8; everything is in double and (1) is evaluated
// in the log domain, so the result is finite (non-finite results become 0,
// as the quadrature's do).
//
// A clear coat (KHR_materials_clearcoat, core/material.h) is not fitted: a
// pair with a coated BRDF at either end takes the quadrature instead
// (Gatherer::addVsl), so the closed form never sees one.
//
// Thread-safe (pure functions).
#pragma once

#include <span>

#include "core/vsl_integral.h"

namespace vsl {

// An SG exp(logAmplitude + lambda (axis.l - 1)) over unit directions l.
struct SphericalGaussian {
  Vec3 axis{0, 0, 1};
  double lambda = 0;
  double logAmplitude = 0;
  double eval(const Vec3& l) const;
};

// The least-squares SG fit of max(0, n.l): sharpness (ratio form, above).
constexpr double kSgCosineSharpness = 2.133;

// The integral over the sphere of exp(v.l - B), formula (1), as its log.
double sgLogIntegral(double vx, double vy, double vz, double B);
// The integral over the whole sphere of the product of the SGs.
double sgProductIntegral(std::span<const SphericalGaussian> g);
// lambda such that the integral of exp(lambda (a.l - 1)) over the sphere,
// 2 pi (1 - exp(-2 lambda)) / lambda, is 2 pi omc (the solid angle of a cone
// with 1 - cos(half-angle) = omc, in (0, 1]).
double sgSharpnessForSolidAngle(double omc);

// The warped specular lobe of a BRDF with its first direction w fixed
// (local frame): axis m (local), sharpness, and whether there is one (false
// where the specular lobe is off or w is below the surface).
struct SgLobe {
  Vec3 axis{0, 0, 1};
  double lambda = 0;
  bool on = false;
};
SgLobe sgSpecularLobe(const BrdfAt& f);

// Whether a pair at distance d from a light of this radius takes the closed
// form: options.integral is Sg and the cone is at most
// options.sgMaxOneMinusCos wide (wider ones take the quadrature).
bool vslUsesSg(const VslOptions& options, double radius, double d);

// T_VSL in closed form (see above); evaluations = 0. Same arguments as
// vslTransfer (toLight = p - x), without the random stream.
VslResult vslTransferSg(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius,
                        const VslOptions& options);

// One pair for the block form: the receiver, the light, p - x and the
// radius as vslTransferSg takes them, and optionally their BRDFs packed
// (BrdfAt::pack of x->f and p->f; null: packed here). Neither BRDF may be
// coated (the closed form never sees a coat, above).
struct VslSgPair {
  const VslReceiver* x = nullptr;
  const VslEmitter* p = nullptr;
  const float* xPacked = nullptr;
  const float* pPacked = nullptr;
  Vec3 toLight;
  float radius = 0;
};

// vslTransferSg for n pairs: out[i] the transfer of pairs[i]. Where
// simdAvailable(), eight pairs at a time on AVX2 lanes in float
// (vslTransferSgManyAvx2, core/vsl_sg_avx2.cpp); otherwise the scalar form
// pair by pair. The lanes compute the same factors and the same formula (1)
// with the exponent |v| - B formed without cancellation (its header) and
// agree with the scalar double form to about 1e-4 relative (median; the
// distribution in tests/test_vsl_sg.cpp, VslSg.LanesAgreeWithTheScalarForm).
// One difference: a radius below 1e-8 d is taken as 1e-8 d (float's range;
// the result is then the VPL limit, which such a radius gives anyway).
// Thread-safe.
void vslTransferSgMany(int n, const VslSgPair* pairs, const VslOptions& options, Vec3* out);
void vslTransferSgManyAvx2(int n, const VslSgPair* pairs, const VslOptions& options, Vec3* out);

}  // namespace vsl
