// A light tree over a virtual light set (built binary, sampled four-wide),
// for stochastic lightcuts (Yuksel, "Stochastic Lightcuts", HPG 2019): each
// node bounds its lights' positions (an axis-aligned box), their emission
// normals (an orientation cone, Conty Estevez and Kulla, "Importance
// Sampling of Many Lights with Adaptive Tree Splitting", HPG 2018) and holds
// their total flux (the luminance of their power) and their largest VSL
// radius.
//
// Built in O(n log n): the lights sorted by the Morton code of their
// positions, each range split where its codes' highest differing bit
// changes (Karras 2012's rule, serially), bounds merged bottom-up.
//
// Sampling (sample): the binary tree stored four-wide (each wide node's
// binary subtree expanded to four entries, the largest first); from the
// root, each step takes one of a node's entries with probability
// proportional to its importance at the receiver (importance4() below, in
// SIMD lanes: flux x orientation bounds x a bound of one lobe of the
// receiver's BRDF / distance^2), the lobe chosen per descent (one-sample
// MIS); with probability `floor` the whole descent by flux alone instead.
// The pdf of a light is the mixture of the three descents' path products,
// so every light with flux has a non-zero probability at every receiver.
// Thread-safety: const methods are safe from any thread.
#pragma once

#include <cstdint>
#include <vector>

#include "core/check.h"
#include "core/gather.h"
#include "core/math.h"
#include "core/rng.h"
#include "core/virtual_lights.h"

namespace vsl {

// One binary node's bounds: what the build merges (LightTree::buildNode)
// and what the scalar importance reads; the tree keeps them four-wide
// (LightTreeWide).
struct LightTreeNode {
  Vec3 lo, hi;          // box of the lights' positions
  Vec3 axis;            // orientation cone's axis (emission normals)
  float cosTheta = 1;   // cone's half-angle cosine (-1: every direction)
  float flux = 0;       // sum of the lights' luminance(Phi)
  float radius = 0;     // largest VSL radius below
  float radiusMin = 0;  // smallest VSL radius below
};

// What a descent needs of a gather point, computed once per point: its
// position, shading normal, and bounds of its BRDF times the receiver
// cosine (a conservative bound for the GGX lobe, LightTreeReceiver::make).
struct LightTreeReceiver {
  Vec3 p, n;
  Vec3 mirror;         // wo reflected about n (the specular lobe's peak), world
  float diffuse = 0;   // luminance of the diffuse lobe's largest value
  float specular = 0;  // F_max G1(wo) / (4 cos_o): the specular lobe's factor besides D
  float ax = 1, ay = 1;
  bool specularOn = false;
  // The largest share of light from the whole hemisphere the BRDF returns
  // (its albedo, at most 1 for an energy-conserving BRDF; max(1,
  // specularWeight) here).
  float albedo = 1;
  // What a single light can contribute at most, besides its flux and the
  // bounds' cosines (LightTree::importance): for VSL, albedo / (pi r^2)
  // (the sphere's light over its area, from at most the whole hemisphere,
  // twice that for the clipped disk); for VPL alone, the clamp x pi (T <=
  // clamp with a Lambertian light's 1/pi); infinite for neither.
  bool vsl = true;
  float vplCap = kInf;
  // One-sample MIS over the lobes (Veach 1997's balance heuristic as a
  // mixture): the share of importance descents that follow the specular
  // lobe's bound, the rest the diffuse lobe's, by the lobes' albedos (in
  // [0.1, 0.9] where both are on). A narrow lobe's bound is large wherever
  // its peak falls inside a node's cone, and would otherwise swamp the
  // diffuse lobe's choice.
  float specularShare = 0;
  // vsl: computeVsl; vplClamp: the VPL clamp bound where only VPL is
  // computed (+inf: none).
  static LightTreeReceiver make(const GatherPoint& gp, bool vsl = true, float vplClamp = kInf);
  // Upper bounds of f_r(wo, wi) cos(wi), [0] of the diffuse lobe and [1]
  // of the specular lobe, over directions wi whose cosine with the mirror
  // direction is at most cosR and with n at most cosX (for cosX <= 0:
  // zero).
  void brdfCosBounds(float cosR, float cosX, float out[2]) const;
};

// Four entries of the tree, structure of arrays, for evaluating them in
// SIMD lanes (LightTree::importance4): each entry one binary node's bounds
// (its box as centre and half diagonal, the sphere pbrt-v4's light sampler
// takes). An entry is an inner node (child >= 0: the wide node of its own
// entries), a light (child < 0: light -(child + 1)) or empty (kEmpty, no
// flux).
struct alignas(16) LightTreeWide {
  static constexpr int32_t kEmpty = INT32_MIN;
  float cx[4] = {}, cy[4] = {}, cz[4] = {}, halfDiag[4] = {};
  float nx[4] = {}, ny[4] = {}, nz[4] = {}, cosTheta[4] = {}, sinTheta[4] = {};
  float flux[4] = {}, radius[4] = {};
  float invArea[4] = {};  // 1 / (pi radiusMin^2): the VSL cap's area
  int32_t child[4] = {kEmpty, kEmpty, kEmpty, kEmpty};
  // Entry `lane` from a binary node (its child index is set by the caller).
  void set(int lane, const LightTreeNode& node);
};

class LightTree {
 public:
  LightTree() = default;
  // The tree over lights (their positions, emission normals L.n, flux, radii).
  static LightTree build(const std::vector<GatherLight>& lights);
  // The same from the set itself, without keeping decoded lights.
  static LightTree build(const VirtualLightSet& set, const std::vector<float>& radii);

