// The many-light gather kernel shared by the progressive renderer and matrix
// row-column sampling: eye paths to gather points, and the evaluation of one
// (gather point, virtual light) pair for every estimator from one shadow ray.
// See many_light.h for the methods and their bias.
#pragma once

#include <algorithm>
#include <span>
#include <vector>

#include "core/accel.h"
#include "core/lights.h"
#include "core/many_light.h"
#include "core/vsl_sg.h"

namespace vsl {

// A virtual light decoded for gathering.
struct GatherLight {
  // n: the normal of the emission cosine: the shading normal, or the
  // geometric one for a normal-mapped light (VirtualLight::normalMapped).
  Vec3 p, Phi, n, ng;
  Vec3 pOff;  // shadow-ray end: p moved off its surface (offsetToLitSide(p, ng))
  VslEmitter em;
  float radius;
  float alpha;  // the narrower GGX axis of the light's specular lobe
};
GatherLight decodeGatherLight(const VirtualLight& v, float radius);

struct GatherPoint {
  bool valid = false;
  Vec3 p, beta;  // beta: throughput of the near-specular chain before the gather point
  Vec3 pOff;     // shadow-ray origin: p moved off its surface (offsetToLitSide(p, rx.ng))
  VslReceiver rx;
  Vec3 shared;  // indirect light found on the way, common to every method
  // The lobe gather (ManyLightSettings::lobeGather): VSL gathers the diffuse
  // lobe only, and vslLobe (beta applied) is its specular lobe's estimate.
  bool lobe = false;
  Vec3 vslLobe{0.0f};
};

// One eye sample's gather points: one, or two where lobe splitting sent the
// specular lobe on (ManyLightSettings::splitAlpha). The pixel's estimate is
// the sum over both points of their shared light and their gathers. Point k
// seeds its VSL quadrature with gatherStream(pixel, k).
constexpr int kMaxGatherPoints = 2;
struct EyeSample {
  GatherPoint points[kMaxGatherPoints];
  int count = 0;  // points used (an unused or escaped point is not valid)
  Vec3 shared() const {
    Vec3 s(0.0f);
    for (int k = 0; k < count; ++k) s += points[k].shared;
    return s;
  }
  bool anyValid() const {
    for (int k = 0; k < count; ++k)
      if (points[k].valid) return true;
    return false;
  }
  // Point k if it is used and valid, else null (the gather loops' entries).
  const GatherPoint* point(int k) const { return k < count && points[k].valid ? &points[k] : nullptr; }
};
// The VSL quadrature stream of gather point k of a pixel (k = 0: the pixel).
inline uint64_t gatherStream(uint64_t pixel, int k) { return k == 0 ? pixel : pixel ^ (uint64_t(k) << 48); }

struct GatherCounters {
  uint64_t rays = 0, pairs = 0, shadowRays = 0, vslEvaluations = 0, nonFinite = 0;
  // The pair roulette: pairs it dropped, and pairs it was offered (kept or
  // dropped; the next batch's threshold is per pair offered).
  uint64_t rouletteDropped = 0, rouletteOffered = 0;
  double vslOwnSeconds = 0;  // VSL's own work inside eyePath (the lobe gather)
};

// Pixel (x, y)'s direct light: the mean of the direct estimator's samples
// [sBegin, sEnd) (emission plus one scattering event, as in the reference).
Vec3 directLight(const PathTracer& direct, int x, int y, int sBegin, int sEnd, GatherCounters& c);

// A pair that passed the orientation and visibility tests: the direction
// from the gather point to the light's centre and the cosines along it.
struct PairGeometry {
  Vec3 d, l;  // d = L.p - gp.p, l = d / |d|
  float d2, dist, cosX, cosP;
  // The pair roulette's weight (ManyLightSettings::pairRoulette): 1 where
  // the pair was not offered to it, 1/q where it survived with probability q.
  float weight = 1;
};

// The pair roulette's inputs for one light against many gather points
// (Gatherer::connectMany): the threshold in luminance of the pair's estimated
// contribution (Gatherer::pairEstimate) below which a pair is kept with
// probability estimate / threshold, the light's id and each point's
// quadrature stream (seeding the decision).
struct PairRoulette {
  float threshold = 0;  // <= 0: off
  uint64_t lightId = 0;
  const uint64_t* streams = nullptr;  // one per gather point
};

class LobeGatherMap;
class Gatherer {
 public:
  // clampBound: the VPL clamp on the luminance of the transfer. From the
  // settings: the VSL quadrature, where eye paths continue, the seed.
  // lobeMap: the lobe gather's light set (settings.lobeGather), or null.
  Gatherer(const Scene& scene, const Accel& accel, const LightSampler& lights, const ManyLightSettings& settings,
           float clampBound, bool computeVsl, bool computeVpl, const LobeGatherMap* lobeMap = nullptr);

