// The light tree of stochastic lightcuts (light_tree.h).
// Sections: [1] bounds at a receiver  [2] build  [3] sampling and pdf
#include "core/estimators/slc/light_tree.h"

#include <algorithm>
#include <bit>
#include <limits>

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

void LightTree::importance(const LightTreeNode& nd, const LightTreeReceiver& r, float out[2], bool withDistance) const {
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

float PairImportance::operator()(uint32_t i) const {
  const GatherLight L = decodeGatherLight(set_.lights[i], radii_[i]);
  PairGeometry pg;
  pg.d = L.p - gp_.p;
  pg.d2 = lengthSquared(pg.d);
  pg.dist = std::sqrt(pg.d2);
  if (!(pg.dist > 0)) return 0;
  pg.l = pg.d / pg.dist;
  pg.cosX = dot(gp_.rx.frame.n, pg.l);
  pg.cosP = -dot(L.n, pg.l);
  if (!(pg.cosX > 0 && dot(gp_.rx.ng, pg.l) > 0 && pg.cosP > 0 && -dot(L.ng, pg.l) > 0)) return 0;
  const float e = g_.pairEstimate(gp_, L, pg);
  return std::isfinite(e) ? std::max(e, 0.0f) : std::numeric_limits<float>::max();
}

double LightTree::fluxProbability(const LightTreeNode& nd) const {
  const double f0 = nodes_[size_t(nd.child)].flux, f1 = nodes_[size_t(nd.child) + 1].flux;
  return f0 + f1 > 0 ? f0 / (f0 + f1) : 0.5;
}

void LightTree::childProbabilities(const LightTreeNode& nd, const LightTreeReceiver& r, const LeafImportance* leaf,
                                   double p0[2]) const {
  const LightTreeNode& c0 = nodes_[size_t(nd.child)];
  const LightTreeNode& c1 = nodes_[size_t(nd.child) + 1];
  if (leaf && c0.leaf() && c1.leaf()) {
    const double e0 = (*leaf)(c0.light()), e1 = (*leaf)(c1.light());
    if (e0 + e1 > 0 && std::isfinite(e0 + e1)) {
      p0[0] = p0[1] = e0 / (e0 + e1);
      return;
    }
  }
  float w0[2], w1[2];
  importance(c0, r, w0);
  importance(c1, r, w1);
  for (int k = 0; k < 2; ++k) {
    double a = w0[k], b = w1[k];
    if (!std::isfinite(a) || !std::isfinite(b)) {
      float u0[2], u1[2];
      importance(c0, r, u0, false);
      importance(c1, r, u1, false);
      a = u0[k];
      b = u1[k];
    }
    // Neither child can face the receiver (or a bound overflowed): by flux.
    p0[k] = a + b > 0 && std::isfinite(a + b) ? a / (a + b) : fluxProbability(nd);
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

LightTree LightTree::fromPrims(std::vector<Prim> prims) {
  Stopwatch clock;
  LightTree t;
  const size_t n = prims.size();
  if (n == 0) return t;
  VSL_CHECK(n < size_t(1) << 30);
  const std::vector<uint64_t> keys = sortedKeys(prims);
  reserveHugePages(t.nodes_, 2 * n - 1);
  t.nodes_.resize(2 * n - 1);
  reserveHugePages(t.parent_, 2 * n - 1);
  t.parent_.assign(2 * n - 1, -1);
  t.leafOf_.assign(n, -1);
  int32_t next = 1;
  // An explicit stack: ranges to split, each with its node.
  struct Range {
    uint32_t b, e;
    int32_t node;
  };
  std::vector<Range> stack{{0, uint32_t(n), 0}};
  std::vector<int32_t> inner;  // in creation order: parents before children
  while (!stack.empty()) {
    const Range r = stack.back();
    stack.pop_back();
    LightTreeNode& nd = t.nodes_[size_t(r.node)];
    if (r.e - r.b == 1) {
      const uint32_t li = uint32_t(keys[r.b]);
      const Prim& p = prims[li];
      nd.lo = nd.hi = p.p;
      nd.axis = p.n;
      nd.cosTheta = 1;
      nd.flux = p.flux;
      nd.radius = nd.radiusMin = p.radius;
      nd.child = -int32_t(li) - 1;
      t.leafOf_[li] = r.node;
      continue;
    }
    // Split where the highest differing bit of the range's codes changes
    // (the codes share every bit above it), or in the middle.
    const uint32_t kb = uint32_t(keys[r.b] >> 32), ke = uint32_t(keys[r.e - 1] >> 32);
    uint32_t m = r.b + (r.e - r.b) / 2;
    if (kb != ke) {
      const int bit = 31 - std::countl_zero(kb ^ ke);
      auto it = std::partition_point(keys.begin() + r.b, keys.begin() + r.e,
                                     [&](uint64_t k) { return ((k >> 32) >> bit & 1) == 0; });
      m = uint32_t(it - keys.begin());
    }
    nd.child = next;
    next += 2;
    t.parent_[size_t(nd.child)] = t.parent_[size_t(nd.child) + 1] = r.node;
    inner.push_back(r.node);
    stack.push_back({r.b, m, nd.child});
    stack.push_back({m, r.e, nd.child + 1});
  }
  VSL_CHECK_EQ(size_t(next), 2 * n - 1);
  // Bounds bottom-up: children were made after their parents.
  for (auto it = inner.rbegin(); it != inner.rend(); ++it) {
    LightTreeNode& nd = t.nodes_[size_t(*it)];
    const LightTreeNode &a = t.nodes_[size_t(nd.child)], &b = t.nodes_[size_t(nd.child) + 1];
    nd.lo = min(a.lo, b.lo);
    nd.hi = max(a.hi, b.hi);
    nd.flux = a.flux + b.flux;
    nd.radius = std::max(a.radius, b.radius);
    nd.radiusMin = std::min(a.radiusMin, b.radiusMin);
    mergeCones(a.axis, a.cosTheta, b.axis, b.cosTheta, nd.axis, nd.cosTheta);
  }
  t.buildSeconds_ = clock.seconds();
  return t;
}

// ---- [3] Sampling and pdf ------------------------------------------------------------

LightTree::Sample LightTree::sample(const LightTreeReceiver& r, Rng& rng, float floor,
                                    const LeafImportance* leaf) const {
  // The descent: diffuse lobe's (0), specular lobe's (1), or by flux (2).
  const float u = rng.uniform();
  const int strategy = u < floor ? 2 : (u < floor + (1 - floor) * r.specularShare ? 1 : 0);
  double p[3] = {1, 1, 1};
  int32_t i = 0;
  while (!nodes_[size_t(i)].leaf()) {
    const LightTreeNode& nd = nodes_[size_t(i)];
    double q[3];
    childProbabilities(nd, r, leaf, q);
    q[2] = fluxProbability(nd);
    const bool first = rng.uniform() < q[strategy];
    for (int k = 0; k < 3; ++k) p[k] *= first ? q[k] : 1 - q[k];
    i = nd.child + (first ? 0 : 1);
  }
  return {nodes_[size_t(i)].light(), mix(p, floor, r.specularShare)};
}

double LightTree::mix(const double p[3], float floor, float share) {
  // Equal parts give that value exactly (a tree of one light: 1).
  if (p[0] == p[1] && p[1] == p[2]) return p[0];
  const double f = floor, s = share;
  return f * p[2] + (1 - f) * (s * p[1] + (1 - s) * p[0]);
}

double LightTree::pdf(const LightTreeReceiver& r, uint32_t light, float floor, const LeafImportance* leaf) const {
  VSL_CHECK(light < leafOf_.size());
  int32_t path[128];
  int depth = 0;
  for (int32_t i = leafOf_[light]; i >= 0; i = parent_[size_t(i)]) {
    VSL_CHECK(depth < 128);
    path[depth++] = i;
  }
  double p[3] = {1, 1, 1};
  for (int k = depth - 1; k > 0; --k) {
    const LightTreeNode& nd = nodes_[size_t(path[k])];
    const bool first = path[k - 1] == nd.child;
    double q[3];
    childProbabilities(nd, r, leaf, q);
    q[2] = fluxProbability(nd);
    for (int j = 0; j < 3; ++j) p[j] *= first ? q[j] : 1 - q[j];
  }
  return mix(p, floor, r.specularShare);
}

}  // namespace vsl
