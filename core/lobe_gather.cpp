#include "core/lobe_gather.h"

#include <nanoflann.hpp>

#include <algorithm>
#include <limits>
#include <utility>

namespace vsl {

namespace {
// The lights' positions alone, packed (x, y, z per light): the search reads
// a point's coordinates at every step, and from the decoded lights (a few
// hundred bytes apart) almost every read missed the cache (55% of a
// lobe-gathered render's time was the search).
struct Cloud {
  std::vector<float> xyz;
  size_t kdtree_get_point_count() const { return xyz.size() / 3; }
  float kdtree_get_pt(size_t i, size_t dim) const { return xyz[3 * i + dim]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};
using Kd = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>, Cloud, 3>;
}  // namespace

struct LobeGatherMap::Tree {
  Cloud cloud;
  Kd kd;
  explicit Tree(const std::vector<GatherLight>& l)
      : cloud{packed(l)}, kd(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {}
  static std::vector<float> packed(const std::vector<GatherLight>& l) {
    std::vector<float> xyz;
    xyz.reserve(3 * l.size());
    for (const GatherLight& L : l) xyz.insert(xyz.end(), {L.p.x, L.p.y, L.p.z});
    return xyz;
  }
};

namespace {
// Spreads the low 10 bits of v to every third bit (a Morton code's axis).
uint32_t spreadBits(uint32_t v) {
  v &= 0x3ffu;
  v = (v | (v << 16)) & 0x030000ffu;
  v = (v | (v << 8)) & 0x0300f00fu;
  v = (v | (v << 4)) & 0x030c30c3u;
  v = (v | (v << 2)) & 0x09249249u;
  return v;
}
}  // namespace

LobeGatherMap::LobeGatherMap(const VirtualLightSet& set, int k) : k_(std::max(k, 1)) {
  // The lights in Morton order of their positions, so that the neighbours
  // one estimate reads lie close together in memory. The estimate does not
  // depend on the order (the search returns the same lights by distance).
  const size_t n = set.lights.size();
  Vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (const VirtualLight& v : set.lights) {
    lo = min(lo, v.p);
    hi = max(hi, v.p);
  }
  std::vector<std::pair<uint32_t, uint32_t>> order(n);
  for (size_t i = 0; i < n; ++i) {
    uint32_t code = 0;
    for (int a = 0; a < 3; ++a) {
      const float extent = hi[a] - lo[a];
      const float t = extent > 0 ? (set.lights[i].p[a] - lo[a]) / extent : 0.0f;
      code |= spreadBits(uint32_t(std::clamp(t, 0.0f, 1.0f) * 1023.0f)) << a;
    }
    order[i] = {code, uint32_t(i)};
  }
  std::sort(order.begin(), order.end());
  lights_.reserve(n);
  for (const auto& [code, i] : order) lights_.push_back(decodeGatherLight(set.lights[i], 0.0f));
  tree_ = std::make_unique<Tree>(lights_);
}
LobeGatherMap::~LobeGatherMap() = default;

Vec3 LobeGatherMap::radiance(const Vec3& z, const Vec3& nz, const Vec3& wOut, bool diffuseOnly) const {
  if (lights_.empty()) return Vec3(0.0f);
  const size_t want = std::min<size_t>(size_t(k_), lights_.size());
  // Small k lives on the stack; the default (kLobeGatherK) fits.
  constexpr size_t kStack = 512;
  uint32_t idxStack[kStack];
  float d2Stack[kStack];
  std::vector<uint32_t> idxHeap;
  std::vector<float> d2Heap;
  uint32_t* idx = idxStack;
  float* d2 = d2Stack;
  if (want > kStack) {
    idxHeap.resize(want);
    d2Heap.resize(want);
    idx = idxHeap.data();
    d2 = d2Heap.data();
  }
  float q[3] = {z.x, z.y, z.z};
  size_t found = tree_->kd.knnSearch(q, want, idx, d2);
  if (found == 0) return Vec3(0.0f);
  const float r2 = d2[found - 1];
  if (!(r2 > 0)) return Vec3(0.0f);
  // The k-th light only sets the radius: (k - 1) / (pi r_k^2) is the
  // unbiased density of independent points (k / (pi r_k^2) is k / (k - 1)
  // too high: 3% at k = 32).
  Vec3 sum(0.0f);
  for (size_t i = 0; i + 1 < found; ++i) {
    const GatherLight& L = lights_[idx[i]];
    if (dot(L.ng, nz) < 0.5f || dot(L.n, wOut) <= 0 || dot(L.ng, wOut) <= 0) continue;
    const BrdfAt::Parts f = L.em.f.evalParts(L.em.frame.toLocal(wOut));
    sum += L.Phi * (diffuseOnly ? f.diffuse : f.total());
  }
  return sum / float(kPi * r2);
}

}  // namespace vsl
