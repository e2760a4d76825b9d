// The light tree of stochastic lightcuts (light_tree.h).
// Sections: [1] bounds at a receiver  [2] build  [3] sampling and pdf
#include "core/estimators/slc/light_tree.h"

#include <emmintrin.h>
#include <xmmintrin.h>
#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <utility>

#include "core/check.h"
#include "core/memory_budget.h"
#include "core/point_tree.h"
#include "core/stopwatch.h"

namespace vsl {

// ---- [1] Bounds at a receiver ---------------------------------------------------------

namespace {

// cos and sin of max(0, a - b) for angles a, b in [0, pi] given by theirs:
// the angle a, narrowed by b (a cone's half-angle, a box's angular radius).
struct CosSin {
  float c = 1, s = 0;
};
CosSin narrowed(CosSin a, CosSin b) {
  if (a.c >= b.c) return {};
  return {a.c * b.c + a.s * b.s, std::max(0.0f, a.s * b.c - a.c * b.s)};
}
CosSin fromCos(float c) {
  c = clamp(c, -1.0f, 1.0f);
  return {c, safeSqrt(1 - c * c)};
}

}  // namespace

LightTreeReceiver LightTreeReceiver::make(const GatherPoint& gp, bool vsl, float vplClamp) {
  LightTreeReceiver r;
  r.vsl = vsl;
  r.vplCap = vplClamp < kInf ? kPi * vplClamp : kInf;
  r.p = gp.p;
  r.n = gp.rx.frame.n;
  const BrdfAt& f = gp.rx.f;
  const Vec3 wo = f.w();
  r.mirror = gp.rx.frame.toWorld(Vec3(-wo.x, -wo.y, wo.z));
  if (!(wo.z > 0)) return r;  // the BRDF is zero for a viewer below the surface
  r.diffuse = luminance(f.kd());
  const Brdf& b = f.brdf();
  r.specularOn = f.specularOn();
  r.ax = std::max(b.ggx.ax, 1e-4f);
  r.ay = std::max(b.ggx.ay, 1e-4f);
  // f_s cos_i = F D G2 / (4 cos_o): F <= max(1, specularWeight) (Schlick
  // blends towards 1 from F0 <= 1), G2 <= G1(wo) (Heitz 2014, height-
  // correlated Smith).
  r.specular = std::max(1.0f, b.specularWeight) * b.ggx.G1(wo) / (4 * wo.z);
  r.albedo = std::max(1.0f, b.specularWeight);
  if (f.coated() && r.specularOn) {
    // A clear coat (core/material.h): its lobe bounded as a dielectric one
    // (F <= 1) added, the shape taken as the narrower of the two lobes'
    // about the shading normal's mirror (a coat normal's tilt is not bounded).
    r.ax = std::min(r.ax, std::max(b.coat.ax, 1e-4f));
    r.ay = std::min(r.ay, std::max(b.coat.ay, 1e-4f));
    r.specular += b.clearcoat * b.coat.G1(wo) / (4 * wo.z);
    r.albedo += b.clearcoat;
  }
  // The lobes' albedos, roughly: the dielectric layer's E(cos_o, alpha) and
  // the metal's colour; the diffuse lobe's at most pi kd.
  if (!r.specularOn) return r;
  const float alpha = std::sqrt(b.ggx.ax * b.ggx.ay);
  const float as =
      (1 - b.metallic) * b.specularWeight * dielectricSpecularAlbedo(wo.z, alpha) + b.metallic * luminance(b.baseColor);
  const float ad = kPi * r.diffuse;
  r.specularShare = ad > 0 ? clamp(as / std::max(as + ad, 1e-20f), 0.1f, 0.9f) : 1.0f;
  return r;
}

// The anisotropic GGX D (Heitz 2014, eq. 85) at a half vector at angle
// theta_h from n is at most 1 / (pi ax ay cos^4 (1 + tan^2 / a_max^2)^2),
// since tan^2 (cos^2 phi / ax^2 + sin^2 phi / ay^2) >= tan^2 / a_max^2; it
// falls with theta_h. A half vector is at least half as far from n as wi
// is from the mirror direction: reflections about two axes theta apart
// differ by a rotation of 2 theta, so |angle(wi, mirror)| <= 2 angle(h, n).
void LightTreeReceiver::brdfCosBounds(float thetaRCos, float cosX, float out[2]) const {
  out[0] = out[1] = 0;
  if (!(cosX > 0)) return;
  out[0] = diffuse * cosX;
  if (specularOn) {
    const float c2 = std::max(0.0f, 0.5f * (1 + thetaRCos)), s2 = std::max(0.0f, 1 - c2);  // cos^2, sin^2 theta_h
    const float am = std::max(ax, ay), am2 = am * am;
    const float den = am2 * c2 + s2;
    out[1] = specular * am2 * am2 / (kPi * ax * ay * den * den);
  }
}

void LightTree::importance(const LightTreeNode& nd, const LightTreeReceiver& r, float out[2], bool withDistance) {
  out[0] = out[1] = 0;
  if (!(nd.flux > 0)) return;
  const Vec3 c = 0.5f * (nd.lo + nd.hi);
  const float R = 0.5f * length(nd.hi - nd.lo);
  const Vec3 d = c - r.p;
  const float dist = length(d);
  // The box's angular radius from x (every direction when x is inside its
  // bounding sphere), and with the VSL spheres around its lights.
  CosSin box{-1, 0}, sphere{-1, 0};
  Vec3 dir = r.n;
  if (dist > R) {
    dir = d / dist;
    const float sb = R / dist;
    box = {safeSqrt(1 - sb * sb), sb};
    const float rs = std::min(1.0f, (R + nd.radius) / dist);
    sphere = {safeSqrt(1 - rs * rs), rs};
  }
  // The cosines: zero (the pair contributes nothing, Gatherer::connect's
  // test at the lights' centres) where they are zero over the box's
  // directions; otherwise their largest over the cone to the lights'
  // spheres, which VSL integrates over (a receiver near a sphere sees it
  // at grazing angles from its centre's direction).
  const CosSin toX = fromCos(dot(r.n, dir));
  if (!(narrowed(toX, box).c > 0)) return;
  const float cosX = narrowed(toX, sphere).c;
  // Emission cosine: over the cone's normals as well (Conty Estevez and
  // Kulla 2018, eq. 5's theta').
  const CosSin toP = narrowed(fromCos(-dot(nd.axis, dir)), fromCos(nd.cosTheta));
  if (!(narrowed(toP, box).c > 0)) return;
  const float cosP = narrowed(toP, sphere).c;
  // The receiver's lobe: the closest direction to its peak within the cone
  // to the lights' spheres.
  const float cosR = narrowed(fromCos(dot(r.mirror, dir)), sphere).c;
  float f[2];
  r.brdfCosBounds(cosR, cosX, f);
  // A VSL's light is at most its sphere's over the sphere's area (twice
  // that for the clipped disk) from the whole hemisphere: albedo / (pi
  // r^2); the smallest sphere below bounds them all.
  const float cap = r.vsl ? 2 * r.albedo / (kPi * sqr(std::max(nd.radiusMin, 1e-20f))) : r.vplCap;
  // Distance as pbrt-v4's BVH light sampler takes it (after Conty Estevez
  // and Kulla 2018): to the box's centre, at least half its diagonal, so
  // that a box around the receiver is not infinitely important.
  const float d2 = withDistance ? std::max(dist * dist, R * R) : 1.0f;
  for (int k = 0; k < 2; ++k) {
    if (withDistance) f[k] = d2 > 0 ? std::min(f[k] / d2, cap) : (f[k] > 0 ? cap : 0.0f);
    out[k] = nd.flux * cosP * f[k];
  }
}

void LightTreeWide::set(int lane, const LightTreeNode& nd) {
  const Vec3 c = 0.5f * (nd.lo + nd.hi);
  cx[lane] = c.x;
  cy[lane] = c.y;
  cz[lane] = c.z;
  halfDiag[lane] = 0.5f * length(nd.hi - nd.lo);
  nx[lane] = nd.axis.x;
  ny[lane] = nd.axis.y;
  nz[lane] = nd.axis.z;
  const CosSin cone = fromCos(nd.cosTheta);
  cosTheta[lane] = cone.c;
  sinTheta[lane] = cone.s;
  flux[lane] = nd.flux;
  radius[lane] = nd.radius;
  invArea[lane] = 1 / (kPi * sqr(std::max(nd.radiusMin, 1e-20f)));
}

namespace {

// Four lanes of floats (SSE2) and of (cos, sin) pairs, as CosSin above.
using F4 = __m128;
inline F4 splat4(float v) { return _mm_set1_ps(v); }
inline F4 sel4(F4 mask, F4 a, F4 b) { return _mm_or_ps(_mm_and_ps(mask, a), _mm_andnot_ps(mask, b)); }
// std::max(0, v): a NaN gives 0, as std::max's.
inline F4 max0(F4 v) { return _mm_max_ps(v, _mm_setzero_ps()); }
inline F4 dot4(F4 x, F4 y, F4 z, const Vec3& v) {
  return _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, splat4(v.x)), _mm_mul_ps(y, splat4(v.y))), _mm_mul_ps(z, splat4(v.z)));
}
struct CosSin4 {
  F4 c, s;
};
CosSin4 fromCos4(F4 c) {
  c = _mm_min_ps(splat4(1), _mm_max_ps(splat4(-1), c));
  return {c, _mm_sqrt_ps(max0(_mm_sub_ps(splat4(1), _mm_mul_ps(c, c))))};
}
CosSin4 narrowed4(CosSin4 a, CosSin4 b) {
  const F4 within = _mm_cmpge_ps(a.c, b.c);
  const F4 c = _mm_add_ps(_mm_mul_ps(a.c, b.c), _mm_mul_ps(a.s, b.s));
  const F4 s = max0(_mm_sub_ps(_mm_mul_ps(a.s, b.c), _mm_mul_ps(a.c, b.s)));
  return {sel4(within, splat4(1), c), sel4(within, _mm_setzero_ps(), s)};
}

