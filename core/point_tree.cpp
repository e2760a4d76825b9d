#include "core/point_tree.h"

#include <nanoflann.hpp>

#include "core/check.h"
#include "core/memory_budget.h"
#include "core/parallel.h"

#include <algorithm>
#include <bit>
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

namespace {

// kthNearestSquared's tree over points in Morton order: a node holds the
// points at positions [b, e) and its children are child and child + 1,
// split where the highest differing bit of its points' Morton codes changes
// (the halves lie on either side of a plane). Where the codes are equal (a
// cell of the 10-bit grid: points in index order, spread over the cell), at
// the median of the box's widest axis, the points reordered within the
// range (so again on either side of a plane: an index-order split there
// left both halves the whole cell, and a dense cell, behind one far light
// that made the grid coarse, cost its size per query). Ranges of at most
// kLeafPoints are leaves. The tree keeps its own copy of the points; perm
// maps its positions to m's.
constexpr uint32_t kLeafPoints = 32;

struct RangeNode {
  float lo[3], hi[3];
  uint32_t b = 0, e = 0, child = 0;
};

class RangeTree {
 public:
  explicit RangeTree(const MortonSorted& m) : codes_(m.codes) {
    const size_t n = m.codes.size();
    xyz_ = hugePageVector<float>(3 * n);
    std::copy(m.xyz.begin(), m.xyz.end(), xyz_.begin());
    perm_.resize(n);
    for (size_t i = 0; i < n; ++i) perm_[i] = uint32_t(i);
    nodes_.reserve(2 * (n / kLeafPoints + 1));
    nodes_.emplace_back();
    build(0, 0, uint32_t(n));
  }
  static bool leaf(const RangeNode& nd) { return nd.e - nd.b <= kLeafPoints; }
  const RangeNode& node(size_t i) const { return nodes_[i]; }
  const float* point(size_t i) const { return xyz_.data() + 3 * i; }
  uint32_t original(size_t i) const { return perm_[i]; }
  // Squared distance from q to node i's box (0 inside), never above a
  // point's in it: float subtraction and squares are monotone.
  float boxDistance2(const float* q, size_t i) const {
    const RangeNode& nd = nodes_[i];
    float d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const float d = q[a] < nd.lo[a] ? nd.lo[a] - q[a] : q[a] > nd.hi[a] ? q[a] - nd.hi[a] : 0.0f;
      d2 += d * d;
    }
    return d2;
  }

 private:
  void boxOf(uint32_t b, uint32_t e, RangeNode& nd) const {
    for (int a = 0; a < 3; ++a) nd.lo[a] = nd.hi[a] = point(b)[a];
    for (uint32_t j = b + 1; j < e; ++j)
      for (int a = 0; a < 3; ++a) {
        nd.lo[a] = std::min(nd.lo[a], point(j)[a]);
        nd.hi[a] = std::max(nd.hi[a], point(j)[a]);
      }
  }
  // A coordinate as an order (NaN last: nth_element needs a strict weak order).
  static float key(float v) { return std::isnan(v) ? std::numeric_limits<float>::infinity() : v; }
  // Equal codes: the points of [b, e) reordered about the median of the
  // box's widest axis; returns the middle.
  uint32_t medianSplit(uint32_t b, uint32_t e) {
    RangeNode box;
    boxOf(b, e, box);
    int axis = 0;
    for (int a = 1; a < 3; ++a)
      if (box.hi[a] - box.lo[a] > box.hi[axis] - box.lo[axis]) axis = a;
    std::vector<uint32_t> at(e - b);
    for (uint32_t j = b; j < e; ++j) at[j - b] = j;
    const uint32_t m = (e - b) / 2;
    std::nth_element(at.begin(), at.begin() + m, at.end(),
                     [&](uint32_t x, uint32_t y) { return key(point(x)[axis]) < key(point(y)[axis]); });
    std::vector<float> xyz(3 * at.size());
    std::vector<uint32_t> perm(at.size());
    for (size_t k = 0; k < at.size(); ++k) {
      std::copy(point(at[k]), point(at[k]) + 3, &xyz[3 * k]);
      perm[k] = perm_[at[k]];
    }
    std::copy(xyz.begin(), xyz.end(), xyz_.begin() + 3 * size_t(b));
    std::copy(perm.begin(), perm.end(), perm_.begin() + b);
    return b + m;
  }
  uint32_t split(uint32_t b, uint32_t e) {
    const uint32_t cb = codes_[b], ce = codes_[e - 1];
    if (cb == ce) return medianSplit(b, e);
    const int bit = 31 - std::countl_zero(cb ^ ce);
    return uint32_t(
        std::partition_point(codes_.begin() + b, codes_.begin() + e, [&](uint32_t c) { return (c >> bit & 1u) == 0; }) -
        codes_.begin());
  }
  void build(size_t i, uint32_t b, uint32_t e) {
    nodes_[i].b = b;
    nodes_[i].e = e;
    if (e - b <= kLeafPoints) {
      boxOf(b, e, nodes_[i]);
      return;
    }
    const uint32_t m = split(b, e), c = uint32_t(nodes_.size());
    nodes_[i].child = c;
    nodes_.emplace_back();
    nodes_.emplace_back();
    build(c, b, m);
    build(c + 1, m, e);
    RangeNode& nd = nodes_[i];
    const RangeNode &l = nodes_[c], &r = nodes_[c + 1];
    for (int a = 0; a < 3; ++a) {
      nd.lo[a] = std::min(l.lo[a], r.lo[a]);
      nd.hi[a] = std::max(l.hi[a], r.hi[a]);
    }
  }

