// The lobe gather (ManyLightSettings::lobeGather, off by default): VSL's
// estimate of a narrow receiver's specular lobe, found by sampling that lobe
// instead of from each light's sphere.
//
// A receiver lobe narrower than the VSL cones sees each light's sphere as a
// disk of uniform radiance: on tableau's polished table (GGX alpha 0.0225)
// one light set paints a few bright disks and the next none (most of VSL's
// squared error there; docs/notebook/2026-12-04-lobe-gather.md); a lobe
// narrow along one axis (brushed metal) sees it as a bright streak. The VSL
// integral's receiver strategy, turned around: each of M directions drawn
// from the specular lobe at x is traced to the surface point z it reaches,
// and the radiance leaving z toward x is the density estimate of a second,
// denser light set (the K nearest lights to z, as in photon mapping):
//   L(z -> x) = sum_{K-1} Phi_y f_y(wi_y, z -> x) / (pi r_K^2),
// where r_K is the distance to the K-th one (which only sets the radius). The receiver's estimate is the
// mean over the M directions of f cos / pdf x L(z -> x). For a light on the
// surface z lies on, "z within r of y" is the ray passing through y's
// sphere (the projected disk already holds the cosine at y), so this is the
// VSL integral with its kernel taken from the denser set. The diffuse lobe
// is gathered from the light set (only that lobe at such points), and
// clamped VPL does not change. Where a direction lands on a lobe narrow
// along both axes, the lights' diffuse lobes give the estimate there and the
// direction continues along that surface's specular lobe (at most 8
// bounces), with the punctual lights it reflects added by next-event
// estimation (see Gatherer::lobeGather).
// Many directions and few lights per estimate (M = 128, K = 32) beat few
// directions and many lights (8, 256) at the same cost: each direction's
// cost is mostly its K BRDF evaluations, and the error mostly the
// directions' sampling (docs/notebook/2026-12-04-lobe-gather.md, "Brushed receivers").
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "core/gather.h"
#include "core/point_tree.h"

namespace vsl {

// The denser light set, decoded, with a k-d tree over its positions.
// Immutable after construction; safe to share between threads.
class LobeGatherMap {
 public:
  // The narrowest GGX alpha (either axis) of an indirect light's lobe in the
  // map (a light of depth 2 or more; a first-hit light keeps its own). An
  // indirect light's incoming direction is one draw from a broad incoming
  // distribution, and its own narrow lobe turns that draw into a beam: on
  // tableau's brushed panels (alpha 0.0225 across the brushing) one such
  // light held more than 90% of 99% of the estimates above 5, up to 575
  // where the estimate is about 0.2, and those estimates were the bright
  // streaks of the worst light sets. Widened, the light stands for the
  // spread of directions its neighbours sample (biased, a blur of indirect
  // glossy reflections; first-hit lights share their source's direction,
  // and widening them blurs the highlights themselves: relMSE 0.26 -> 0.64
  // on one set). 0.1 measured best of 0.05, 0.1, 0.15 and 0.3
  // (docs/notebook/2026-12-05-tableau-worst-sets.md).
  static constexpr float kIndirectAlphaFloor = 0.1f;
  // k: lights per density estimate (>= 1).
  LobeGatherMap(const VirtualLightSet& set, int k);
  ~LobeGatherMap();
  // Radiance leaving the surface at z (geometric normal nz, facing wOut)
  // toward the unit direction wOut, from the k nearest lights: sum Phi f /
  // (pi r_k^2) over the k - 1 nearest (the k-th sets r_k; unbiased for
  // independent lights) that lie on z's side (geometric normal within 60
  // degrees of nz: not the back of a thin wall) and face wOut. Zero with
  // fewer than two lights.
  // diffuseOnly: the lights' diffuse lobes only (where z's own specular lobe
  // is continued instead). minAlpha: each light's lobe at least this GGX
  // alpha wide on each axis for this estimate (0: as kept).
  Vec3 radiance(const Vec3& z, const Vec3& nz, const Vec3& wOut, bool diffuseOnly, float minAlpha = 0.0f) const;
  size_t size() const { return lights_.size(); }
  // Floats per light in the map's records for its estimates (its memory).
  static constexpr int kRecordFloats = 48;
  // The min(k, size()) lights nearest to z (indices into the map's own
  // order, see light(); squared distances), the farthest of them last, the
  // others in no set order; returns how many (0 where z is not finite or
  // is so far away that its distances overflow). Read from the candidate
  // list of a light next to z (where a walk from z's Morton neighbour toward
  // z stops) where that list must hold them all, else from the tree: the
  // same lights either way. fromList (if given): whether the list answered.
  size_t nearest(const Vec3& z, size_t k, uint32_t* idx, float* d2, bool* fromList = nullptr) const;
  const GatherLight& light(size_t i) const { return lights_[i]; }