// The receiver's lobe bounds of LightTreeReceiver::brdfCosBounds, lane by
// lane, for cosX > 0.
void brdfCosBounds4(const LightTreeReceiver& r, F4 cosR, F4 cosX, F4 out[2]) {
  out[0] = _mm_mul_ps(splat4(r.diffuse), cosX);
  out[1] = _mm_setzero_ps();
  if (!r.specularOn) return;
  const F4 c2 = max0(_mm_mul_ps(splat4(0.5f), _mm_add_ps(splat4(1), cosR)));
  const F4 s2 = max0(_mm_sub_ps(splat4(1), c2));
  const float am = std::max(r.ax, r.ay), am2 = am * am;
  const F4 den = _mm_add_ps(_mm_mul_ps(splat4(am2), c2), s2);
  out[1] = _mm_div_ps(splat4(r.specular * am2 * am2), _mm_mul_ps(splat4(kPi * r.ax * r.ay), _mm_mul_ps(den, den)));
}

}  // namespace

// LightTree::importance on the four entries, operation for operation but
// for the reciprocals of the squared distance and of the cap's area (kept
// per entry).
void LightTree::importance4(const LightTreeWide& nd, const LightTreeReceiver& r, float out[2][4], bool withDistance) {
  const F4 zero = _mm_setzero_ps(), one = splat4(1);
  const F4 dx = _mm_sub_ps(_mm_load_ps(nd.cx), splat4(r.p.x));
  const F4 dy = _mm_sub_ps(_mm_load_ps(nd.cy), splat4(r.p.y));
  const F4 dz = _mm_sub_ps(_mm_load_ps(nd.cz), splat4(r.p.z));
  const F4 dist = _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz)));
  const F4 R = _mm_load_ps(nd.halfDiag);
  // Outside the box's sphere: the directions to it; inside, every
  // direction (the bounds' cosines all one).
  const F4 outside = _mm_cmpgt_ps(dist, R);
  // As the scalar form's, to its bits: a narrow lobe's bound magnifies a
  // direction's rounding (sin = sqrt(1 - cos^2) near cos = 1, and the lobe's
  // 1 / (alpha^2 cos^2 + sin^2)^2).
  const F4 inv = _mm_div_ps(one, dist);
  const F4 ux = sel4(outside, _mm_mul_ps(dx, inv), splat4(r.n.x));
  const F4 uy = sel4(outside, _mm_mul_ps(dy, inv), splat4(r.n.y));
  const F4 uz = sel4(outside, _mm_mul_ps(dz, inv), splat4(r.n.z));
  const F4 sb = _mm_and_ps(outside, _mm_div_ps(R, dist));
  const F4 rs = _mm_and_ps(outside, _mm_min_ps(one, _mm_div_ps(_mm_add_ps(R, _mm_load_ps(nd.radius)), dist)));
  const F4 minus1 = splat4(-1);
  const CosSin4 box{sel4(outside, _mm_sqrt_ps(max0(_mm_sub_ps(one, _mm_mul_ps(sb, sb)))), minus1), sb};
  const CosSin4 sphere{sel4(outside, _mm_sqrt_ps(max0(_mm_sub_ps(one, _mm_mul_ps(rs, rs)))), minus1), rs};
  const CosSin4 toX = fromCos4(dot4(ux, uy, uz, r.n));
  F4 on = _mm_and_ps(_mm_cmpgt_ps(narrowed4(toX, box).c, zero), _mm_cmpgt_ps(_mm_load_ps(nd.flux), zero));
  const F4 cosX = narrowed4(toX, sphere).c;
  const F4 toDirAxis = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_load_ps(nd.nx), ux), _mm_mul_ps(_mm_load_ps(nd.ny), uy)),
                                  _mm_mul_ps(_mm_load_ps(nd.nz), uz));
  const CosSin4 toP =
      narrowed4(fromCos4(_mm_sub_ps(zero, toDirAxis)), CosSin4{_mm_load_ps(nd.cosTheta), _mm_load_ps(nd.sinTheta)});
  on = _mm_and_ps(on, _mm_cmpgt_ps(narrowed4(toP, box).c, zero));
  const F4 cosP = narrowed4(toP, sphere).c;
  const F4 cosR = narrowed4(fromCos4(dot4(ux, uy, uz, r.mirror)), sphere).c;
  F4 f[2];
  brdfCosBounds4(r, cosR, cosX, f);
  const F4 cap = r.vsl ? _mm_mul_ps(splat4(2 * r.albedo), _mm_load_ps(nd.invArea)) : splat4(r.vplCap);
  const F4 d2 = _mm_max_ps(_mm_mul_ps(dist, dist), _mm_mul_ps(R, R));
  const F4 d2Positive = _mm_cmpgt_ps(d2, zero);
  const F4 invD2 = _mm_div_ps(one, d2);
  const F4 flux = _mm_load_ps(nd.flux);
  for (int k = 0; k < 2; ++k) {
    F4 v = f[k];
    if (withDistance) {
      const F4 atZero = _mm_and_ps(_mm_cmpgt_ps(v, zero), cap);
      v = sel4(d2Positive, _mm_min_ps(_mm_mul_ps(v, invD2), cap), atZero);
    }
    _mm_storeu_ps(out[k], _mm_and_ps(on, _mm_mul_ps(_mm_mul_ps(flux, cosP), v)));
  }
}