  std::vector<float> xyz_;
  const std::vector<uint32_t>& codes_;  // equal within a range reordered
  std::vector<uint32_t> perm_;
  std::vector<RangeNode> nodes_;
};

float distance2(const float* a, const float* b) {
  const float dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return dx * dx + dy * dy + dz * dz;
}

// The want smallest squared distances offered, ascending in best[0, count);
// once there are want, bound is the largest of them.
struct Smallest {
  float* best;
  size_t want, count = 0;
  float bound = std::numeric_limits<float>::infinity();
  void offer(float d2) {
    if (!(d2 < bound)) return;  // NaN too: a point without a position is no neighbour
    size_t i = count < want ? count++ : want - 1;
    for (; i > 0 && best[i - 1] > d2; --i) best[i] = best[i - 1];
    best[i] = d2;
    if (count == want) bound = best[want - 1];
  }
  uint64_t offered = 0;
  void offerRange(const RangeTree& t, const float* q, uint32_t b, uint32_t e) {
    for (uint32_t j = b; j < e; ++j) offer(distance2(q, t.point(j)));
    offered += e - b;
  }
};

// Point o's want-th squared distance: first every point of its smallest
// enclosing range of at least 2 x want points (a tight bound), then each
// sibling range up to the root whose box comes within the bound, nearer
// halves first.
float kthFrom(const RangeTree& t, uint32_t o, size_t want, float* best, std::vector<uint32_t>& stack,
              uint64_t& distances) {
  uint32_t path[64];
  int depth = 0;
  for (uint32_t i = 0;; ++depth) {
    path[depth] = i;
    const RangeNode& nd = t.node(i);
    if (RangeTree::leaf(nd) || depth == 63) break;
    i = o < t.node(nd.child).e ? nd.child : nd.child + 1;
  }
  int top = depth;
  while (top > 0 && t.node(path[top]).e - t.node(path[top]).b < 2 * want) --top;
  const float* q = t.point(o);
  Smallest s{best, want};
  s.offerRange(t, q, t.node(path[top]).b, t.node(path[top]).e);
  for (int level = top; level > 0; --level) {
    const uint32_t parentChild = t.node(path[level - 1]).child;
    stack.assign(1, path[level] == parentChild ? parentChild + 1 : parentChild);
    while (!stack.empty()) {
      const uint32_t i = stack.back();
      stack.pop_back();
      if (t.boxDistance2(q, i) >= s.bound) continue;
      const RangeNode& nd = t.node(i);
      if (RangeTree::leaf(nd)) {
        s.offerRange(t, q, nd.b, nd.e);
        continue;
      }
      const bool firstNearer = t.boxDistance2(q, nd.child) <= t.boxDistance2(q, nd.child + 1);
      stack.push_back(firstNearer ? nd.child + 1 : nd.child);
      stack.push_back(firstNearer ? nd.child : nd.child + 1);
    }
  }
  distances += s.offered;
  return s.count > 0 ? best[std::min(want, s.count) - 1] : std::numeric_limits<float>::infinity();
}

}  // namespace

