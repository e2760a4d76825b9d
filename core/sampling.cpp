#include "core/sampling.h"

#include <algorithm>

#include "core/simd.h"

namespace vsl {

void multiJittered(int count, Rng& rng, Vec2* out) {
  if (count <= 0) return;
  int m = 1;
  for (int d = 1; d * d <= count; ++d)
    if (count % d == 0) m = d;
  const int n = count / m;
  // v in [lo, hi) (double) as a float still in it, rounding aside.
  auto within = [](double v, double lo, double hi) {
    float f = float(v);
    while (double(f) >= hi) f = std::nextafter(f, 0.0f);
    while (double(f) < lo) f = std::nextafter(f, 1.0f);
    return f;
  };
  // Point (i, j) lies in column i (of m) and row j (of n). Within column i
  // its x takes sub-stratum px[i][j] of n, within row j its y sub-stratum
  // py[j][i] of m: random permutations, so that the x strata i * n + px and
  // the y strata j * m + py are each used once.
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) out[j * m + i] = {float(j), float(i)};
  for (int i = 0; i < m; ++i)  // shuffle the x sub-strata of column i
    for (int j = n - 1; j > 0; --j) std::swap(out[j * m + i].x, out[int(rng.uniformInt(uint32_t(j + 1))) * m + i].x);
  for (int j = 0; j < n; ++j)  // and the y sub-strata of row j
    for (int i = m - 1; i > 0; --i) std::swap(out[j * m + i].y, out[j * m + int(rng.uniformInt(uint32_t(i + 1)))].y);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < m; ++i) {
      Vec2& p = out[j * m + i];
      const double sx = double(i) * n + p.x, sy = double(j) * m + p.y;  // the x and y strata
      p = {within((sx + rng.uniformDouble()) / count, sx / count, (sx + 1) / count),
           within((sy + rng.uniformDouble()) / count, sy / count, (sy + 1) / count)};
    }
}

Vec2 sampleUniformDiskConcentric(Vec2 u) {
  float ox = 2 * u.x - 1, oy = 2 * u.y - 1;
  if (ox == 0 && oy == 0) return {0, 0};
  // theta = pi/4 (oy/ox), or pi/2 - pi/4 (ox/oy), whose cosine and sine are
  // the sine and cosine of pi/4 (ox/oy).
  float s, c;
  if (std::abs(ox) > std::abs(oy)) {
    sinCosQuarterPi(oy / ox, s, c);
    return {ox * c, ox * s};
  }
  sinCosQuarterPi(ox / oy, s, c);
  return {oy * s, oy * c};
}

Vec2 invertUniformDiskConcentric(Vec2 p) {
  float theta = std::atan2(p.y, p.x);
  float r = std::sqrt(p.x * p.x + p.y * p.y);
  if (theta < -kPi / 4) theta += 2 * kPi;
  float a, b;
  if (theta < kPi / 4) {  // r = ox, theta = pi/4 * oy/ox
    a = r;
    b = theta * 4 / kPi * r;
  } else if (theta < 3 * kPi / 4) {  // r = oy, theta = pi/2 - pi/4 * ox/oy
    b = r;
    a = (kPi / 2 - theta) * 4 / kPi * r;
  } else if (theta < 5 * kPi / 4) {  // r = -ox
    a = -r;
    b = (theta - kPi) * 4 / kPi * a;
  } else {  // r = -oy
    b = -r;
    a = (3 * kPi / 2 - theta) * 4 / kPi * b;
  }
  return {(a + 1) / 2, (b + 1) / 2};
}

Vec3 sampleCosineHemisphere(Vec2 u) {
  Vec2 d = sampleUniformDiskConcentric(u);
  float z = safeSqrt(1 - d.x * d.x - d.y * d.y);
  return {d.x, d.y, z};
}

Vec2 invertCosineHemisphere(const Vec3& w) { return invertUniformDiskConcentric({w.x, w.y}); }