// ---- [2] Build ------------------------------------------------------------------------

namespace {

// 10 bits per axis, interleaved (x highest).
uint32_t spread10(uint32_t v) {
  v &= 0x3ff;
  v = (v | (v << 16)) & 0x030000ff;
  v = (v | (v << 8)) & 0x0300f00f;
  v = (v | (v << 4)) & 0x030c30c3;
  v = (v | (v << 2)) & 0x09249249;
  return v;
}

// The union of two orientation cones (Conty Estevez and Kulla 2018,
// Algorithm 1).
void mergeCones(const Vec3& a, float cosA, const Vec3& b, float cosB, Vec3& axis, float& cosOut) {
  float ta = std::acos(clamp(cosA, -1.0f, 1.0f)), tb = std::acos(clamp(cosB, -1.0f, 1.0f));
  Vec3 ca = a, cb = b;
  if (tb > ta) {
    std::swap(ta, tb);
    std::swap(ca, cb);
  }
  const float td = std::acos(clamp(dot(ca, cb), -1.0f, 1.0f));
  if (std::min(td + tb, kPi) <= ta) {
    axis = ca;
    cosOut = std::cos(ta);
    return;
  }
  const float to = 0.5f * (ta + td + tb);
  if (to >= kPi) {
    axis = ca;
    cosOut = -1;
    return;
  }
  const float tr = to - ta;
  Vec3 perp = cb - ca * dot(ca, cb);
  if (!(lengthSquared(perp) > 1e-12f)) {
    Vec3 t;
    coordinateSystem(ca, perp, t);
  }
  perp = normalize(perp);
  axis = normalize(ca * std::cos(tr) + perp * std::sin(tr));
  // A little wider, for the rounding of the rotation.
  cosOut = std::cos(std::min(to * 1.0001f + 1e-6f, kPi));
}

}  // namespace

