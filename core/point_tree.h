// A k-d tree over points stored packed (x, y, z floats, one point after the
// other), for nearest-neighbour queries: the k-NN radii of a light set
// (knnRadii) and the lobe gather's density estimates (LobeGatherMap).
//
// Packed, because a search reads a candidate's coordinates at every step: read
// from the lights themselves (structs of 56 to a few hundred bytes) nearly
// every read missed the cache (55% of a lobe-gathered tableau render was the
// search; docs/notebook/2026-12-02-gather-simd-and-pair-cost.md, 2026-12-04).
// Immutable after construction;
// safe to query from many threads.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/math.h"
#include "core/memory_budget.h"

namespace vsl {

class PointTree {
 public:
  // xyz: 3 floats per point. The tree keeps it (query results index it).
  explicit PointTree(std::vector<float> xyz);
  ~PointTree();
  PointTree(const PointTree&) = delete;
  PointTree& operator=(const PointTree&) = delete;

  // The min(k, size()) points nearest to q, closest first: their indices in
  // idx and squared distances in d2 (each with room for k). Returns how many.
  size_t nearest(const Vec3& q, size_t k, uint32_t* idx, float* d2) const;
  // The same where the caller knows that the k nearest lie within a squared
  // distance below maxD2 (k points closer than it, for one): the search skips
  // every branch farther than that from its start, with the same answer (the
  // points at or beyond maxD2 are never the k nearest then). Where fewer than
  // min(k, size()) points lie within maxD2, the unbounded search answers.
  size_t nearestWithin(const Vec3& q, size_t k, float maxD2, uint32_t* idx, float* d2) const;
  size_t size() const;
  // Point i's coordinates (3 floats), as given to the constructor.
  const float* point(size_t i) const { return xyz_ + 3 * i; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  const float* xyz_ = nullptr;  // the points, held by impl_
};

// The positions (member p) of items, packed for PointTree.
template <class T>
std::vector<float> packedPositions(const std::vector<T>& items) {
  std::vector<float> xyz;
  reserveHugePages(xyz, 3 * items.size());
  for (const T& t : items) xyz.insert(xyz.end(), {t.p.x, t.p.y, t.p.z});
  return xyz;
}

// The indices of the points (3 floats each) in Morton order of their
// positions within their bounding box (10 bits per axis; ties by index): points
// close in that order lie close in space, so a sequence of nearby queries, or
// the points one query finds, stay close in memory.
std::vector<uint32_t> mortonOrder(const std::vector<float>& xyz);

// Points (3 floats each) in Morton order: their coordinates, Morton codes
// (MortonBox, 10 bits per axis) and indices in the set given.
struct MortonSorted {
  std::vector<float> xyz;
  std::vector<uint32_t> codes, order;
};
MortonSorted mortonSorted(const std::vector<float>& xyz);

// For every point of m, the squared distance to its want-th nearest point
// of the set, itself the first at 0 (fewer points: the farthest), in m's
// order: for finite points, PointTree::nearest's last distance, the same
// values, searched sooner (docs/RESULTS.md, "Scale and MRCS"); a point
// with a non-finite coordinate is no one's neighbour (its own: infinity).
// A binary tree over m's order, split on planes (the codes' highest
// differing bit; in a cell of equal codes, the median of its widest axis),
// is searched from each point's own range outward, so that the bound is
// tight from the start. *distances (if given): the distances computed, for
// tests of the work per point. Incomplete if *stop becomes true (the
// caller discards them then).
std::vector<float> kthNearestSquared(const MortonSorted& m, size_t want, const std::atomic<bool>* stop = nullptr,
                                     uint64_t* distances = nullptr);

// Sorts keys of the form (code << 32) | index, with code < 2^30, that come
// in increasing order of index: afterwards they are in increasing order, as
// std::sort leaves them, by a stable radix sort of the codes (three passes
// of 10 bits; about 5x std::sort's speed on a million keys).
void sortMortonKeys(std::vector<uint64_t>& keys);

// The Morton code (10 bits per axis) of a point within the bounding box of a
// set of points (3 floats each), as mortonOrder orders them; points outside
// the box take the code of the nearest point of it.
class MortonBox {
 public:
  MortonBox() = default;
  explicit MortonBox(const std::vector<float>& xyz);
  uint32_t code(const float* p) const;

 private:
  float lo_[3] = {0, 0, 0}, extent_[3] = {0, 0, 0};
};

}  // namespace vsl