std::vector<float> kthNearestSquared(const MortonSorted& m, size_t want, const std::atomic<bool>* stop,
                                     uint64_t* distances) {
  const size_t n = m.codes.size();
  std::vector<float> out = hugePageVector<float>(n);
  want = std::min(want, n);
  if (want == 0) return out;
  VSL_CHECK(n < (size_t(1) << 31));
  const RangeTree tree(m);
  std::atomic<uint64_t> offered{0};
  parallelForChunks(n, 1024, [&](size_t o0, size_t o1) {
    if (stop && stop->load(std::memory_order_relaxed)) return;
    std::vector<float> best(want);
    std::vector<uint32_t> stack;
    uint64_t mine = 0;
    for (size_t o = o0; o < o1; ++o) out[tree.original(o)] = kthFrom(tree, uint32_t(o), want, best.data(), stack, mine);
    offered.fetch_add(mine, std::memory_order_relaxed);
  });
  if (distances) *distances = offered.load();
  return out;
}

void sortMortonKeys(std::vector<uint64_t>& keys) {
  constexpr int kBits = 10;
  constexpr size_t kBuckets = size_t(1) << kBits;
  std::vector<uint64_t> other = hugePageVector<uint64_t>(keys.size());
  std::vector<size_t> start(kBuckets);
  for (int pass = 0; pass < 3; ++pass) {
    const int shift = 32 + kBits * pass;
    std::fill(start.begin(), start.end(), 0);
    for (uint64_t k : keys) ++start[(k >> shift) & (kBuckets - 1)];
    size_t sum = 0;
    for (size_t& s : start) sum += std::exchange(s, sum);
    for (uint64_t k : keys) other[start[(k >> shift) & (kBuckets - 1)]++] = k;
    keys.swap(other);
  }
}

namespace {
// (code << 32) | index for every point, sorted (sortMortonKeys).
std::vector<uint64_t> sortedMortonKeys(const std::vector<float>& xyz) {
  const size_t n = xyz.size() / 3;
  const MortonBox box(xyz);
  std::vector<uint64_t> keys = hugePageVector<uint64_t>(n);
  parallelForChunks(n, 1 << 16, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) keys[i] = uint64_t(box.code(&xyz[3 * i])) << 32 | uint64_t(i);
  });
  sortMortonKeys(keys);
  return keys;
}
}  // namespace

MortonSorted mortonSorted(const std::vector<float>& xyz) {
  const size_t n = xyz.size() / 3;
  const std::vector<uint64_t> keys = sortedMortonKeys(xyz);
  MortonSorted m;
  m.xyz = hugePageVector<float>(3 * n);
  m.codes = hugePageVector<uint32_t>(n);
  m.order = hugePageVector<uint32_t>(n);
  parallelForChunks(n, 1 << 16, [&](size_t b, size_t e) {
    for (size_t o = b; o < e; ++o) {
      const uint32_t i = uint32_t(keys[o]);
      m.order[o] = i;
      m.codes[o] = uint32_t(keys[o] >> 32);
      for (int a = 0; a < 3; ++a) m.xyz[3 * o + a] = xyz[3 * size_t(i) + a];
    }
  });
  return m;
}

std::vector<uint32_t> mortonOrder(const std::vector<float>& xyz) {
  const std::vector<uint64_t> keys = sortedMortonKeys(xyz);
  std::vector<uint32_t> order(keys.size());
  for (size_t o = 0; o < keys.size(); ++o) order[o] = uint32_t(keys[o]);
  return order;
}

}  // namespace vsl