Vec3 sampleUniformSphere(Vec2 u) {
  float z = 1 - 2 * u.x;
  float r = safeSqrt(1 - z * z);
  float phi = 2 * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

Vec2 invertUniformSphere(const Vec3& w) {
  float phi = std::atan2(w.y, w.x);
  if (phi < 0) phi += 2 * kPi;
  return {(1 - w.z) / 2, std::min(phi / (2 * kPi), 0.99999994f)};
}

Vec3 sampleUniformCone(Vec2 u, float cosMax) { return sampleUniformConeOmc(u, 1 - cosMax); }

Vec3 sampleUniformConeOmc(Vec2 u, float oneMinusCosMax) {
  // Work with v = 1 - cos(theta) so that tiny cones keep their precision:
  // sin^2 = (1 - cos)(1 + cos) = v (2 - v).
  float v = u.x * oneMinusCosMax;
  float cosTheta = 1 - v;
  float sinTheta = safeSqrt(v * (2 - v));
  float sinPhi, cosPhi;
  sinCosTwoPi(u.y, sinPhi, cosPhi);
  return {cosPhi * sinTheta, sinPhi * sinTheta, cosTheta};
}

Vec2 invertUniformCone(const Vec3& w, float cosMax) { return invertUniformConeOmc(w, 1 - cosMax); }

Vec2 invertUniformConeOmc(const Vec3& w, float oneMinusCosMax) {
  // 1 - cos(theta) = sin^2 / (1 + cos) near the axis, where 1 - z cancels.
  float sin2 = w.x * w.x + w.y * w.y;
  float oneMinusCos = w.z > 0 ? sin2 / (1 + w.z) : 1 - w.z;
  float phi = std::atan2(w.y, w.x);
  if (phi < 0) phi += 2 * kPi;
  return {std::min(oneMinusCos / oneMinusCosMax, 1.0f), std::min(phi / (2 * kPi), 0.99999994f)};
}

Vec2 sampleUniformTriangle(Vec2 u) {
  float b0, b1;
  if (u.x < u.y) {
    b0 = u.x / 2;
    b1 = u.y - b0;
  } else {
    b1 = u.y / 2;
    b0 = u.x - b1;
  }
  return {b0, b1};
}

Vec2 invertUniformTriangle(Vec2 b) {
  // The two branches of sampleUniformTriangle: b0 < b1 came from u.x < u.y.
  if (b.x < b.y) return {2 * b.x, b.y + b.x};
  return {b.x + b.y, 2 * b.y};
}

DiscreteDistribution::DiscreteDistribution(std::span<const double> weights) {
  size_t n = weights.size();
  cdf_.assign(n + 1, 0.0);
  pmf_.assign(n, 0.0f);
  for (size_t i = 0; i < n; ++i) {
    double w = std::isfinite(weights[i]) && weights[i] > 0 ? weights[i] : 0.0;
    cdf_[i + 1] = cdf_[i] + w;
  }
  total_ = cdf_[n];
  if (total_ <= 0) {
    pmf_.clear();
    cdf_.clear();
    return;
  }
  for (size_t i = 0; i < n; ++i) pmf_[i] = float((cdf_[i + 1] - cdf_[i]) / total_);
  for (double& c : cdf_) c /= total_;
  cdf_[n] = 1.0;
}

size_t DiscreteDistribution::sample(float u, float* pmf, float* uRemapped) const {
  if (pmf_.empty()) {
    if (pmf) *pmf = 0;
    return 0;
  }
  // First index i with cdf_[i+1] > u, skipping zero-weight entries.
  auto it = std::upper_bound(cdf_.begin() + 1, cdf_.end(), double(u));
  size_t i = std::min(size_t(it - cdf_.begin()) - 1, pmf_.size() - 1);
  while (pmf_[i] == 0 && i > 0) --i;  // u landed past the end of a zero run
  if (pmf) *pmf = pmf_[i];
  if (uRemapped) {
    double w = cdf_[i + 1] - cdf_[i];
    *uRemapped = w > 0 ? float(std::min((double(u) - cdf_[i]) / w, 0.99999994)) : 0.0f;
    if (*uRemapped < 0) *uRemapped = 0;
  }
  return i;
}

namespace {
// a * b mod 2^64 on four 64-bit lanes, b a constant: the low product plus
// the two cross products shifted up (the high one falls off).
VSL_AVX2 __m256i mul64(__m256i a, uint64_t b) {
  const __m256i lo = _mm256_set1_epi64x(int64_t(b & 0xffffffffu)), hi = _mm256_set1_epi64x(int64_t(b >> 32));
  const __m256i cross = _mm256_add_epi64(_mm256_mul_epu32(_mm256_srli_epi64(a, 32), lo), _mm256_mul_epu32(a, hi));
  return _mm256_add_epi64(_mm256_mul_epu32(a, lo), _mm256_slli_epi64(cross, 32));
}
// Rng's output and toUniform on four states, the results in the even
// 32-bit slots.
VSL_AVX2 __m256 uniformsOf(__m256i old) {
  const __m256i x = _mm256_srli_epi64(_mm256_xor_si256(_mm256_srli_epi64(old, 18), old), 27);
  const __m256i rot = _mm256_srli_epi64(old, 59);
  const __m256i back = _mm256_and_si256(_mm256_sub_epi32(_mm256_setzero_si256(), rot), _mm256_set1_epi32(31));
  const __m256i r = _mm256_or_si256(_mm256_srlv_epi32(x, rot), _mm256_sllv_epi32(x, back));
  return _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32(r, 8)), _mm256_set1_ps(0x1p-24f));
}
}  // namespace

VSL_AVX2 void Rng::uniformsAvx2(float* out, int n) {
  // Chain k starts k steps on and strides eight steps.
  static constexpr PcgJump kStart[8] = {pcgJump(0), pcgJump(1), pcgJump(2), pcgJump(3),
                                        pcgJump(4), pcgJump(5), pcgJump(6), pcgJump(7)};
  uint64_t start[8];
  for (int k = 0; k < 8; ++k) start[k] = kStart[k].mul * state_ + inc_ * kStart[k].add;
  constexpr PcgJump k8 = pcgJump(8);
  __m256i lo = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(start));
  __m256i hi = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(start + 4));
  const __m256i step = _mm256_set1_epi64x(int64_t(inc_ * k8.add));
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    // Chains 0, 1 (lo) and 4, 5 (hi), then 2, 3 and 6, 7, in 64-bit units.
    const __m256 mixed = _mm256_shuffle_ps(uniformsOf(lo), uniformsOf(hi), 0x88);
    _mm256_storeu_ps(out + i, _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(mixed), 0xd8)));
    lo = _mm256_add_epi64(mul64(lo, k8.mul), step);
    hi = _mm256_add_epi64(mul64(hi, k8.mul), step);
  }
  state_ = uint64_t(_mm256_extract_epi64(lo, 0));
  for (; i < n; ++i) out[i] = uniform();
}

}  // namespace vsl
