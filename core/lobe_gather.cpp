#include "core/lobe_gather.h"

#include <nanoflann.hpp>

#include <algorithm>

namespace vsl {

namespace {
struct Cloud {
  const std::vector<GatherLight>& lights;
  size_t kdtree_get_point_count() const { return lights.size(); }
  float kdtree_get_pt(size_t i, size_t dim) const { return lights[i].p[int(dim)]; }
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
      : cloud{l}, kd(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {}
};

LobeGatherMap::LobeGatherMap(const VirtualLightSet& set, int k) : k_(std::max(k, 1)) {
  lights_.reserve(set.lights.size());
  for (const VirtualLight& v : set.lights) lights_.push_back(decodeGatherLight(v, 0.0f));
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