LightTree LightTree::build(const std::vector<GatherLight>& lights) {
  std::vector<Prim> prims = hugePageVector<Prim>(lights.size());
  for (size_t i = 0; i < lights.size(); ++i) {
    prims[i] = {lights[i].p, lights[i].n, std::max(0.0f, luminance(lights[i].Phi)), lights[i].radius};
  }
  return fromPrims(std::move(prims));
}

LightTree LightTree::build(const VirtualLightSet& set, const std::vector<float>& radii) {
  VSL_CHECK_EQ(set.lights.size(), radii.size());
  std::vector<Prim> prims = hugePageVector<Prim>(set.lights.size());
  for (size_t i = 0; i < prims.size(); ++i) {
    const VirtualLight& v = set.lights[i];
    // The emission cosine's normal (decodeGatherLight: the geometric one
    // for a normal-mapped light).
    const Vec3 n = decodeUnit(v.normalMapped ? v.ng : v.n);
    prims[i] = {v.p, n, std::max(0.0f, luminance(v.Phi)), radii[i]};
  }
  return fromPrims(std::move(prims));
}

// The prims' Morton codes (10 bits per axis in their box) above their
// indices, sorted.
std::vector<uint64_t> LightTree::sortedKeys(const std::vector<Prim>& prims) {
  Vec3 lo(kInf), hi(-kInf);
  for (const Prim& p : prims) {
    lo = min(lo, p.p);
    hi = max(hi, p.p);
  }
  const Vec3 ext = max(hi - lo, Vec3(1e-20f));
  std::vector<uint64_t> keys = hugePageVector<uint64_t>(prims.size());
  for (size_t i = 0; i < prims.size(); ++i) {
    const Vec3 u = (prims[i].p - lo) / ext;
    auto q = [](float v) { return uint32_t(clamp(v * 1024.0f, 0.0f, 1023.0f)); };
    const uint32_t code = (spread10(q(u.x)) << 2) | (spread10(q(u.y)) << 1) | spread10(q(u.z));
    keys[i] = (uint64_t(code) << 32) | uint64_t(i);
  }
  sortMortonKeys(keys);
  return keys;
}

