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
// AVX2 with fused multiply-adds, for the closed-form VSL's lanes
// (core/vsl_sg_avx2.cpp), which need no scalar code's bits: madd below.
// simdAvailable() checks for both.
#define VSL_FMA __attribute__((target("avx2,fma")))

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

// a b + c with one rounding.
VSL_FMA inline __m256 madd(__m256 a, __m256 b, __m256 c) { return _mm256_fmadd_ps(a, b, c); }
// a b - c with one rounding.
VSL_FMA inline __m256 msub(__m256 a, __m256 b, __m256 c) { return _mm256_fmsub_ps(a, b, c); }

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

// exp(x) on eight lanes, for the closed-form VSL (core/vsl_sg_avx2.cpp).
// Range reduction x = n ln2 + r, |r| <= ln2 / 2 (ln2 split in two so that
// n ln2 is exact to float), e^r by its Taylor polynomial of degree 7
// (truncation below 2e-9 relative on that range), times 2^n through the
// exponent bits. Relative error about 2e-7 (a few float ulps) over
// [-87, 88] (tests/test_vsl_sg.cpp, VslSg.LaneExpAndLog). Below -87.3 it
// returns 0 (the result would be denormal), above 88.7 +inf; NaN stays NaN.
VSL_FMA inline __m256 exp8(__m256 x) {
  const __m256 lo = splat(-87.3f), hi = splat(88.7f);
  const __m256 xc = _mm256_max_ps(lo, _mm256_min_ps(hi, x));  // NaN passes through min, then max keeps it
  const __m256 n = _mm256_round_ps(mul(xc, splat(1.44269504088896341f)), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  const __m256 r = _mm256_fnmadd_ps(n, splat(-2.12194440e-4f), _mm256_fnmadd_ps(n, splat(0.693359375f), xc));
  __m256 p = splat(1.0f / 5040.0f);
  p = madd(r, p, splat(1.0f / 720.0f));
  p = madd(r, p, splat(1.0f / 120.0f));
  p = madd(r, p, splat(1.0f / 24.0f));
  p = madd(r, p, splat(1.0f / 6.0f));
  p = madd(r, p, splat(0.5f));
  p = madd(r, p, splat(1.0f));
  p = madd(r, p, splat(1.0f));
  // 2^n: n in [-126, 128]; 2^128 is split as 2^127 x 2 so the bits stay normal.
  const __m256i ni = _mm256_cvtps_epi32(n);
  const __m256i half = _mm256_srai_epi32(ni, 1);
  const __m256 s1 = _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_add_epi32(half, _mm256_set1_epi32(127)), 23));
  const __m256 s2 =
      _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_add_epi32(_mm256_sub_epi32(ni, half), _mm256_set1_epi32(127)), 23));
  __m256 e = mul(mul(p, s1), s2);
  e = select(less(x, lo), _mm256_setzero_ps(), e);
  e = select(greater(x, hi), splat(kInf), e);
  return select(_mm256_cmp_ps(x, x, _CMP_UNORD_Q), x, e);
}

// log(x) on eight lanes for finite x > 0 (denormals included): x = 2^k m,
// m in [sqrt(1/2), sqrt(2)), log m = 2 atanh(s), s = (m - 1) / (m + 1),
// |s| <= 0.172, by its series to s^11 (truncation below 1e-9). Absolute
// error about 1e-7 near x = 1, relative about 1e-7 elsewhere
// (VslSg.LaneExpAndLog). x = 0 gives -inf; x < 0 and NaN give NaN; +inf gives +inf.
VSL_FMA inline __m256 log8(__m256 x) {
  // Denormals: scaled by 2^23 first (k corrected below).
  const __m256 tiny = less(x, splat(1.17549435e-38f));
  const __m256 xs = select(tiny, mul(x, splat(8388608.0f)), x);
  const __m256i bits = _mm256_castps_si256(xs);
  __m256i k = _mm256_sub_epi32(_mm256_srli_epi32(bits, 23), _mm256_set1_epi32(127));
  __m256 m = _mm256_castsi256_ps(
      _mm256_or_si256(_mm256_and_si256(bits, _mm256_set1_epi32(0x007fffff)), _mm256_set1_epi32(0x3f800000)));
  const __m256 big = greater(m, splat(1.41421356f));
  m = select(big, mul(m, splat(0.5f)), m);
  k = _mm256_sub_epi32(k, _mm256_castps_si256(big));  // big lanes are -1: k + 1
  const __m256 s = div(sub(m, splat(1.0f)), add(m, splat(1.0f))), s2 = mul(s, s);
  __m256 p = splat(2.0f / 11.0f);
  p = madd(s2, p, splat(2.0f / 9.0f));
  p = madd(s2, p, splat(2.0f / 7.0f));
  p = madd(s2, p, splat(2.0f / 5.0f));
  p = madd(s2, p, splat(2.0f / 3.0f));
  p = madd(s2, p, splat(2.0f));
  const __m256 kf = sub(_mm256_cvtepi32_ps(k), where(tiny, splat(23.0f)));
  // k ln2 in two parts (the first exact in float for |k| < 2^9).
  __m256 r = madd(kf, splat(0.693359375f), madd(s, p, mul(kf, splat(-2.12194440e-4f))));
  r = select(_mm256_cmp_ps(x, _mm256_setzero_ps(), _CMP_EQ_OQ), splat(-kInf), r);
  r = select(_mm256_cmp_ps(x, splat(kInf), _CMP_EQ_OQ), splat(kInf), r);
  return select(_mm256_cmp_ps(x, _mm256_setzero_ps(), _CMP_NGE_UQ), splat(std::numeric_limits<float>::quiet_NaN()), r);
}

}  // namespace vsl::simd