  size_t lights() const { return leafOf_.size(); }
  // The sampling tree: the binary tree's nodes four to a wide node (each
  // wide node's binary subtree expanded, the largest range first, to four
  // entries), so that a descent takes one choice among up to four per
  // step; root at 0.
  const std::vector<LightTreeWide>& nodes() const { return wide_; }
  // A node's importance at the receiver for each lobe, [0] diffuse and [1]
  // specular (not normalised): flux x bound of the emission cosine x the
  // smaller of (the lobe's bound of f_r cos) / d^2 and the receiver's cap
  // (a VSL's light is finite however near), d the distance to the box's
  // centre but at least half its diagonal (pbrt-v4's BVH light sampler).
  // 0 where no light below can face the receiver (the cosine bounds are
  // conservative); infinite only for an uncapped VPL at the receiver.
  // withDistance false: without the distance and the cap. The scalar
  // reference of importance4.
  static void importance(const LightTreeNode& node, const LightTreeReceiver& r, float out[2], bool withDistance = true);
  // The same for a wide node's four entries, in SSE lanes: out[k][lane]
  // (0 for an empty entry).
  static void importance4(const LightTreeWide& node, const LightTreeReceiver& r, float out[2][4],
                          bool withDistance = true);
  // A wide node's entries' weights at the receiver, [0] and [1] for each
  // lobe's descent (by importance4; where a sum is infinite, by importance
  // without distance; where it is zero, by flux) and [2] by flux alone
  // (uniform over the entries when none has flux), with their sums.
  struct EntryWeights {
    float w[3][4];
    double sum[3];
    double probability(int k, int lane) const { return w[k][lane] / sum[k]; }
  };
  static EntryWeights entryWeights(const LightTreeWide& node, const LightTreeReceiver& r);
  // A light drawn for the receiver (one uniform for the floor's choice and
  // one per wide level), with its pdf (> 0 where the light has flux).
  struct Sample {
    uint32_t light = 0;
    double pdf = 0;
    int count = 1;  // draws that chose this light (sampleSplit)
  };
  Sample sample(const LightTreeReceiver& r, Rng& rng, float floor) const;
  // `count` lights drawn independently, as sample() each (the uniforms
  // taken in another order).
  void sampleMany(const LightTreeReceiver& r, Rng& rng, float floor, int count, Sample* out) const;
  // `count` lights drawn together, stratified: the draws split over the
  // tree's entries in proportion to their probabilities (each node's share
  // k q rounded up or down at random), each light reached with its pdf and
  // the number of draws that reached it. The distinct lights are written
  // to out (at most count) and their number returned; each light's
  // expected draws are count x pdf, as for independent draws.
  int sampleSplit(const LightTreeReceiver& r, Rng& rng, float floor, int count, Sample* out) const;
  // The pdf sample() gives light i at the receiver.
  double pdf(const LightTreeReceiver& r, uint32_t light, float floor) const;
  // Every light whose sphere of radius radiusScale x its VSL radius the ray
  // from o along the unit direction dir (t >= 0) meets, or that holds o,
  // handed to visit(light); the test is each entry's bounding sphere (its
  // box's half diagonal plus radiusScale x its largest radius, a hair wider
  // against rounding), so a few near misses come too. A superset of the
  // lights whose VSL cone at o holds dir (stochastic lightcuts' lobe
  // strategy, docs/REFERENCE.md "Estimators").
  template <typename Visit>
  void lightsOnRay(const Vec3& o, const Vec3& dir, float radiusScale, Visit&& visit) const {
    if (wide_.empty()) return;
    int32_t stack[kRayStack];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const LightTreeWide& w = wide_[size_t(stack[--top])];
      for (int lane = 0; lane < 4; ++lane) {
        const int32_t child = w.child[lane];
        if (child == LightTreeWide::kEmpty || !rayMeets(w, lane, o, dir, radiusScale)) continue;
        if (child < 0) {
          visit(uint32_t(-(child + 1)));
        } else {
          VSL_CHECK(top < kRayStack);
          stack[top++] = child;
        }
      }
    }
  }
  double buildSeconds() const { return buildSeconds_; }
  // Bytes held.
  size_t bytes() const {
    return wide_.size() * sizeof(LightTreeWide) + (parent_.size() + leafOf_.size()) * sizeof(int32_t);
  }