  // Next-event samples for the light found behind a specular chain, per eye
  // path where one eye path per pixel is traced. Several, because behind a
  // specular chain this is the pixel's own estimate of the light there (one
  // sample made glossy floors' reflections of lit walls speckled).
  static constexpr int kSharedLightSamples = 16;
  // What an eye path computes besides its gather points.
  struct EyePathOptions {
    // The lobe gather's estimate at lobe-gathered points; false for a path
    // traced for its shared light only (sharedLight below).
    bool lobeGather = true;
    // Next-event samples per vertex for the shared light (nextEvent).
    int lightSamples = kSharedLightSamples;
    // The lobe gather's directions per point (0: the settings' lobeGatherRays).
    int lobeRays = 0;
  };
  // Camera ray through (x + jitter, y + jitter), continued through
  // near-specular surfaces to the first surface that is not, and split there
  // by lobe if its specular lobe is narrow (see ManyLightSettings::splitAlpha).
  EyeSample eyePath(int x, int y, int width, int height, Rng& rng, GatherCounters& c) const {
    return eyePath(x, y, width, height, rng, c, EyePathOptions{});
  }
  EyeSample eyePath(int x, int y, int width, int height, Rng& rng, GatherCounters& c, const EyePathOptions& o) const;
  // Eye paths per pixel for the shared light (EyeSample::shared) over a
  // brute-force render, spread over its batches like its lights (at least one
  // per batch, so about 64: 16 batches of 1,500 lights take 1 in each of the
  // first seven and 6-7 in the others), at most kMaxSharedEyePaths in one
  // batch or MRCS pass (sharedEyePaths), each with max(1,
  // kSharedLightSamples / paths) next-event samples (eyePathOptions). The
  // light behind a specular chain is a path-traced estimate of a pixel's
  // footprint: with one eye path per batch, a curved mirror's pixel that
  // reflects a highlight in one batch of 16 showed 16x its value (tableau's
  // pot rims; docs/notebook/2026-12-05-tableau-worst-sets.md). The gather itself keeps one
  // eye path per batch.
  static constexpr int kSharedEyePaths = 64;
  static constexpr int kMaxSharedEyePaths = 16;
  static int sharedEyePaths(int scheduled) { return std::clamp(scheduled, 1, kMaxSharedEyePaths); }
  // The shared light of pixel (x, y) from `paths` eye paths (at most
  // kMaxSharedEyePaths): `first`'s (already traced, with the lightSamples of
  // eyePathOptions(paths)) and paths - 1 more traced for it alone from
  // streams of (pixel, pass). A path whose light is not finite adds nothing
  // and is counted in c.nonFinite.
  Vec3 sharedLight(const EyeSample& first, int paths, int x, int y, int width, int height, uint64_t pass,
                   GatherCounters& c) const;
  static EyePathOptions eyePathOptions(int paths) {
    EyePathOptions o;
    o.lightSamples = std::max(1, kSharedLightSamples / std::max(paths, 1));
    return o;
  }
  // Adds light L's contribution to acc (per layer, RGB). lightId and pixel
  // seed the VSL quadrature's random stream.
  void evaluate(const GatherPoint& gp, const GatherLight& L, uint64_t lightId, uint64_t pixel,
                double acc[kGatherLayers][3], GatherCounters& c) const;
  // evaluate() in its three parts, so that callers can time each method's own
  // work: connect() is what every estimator shares (orientation and the one
  // shadow ray; false: the pair contributes nothing), then each estimator's
  // transfer. addVpl and addVsl do nothing for an estimator not computed.
  bool connect(const GatherPoint& gp, const GatherLight& L, PairGeometry& g, GatherCounters& c) const;
  // connect()'s orientation tests alone, for a light at p with the normal
  // of its emission cosine n and geometric normal ng (GatherLight's): both
  // sides face each other along the direction to p (g's direction and
  // cosines set). The second form reads them from an undecoded light,
  // with the same result as on decodeGatherLight(v)'s (a cheap test before
  // the decoding).
  static bool facing(const GatherPoint& gp, const Vec3& p, const Vec3& n, const Vec3& ng, PairGeometry& g);
  static bool facing(const GatherPoint& gp, const VirtualLight& v);
  // connect() for one light against many gather points, with the shadow rays
  // traced as one coherent batch (Accel::occluded on a span: 2-4x the rays/s
  // of one call per ray when the points are neighbouring pixels). Sets
  // visible[i] and, where it is set, geo[i], exactly as connect(*gps[i], L,
  // geo[i], c) would (a null gps[i] is not visible); the counters add up the
  // same. `scratch` holds the rays between calls (any thread's own). With
  // `known` (one entry per point: an earlier call's visible[i] for the same
  // light), no ray is traced and nothing is counted (the earlier call
  // counted the pairs and rays): a pair is visible where it passes the
  // orientation tests and known[i] is set.
  struct ConnectScratch {
    std::vector<Ray> rays;
    std::vector<uint32_t> rayOf;
    std::vector<uint8_t> blocked;
  };
  // With `roulette` (not with `known`), a pair whose estimate (pairEstimate)
  // is below the threshold is kept with probability estimate / threshold and
  // weighted by its inverse (geo[i].weight); a pair it drops is not visible
  // and needs no shadow ray.
  void connectMany(std::span<const GatherPoint* const> gps, const GatherLight& L, PairGeometry* geo, uint8_t* visible,
                   ConnectScratch& scratch, GatherCounters& c, std::span<const uint8_t> known = {},
                   const PairRoulette* roulette = nullptr) const;
  // An estimate from above of the luminance of the pair's VSL contribution
  // (beta x Phi x T_VSL) before its shadow ray and quadrature: each BRDF at
  // the direction inside the cone closest to its lobe's peak (the mirror
  // direction), each cosine at its largest over the cone, times the cone's
  // solid angle over the sphere's area. Not a strict bound (Fresnel, masking
  // and anisotropy can put the largest value elsewhere); the roulette stays
  // unbiased whatever it returns, it only decides where the roulette plays.
  float vslBound(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g) const;
  // The pair roulette's estimate of a pair's contribution (luminance), for
  // the estimators computed: vslBound for VSL, the unclamped full-BRDF VPL
  // contribution for VPL (it bounds every VPL layer), the larger of the two
  // where both are computed.
  float pairEstimate(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g) const;
  // Both transfers of a connected pair: evaluate() after connect().
  void addConnected(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g, uint64_t lightId,
                    uint64_t pixel, double acc[kGatherLayers][3], GatherCounters& c) const {
    addVpl(gp, L, g, acc, c);
    addVsl(gp, L, g, lightId, pixel, acc, c);
  }
  void addVpl(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g, double acc[kGatherLayers][3],
              GatherCounters& c) const;
  // addVpl with the two BRDF values given: fx, the receiver's at the
  // direction to the light, and fp, the light's lobes toward the receiver.
  void addVpl(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g, const Vec3& fx,
              const BrdfAt::Parts& fp, double acc[kGatherLayers][3], GatherCounters& c) const;
  // The BRDF values of addVpl for the pairs list[0..n) of one light against
  // the points pts (connectMany's visible ones), evaluated in blocks: the
  // receivers' from their BRDFs packed once per gather point (packReceivers:
  // pts[i]'s at packed + i x BrdfAt::kPackedFloats), the light's at every
  // direction in one call. fx(v) and fp(v) are then bit for bit what addVpl
  // evaluates for pair list[v].
  class VplBrdfs {
   public:
    Vec3 fx(size_t v) const { return {f_[0][v], f_[1][v], f_[2][v]}; }
    BrdfAt::Parts fp(size_t v) const { return {{f_[3][v], f_[4][v], f_[5][v]}, {f_[6][v], f_[7][v], f_[8][v]}}; }