 private:
  std::vector<GatherLight> lights_;  // in Morton order of their positions
  static constexpr float kWideAlpha = ManyLightSettings::kLobeGatherChainAlpha;
  // Per light, what an estimate reads, together: its BRDF (BrdfAt::pack),
  // then its geometric normal, its shading normal, its flux and its shading
  // frame (s, t, n), padded to 48 floats (three cache lines of 64 bytes; the
  // records start on a line: recordAt()).
  static constexpr int kNg = BrdfAt::kPackedFloats, kN = kNg + 3, kPhi = kN + 3, kS = kPhi + 3, kT = kS + 3,
                       kFn = kT + 3;
  static_assert(kFn + 3 <= kRecordFloats, "a light's record holds its terms");
  const float* recordAt(size_t i) const { return records_.data() + recordStart_ + i * kRecordFloats; }
  std::vector<float> records_;
  size_t recordStart_ = 0;          // where the first record begins (64-byte aligned)
  std::vector<float> wideRecords_;  // each light's BRDF at least kWideAlpha wide, packed
  std::unique_ptr<PointTree> tree_;
  int k_;
  // Each light's 2k nearest lights (itself among them), so that a query
  // costs a short walk and 2k distances instead of a k-nearest search of the
  // tree (that search was 40% of a lobe-gathered tableau render;
  // docs/notebook/2026-12-02-gather-simd-and-pair-cost.md, 2026-12-05 and 2026-12-06).
  static constexpr size_t kMaxCandidates = 1024;
  // Steps of a query's walk toward z from its Morton neighbour (nearest()).
  static constexpr int kMaxWalk = 8;
  static constexpr size_t kWalkWidth = 12;
  int candidates_ = 0;          // per light; 0: every query searches the tree
  std::vector<uint32_t> cand_;  // candidates_ per light
  std::vector<float> candR2_;   // the squared distance to each light's farthest candidate
  // Where a query starts: the lights' Morton codes (ascending: the lights are
  // in that order) and the box they were taken in.
  MortonBox box_;
  std::vector<uint32_t> codes_;
};

// The lobe gather's light set for a render with these settings (a seed of its
// own, derived from settings.seed), or null where settings.lobeGather is 0, VSL
// is not computed or stop was raised while it was traced (a partial set is not
// used). Lights rejected as non-finite are added to nonFinite. The brute-force
// gather (ManyLightRenderer) and MRCS (renderMrcs) build it the same way.
std::unique_ptr<LobeGatherMap> buildLobeGatherMap(const Scene& scene, const Accel& accel, const LightSampler& lights,
                                                  const ManyLightSettings& settings, const std::atomic<bool>* stop,
                                                  std::atomic<uint64_t>& nonFinite);

// The lobe gather's map of the last render of one scene, kept for the next
// (RenderContext::lobeGatherMaps): the studio restarts a render at every
// change of a control, and most changes (a radius, the light count, the
// estimator's options) leave the map as it was. A map depends only on the
// scene and on settings.lobeGather, the seed and lightMaxDepth, so the kept
// one is reused, bit for bit what a new build would give, where those agree;
// otherwise it is released before the new one is built (so no more than one
// map is alive because of the cache). Thread-safe; a build holds the lock.
class LobeGatherCache {
 public:
  // buildLobeGatherMap's map (and its count of rejected lights, added to
  // nonFinite again on reuse), from the cache or built now; a map that was
  // stopped (null) is not kept.
  std::shared_ptr<const LobeGatherMap> get(const Scene& scene, const Accel& accel, const LightSampler& lights,
                                           const ManyLightSettings& settings, const std::atomic<bool>* stop,
                                           std::atomic<uint64_t>& nonFinite);
  uint64_t builds() const;  // maps built so far (not reused)

 private:
  mutable std::mutex mutex_;
  uint32_t count_ = 0;
  uint64_t seed_ = 0;
  int maxDepth_ = 0;
  uint64_t nonFinite_ = 0;
  std::shared_ptr<const LobeGatherMap> map_;
  uint64_t builds_ = 0;
};

}  // namespace vsl