// The range [b, e) of sorted keys split where the highest differing bit of
// its codes changes (the codes share every bit above it), or in the middle.
uint32_t LightTree::split(const std::vector<uint64_t>& keys, uint32_t b, uint32_t e) {
  const uint32_t kb = uint32_t(keys[b] >> 32), ke = uint32_t(keys[e - 1] >> 32);
  if (kb == ke) return b + (e - b) / 2;
  const int bit = 31 - std::countl_zero(kb ^ ke);
  auto it =
      std::partition_point(keys.begin() + b, keys.begin() + e, [&](uint64_t k) { return ((k >> 32) >> bit & 1) == 0; });
  return uint32_t(it - keys.begin());
}

namespace {

// The binary tree's bounds of a node from its children's (its box, flux,
// radii and orientation cone).
LightTreeNode merged(const LightTreeNode& a, const LightTreeNode& b) {
  LightTreeNode nd;
  nd.lo = min(a.lo, b.lo);
  nd.hi = max(a.hi, b.hi);
  nd.flux = a.flux + b.flux;
  nd.radius = std::max(a.radius, b.radius);
  nd.radiusMin = std::min(a.radiusMin, b.radiusMin);
  mergeCones(a.axis, a.cosTheta, b.axis, b.cosTheta, nd.axis, nd.cosTheta);
  return nd;
}

}  // namespace

LightTree LightTree::fromPrims(std::vector<Prim> prims) {
  Stopwatch clock;
  LightTree t;
  if (prims.empty()) return t;
  // Entries are addressed as 4 x wide node + lane in an int32.
  VSL_CHECK(prims.size() < size_t(1) << 28);
  const std::vector<uint64_t> keys = sortedKeys(prims);
  // At most n - 1 wide nodes (each has two entries or more), about n / 2
  // (three entries on average).
  reserveHugePages(t.wide_, std::max<size_t>(prims.size() - 1, 1));
  t.leafOf_.assign(prims.size(), -1);
  t.buildNode(keys, prims, 0, uint32_t(keys.size()), -1, 0);
  t.buildSeconds_ = clock.seconds();
  return t;
}

