// The closed-form VSL transfer (core/vsl_sg.h) for eight pairs at a time on
// AVX2 lanes, in float: vslTransferSgMany.
//
// Every factor is the scalar form's (core/vsl_sg.cpp); what changes is how
// the exponent of formula (1), |v| - B, is formed. Sharpnesses reach 1e8 and
// more (zero roughness, needle cones), so |v| and B (each about the largest
// sharpness) cannot be subtracted in float. With r a unit axis,
//   |v| - B = (|v| - v.r) + (v.r - B),
//   |v| - v.r = |v x r|^2 / (|v| + v.r)             (v.r > 0; else directly),
//   v.r - B = sum over the factors of (lambda_k u_k.r - B_k),
// each factor's term formed exactly: the cone's -lambda_c (1 - a.r), a
// cosine's k (n.r - n.a) (its B is k n.a, header item 2), a lobe's
// -lambda (1 - u.r) + local lambda_local (1 - u.a) + global logPeak
// (lobeFactor's B), every 1 - cos from the cross product, |u x r|^2 /
// (1 + u.r), not from u.r. r is the axis of the product's sharpest factor,
// whose term is then exactly 0: no large sharpness multiplies a rounding
// error (about the cone's axis, a needle lobe seen inside a wide cone would
// multiply 1 - u.a's by 1e8; tests/test_vsl_sg.cpp measured 20% errors so).
// |v| is sqrt((v.r)^2 + |v x r|^2). The integral over the area is then
// exp(E) g(|v|), E = |v| - B + log(2 pi / area), g(m) = (1 - exp(-2m)) / m,
// so that a small tail meets a large amplitude without underflow (and
// exp(E + log g) where E is large, so that exp(E) does not overflow).
// Fused multiply-adds (madd, core/simd.h) everywhere but the dot products,
// which round as the scalar form's do (a grazing axis magnifies the
// difference). The BRDFs at the axis are
// BrdfAt::evalPartsPackedAvx2's (the scalar evalParts's bits). exp8 and
// log8 (core/simd.h) have about 1e-7 relative error.
//
// Sections: [1] lane inputs  [2] the cone  [3] the lobes  [4] the products  [5] the block
#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/simd.h"
#include "core/vsl_sg.h"

