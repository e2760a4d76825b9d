#include "core/lobe_gather.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/parallel.h"
#include "core/point_tree.h"
#include "core/vsl_integral.h"

namespace vsl {

LobeGatherMap::LobeGatherMap(const VirtualLightSet& set, int k) : k_(std::max(k, 1)) {
  // The lights in Morton order of their positions, so that the neighbours
  // one estimate reads lie close together in memory. The estimate does not
  // depend on the order (the search returns the same lights by distance).
  const std::vector<float> xyz = packedPositions(set.lights);
  const std::vector<uint32_t> order = mortonOrder(xyz);
  box_ = MortonBox(xyz);
  lights_.reserve(order.size());
  for (uint32_t i : order) {
    GatherLight g = decodeGatherLight(set.lights[i], 0.0f);
    // The indirect lights' lobes at least kIndirectAlphaFloor wide (header).
    if (set.lights[i].depth >= 2 && widenLobeTo(g.em, kIndirectAlphaFloor, g.em)) g.alpha = g.em.f.brdf().minAlpha();
    lights_.push_back(g);
  }
  // Each light's record for the estimates (its BRDF packed, then its
  // normals, flux and frame: the header) and its BRDF widened as the chains
  // take it (radiance(..., kWideAlpha)), packed. The records start on a
  // 64-byte line, so that each takes exactly three.
  constexpr size_t kLineFloats = 64 / sizeof(float);
  records_.assign(lights_.size() * kRecordFloats + kLineFloats, 0.0f);
  const uintptr_t base = reinterpret_cast<uintptr_t>(records_.data());
  recordStart_ = ((64 - base % 64) % 64) / sizeof(float);
  wideRecords_.assign(lights_.size() * BrdfAt::kPackedFloats, 0.0f);
  for (size_t i = 0; i < lights_.size(); ++i) {
    const GatherLight& L = lights_[i];
    float* r = records_.data() + recordStart_ + i * kRecordFloats;
    L.em.f.pack(r);
    const Vec3* parts[] = {&L.ng, &L.n, &L.Phi, &L.em.frame.s, &L.em.frame.t, &L.em.frame.n};
    const int at[] = {kNg, kN, kPhi, kS, kT, kFn};
    for (int v = 0; v < 6; ++v)
      for (int c = 0; c < 3; ++c) r[at[v] + c] = (*parts[v])[c];
    VslEmitter wide;
    (widenLobeTo(L.em, kWideAlpha, wide) ? wide.f : L.em.f).pack(&wideRecords_[i * BrdfAt::kPackedFloats]);
  }
  tree_ = std::make_unique<PointTree>(packedPositions(lights_));
  const size_t n = lights_.size();
  codes_.resize(n);
  for (size_t i = 0; i < n; ++i) codes_[i] = box_.code(tree_->point(i));
  // Each light's 2k nearest: with k = 32, about 90% of tableau's queries
  // find their k nearest among them (3k: 97%, no faster).
  const size_t c = std::min({size_t(2) * size_t(k_), n, kMaxCandidates});
  if (c < 2) return;
  candidates_ = int(c);
  cand_.resize(n * c);
  candR2_.resize(n);
  parallelForChunks(n, 1024, [&](size_t begin, size_t end) {
    std::vector<float> d2(c);
    for (size_t i = begin; i < end; ++i) {
      const size_t found = tree_->nearest(lights_[i].p, c, &cand_[i * c], d2.data());
      // Where the list holds every light, every query is answered from it; a
      // short list (which finite positions never give) is never used.
      candR2_[i] = found < c ? 0.0f : c == n ? std::numeric_limits<float>::infinity() : d2.back();
    }
  });
}

namespace {
// A candidate: squared distance, then index (no initialisation: the array
// below is filled before it is read).
struct Candidate {
  float d2;
  uint32_t i;
  bool operator<(const Candidate& o) const { return d2 < o.d2 || (d2 == o.d2 && i < o.i); }
};
}  // namespace

size_t LobeGatherMap::nearest(const Vec3& z, size_t k, uint32_t* idx, float* d2, bool* fromList) const {
  if (fromList) *fromList = false;
  const size_t m = size_t(candidates_);
  if (k == 0 || k > m) return tree_->nearest(z, k, idx, d2);
  auto dist2 = [&](uint32_t i) {
    const float* q = tree_->point(i);
    const float dx = q[0] - z.x, dy = q[1] - z.y, dz = q[2] - z.z;
    return dx * dx + dy * dy + dz * dz;
  };
  // Start at a light next to z in Morton order (the nearer of the two about
  // z's code), then walk: while a light's list holds a light nearer to z,
  // move to it. This replaces a 1-NN search of the tree (about half of the
  // tree's 14% of a lobe-gathered tableau render). Where the walk stops does
  // not change the answer, only whether the list can give it (the test
  // below).
  const float at[3] = {z.x, z.y, z.z};
  const size_t n = codes_.size();
  size_t j = size_t(std::lower_bound(codes_.begin(), codes_.end(), box_.code(at)) - codes_.begin());
  uint32_t y = uint32_t(std::min(j, n - 1));
  float dy = dist2(y);
  if (j > 0 && j < n) {
    const float dPrev = dist2(uint32_t(j - 1));
    if (dPrev < dy) {
      y = uint32_t(j - 1);
      dy = dPrev;
    }
  }
  // A step looks at the nearest few of y's list only (the list is sorted by
  // distance to y), which is where a nearer light usually is.
  for (int step = 0; step < kMaxWalk; ++step) {
    const uint32_t* list = &cand_[size_t(y) * m];
    uint32_t next = y;
    for (size_t i = 1; i < std::min(m, kWalkWidth); ++i) {
      const float d = dist2(list[i]);
      if (d < dy) {
        dy = d;
        next = list[i];
      }
    }
    if (next == y) break;
    y = next;
  }
  Candidate c[kMaxCandidates];
  const uint32_t* list = &cand_[size_t(y) * m];
  for (size_t i = 0; i < m; ++i) c[i] = {dist2(list[i]), list[i]};
  std::nth_element(c, c + (k - 1), c + m);
  // The answer is exact when every light within r_k of z is a candidate: such
  // a light lies within r_k + |z - y| of y, so inside the list's radius (with
  // a margin for rounding). Otherwise the tree answers.
  const float reach = (std::sqrt(c[k - 1].d2) + std::sqrt(dy)) * 1.0001f;
  if (!(reach * reach < candR2_[y])) {
    // The list's k-th nearest bounds z's k-th nearest from above (k lights
    // lie that close), which prunes the tree's search.
    const float bound = c[k - 1].d2 * 1.0001f + std::numeric_limits<float>::min();
    return bound < std::numeric_limits<float>::infinity() ? tree_->nearestWithin(z, k, bound, idx, d2)
                                                          : tree_->nearest(z, k, idx, d2);
  }
  for (size_t i = 0; i < k; ++i) {
    idx[i] = c[i].i;
    d2[i] = c[i].d2;
  }
  if (fromList) *fromList = true;
  return k;
}
LobeGatherMap::~LobeGatherMap() = default;

Vec3 LobeGatherMap::radiance(const Vec3& z, const Vec3& nz, const Vec3& wOut, bool diffuseOnly, float minAlpha) const {
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
  const size_t found = nearest(z, want, idx, d2);
  if (found == 0) return Vec3(0.0f);
  const float r2 = d2[found - 1];
  if (!(r2 > 0)) return Vec3(0.0f);
  // The k-th light only sets the radius: (k - 1) / (pi r_k^2) is the
  // unbiased density of independent points (k / (pi r_k^2) is k / (k - 1)
  // too high: 3% at k = 32). The lights on z's side that face wOut are
  // evaluated together, in blocks, from their packed records (the map's
  // lobes, or the chains' widened ones), then summed in the order found.
  const bool keptWide = minAlpha == kWideAlpha && !diffuseOnly;
  constexpr int kBlock = 64;
  const float* rec[kBlock];
  alignas(32) float wx[kBlock], wy[kBlock], wz[kBlock], f[3][kBlock];
  float* const out[3] = {f[0], f[1], f[2]};
  Vec3 phi[kBlock];
  float widenedHere[kBlock][BrdfAt::kPackedFloats];  // other minAlpha: widened now
  Vec3 sum(0.0f);
  for (size_t i0 = 0; i0 + 1 < found;) {
    int n = 0;
    for (; i0 + 1 < found && n < kBlock; ++i0) {
      const uint32_t i = idx[i0];
      const float* r = recordAt(i);
      const Vec3 ng(r[kNg], r[kNg + 1], r[kNg + 2]), ns(r[kN], r[kN + 1], r[kN + 2]);
      // (Written so that NaN fails them too.)
      if (!(dot(ng, nz) >= 0.5f) || !(dot(ns, wOut) > 0) || !(dot(ng, wOut) > 0)) continue;
      const Vec3 s(r[kS], r[kS + 1], r[kS + 2]), t(r[kT], r[kT + 1], r[kT + 2]);
      wx[n] = dot(wOut, s);
      wy[n] = dot(wOut, t);
      wz[n] = dot(wOut, Vec3(r[kFn], r[kFn + 1], r[kFn + 2]));
      phi[n] = Vec3(r[kPhi], r[kPhi + 1], r[kPhi + 2]);
      rec[n] = keptWide ? &wideRecords_[size_t(i) * BrdfAt::kPackedFloats] : r;
      // (minAlpha first: the common minAlpha = 0 reads no decoded light.)
      if (!keptWide && !diffuseOnly && minAlpha > 0 && lights_[i].alpha < minAlpha) {
        VslEmitter wide;
        if (widenLobeTo(lights_[i].em, minAlpha, wide)) {
          wide.f.pack(widenedHere[n]);
          rec[n] = widenedHere[n];
        }
      }
      ++n;
    }
    BrdfAt::evalTotalsPacked(n, rec, wx, wy, wz, diffuseOnly, out);
    for (int j = 0; j < n; ++j) sum += phi[j] * Vec3(f[0][j], f[1][j], f[2][j]);
  }
  return sum / float(kPi * r2);
}

std::unique_ptr<LobeGatherMap> buildLobeGatherMap(const Scene& scene, const Accel& accel, const LightSampler& lights,
                                                  const ManyLightSettings& settings, const std::atomic<bool>* stop,
                                                  std::atomic<uint64_t>& nonFinite) {
  if (settings.lobeGather == 0 || !settings.computeVsl) return nullptr;
  LightTracingSettings lt;
  lt.count = settings.lobeGather;
  lt.seed = settings.seed ^ 0x9e3779b97f4a7c15ull;
  lt.maxDepth = settings.lightMaxDepth;
  const VirtualLightSet dense = traceVirtualLights(scene, accel, lights, lt, stop);
  nonFinite.fetch_add(dense.nonFiniteRejected, std::memory_order_relaxed);
  if (dense.stopped) return nullptr;
  return std::make_unique<LobeGatherMap>(dense, ManyLightSettings::kLobeGatherK);
}

std::shared_ptr<const LobeGatherMap> LobeGatherCache::get(const Scene& scene, const Accel& accel,
                                                          const LightSampler& lights, const ManyLightSettings& settings,
                                                          const std::atomic<bool>* stop,
                                                          std::atomic<uint64_t>& nonFinite) {
  if (settings.lobeGather == 0 || !settings.computeVsl) return nullptr;
  std::lock_guard<std::mutex> lock(mutex_);
  if (map_ && count_ == settings.lobeGather && seed_ == settings.seed && maxDepth_ == settings.lightMaxDepth) {
    nonFinite.fetch_add(nonFinite_, std::memory_order_relaxed);
    return map_;
  }
  map_.reset();
  std::atomic<uint64_t> rejected{0};
  std::shared_ptr<const LobeGatherMap> map = buildLobeGatherMap(scene, accel, lights, settings, stop, rejected);
  nonFinite.fetch_add(rejected.load(), std::memory_order_relaxed);
  if (!map) return nullptr;
  ++builds_;
  map_ = map;
  count_ = settings.lobeGather;
  seed_ = settings.seed;
  maxDepth_ = settings.lightMaxDepth;
  nonFinite_ = rejected.load();
  return map;
}

uint64_t LobeGatherCache::builds() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return builds_;
}

}  // namespace vsl