   private:
    friend class Gatherer;
    std::vector<float> f_[9];     // fx RGB, then fp's diffuse and specular RGB
    std::vector<float> dirs_[6];  // the receivers' local directions, then the light's
    std::vector<const float*> packed_;
  };
  // Packs pts' BRDFs for vplBrdfs where this gatherer computes VPL (else
  // leaves packed empty; null points get a record of zeros).
  void packReceivers(std::span<const GatherPoint* const> pts, std::vector<float>& packed) const;
  void vplBrdfs(std::span<const GatherPoint* const> pts, const float* packed, const uint32_t* list, size_t n,
                const GatherLight& L, const PairGeometry* geo, VplBrdfs& out) const;
  // addConnected for the pairs list[0..n) of one light against pts, in that
  // order, the VPL BRDFs evaluated in blocks (vplBrdfs): each pair's
  // transfers go to a zeroed acc handed to done(i, acc). streamOf(i) is
  // point i's quadrature stream. The same values, bit for bit, as
  // addConnected pair by pair.
  template <typename StreamOf, typename Done>
  void addConnectedMany(std::span<const GatherPoint* const> pts, const float* packed, const uint32_t* list, size_t n,
                        const GatherLight& L, const PairGeometry* geo, uint64_t lightId, StreamOf&& streamOf,
                        Done&& done, VplBrdfs& blocks, GatherCounters& c) const {
    if (computeVpl_) vplBrdfs(pts, packed, list, n, L, geo, blocks);
    for (size_t v = 0; v < n; ++v) {
      const uint32_t i = list[v];
      double acc[kGatherLayers][3] = {};
      if (computeVpl_) addVpl(*pts[i], L, geo[i], blocks.fx(v), blocks.fp(v), acc, c);
      addVsl(*pts[i], L, geo[i], lightId, streamOf(i), acc, c);
      done(i, acc);
    }
  }
  void addVsl(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g, uint64_t lightId, uint64_t pixel,
              double acc[kGatherLayers][3], GatherCounters& c) const;