// The wide node of the sorted keys [b, e): the binary tree's nodes below
// it (each range split by split()) expanded, the largest range first,
// until there are four entries or all are lights; each inner entry's own
// wide node made the same way (depth first, so that a node comes after
// its parent). Returns the bounds of [b, e), its entries' merged (treeletBounds). A tree of
// one light is one node of one entry.
LightTreeNode LightTree::buildNode(const std::vector<uint64_t>& keys, const std::vector<Prim>& prims, uint32_t b,
                                   uint32_t e, int32_t parentEntry, int depth) {
  VSL_CHECK(depth < 128);
  const int32_t w = int32_t(wide_.size());
  wide_.emplace_back();
  parent_.push_back(parentEntry);
  uint32_t lo[4] = {b}, hi[4] = {e};
  int m = 1;
  for (; m < 4;) {
    int widest = -1;
    for (int i = 0; i < m; ++i)
      if (hi[i] - lo[i] > 1 && (widest < 0 || hi[i] - lo[i] > hi[widest] - lo[widest])) widest = i;
    if (widest < 0) break;
    const uint32_t mid = split(keys, lo[widest], hi[widest]);
    for (int i = m; i > widest + 1; --i) {
      lo[i] = lo[i - 1];
      hi[i] = hi[i - 1];
    }
    lo[widest + 1] = mid;
    hi[widest + 1] = hi[widest];
    hi[widest] = mid;
    ++m;
  }
  LightTreeNode bounds[4];
  for (int lane = 0; lane < m; ++lane) {
    LightTreeNode& nd = bounds[lane];
    int32_t child;
    if (hi[lane] - lo[lane] == 1) {
      const uint32_t li = uint32_t(keys[lo[lane]]);
      const Prim& p = prims[li];
      nd.lo = nd.hi = p.p;
      nd.axis = p.n;
      nd.cosTheta = 1;
      nd.flux = p.flux;
      nd.radius = nd.radiusMin = p.radius;
      child = -int32_t(li) - 1;
      leafOf_[li] = 4 * w + lane;
    } else {
      child = int32_t(wide_.size());
      nd = buildNode(keys, prims, lo[lane], hi[lane], 4 * w + lane, depth + 1);
    }
    wide_[size_t(w)].set(lane, nd);
    wide_[size_t(w)].child[lane] = child;
  }
  return treeletBounds(keys, b, e, lo, hi, bounds, m);
}

// The bounds of the binary node over keys [b, e) from those of the entries
// below it (their ranges lo, hi), merged pair by pair as the binary tree
// pairs them: the cones' union depends on the order, and the binary
// order keeps them narrowest.
LightTreeNode LightTree::treeletBounds(const std::vector<uint64_t>& keys, uint32_t b, uint32_t e, const uint32_t* lo,
                                       const uint32_t* hi, const LightTreeNode* bounds, int m) {
  for (int i = 0; i < m; ++i)
    if (lo[i] == b && hi[i] == e) return bounds[i];
  const uint32_t mid = split(keys, b, e);
  return merged(treeletBounds(keys, b, mid, lo, hi, bounds, m), treeletBounds(keys, mid, e, lo, hi, bounds, m));
}

// ---- [3] Sampling and pdf ------------------------------------------------------------

LightTree::EntryWeights LightTree::entryWeights(const LightTreeWide& nd, const LightTreeReceiver& r) {
  EntryWeights e;
  importance4(nd, r, e.w);
  double fluxSum = 0;
  int entries = 0;
  for (int lane = 0; lane < 4; ++lane)
    if (nd.child[lane] != LightTreeWide::kEmpty) {
      ++entries;
      fluxSum += nd.flux[lane];
    }
  // By flux; uniform over the entries where none has any.
  for (int lane = 0; lane < 4; ++lane)
    e.w[2][lane] = fluxSum > 0 || nd.child[lane] == LightTreeWide::kEmpty ? nd.flux[lane] : 1.0f;
  e.sum[2] = fluxSum > 0 ? fluxSum : entries;
  for (int k = 0; k < 2; ++k) {
    e.sum[k] = double(e.w[k][0]) + e.w[k][1] + e.w[k][2] + e.w[k][3];
    if (!std::isfinite(e.sum[k])) {
      // An uncapped VPL at the receiver: by importance without distance.
      float u[2][4];
      importance4(nd, r, u, false);
      std::copy(u[k], u[k] + 4, e.w[k]);
      e.sum[k] = double(u[k][0]) + u[k][1] + u[k][2] + u[k][3];
    }
    if (!(e.sum[k] > 0 && std::isfinite(e.sum[k]))) {
      // No entry can face the receiver (or a bound overflowed): by flux.
      std::copy(e.w[2], e.w[2] + 4, e.w[k]);
      e.sum[k] = e.sum[2];
    }
  }
  return e;
}

