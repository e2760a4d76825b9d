// The light tree of stochastic lightcuts (light_tree.h).
// Sections: [1] bounds at a receiver  [2] build  [3] sampling and pdf
#include "core/estimators/slc/light_tree.h"

#include <algorithm>
#include <bit>

#include "core/check.h"
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

// Squared distance from x to the box's closest point (0 inside).
float closestDistance2(const LightTreeNode& nd, const Vec3& x) {
  const Vec3 d = max(max(nd.lo - x, x - nd.hi), Vec3(0.0f));
  return lengthSquared(d);
}

}  // namespace

LightTreeReceiver LightTreeReceiver::make(const GatherPoint& gp) {
  LightTreeReceiver r;
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
  return r;
}

// The anisotropic GGX D (Heitz 2014, eq. 85) at a half vector at angle
// theta_h from n is at most 1 / (pi ax ay cos^4 (1 + tan^2 / a_max^2)^2),
// since tan^2 (cos^2 phi / ax^2 + sin^2 phi / ay^2) >= tan^2 / a_max^2; it
// falls with theta_h. A half vector is at least half as far from n as wi
// is from the mirror direction: reflections about two axes theta apart
// differ by a rotation of 2 theta, so |angle(wi, mirror)| <= 2 angle(h, n).
float LightTreeReceiver::brdfCosBound(float thetaRCos, float cosX) const {
  if (!(cosX > 0)) return 0;
  float b = diffuse * cosX;
  if (specularOn) {
    const float c2 = std::max(0.0f, 0.5f * (1 + thetaRCos)), s2 = std::max(0.0f, 1 - c2);  // cos^2, sin^2 theta_h
    const float am = std::max(ax, ay), am2 = am * am;
    const float den = am2 * c2 + s2;
    b += specular * am2 * am2 / (kPi * ax * ay * den * den);
  }
  return b;
}

float LightTree::orientedFlux(const LightTreeNode& nd, const LightTreeReceiver& r) const {
  if (!(nd.flux > 0)) return 0;
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
    box = fromCos(safeSqrt(1 - sqr(R / dist)));
    const float rs = std::min(1.0f, (R + nd.radius) / dist);
    sphere = fromCos(safeSqrt(1 - rs * rs));
  }
  // Receiver cosine: the largest over the box's directions.
  const float cosX = narrowed(fromCos(dot(r.n, dir)), box).c;
  if (!(cosX > 0)) return 0;
  // Emission cosine: the largest over the cone's normals and the box's
  // directions (Conty Estevez and Kulla 2018, eq. 5's theta').
  const CosSin cone = fromCos(nd.cosTheta);
  const float cosP = narrowed(narrowed(fromCos(-dot(nd.axis, dir)), cone), box).c;
  if (!(cosP > 0)) return 0;
  // The receiver's lobe: the closest direction to its peak within the cone
  // to the lights' spheres.
  const float cosR = narrowed(fromCos(dot(r.mirror, dir)), sphere).c;
  const float f = r.brdfCosBound(cosR, cosX);
  return nd.flux * cosP * f;
}

double LightTree::fluxProbability(const LightTreeNode& nd) const {
  const double f0 = nodes_[size_t(nd.child)].flux, f1 = nodes_[size_t(nd.child) + 1].flux;
  return f0 + f1 > 0 ? f0 / (f0 + f1) : 0.5;
}

double LightTree::childProbability(const LightTreeNode& nd, const LightTreeReceiver& r) const {
  const LightTreeNode& c0 = nodes_[size_t(nd.child)];
  const LightTreeNode& c1 = nodes_[size_t(nd.child) + 1];
  double w0 = orientedFlux(c0, r), w1 = orientedFlux(c1, r);
  // Distance (Yuksel 2019, section 4.2): the box's closest point, not used
  // while the receiver is within either box's size (it would favour the
  // box it is in whatever its lights); at least the VSL radius (a sphere's
  // light is finite inside it).
  const float d0 = closestDistance2(c0, r.p), d1 = closestDistance2(c1, r.p);
  if (!(d0 < lengthSquared(c0.hi - c0.lo) || d1 < lengthSquared(c1.hi - c1.lo))) {
    w0 /= std::max({double(d0), double(c0.radius) * c0.radius, 1e-30});
    w1 /= std::max({double(d1), double(c1.radius) * c1.radius, 1e-30});
  }
  const double s = w0 + w1;
  // Neither child can face the receiver (or a bound overflowed): by flux.
  if (!(s > 0) || !std::isfinite(s)) return fluxProbability(nd);
  return w0 / s;
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
  std::vector<Prim> prims(lights.size());
  for (size_t i = 0; i < lights.size(); ++i)
    prims[i] = {lights[i].p, lights[i].n, std::max(0.0f, luminance(lights[i].Phi)), lights[i].radius};
  return fromPrims(std::move(prims));
}