namespace vsl {

namespace {

using namespace simd;

// ---- [1] Lane inputs ---------------------------------------------------------------

// The pairs' inputs, structure of arrays: field k of lane j at v[k][j].
// Frames: s, t, n; g: the light's emission normal (local: +z, or ngLocal
// for the geometric cosine); w: each BRDF's fixed direction; on: its
// specular lobe exists (sgSpecularLobe); area: the normalisation.
enum Field {
  kT = 0,
  kR = 3,
  kXs = 4,
  kXt = 7,
  kXn = 10,
  kPs = 13,
  kPt = 16,
  kPn = 19,
  kG = 22,
  kXw = 25,
  kXax = 28,
  kXay,
  kXon,
  kPw,
  kPax = kPw + 3,
  kPay,
  kPon,
  kArea,
  kFields
};

struct LaneInputs {
  alignas(32) float v[kFields][8];
  const float* packed[2][8];
  float pack[2][8][BrdfAt::kPackedFloats];
};

// Below this ratio r / d the radius is taken as ratio x d (vsl_sg.h).
constexpr float kMinRadiusRatio = 1e-8f;

void put3(LaneInputs& in, int field, int j, const Vec3& v) {
  for (int k = 0; k < 3; ++k) in.v[field + k][j] = v[k];
}

bool lobeOn(const BrdfAt& f) {
  const Brdf& b = f.brdf();
  return f.specularOn() && f.w().z > 0 && (b.metallic > 0 || b.specularWeight > 0);
}

// The light's fields of lane j (fillLane) and of every lane (a block whose
// pairs share one light, as the gather's do: Gatherer::vslPrepare).
void fillEmitterLane(const VslEmitter& p, int j, LaneInputs& in) {
  put3(in, kPs, j, p.frame.s);
  put3(in, kPt, j, p.frame.t);
  put3(in, kPn, j, p.frame.n);
  put3(in, kG, j, p.geometricCosine ? p.ngLocal : Vec3(0, 0, 1));
  put3(in, kPw, j, p.f.w());
  in.v[kPax][j] = p.f.brdf().ggx.ax;
  in.v[kPay][j] = p.f.brdf().ggx.ay;
  in.v[kPon][j] = lobeOn(p.f) ? 1.0f : 0.0f;
}

VSL_FMA void fillEmitterAll(const VslEmitter& p, LaneInputs& in) {
  fillEmitterLane(p, 0, in);
  for (int field : {kPs, kPt, kPn, kG, kPw})
    for (int k = field; k < field + 3; ++k) _mm256_store_ps(in.v[k], splat(in.v[k][0]));
  for (int k : {kPax, kPay, kPon}) _mm256_store_ps(in.v[k], splat(in.v[k][0]));
}

// Lane j's pair (its light's fields too unless emitterFilled).
void fillLane(const VslSgPair& q, int j, const VslOptions& o, bool emitterFilled, LaneInputs& in) {
  static const float kZero[BrdfAt::kPackedFloats] = {};
  if (!q.x) {  // a lane past the pairs: zero frames fail the cosine test
    in.packed[0][j] = in.packed[1][j] = kZero;
    return;
  }
  const VslReceiver& x = *q.x;
  const VslEmitter& p = *q.p;
  put3(in, kT, j, q.toLight);
  in.v[kR][j] = q.radius;  // at least kMinRadiusRatio d: cone8
  put3(in, kXs, j, x.frame.s);
  put3(in, kXt, j, x.frame.t);
  put3(in, kXn, j, x.frame.n);
  put3(in, kXw, j, x.f.w());
  in.v[kXax][j] = x.f.brdf().ggx.ax;
  in.v[kXay][j] = x.f.brdf().ggx.ay;
  in.v[kXon][j] = lobeOn(x.f) ? 1.0f : 0.0f;
  if (!emitterFilled) fillEmitterLane(p, j, in);
  if (o.clippedDisk) {  // else pi r^2, in block8
    const float r = q.radius > 0 ? std::max(q.radius, kMinRadiusRatio * length(q.toLight)) : q.radius;
    in.v[kArea][j] = float(vslClippedDiskArea(r, dot(q.toLight, x.ng)));
  }
  if (q.xPacked) {
    in.packed[0][j] = q.xPacked;
  } else {
    x.f.pack(in.pack[0][j]);
    in.packed[0][j] = in.pack[0][j];
  }
  if (q.pPacked) {
    in.packed[1][j] = q.pPacked;
  } else {
    p.f.pack(in.pack[1][j]);
    in.packed[1][j] = in.pack[1][j];
  }
}

VSL_FMA __m256 lane(const LaneInputs& in, int field) { return _mm256_load_ps(in.v[field]); }
VSL_FMA Vec3x8 lane3(const LaneInputs& in, int field) {
  return {lane(in, field), lane(in, field + 1), lane(in, field + 2)};
}
VSL_FMA __m256 dot3(const Vec3x8& a, const Vec3x8& b) { return add(add(mul(a.x, b.x), mul(a.y, b.y)), mul(a.z, b.z)); }
VSL_FMA Vec3x8 cross3(const Vec3x8& a, const Vec3x8& b) {
  return {msub(a.y, b.z, mul(a.z, b.y)), msub(a.z, b.x, mul(a.x, b.z)), msub(a.x, b.y, mul(a.y, b.x))};
}
VSL_FMA Vec3x8 scale3(const Vec3x8& a, __m256 s) { return {mul(a.x, s), mul(a.y, s), mul(a.z, s)}; }
VSL_FMA Vec3x8 add3(const Vec3x8& a, const Vec3x8& b) { return {add(a.x, b.x), add(a.y, b.y), add(a.z, b.z)}; }
// Divisions and square roots are the lanes' slowest operations: 1/sqrt(q)
// and a/b by their estimates (12 bits) and one Newton step, about 2e-7
// relative. q = 0 and b = 0 give NaN (the callers exclude them).
VSL_FMA __m256 invSqrt(__m256 q) {
  const __m256 y = _mm256_rsqrt_ps(q);
  return mul(mul(splat(0.5f), y), _mm256_fnmadd_ps(mul(q, y), y, splat(3)));
}
VSL_FMA __m256 quot(__m256 a, __m256 b) {
  const __m256 y = _mm256_rcp_ps(b);
  return mul(a, mul(y, _mm256_fnmadd_ps(b, y, splat(2))));
}
VSL_FMA Vec3x8 normalize3(const Vec3x8& a) { return scale3(a, invSqrt(dot3(a, a))); }
// v in the frame (s, t, n) and back.
VSL_FMA Vec3x8 toLocal3(const Vec3x8 f[3], const Vec3x8& v) { return {dot3(v, f[0]), dot3(v, f[1]), dot3(v, f[2])}; }
VSL_FMA Vec3x8 toWorld3(const Vec3x8 f[3], const Vec3x8& v) {
  return {madd(f[2].x, v.z, madd(f[1].x, v.y, mul(f[0].x, v.x))),
          madd(f[2].y, v.z, madd(f[1].y, v.y, mul(f[0].y, v.x))),
          madd(f[2].z, v.z, madd(f[1].z, v.y, mul(f[0].z, v.x)))};
}

// 1 - cos of the angle between unit u and a without cancellation for
// small angles: sin^2 / (1 + cos) from the cross product.
VSL_FMA __m256 oneMinusCos(const Vec3x8& u, const Vec3x8& a) {
  const __m256 c = dot3(u, a);
  const Vec3x8 x = cross3(u, a);
  return select(greater(c, _mm256_setzero_ps()), quot(dot3(x, x), add(splat(1), c)), sub(splat(1), c));
}

// 1 - exp(-x) for x >= 0, by its series below 0.01 (no cancellation).
VSL_FMA __m256 oneMinusExpNeg(__m256 x) {
  const __m256 series = mul(x, sub(splat(1), mul(mul(x, splat(0.5f)), sub(splat(1), mul(x, splat(1.0f / 3.0f))))));
  return select(less(x, splat(0.01f)), series, sub(splat(1), exp8(neg(x))));
}

// ---- [2] The cone ------------------------------------------------------------------

struct Cone8 {
  Vec3x8 a;           // the axis x -> p (float unit; x's normal where d = 0)
  __m256 lambda;      // sgSharpnessForSolidAngle(omc)
  __m256 omc, chord;  // 1 - cos of the half-angle; 2 sin(half-angle / 2)
  __m256 r;           // the radius, at least kMinRadiusRatio d
};

VSL_FMA void cone8(const LaneInputs& in, Cone8& c) {
  const Vec3x8 t = lane3(in, kT), n = lane3(in, kXn);
  // The axis as the scalar form rounds it (a grazing axis's cosine
  // magnifies any other rounding).
  const __m256 d = _mm256_sqrt_ps(dot3(t, t)), r0 = lane(in, kR);
  // (A radius that is zero or NaN stays so: no area, no transfer.)
  const __m256 r = select(greater(r0, _mm256_setzero_ps()), _mm256_max_ps(r0, mul(splat(kMinRadiusRatio), d)), r0);
  c.r = r;
  const __m256 dpos = greater(d, _mm256_setzero_ps());
  const __m256 inv = div(splat(1), d);
  c.a = {select(dpos, mul(t.x, inv), n.x), select(dpos, mul(t.y, inv), n.y), select(dpos, mul(t.z, inv), n.z)};
  // vslConeOneMinusCos: 1 inside the sphere (d <= r, NaN too).
  const __m256 s = mul(r, inv), s2 = mul(s, s);
  const __m256 omc = quot(s2, add(splat(1), safeSqrt8(sub(splat(1), s2))));
  c.omc = select(greater(d, r), omc, splat(1));
  // sgSharpnessForSolidAngle: 1/omc below 0.05, else Newton's steps from
  // there (monotone, quadratic: the fourth is within 1e-7 of the root from
  // omc = 1, the farthest start).
  __m256 lambda = quot(splat(1), c.omc);
  const __m256 wide = _mm256_cmp_ps(c.omc, splat(0.05f), _CMP_GE_OQ);
  if (!none(wide)) {
    __m256 l = select(wide, lambda, splat(1));
    const __m256 o = select(wide, c.omc, splat(1));
    for (int i = 0; i < 4; ++i) {
      const __m256 e = exp8(mul(splat(-2), l));
      const __m256 h = sub(sub(splat(1), e), mul(o, l)), dh = sub(mul(splat(2), e), o);
      l = sub(l, div(h, dh));
    }
    lambda = select(wide, l, lambda);
  }
  c.lambda = lambda;
  c.chord = _mm256_sqrt_ps(mul(splat(2), c.omc));
}

// ---- [3] The lobes ----------------------------------------------------------------

// A specular lobe as a factor (lobeFactor in vsl_sg.cpp): exp(lambda
// (u.l - 1) ... ) with u its unit world axis and lambda its blended
// sharpness, and its own part of v.u - B, exact: lambda - B =
// local lambda_local (1 - u.a) + global logPeak. Zero where off.
struct Lobe8 {
  Vec3x8 u;
  __m256 lambda, own;
  __m256 on;  // mask
};

// ndfAt: log(D_max / D(h)) / 2 = log e and the slope of log D per radian
// from l toward the lobe's axis m (all local), over sin psi (= lambda_local
// before its clamps); sin2Psi the squared sine of the angle between l and
// m. With hv = w + l (h = hv / |hv|) and tv = (l x m) x l the tangent
// (|tv| = sin psi for unit l), d log D = -4 / (e |hv|) (M h - e h) . d l
// gives slope / sin psi = -4 (M hv - e hv) . tv / (e |hv|^2 |tv| sin psi):
// one square root and three divisions (M's two by one).
VSL_FMA void ndf8(const Vec3x8& w, const Vec3x8& l, const Vec3x8& m, __m256 ax, __m256 ay, __m256& e,
                  __m256& slopePerSin, __m256& sin2Psi) {
  const Vec3x8 hv = add3(w, l);
  const __m256 len2 = dot3(hv, hv), ax2 = mul(ax, ax), ay2 = mul(ay, ay);
  const __m256 invA = quot(splat(1), mul(ax2, ay2));
  const Vec3x8 Mhv = {mul(hv.x, mul(ay2, invA)), mul(hv.y, mul(ax2, invA)), hv.z};
  e = div(dot3(hv, Mhv), len2);
  const Vec3x8 lm = cross3(l, m), tv = cross3(lm, l);
  sin2Psi = dot3(lm, lm);
  const __m256 num = mul(splat(-4), sub(dot3(Mhv, tv), mul(e, dot3(hv, tv))));
  const __m256 den = mul(mul(e, len2), _mm256_sqrt_ps(mul(dot3(tv, tv), sin2Psi)));
  const __m256 lenPos = greater(len2, _mm256_setzero_ps());
  slopePerSin = where(both(lenPos, greater(sin2Psi, splat(1e-14f))), div(num, den));
  e = select(lenPos, e, splat(1));
}

// side 0: x's lobe about its mirror direction; 1: p's, seen from x along
// minus its axis. l: the direction to the other end (local to this side).
VSL_FMA void lobe8(const LaneInputs& in, int side, const Vec3x8 frame[3], const Vec3x8& l, const Cone8& c, Lobe8& out) {
  const Vec3x8 w = lane3(in, side == 0 ? kXw : kPw);
  const __m256 ax = lane(in, side == 0 ? kXax : kPax), ay = lane(in, side == 0 ? kXay : kPay);
  out.on = greater(lane(in, side == 0 ? kXon : kPon), splat(0.5f));
  if (none(out.on)) {  // no product takes this lobe (block8)
    out.u = {_mm256_setzero_ps(), _mm256_setzero_ps(), _mm256_setzero_ps()};
    out.lambda = out.own = _mm256_setzero_ps();
    return;
  }
  // sgSpecularLobe: Wang et al. 2009's warped NDF.
  const __m256 lambda = quot(splat(0.5f), mul(mul(ax, ay), _mm256_max_ps(splat(0.01f), w.z)));
  const Vec3x8 mLocal = {neg(w.x), neg(w.y), w.z};
  Vec3x8 u = toWorld3(frame, mLocal);
  if (side == 1) u = {neg(u.x), neg(u.y), neg(u.z)};
  __m256 e, slopePerSin, sin2Psi;
  const Vec3x8 wn = normalize3(w);
  ndf8(wn, normalize3(l), {neg(wn.x), neg(wn.y), wn.z}, ax, ay, e, slopePerSin, sin2Psi);
  // The local fit's sharpness, within [0, lambda] and below the lobe's peak at u.
  __m256 lambdaLocal = select(greater(sin2Psi, splat(1e-14f)),
                              _mm256_min_ps(lambda, _mm256_max_ps(_mm256_setzero_ps(), slopePerSin)), lambda);
  u = normalize3(u);
  const __m256 logPeak = mul(splat(2), log8(e)), rise = oneMinusCos(u, c.a);
  lambdaLocal =
      select(greater(rise, splat(1e-12f)),
             _mm256_min_ps(lambdaLocal, quot(_mm256_max_ps(logPeak, _mm256_setzero_ps()), rise)), lambdaLocal);
  // The global fit's share: the lobe's mass inside the cone, falling off
  // as its axis leaves it (angles as chords).
  const __m256 chordPsi = safeSqrt8(mul(splat(2), rise));
  const __m256 outside = _mm256_max_ps(_mm256_setzero_ps(), sub(chordPsi, c.chord));
  const __m256 inside = mul(lambda, c.omc), away = mul(mul(splat(0.5f), lambda), mul(outside, outside));
  const __m256 global = where(lessEqual(away, splat(40)), mul(oneMinusExpNeg(inside), exp8(neg(away))));
  const __m256 local = sub(splat(1), global);
  out.u = u;
  out.lambda = where(out.on, add(mul(local, lambdaLocal), mul(global, lambda)));
  out.own = where(out.on, add(mul(mul(local, lambdaLocal), rise), mul(global, logPeak)));
}

// ---- [4] The products --------------------------------------------------------------

// The cosines' part of the product, shared by the four: v's part, w0 =
// k (nx + np) (unit normals, np facing x), and their axes.
struct Cosines8 {
  Vec3x8 nx, np, w0;
};

// Formula (1) over the area for the product of the cone, the cosines and
// the lobes given (null: not in this product), as exp(E) g: returns E, sets
// g = g(|v|). Its exponent
// |v| - B is formed about the axis r of its sharpest factor:
//   |v| - B = (|v| - v.r) + sum_k (lambda_k u_k.r - B_k),
// |v| - v.r = |v x r|^2 / (|v| + v.r), and each factor's term exact:
// the cone's -lambda_c (1 - a.r), a cosine's k (n.r - n.a), a lobe's
// -lambda (1 - u.r) + own. The sharpest factor's term is then 0 and no
// large sharpness multiplies a rounding error: about a, a needle lobe's
// own sharpness would multiply 1 - u.a's (the lobe's peak seen inside a
// wide cone); about its own axis it does not. E adds log(2 pi / area).
VSL_FMA __m256 logIntegral(const Cone8& c, const Cosines8& n, const Lobe8* const lobes[2], __m256 logNorm, __m256& g) {
  Vec3x8 r = c.a;
  __m256 big = c.lambda;
  for (int s = 0; s < 2; ++s)
    if (lobes[s]) {
      const __m256 sharper = greater(lobes[s]->lambda, big);
      r = {select(sharper, lobes[s]->u.x, r.x), select(sharper, lobes[s]->u.y, r.y),
           select(sharper, lobes[s]->u.z, r.z)};
      big = _mm256_max_ps(big, lobes[s]->lambda);
    }
  Vec3x8 v = add3(scale3(c.a, c.lambda), n.w0);
  const __m256 k = splat(float(kSgCosineSharpness));
  __m256 terms = mul(k, add(sub(dot3(n.nx, r), dot3(n.nx, c.a)), sub(dot3(n.np, r), dot3(n.np, c.a))));
  if (lobes[0] || lobes[1]) terms = sub(terms, mul(c.lambda, oneMinusCos(c.a, r)));
  for (int s = 0; s < 2; ++s)
    if (lobes[s]) {
      v = add3(v, scale3(lobes[s]->u, lobes[s]->lambda));
      terms = add(terms, sub(lobes[s]->own, mul(lobes[s]->lambda, oneMinusCos(lobes[s]->u, r))));
    }
  const Vec3x8 x = cross3(v, r);
  const __m256 cross2 = dot3(x, x), P = dot3(v, r);
  const __m256 m = _mm256_sqrt_ps(add(mul(P, P), cross2));
  const __m256 gap = select(greater(P, _mm256_setzero_ps()), quot(cross2, add(m, P)), sub(m, P));
  // g(m) = (1 - exp(-2m)) / m, by its series below 0.01 (2 at m = 0).
  const __m256 series =
      sub(splat(2), mul(m, sub(splat(2), mul(m, sub(splat(4.0f / 3.0f), mul(m, splat(2.0f / 3.0f)))))));
  g = select(less(m, splat(0.01f)), series, quot(oneMinusExpNeg(mul(splat(2), m)), m));
  return add(add(gap, terms), logNorm);
}

// sum[c] += amplitude[c] x the product's integral over the area, exp(E) g,
// where mask. Where E is large (a tiny area against a tail, g small), as
// exp(E + log g), so that exp(E) alone does not overflow.
VSL_FMA void addProduct(const __m256 amplitude[3], __m256 E, __m256 g, __m256 mask, __m256 sum[3]) {
  __m256 s = mul(exp8(E), g);
  const __m256 big = greater(E, splat(80));
  if (!none(both(big, mask))) s = select(big, exp8(add(E, log8(g))), s);
  s = where(mask, s);
  for (int k = 0; k < 3; ++k) sum[k] = madd(amplitude[k], s, sum[k]);
}

// The BRDFs' parts at the axis: f[side][0 diffuse, 1 specular][channel].
VSL_FMA void parts8(const LaneInputs& in, const Vec3x8& lx, const Vec3x8& lp, __m256 f[2][2][3]) {
  alignas(32) float dir[2][3][8], out[2][2][3][8];
  const Vec3x8* ls[2] = {&lx, &lp};
  for (int s = 0; s < 2; ++s) {
    _mm256_store_ps(dir[s][0], ls[s]->x);
    _mm256_store_ps(dir[s][1], ls[s]->y);
    _mm256_store_ps(dir[s][2], ls[s]->z);
    float* const diffuse[3] = {out[s][0][0], out[s][0][1], out[s][0][2]};
    float* const specular[3] = {out[s][1][0], out[s][1][1], out[s][1][2]};
    BrdfAt::evalPartsPackedAvx2(8, in.packed[s], dir[s][0], dir[s][1], dir[s][2], diffuse, specular);
  }
  for (int s = 0; s < 2; ++s)
    for (int k = 0; k < 2; ++k)
      for (int ch = 0; ch < 3; ++ch) f[s][k][ch] = _mm256_load_ps(out[s][k][ch]);
}

// ---- [5] The block -----------------------------------------------------------------

// Eight pairs' transfers into t[channel][lane].
VSL_FMA void block8(const LaneInputs& in, bool clippedDisk, float t[3][8]) {
  Cone8 c;
  cone8(in, c);
  const Vec3x8 fx[3] = {lane3(in, kXs), lane3(in, kXt), lane3(in, kXn)};
  const Vec3x8 fp[3] = {lane3(in, kPs), lane3(in, kPt), lane3(in, kPn)};
  const Vec3x8 lx = toLocal3(fx, c.a), lp = toLocal3(fp, {neg(c.a.x), neg(c.a.y), neg(c.a.z)});
  const Vec3x8 gLocal = lane3(in, kG);
  const __m256 cosX = lx.z, cosP = dot3(lp, gLocal);
  const __m256 area = clippedDisk ? lane(in, kArea) : mul(splat(kPi), mul(c.r, c.r));
  const __m256 ok = both(both(greater(cosX, _mm256_setzero_ps()), greater(cosP, _mm256_setzero_ps())),
                         greater(area, _mm256_setzero_ps()));
  __m256 sum[3] = {_mm256_setzero_ps(), _mm256_setzero_ps(), _mm256_setzero_ps()};
  if (!none(ok)) {
    __m256 f[2][2][3];
    parts8(in, lx, lp, f);
    // The two cosines (ratio form), p's normal facing x.
    Cosines8 n;
    n.nx = normalize3(fx[2]);
    n.np = scale3(normalize3(toWorld3(fp, gLocal)), splat(-1));
    n.w0 = scale3(add3(n.nx, n.np), splat(float(kSgCosineSharpness)));
    Lobe8 lobe[2];
    lobe8(in, 0, fx, lx, c, lobe[0]);
    lobe8(in, 1, fp, lp, c, lobe[1]);
    const __m256 logNorm = log8(div(splat(2 * kPi), area)), cc = mul(cosX, cosP);
    // The four products: diffuse or specular at each end (a lobe's term
    // only where it is on).
    for (int sx = 0; sx < 2; ++sx)
      for (int sp = 0; sp < 2; ++sp) {
        __m256 mask = ok;
        const Lobe8* const in2[2] = {sx ? &lobe[0] : nullptr, sp ? &lobe[1] : nullptr};
        for (int s = 0; s < 2; ++s)
          if (in2[s]) mask = both(mask, in2[s]->on);
        if (none(mask)) continue;
        // A black amplitude adds nothing (as addTerm: not even a NaN).
        __m256 amplitude[3], lit = _mm256_setzero_ps();
        for (int ch = 0; ch < 3; ++ch) {
          amplitude[ch] = mul(mul(f[0][sx][ch], f[1][sp][ch]), cc);
          lit = _mm256_or_ps(lit, _mm256_cmp_ps(amplitude[ch], _mm256_setzero_ps(), _CMP_NEQ_UQ));
        }
        mask = both(mask, lit);
        if (none(mask)) continue;
        __m256 g;
        const __m256 E = logIntegral(c, n, in2, logNorm, g);
        addProduct(amplitude, E, g, mask, sum);
      }
  }
  // Non-finite results become 0, as the scalar form's.
  __m256 finite = ok;
  for (int ch = 0; ch < 3; ++ch)
    finite = both(finite, _mm256_cmp_ps(sub(sum[ch], sum[ch]), _mm256_setzero_ps(), _CMP_EQ_OQ));
  for (int ch = 0; ch < 3; ++ch) _mm256_storeu_ps(t[ch], where(finite, sum[ch]));
}

}  // namespace

VSL_FMA void vslTransferSgManyAvx2(int n, const VslSgPair* pairs, const VslOptions& options, Vec3* out) {
  LaneInputs in;
  static const VslSgPair kNone{};
  for (int i0 = 0; i0 < n; i0 += 8) {
    const int m = std::min(8, n - i0);
    if (m < 8) std::memset(in.v, 0, sizeof in.v);  // lanes past the pairs read zeros
    bool oneLight = true;
    for (int j = 1; j < m; ++j) oneLight = oneLight && pairs[i0 + j].p == pairs[i0].p;
    if (oneLight) fillEmitterAll(*pairs[i0].p, in);
    for (int j = 0; j < 8; ++j) fillLane(j < m ? pairs[i0 + j] : kNone, j, options, oneLight, in);
    alignas(32) float t[3][8];
    block8(in, options.clippedDisk, t);
    for (int j = 0; j < m; ++j) out[i0 + j] = Vec3(t[0][j], t[1][j], t[2][j]);
  }
}

void vslTransferSgMany(int n, const VslSgPair* pairs, const VslOptions& options, Vec3* out) {
  if (simdAvailable()) return vslTransferSgManyAvx2(n, pairs, options, out);
  for (int i = 0; i < n; ++i)
    out[i] = vslTransferSg(*pairs[i].x, *pairs[i].p, pairs[i].toLight, pairs[i].radius, options).transfer;
}

}  // namespace vsl