namespace {

// The entry of weight w[lane] (of total sum) for a uniform u in [0, 1):
// the number of the cumulative sums at or below u sum, without branches
// (so that descents in flight are not flushed by a mispredicted choice);
// never an entry of weight zero (the sums do not grow there, and a u past
// their total by rounding takes the last entry that has some).
int pickEntry(const float w[4], double sum, float u) {
  const double t = double(u) * sum, c0 = w[0], c1 = c0 + w[1], c2 = c1 + w[2];
  const int lane = int(t >= c0) + int(t >= c1) + int(t >= c2);
  const int last = w[3] > 0 ? 3 : w[2] > 0 ? 2 : w[1] > 0 ? 1 : 0;
  return std::min(lane, last);
}

}  // namespace

// One descent: its strategy, wide node and path products.
struct LightTree::Descent {
  int strategy = 0;
  size_t w = 0;
  double p[3] = {1, 1, 1};
};

int LightTree::strategy(float u, float floor, float share) {
  // The descent: diffuse lobe's (0), specular lobe's (1), or by flux (2).
  return u < floor ? 2 : (u < floor + (1 - floor) * share ? 1 : 0);
}

// One level of a descent; true with the light in `out` at a leaf.
bool LightTree::descend(const LightTreeReceiver& r, float u, float floor, Descent& d, Sample& out) const {
  const LightTreeWide& nd = wide_[d.w];
  // The next node is one of these: its lines are on their way while this
  // node's probabilities are computed.
  for (int lane = 0; lane < 4; ++lane)
    if (nd.child[lane] >= 0) {
      const char* next = reinterpret_cast<const char*>(&wide_[size_t(nd.child[lane])]);
      for (size_t b = 0; b < sizeof(LightTreeWide); b += 64) _mm_prefetch(next + b, _MM_HINT_T0);
    }
  const EntryWeights e = entryWeights(nd, r);
  const int lane = pickEntry(e.w[d.strategy], e.sum[d.strategy], u);
  for (int k = 0; k < 3; ++k) d.p[k] *= e.probability(k, lane);
  const int32_t c = nd.child[lane];
  if (c >= 0) {
    d.w = size_t(c);
    return false;
  }
  out = {uint32_t(-(c + 1)), mix(d.p, floor, r.specularShare)};
  return true;
}

LightTree::Sample LightTree::sample(const LightTreeReceiver& r, Rng& rng, float floor) const {
  Sample out;
  sampleMany(r, rng, floor, 1, &out);
  return out;
}

void LightTree::sampleMany(const LightTreeReceiver& r, Rng& rng, float floor, int count, Sample* out) const {
  if (wide_.empty()) {
    std::fill(out, out + count, Sample{});
    return;
  }
  constexpr int kChunk = 16;
  for (int base = 0; base < count; base += kChunk) {
    const int m = std::min(kChunk, count - base);
    Descent d[kChunk];
    for (int j = 0; j < m; ++j) d[j].strategy = strategy(rng.uniform(), floor, r.specularShare);
    finish(r, rng, floor, d, m, out + base);
  }
}

// Up to four descents in flight, a level of each in turn: each level is a
// chain of square roots and divisions, and the processor overlaps
// independent chains.
void LightTree::finish(const LightTreeReceiver& r, Rng& rng, float floor, Descent* d, int count, Sample* out) const {
  constexpr int kInFlight = 4;
  for (int base = 0; base < count; base += kInFlight) {
    const int m = std::min(kInFlight, count - base);
    bool done[kInFlight] = {};
    for (int active = m; active > 0;)
      for (int j = 0; j < m; ++j)
        if (!done[j] && descend(r, rng.uniform(), floor, d[base + j], out[base + j])) {
          done[j] = true;
          --active;
        }
  }
}

