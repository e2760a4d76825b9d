#include "core/point_tree.h"

#include <nanoflann.hpp>

#include <algorithm>
#include <limits>
#include <utility>

namespace vsl {

namespace {
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

struct PointTree::Impl {
  Cloud cloud;
  Kd kd;
  explicit Impl(std::vector<float> xyz)
      : cloud{std::move(xyz)}, kd(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {}
};

PointTree::PointTree(std::vector<float> xyz)
    : impl_(std::make_unique<Impl>(std::move(xyz))), xyz_(impl_->cloud.xyz.data()) {}
PointTree::~PointTree() = default;

size_t PointTree::nearest(const Vec3& q, size_t k, uint32_t* idx, float* d2) const {
  if (k == 0 || size() == 0) return 0;
  const float at[3] = {q.x, q.y, q.z};
  return impl_->kd.knnSearch(at, k, idx, d2);
}

size_t PointTree::nearestWithin(const Vec3& q, size_t k, float maxD2, uint32_t* idx, float* d2) const {
  if (k == 0 || size() == 0) return 0;
  const float at[3] = {q.x, q.y, q.z};
  nanoflann::KNNResultSet<float, uint32_t, size_t> result(k);
  result.init(idx, d2);
  // The result's worst distance bounds the search; it holds the bound until
  // k points closer than it are found (KNNResultSet keeps its last slot then).
  if (maxD2 > 0) d2[k - 1] = maxD2;
  impl_->kd.findNeighbors(result, at, nanoflann::SearchParams());
  // A bound that held fewer than k points (the caller's promise broken):
  // the unbounded search, so that the answer is what nearest() gives.
  if (result.size() < std::min(k, size())) return nearest(q, k, idx, d2);
  return result.size();
}

size_t PointTree::size() const { return impl_->cloud.kdtree_get_point_count(); }

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

MortonBox::MortonBox(const std::vector<float>& xyz) {
  const size_t n = xyz.size() / 3;
  float hi[3];
  for (int a = 0; a < 3; ++a) {
    lo_[a] = std::numeric_limits<float>::max();
    hi[a] = -std::numeric_limits<float>::max();
  }
  for (size_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      lo_[a] = std::min(lo_[a], xyz[3 * i + a]);
      hi[a] = std::max(hi[a], xyz[3 * i + a]);
    }
  for (int a = 0; a < 3; ++a) extent_[a] = hi[a] - lo_[a];
}

uint32_t MortonBox::code(const float* p) const {
  uint32_t code = 0;
  for (int a = 0; a < 3; ++a) {
    const float t = extent_[a] > 0 ? (p[a] - lo_[a]) / extent_[a] : 0.0f;
    const float c = t >= 0 ? std::min(t, 1.0f) : 0.0f;  // NaN -> 0
    code |= spreadBits(uint32_t(c * 1023.0f)) << a;
  }
  return code;
}

std::vector<uint32_t> mortonOrder(const std::vector<float>& xyz) {
  const size_t n = xyz.size() / 3;
  const MortonBox box(xyz);
  std::vector<std::pair<uint32_t, uint32_t>> keyed(n);
  for (size_t i = 0; i < n; ++i) keyed[i] = {box.code(&xyz[3 * i]), uint32_t(i)};
  std::sort(keyed.begin(), keyed.end());
  std::vector<uint32_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = keyed[i].second;
  return order;
}

}  // namespace vsl
