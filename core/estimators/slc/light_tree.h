// A binary light tree over a virtual light set, for stochastic lightcuts
// (Yuksel, "Stochastic Lightcuts", HPG 2019): each node bounds its lights'
// positions (an axis-aligned box), their emission normals (an orientation
// cone, Conty Estevez and Kulla, "Importance Sampling of Many Lights with
// Adaptive Tree Splitting", HPG 2018) and holds their total flux (the
// luminance of their power) and their largest VSL radius.
//
// Built in O(n log n): the lights sorted by the Morton code of their
// positions, each range split where its codes' highest differing bit
// changes (Karras 2012's rule, serially), bounds merged bottom-up.
//
// Sampling (sample): from the root, each step takes a child with
// probability proportional to its importance at the receiver (importance()
// below: flux x orientation bounds x receiver BRDF bound / distance^2),
// with probability `floor` the whole descent by flux alone instead; the
// pdf of a light is floor x (its flux share) + (1 - floor) x (the product
// of its path's importance choices), so every light with flux has a
// non-zero probability at every receiver. Thread-safety: const methods are
// safe from any thread.
#pragma once

#include <cstdint>
#include <vector>

#include "core/gather.h"
#include "core/math.h"
#include "core/rng.h"
#include "core/virtual_lights.h"

namespace vsl {

struct LightTreeNode {
  Vec3 lo, hi;         // box of the lights' positions
  Vec3 axis;           // orientation cone's axis (emission normals)
  float cosTheta = 1;  // cone's half-angle cosine (-1: every direction)
  float flux = 0;      // sum of the lights' luminance(Phi)
  float radius = 0;    // largest VSL radius below
  // Inner node: children child and child + 1. Leaf: light -(child + 1).
  int32_t child = 0;
  bool leaf() const { return child < 0; }
  uint32_t light() const { return uint32_t(-(child + 1)); }
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
  static LightTreeReceiver make(const GatherPoint& gp);
  // An upper bound of f_r(wo, wi) cos(wi) over directions wi whose angle to
  // the mirror direction is at least thetaR and whose cosine with n is at
  // most cosX (for cosX <= 0: zero).
  float brdfCosBound(float thetaR, float cosX) const;
};

class LightTree {
 public:
  LightTree() = default;
  // The tree over lights (their positions, emission normals L.n, flux, radii).
  static LightTree build(const std::vector<GatherLight>& lights);
  // The same from the set itself, without keeping decoded lights.
  static LightTree build(const VirtualLightSet& set, const std::vector<float>& radii);

  size_t lights() const { return leafOf_.size(); }
  const std::vector<LightTreeNode>& nodes() const { return nodes_; }
  // A node's importance at the receiver (not normalised): flux x bound of
  // the receiver's BRDF and cosine x bound of the emission cosine, without
  // the distance (childProbability applies it). 0 where no light below can
  // face the receiver.
  float orientedFlux(const LightTreeNode& node, const LightTreeReceiver& r) const;
  // The probability of child `node.child` (the first) at the receiver;
  // 1 - it for the second. Distance by Yuksel 2019: 1 / (closest point of
  // the box)^2, ignored while the receiver is within either box's size.
  double childProbability(const LightTreeNode& node, const LightTreeReceiver& r) const;
  // The flux share of the first child (0.5 when neither has flux).
  double fluxProbability(const LightTreeNode& node) const;
  // A light drawn for the receiver (one uniform for the floor's choice and
  // one per level), with its pdf (> 0 where the light has flux).
  struct Sample {
    uint32_t light = 0;
    double pdf = 0;
  };
  Sample sample(const LightTreeReceiver& r, Rng& rng, float floor) const;
  // The pdf sample() gives light i at the receiver.
  double pdf(const LightTreeReceiver& r, uint32_t light, float floor) const;
  double buildSeconds() const { return buildSeconds_; }
  // Bytes held.
  size_t bytes() const {
    return nodes_.size() * sizeof(LightTreeNode) + (parent_.size() + leafOf_.size()) * sizeof(int32_t);
  }

 private:
  struct Prim {
    Vec3 p, n;
    float flux, radius;
  };
  static LightTree fromPrims(std::vector<Prim> prims);
  // floor x pFlux + (1 - floor) x pImp.
  static double mix(double pImp, double pFlux, float floor);
  std::vector<LightTreeNode> nodes_;  // root at 0
  std::vector<int32_t> parent_;       // per node; -1 at the root
  std::vector<int32_t> leafOf_;       // per light
  double buildSeconds_ = 0;
};

}  // namespace vsl