 private:
  struct Prim {
    Vec3 p, n;
    float flux, radius;
  };
  struct Descent;
  static constexpr int kRayStack = 512;
  // Does the ray o + t dir (t >= 0) meet entry lane's bounding sphere, or
  // start inside it? The distance from its line by the perpendicular
  // vector, not |v|^2 - t^2 (which cancels for far entries).
  static bool rayMeets(const LightTreeWide& w, int lane, const Vec3& o, const Vec3& dir, float radiusScale) {
    const float R = (w.halfDiag[lane] + radiusScale * w.radius[lane]) * 1.001f;
    const Vec3 v(w.cx[lane] - o.x, w.cy[lane] - o.y, w.cz[lane] - o.z);
    const float R2 = R * R;
    if (lengthSquared(v) <= R2) return true;
    const float t = dot(v, dir);
    return t >= 0 && lengthSquared(v - dir * t) <= R2;
  }
  static int strategy(float u, float floor, float share);
  bool descend(const LightTreeReceiver& r, float u, float floor, Descent& d, Sample& out) const;
  void finish(const LightTreeReceiver& r, Rng& rng, float floor, Descent* d, int count, Sample* out) const;
  static LightTree fromPrims(std::vector<Prim> prims);
  static std::vector<uint64_t> sortedKeys(const std::vector<Prim>& prims);
  static uint32_t split(const std::vector<uint64_t>& keys, uint32_t b, uint32_t e);
  static LightTreeNode treeletBounds(const std::vector<uint64_t>& keys, uint32_t b, uint32_t e, const uint32_t* lo,
                                     const uint32_t* hi, const LightTreeNode* bounds, int m);
  LightTreeNode buildNode(const std::vector<uint64_t>& keys, const std::vector<Prim>& prims, uint32_t b, uint32_t e,
                          int32_t parentEntry, int depth);
  // floor x p[2] (flux) + (1 - floor) x (share x p[1] (specular) +
  // (1 - share) x p[0] (diffuse)).
  static double mix(const double p[3], float floor, float share);
  std::vector<LightTreeWide> wide_;  // root at 0
  std::vector<int32_t> parent_;      // per wide node: 4 x parent + its entry's lane; -1 at the root
  std::vector<int32_t> leafOf_;      // per light: 4 x wide node + its entry's lane
  double buildSeconds_ = 0;
};

}  // namespace vsl
