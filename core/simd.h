// Eight-lane (AVX2) helpers for the block forms of the BRDF and the VSL
// quadrature. Each function is compiled for AVX2 only (the VSL_AVX2
// attribute; callers check simdAvailable() first) and without fused
// multiply-adds (-ffp-contract=off for the whole build, CMakeLists.txt), so
// that a lane computed with the scalar code's operations in the scalar code's
// order gives the scalar code's bits.
#pragma once

#include <immintrin.h>

#include "core/math.h"

#define VSL_AVX2 __attribute__((target("avx2")))

namespace vsl::simd {

VSL_AVX2 inline __m256 splat(float v) { return _mm256_set1_ps(v); }
VSL_AVX2 inline __m256 add(__m256 a, __m256 b) { return _mm256_add_ps(a, b); }
VSL_AVX2 inline __m256 sub(__m256 a, __m256 b) { return _mm256_sub_ps(a, b); }
VSL_AVX2 inline __m256 mul(__m256 a, __m256 b) { return _mm256_mul_ps(a, b); }
VSL_AVX2 inline __m256 div(__m256 a, __m256 b) { return _mm256_div_ps(a, b); }
VSL_AVX2 inline __m256 neg(__m256 a) { return _mm256_xor_ps(a, splat(-0.0f)); }
VSL_AVX2 inline __m256 clamp01(__m256 v) { return _mm256_min_ps(splat(1), _mm256_max_ps(_mm256_setzero_ps(), v)); }
VSL_AVX2 inline __m256 where(__m256 mask, __m256 v) { return _mm256_and_ps(mask, v); }
// mask ? a : b, lane by lane.
VSL_AVX2 inline __m256 select(__m256 mask, __m256 a, __m256 b) { return _mm256_blendv_ps(b, a, mask); }
VSL_AVX2 inline __m256 greater(__m256 a, __m256 b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
VSL_AVX2 inline __m256 less(__m256 a, __m256 b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
VSL_AVX2 inline __m256 lessEqual(__m256 a, __m256 b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
VSL_AVX2 inline __m256 both(__m256 a, __m256 b) { return _mm256_and_ps(a, b); }
VSL_AVX2 inline bool none(__m256 m) { return _mm256_movemask_ps(m) == 0; }
// safeSqrt: std::max(v, 0) is _mm256_max_ps(0, v) (a NaN stays NaN in both).
VSL_AVX2 inline __m256 safeSqrt8(__m256 v) { return _mm256_sqrt_ps(_mm256_max_ps(_mm256_setzero_ps(), v)); }

// The lanes below m (0 < m <= 8) as a mask; loads of the first m floats
// (the others zero) and stores of the first m lanes, touching nothing past m.
VSL_AVX2 inline __m256i firstLanes(int m) {
  return _mm256_cmpgt_epi32(_mm256_set1_epi32(m), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
}
VSL_AVX2 inline __m256 loadFirst(const float* p, int m) {
  return m == 8 ? _mm256_loadu_ps(p) : _mm256_maskload_ps(p, firstLanes(m));
}
VSL_AVX2 inline void storeFirst(float* p, __m256 v, int m) {
  if (m == 8)
    _mm256_storeu_ps(p, v);
  else
    _mm256_maskstore_ps(p, firstLanes(m), v);
}

// Three lanes of coordinates: eight vectors.
struct Vec3x8 {
  __m256 x, y, z;
};
VSL_AVX2 inline __m256 dot8(const Vec3x8& a, const Vec3& b) {
  return add(add(mul(a.x, splat(b.x)), mul(a.y, splat(b.y))), mul(a.z, splat(b.z)));
}
// Frame::toLocal and Frame::toWorld, operation for operation (results by
// reference: returning eight-lane structs by value is not ABI-stable).
VSL_AVX2 inline void toLocal8(const Frame& f, const Vec3x8& v, Vec3x8& out) {
  out = {dot8(v, f.s), dot8(v, f.t), dot8(v, f.n)};
}
VSL_AVX2 inline __m256 combine8(float s, float t, float n, const Vec3x8& v) {
  return add(add(mul(splat(s), v.x), mul(splat(t), v.y)), mul(splat(n), v.z));
}
VSL_AVX2 inline void toWorld8(const Frame& f, const Vec3x8& v, Vec3x8& out) {
  out = {combine8(f.s.x, f.t.x, f.n.x, v), combine8(f.s.y, f.t.y, f.n.y, v), combine8(f.s.z, f.t.z, f.n.z, v)};
}

// sinCosQuarterPi and sinCosTwoPi (core/math.h) on eight lanes.
VSL_AVX2 inline void sinCosQuarterPi8(__m256 t, __m256& s, __m256& c) {
  const __m256 x = mul(t, splat(kPi / 4)), x2 = mul(x, x);
  __m256 ps = add(splat(kSinTaylor[2]), mul(x2, splat(kSinTaylor[3])));
  ps = add(splat(kSinTaylor[1]), mul(x2, ps));
  ps = add(splat(kSinTaylor[0]), mul(x2, ps));
  s = add(x, mul(mul(x, x2), ps));
  __m256 pc = add(splat(kCosTaylor[2]), mul(x2, splat(kCosTaylor[3])));
  pc = add(splat(kCosTaylor[1]), mul(x2, pc));
  pc = add(splat(kCosTaylor[0]), mul(x2, pc));
  c = add(splat(1.0f), mul(x2, pc));
}
VSL_AVX2 inline void sinCosTwoPi8(__m256 u, __m256& s, __m256& c) {
  const __m256 u4 = mul(splat(4.0f), u);
  const __m256 q = _mm256_round_ps(u4, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  __m256 sr, cr;
  sinCosQuarterPi8(mul(splat(2.0f), sub(u4, q)), sr, cr);
  const __m256i k = _mm256_cvtps_epi32(q);
  const __m256 odd =
      _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(k, _mm256_set1_epi32(1)), _mm256_set1_epi32(1)));
  const __m256 a = select(odd, cr, sr), b = select(odd, sr, cr);
  // The sign bits: k & 2 for the sine, (k + 1) & 2 for the cosine, moved to bit 31.
  const __m256i two = _mm256_set1_epi32(2);
  const __m256 sSign = _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_and_si256(k, two), 30));
  const __m256 cSign =
      _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_and_si256(_mm256_add_epi32(k, _mm256_set1_epi32(1)), two), 30));
  s = _mm256_xor_ps(a, sSign);
  c = _mm256_xor_ps(b, cSign);
}

}  // namespace vsl::simd