  // For an estimator that samples directions from the receiver's BRDF
  // (stochastic lightcuts' lobe strategy, docs/REFERENCE.md "Estimators"):
  // the pair of gp and L oriented as connect() orients it (g set, the pair
  // counted), then the VSL contribution's integrand along the unit
  // direction l (beta Phi vslIntegrand of the pair as addVsl gathers it by
  // the quadrature, so that its integral over l is addVsl's expected
  // contribution with the quadrature), and only where that is not zero the
  // shadow ray (counted then): zero where the pair is not oriented, l
  // leaves its cone or the ray is blocked.
  Vec3 vslAlong(const GatherPoint& gp, const GatherLight& L, const Vec3& l, PairGeometry& g, GatherCounters& c) const;
  // The share of the receiver's BRDF samples that land in the pair's cone,
  // estimated (for the lobe strategy's weights; any value in [0, 1] keeps
  // them unbiased): min(1, the sampling pdf at the cone's direction nearest
  // the mirror direction x the cone's solid angle). Zero where VSL gathers
  // nothing from the pair.
  double vslConeMass(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g) const;
  // The largest factor vslPair applies to a light's radius (the lobe
  // floor's sphere, kVslLobeFloorRadiusScale); infinite with the lobe-aware
  // radius (ManyLightSettings::lobeRadius), which no factor bounds.
  float vslRadiusScaleBound() const;