namespace {

// k draws split over m choices of probabilities q (summing to one) by
// systematic sampling with offset u in [0, 1): the number of the points
// (u + j) / k, j < k, in each choice's share of [0, 1). Each count is
// k q or next to it, k q in expectation; a choice of probability zero gets
// none.
void splitCounts(const double* q, int m, int k, float u, int* counts) {
  int last = 0;
  for (int i = 0; i < m; ++i)
    if (q[i] > 0) last = i;
  double c = 0;
  int before = 0;
  for (int i = 0; i < m; ++i) {
    c += q[i];
    const int upto = i >= last ? k : std::clamp(int(std::ceil(k * c - u)), before, k);
    counts[i] = upto - before;
    before = upto;
  }
}

}  // namespace

// The draws split over the strategies, then at every node over its
// entries (splitCounts), until a node receives one draw, which descends
// alone (finish). E[draws reaching light i] = count x its mixture pdf, as
// for independent draws, so sum(f count_i / (count pdf_i)) stays unbiased;
// the draws are spread over the tree's subtrees in proportion to their
// importance (Yuksel 2019's cut, stratified), and the top of the tree is
// evaluated once for all of them.
int LightTree::sampleSplit(const LightTreeReceiver& r, Rng& rng, float floor, int count, Sample* out) const {
  if (wide_.empty() || count <= 0) return 0;
  struct Node {
    Descent d;
    int k;
  };
  thread_local std::vector<Node> stack;
  thread_local std::vector<Descent> alone;
  stack.clear();
  alone.clear();
  const double share = r.specularShare;
  const double w[3] = {(1 - floor) * (1 - share), (1 - floor) * share, floor};
  int ks[3];
  splitCounts(w, 3, count, rng.uniform(), ks);
  for (int s = 0; s < 3; ++s)
    if (ks[s] > 0) stack.push_back({{s, 0, {1, 1, 1}}, ks[s]});
  int n = 0;
  while (!stack.empty()) {
    const Node nd = stack.back();
    stack.pop_back();
    if (nd.k == 1) {
      alone.push_back(nd.d);
      continue;
    }
    const LightTreeWide& node = wide_[nd.d.w];
    const EntryWeights e = entryWeights(node, r);
    double q[4];
    for (int lane = 0; lane < 4; ++lane) q[lane] = e.probability(nd.d.strategy, lane);
    int counts[4];
    splitCounts(q, 4, nd.k, rng.uniform(), counts);
    for (int lane = 0; lane < 4; ++lane) {
      if (counts[lane] == 0) continue;
      Descent c = nd.d;
      for (int j = 0; j < 3; ++j) c.p[j] *= e.probability(j, lane);
      const int32_t child = node.child[lane];
      if (child < 0) {
        out[n++] = {uint32_t(-(child + 1)), mix(c.p, floor, r.specularShare), counts[lane]};
      } else {
        c.w = size_t(child);
        stack.push_back({c, counts[lane]});
      }
    }
  }
  finish(r, rng, floor, alone.data(), int(alone.size()), out + n);
  return n + int(alone.size());
}

double LightTree::mix(const double p[3], float floor, float share) {
  // Equal parts give that value exactly (a tree of one light: 1).
  if (p[0] == p[1] && p[1] == p[2]) return p[0];
  const double f = floor, s = share;
  return f * p[2] + (1 - f) * (s * p[1] + (1 - s) * p[0]);
}

double LightTree::pdf(const LightTreeReceiver& r, uint32_t light, float floor) const {
  VSL_CHECK(light < leafOf_.size());
  int32_t path[128];  // entries, 4 x wide node + lane, from the light up
  int depth = 0;
  for (int32_t e = leafOf_[light]; e >= 0; e = parent_[size_t(e >> 2)]) {
    VSL_CHECK(depth < 128);
    path[depth++] = e;
  }
  double p[3] = {1, 1, 1};
  for (int k = depth - 1; k >= 0; --k) {
    const EntryWeights e = entryWeights(wide_[size_t(path[k] >> 2)], r);
    for (int j = 0; j < 3; ++j) p[j] *= e.probability(j, path[k] & 3);
  }
  return mix(p, floor, r.specularShare);
}

}  // namespace vsl