LightTree LightTree::build(const VirtualLightSet& set, const std::vector<float>& radii) {
  VSL_CHECK_EQ(set.lights.size(), radii.size());
  std::vector<Prim> prims(set.lights.size());
  for (size_t i = 0; i < prims.size(); ++i) {
    const VirtualLight& v = set.lights[i];
    // The emission cosine's normal (decodeGatherLight: the geometric one
    // for a normal-mapped light).
    const Vec3 n = decodeUnit(v.normalMapped ? v.ng : v.n);
    prims[i] = {v.p, n, std::max(0.0f, luminance(v.Phi)), radii[i]};
  }
  return fromPrims(std::move(prims));
}

LightTree LightTree::fromPrims(std::vector<Prim> prims) {
  Stopwatch clock;
  LightTree t;
  const size_t n = prims.size();
  if (n == 0) return t;
  VSL_CHECK(n < size_t(1) << 30);
  Vec3 lo(kInf), hi(-kInf);
  for (const Prim& p : prims) {
    lo = min(lo, p.p);
    hi = max(hi, p.p);
  }
  const Vec3 ext = max(hi - lo, Vec3(1e-20f));
  std::vector<uint64_t> keys(n);
  for (size_t i = 0; i < n; ++i) {
    const Vec3 u = (prims[i].p - lo) / ext;
    auto q = [](float v) { return uint32_t(clamp(v * 1024.0f, 0.0f, 1023.0f)); };
    const uint32_t code = (spread10(q(u.x)) << 2) | (spread10(q(u.y)) << 1) | spread10(q(u.z));
    keys[i] = (uint64_t(code) << 32) | uint64_t(i);
  }
  std::sort(keys.begin(), keys.end());
  t.nodes_.resize(2 * n - 1);
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
      nd.radius = p.radius;
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
    mergeCones(a.axis, a.cosTheta, b.axis, b.cosTheta, nd.axis, nd.cosTheta);
  }
  t.buildSeconds_ = clock.seconds();
  return t;
}

// ---- [3] Sampling and pdf ------------------------------------------------------------

LightTree::Sample LightTree::sample(const LightTreeReceiver& r, Rng& rng, float floor) const {
  const bool byFlux = rng.uniform() < floor;
  double pImp = 1, pFlux = 1;
  int32_t i = 0;
  while (!nodes_[size_t(i)].leaf()) {
    const LightTreeNode& nd = nodes_[size_t(i)];
    const double pi0 = childProbability(nd, r), pf0 = fluxProbability(nd);
    const bool first = rng.uniform() < (byFlux ? pf0 : pi0);
    pImp *= first ? pi0 : 1 - pi0;
    pFlux *= first ? pf0 : 1 - pf0;
    i = nd.child + (first ? 0 : 1);
  }
  return {nodes_[size_t(i)].light(), mix(pImp, pFlux, floor)};
}

double LightTree::mix(double pImp, double pFlux, float floor) {
  // Equal parts give that value exactly (a tree of one light: 1).
  return pImp == pFlux ? pImp : double(floor) * pFlux + (1 - double(floor)) * pImp;
}

double LightTree::pdf(const LightTreeReceiver& r, uint32_t light, float floor) const {
  VSL_CHECK(light < leafOf_.size());
  int32_t path[128];
  int depth = 0;
  for (int32_t i = leafOf_[light]; i >= 0; i = parent_[size_t(i)]) {
    VSL_CHECK(depth < 128);
    path[depth++] = i;
  }
  double pImp = 1, pFlux = 1;
  for (int k = depth - 1; k > 0; --k) {
    const LightTreeNode& nd = nodes_[size_t(path[k])];
    const bool first = path[k - 1] == nd.child;
    const double pi0 = childProbability(nd, r), pf0 = fluxProbability(nd);
    pImp *= first ? pi0 : 1 - pi0;
    pFlux *= first ? pf0 : 1 - pf0;
  }
  return mix(pImp, pFlux, floor);
}

}  // namespace vsl
