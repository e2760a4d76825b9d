// Sampling routines, in threes where an inverse exists: sample(u) returns the
// point, pdf(x) its density, invert(x) the u that maps to x. Each comment names
// the measure of the pdf. Modelled on pbrt-v4's util/sampling.h.
#pragma once

#include <cstddef>
#include <new>
#include <span>
#include <vector>

#include "core/math.h"
#include "core/rng.h"

namespace vsl {

// count points in [0,1)^2, multi-jittered (Chiu, Shirley and Wang 1994): an
// m x n grid (m the largest divisor of count not above its square root, n =
// count / m) with one point per cell, and each point also alone in its
// 1/count-wide stratum of x and of y. Point j m + i is uniformly distributed
// in its cell (i, j), of area 1 / count, so the mean of f over the points is
// an unbiased estimate of f's integral, as over independent points, and for a
// smooth f one with far less variance (a prime count gives a 1 x count grid:
// strata along each axis only). out holds count points; count <= 2^20.
void multiJittered(int count, Rng& rng, Vec2* out);
// Room for N points that is not initialised (a Vec2 array would be zeroed:
// 8 KB per lobe-gather point): for multiJittered.
template <int N>
struct Vec2Scratch {
  alignas(Vec2) std::byte raw[N * sizeof(Vec2)];
  Vec2* data() { return std::launder(reinterpret_cast<Vec2*>(raw)); }
  const Vec2* data() const { return std::launder(reinterpret_cast<const Vec2*>(raw)); }
};

// Concentric map of [0,1)^2 to the unit disk (Shirley-Chiu). pdf = 1/pi (area).
Vec2 sampleUniformDiskConcentric(Vec2 u);
inline float uniformDiskPdf() { return kInvPi; }
Vec2 invertUniformDiskConcentric(Vec2 p);

// Cosine-weighted hemisphere about +z. pdf(w) = cos(theta)/pi (solid angle).
Vec3 sampleCosineHemisphere(Vec2 u);
inline float cosineHemispherePdf(float cosTheta) { return cosTheta > 0 ? cosTheta * kInvPi : 0.0f; }
Vec2 invertCosineHemisphere(const Vec3& w);

// Uniform sphere. pdf = 1/(4 pi) (solid angle). The inverse returns
// u = ((1 - z)/2, phi/(2 pi)) with phi in [0, 2 pi).
Vec3 sampleUniformSphere(Vec2 u);
inline float uniformSpherePdf() { return 1.0f / (4.0f * kPi); }
Vec2 invertUniformSphere(const Vec3& w);

// Uniform cone about +z with cos(half-angle) = cosMax. pdf = 1/(2 pi (1 - cosMax))
// (solid angle).
Vec3 sampleUniformCone(Vec2 u, float cosMax);
// The same cone given by 1 - cos(half-angle), which keeps tiny cones precise.
// pdf = 1/(2 pi oneMinusCosMax).
Vec3 sampleUniformConeOmc(Vec2 u, float oneMinusCosMax);
inline float uniformConePdf(float cosMax) { return 1.0f / (2.0f * kPi * (1.0f - cosMax)); }
inline float uniformConeOmcPdf(float oneMinusCosMax) { return 1.0f / (2.0f * kPi * oneMinusCosMax); }
// The u that sampleUniformCone(u, cosMax) / sampleUniformConeOmc(u,
// oneMinusCosMax) maps to the unit direction w inside the cone. 1 - cos(theta)
// is taken from w's sine, so tiny cones invert precisely.
Vec2 invertUniformCone(const Vec3& w, float cosMax);
Vec2 invertUniformConeOmc(const Vec3& w, float oneMinusCosMax);

// Uniform point on a triangle, as barycentrics (b0, b1); b2 = 1 - b0 - b1.
// pdf = 1/area (area measure on the triangle). Uses the low-distortion
// square-to-triangle map of pbrt-v4 (after Heitz 2019); the inverse maps
// barycentrics back to the u that produced them.
Vec2 sampleUniformTriangle(Vec2 u);
inline float uniformTrianglePdf(float area) { return 1.0f / area; }
Vec2 invertUniformTriangle(Vec2 b);

// Multiple importance sampling heuristics for one sample of each strategy.
inline float powerHeuristic(float pdfA, float pdfB) {
  float a = pdfA * pdfA, b = pdfB * pdfB;
  if (std::isinf(a)) return 1.0f;
  return a + b > 0 ? a / (a + b) : 0.0f;
}
inline float balanceHeuristic(float pdfA, float pdfB) { return pdfA + pdfB > 0 ? pdfA / (pdfA + pdfB) : 0.0f; }

// Piecewise-constant discrete distribution over n items with non-negative
// weights. sample() returns an index with probability weight/sum (pmf).
class DiscreteDistribution {
 public:
  DiscreteDistribution() = default;
  explicit DiscreteDistribution(std::span<const double> weights);
  size_t size() const { return pmf_.size(); }
  double total() const { return total_; }
  // Returns the index; *pmf receives its probability. uRemapped (optional)
  // receives u rescaled to [0,1) within the chosen bucket, for reuse.
  size_t sample(float u, float* pmf, float* uRemapped = nullptr) const;
  float pmf(size_t i) const { return i < pmf_.size() ? pmf_[i] : 0.0f; }

 private:
  std::vector<double> cdf_;  // cdf_[i] = sum of pmf over [0, i); size n+1
  std::vector<float> pmf_;
  double total_ = 0;
};

}  // namespace vsl