  // The VSL pair as addVsl gathers it: the receiver (its diffuse lobe at a
  // lobe-gathered point), the light (its lobe widened by the floor) and the
  // sphere's radius. rx and em point at the gather point's and the light's
  // own, or at ownRx and ownEm where the pair changes them (no copy
  // otherwise: the gather makes one per pair). Not to be copied.
  struct VslPair {
    const VslReceiver* rx = nullptr;
    const VslEmitter* em = nullptr;
    float radius = 0;
    VslReceiver ownRx;
    VslEmitter ownEm;
  };
  // addVsl for the pairs list[0..n) of one light against pts (connectMany's
  // visible ones) in two steps: vslPrepare decides each pair's integral and
  // evaluates the closed-form ones together, eight to a call
  // (vslTransferSgMany: AVX2 lanes in float), then addVslPrepared(v) adds
  // pair list[v]'s contribution, as addVsl would: the quadrature's pairs
  // bit for bit (same stream), the closed form's to the lanes' rounding
  // (about 1e-4 relative against the scalar form; core/vsl_sg.h). A
  // pixel's sums then add in the order they always have. Any thread's own.
  class VslBlock {
   private:
    friend class Gatherer;
    std::vector<VslPair> pairs_;
    std::vector<uint8_t> kind_;  // 0: nothing gathered; 1: closed form (transfer_[sgOf_]); 2: quadrature
    std::vector<uint32_t> sgOf_;
    std::vector<VslSgPair> sg_;
    std::vector<Vec3> transfer_;
    std::vector<float> packed_;  // the closed form's BRDFs, packed (BrdfAt::pack)
  };
  // packedRx (or null: packed per pair): packVslReceivers's records of pts.
  void vslPrepare(std::span<const GatherPoint* const> pts, const float* packedRx, const uint32_t* list, size_t n,
                  const GatherLight& L, const PairGeometry* geo, VslBlock& b) const;
  // The receivers' BRDFs as the closed form sees them (a lobe-gathered
  // point's diffuse lobe), packed once per gather point for vslPrepare where
  // this gatherer computes VSL in closed form (else packed is left empty;
  // null points get a record of zeros).
  void packVslReceivers(std::span<const GatherPoint* const> pts, std::vector<float>& packed) const;
  void addVslPrepared(const VslBlock& b, size_t v, const GatherPoint& gp, const GatherLight& L, const PairGeometry& g,
                      uint64_t lightId, uint64_t pixel, double acc[kGatherLayers][3], GatherCounters& c) const;

 private:
  // False: VSL gathers nothing from the pair.
  bool vslPair(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g, VslPair& out) const;
  // The pair takes the closed form (vslUsesSg, and no clear coat at either end).
  bool vslTakesSg(const VslPair& pr, const PairGeometry& g) const;
  // addVsl's last step: the transfer r of the pair into acc's VSL layer.
  void addVslResult(const GatherPoint& gp, const GatherLight& L, const PairGeometry& g, const VslResult& r,
                    double acc[kGatherLayers][3], GatherCounters& c) const;
  // Next-event light at sh reflected by f toward the viewer, from `samples`
  // lights sampled by power; deltaOnly: punctual lights only (zero for area
  // lights, whose light a continued ray finds by hitting them).
  // connect() up to its shadow ray: false if the pair contributes nothing;
  // otherwise needsRay says whether `ray` must be unoccluded (the ends may
  // coincide, and then nothing can block them).
  bool orient(const GatherPoint& gp, const GatherLight& L, PairGeometry& g, Ray& ray, bool& needsRay,
              GatherCounters& c) const;
  Vec3 nextEvent(const BrdfAt& f, const SurfaceHit& sh, bool deltaOnly, Rng& rng, GatherCounters& c,
                 int samples = kSharedLightSamples) const;

  const Scene& scene_;
  const Accel& accel_;
  const LightSampler& lights_;
  float clamp_;
  VslOptions vsl_;
  float continueAlpha_, splitAlpha_, lobeRadius_, lobeFloor_;
  bool computeVsl_, computeVpl_;
  uint64_t seed_;
  const LobeGatherMap* lobeMap_;
  int lobeRays_;
  float lobeAlpha_;  // receivers narrower than this are lobe-gathered
  // The lobe gather's estimate of spec (a specular lobe at sh) toward the
  // viewer: the mean over rays sampled directions (LobeGatherMap).
  Vec3 lobeGather(const BrdfAt& spec, const SurfaceHit& sh, int rays, Rng& rng, GatherCounters& c) const;
};

}  // namespace vsl
