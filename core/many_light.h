// Many-light rendering (instant radiosity, step 2): gathering a
// VirtualLightSet as Virtual Spherical Lights and as Virtual Point Lights,
// from one shared visibility ray per (pixel, light) pair.
//
// Methods and their known bias
//   VSL  Hasan, Krivanek, Walter, Bala, "Virtual Spherical Lights for
//        Many-Light Rendering of Glossy Scenes", SIGGRAPH Asia 2009. Each
//        light's flux is spread over a sphere of radius r_i and integrated over
//        the cone it subtends (see vsl_integral.h). Radius r_i = s x distance to
//        the k-th nearest other light (default s = 1, k = 10: against s = 2,
//        lower median error and 2-7% less darkening on cornell-glossy and hall
//        over five light sets, docs/REFERENCE.md "VSL"), or one global radius (a
//        fraction of the scene's bounding radius). Bias: blurs illumination at
//        low light counts; some darkening in corners.
//   VPL  Keller 1997 (instant radiosity). Transfer per unit flux
//        T = f_x(wo,l) cos_x f_p(w_p,-l) cos_p / d^2. Variants:
//        - unclamped (unbiased, spiky);
//        - clamped: T is scaled so its luminance is at most c (the whole
//          transfer is clamped, not only the geometry term). Default c is
//          scene-relative: 1/(pi^2 (0.1 R)^2), the transfer between two facing
//          white Lambertian points one tenth of the scene's bounding radius R
//          apart. Bias: loses energy near corners and on glossy surfaces;
//        - diffuse-only emission: f_p replaced by its diffuse lobe. Bias: loses
//          all glossy-to-anything transport; pure metals re-emit nothing.
// Components: "direct" is computed by the path tracer's direct estimator
// (emission plus one scattering event), so all methods differ only in the
// indirect component.
// Gathering happens at the first camera hit that is not a narrow metal (GGX
// alpha below continueAlpha on both axes); eye paths continue through those,
// adding their own emission and next-event light so that nothing is double
// counted or dropped. With lobe splitting (splitAlpha), a gather point whose
// specular lobe is narrow gathers its diffuse lobe only (next-event light
// too), and its specular lobe, sampled alone, continues to one more gather
// point, where emission that the continued ray hits is counted instead of
// next-event light for that lobe. Each eye sample so has one or two gather
// points (kMaxGatherPoints); their sum is the pixel's estimate.
// Progressive batches: lights are processed in a random order, in batches of
// geometrically growing size; after each batch every layer is an unbiased
// estimate of the image with all N lights (batch sums scaled by N / batch size).
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/film.h"
#include "core/pathtracer.h"
#include "core/result.h"
#include "core/virtual_lights.h"
#include "core/vsl_integral.h"

namespace vsl {

class Gatherer;
class LobeGatherMap;
class LobeGatherCache;

// The progressive batches' relative sizes (weights) for `lights` lights in
// `batches` batches (at most one batch per light): sizes double for c
// batches, then stay constant. The first picture comes quickly, no batch
// holds more than a modest share of the work, and c stops where the first
// batch would hold less than one light (c = batches / 2 when it does not:
// the rule before 2026-12-05, under which 64 batches of 4,000 lights were
// 30 batches of one light each and 34 of the rest).
std::vector<double> batchWeights(size_t lights, int batches);

struct ManyLightSettings {
  uint32_t lights = 10000;  // target number of virtual lights
  uint64_t seed = 0;
  int width = 0, height = 0;
  int batches = 8;         // progressive batches (>= 1)
  int directSamples = 64;  // direct-light samples per pixel over the whole render
  int lightMaxDepth = 16;
  // VSL
  float radiusScale = 1.0f;            // s
  int knn = 10;                        // k
  float globalRadius = 0;              // > 0: one radius = globalRadius x scene bounding radius
  int vslSamples = 0;                  // per strategy; 0 = auto (grows with the cone angle)
  bool clippedDisk = false;            // VSL normalised by the clipped disk's area (vsl_integral.h)
  VslCount vslCount = VslCount::Lobe;  // the automatic count (vsl_integral.h)
  // The cone integral: the closed form by spherical Gaussians (core/vsl_sg.h;
  // the default by measurement, docs/REFERENCE.md "The paper's VSL") or the
  // quadrature (the paper's; --preset paper).
  VslIntegral vslIntegral = VslIntegral::Sg;
  // With the closed form: pairs whose cone's half-angle exceeds this
  // (degrees) use the quadrature, where the SG fits are weakest (wide cones,
  // lobes as wide as the cone; core/vsl_sg.h). 5 by measurement: on kitchen
  // at 10,000 lights the SG pairs of cones of 5-10 degrees cost 2.6% of the
  // indirect mean (docs/RESULTS.md, "Closed-form VSL by spherical Gaussians").
  float vslSgMaxAngle = kDefaultVslSgMaxAngle;
  static constexpr float kDefaultVslSgMaxAngle = 5.0f;
  // Lobe-aware minimum radius (0 = off): for a receiver at distance d, the
  // radius is at least lobeRadius x d x alpha, alpha the narrower GGX axis of
  // the light's specular lobe, so that the cone is about as wide as the
  // light's emission lobe (a VSL whose cone is narrower than that lobe is a
  // spiky unclamped VPL). Trades those spikes for blur.
  float lobeRadius = 0;
  // Lobe floor (0 = off): a metal light's GGX lobe is at least lobeFloor x
  // the half-angle of the cone to its own sphere wide (alpha, radians; at
  // most kVslLobeFloorMaxAlpha) for each receiver, so that a narrow light
  // seen through a wider cone lights the receiver as a sphere would, not as
  // a beam (vslLobeFloor in vsl_integral.h; not at receivers narrower than
  // kVslLobeFloorMinReceiverAlpha, not for dielectric lights); where it
  // applies, the light's sphere is kVslLobeFloorRadiusScale x wider too.
  // Trades the beams' spikes for blur of glossy-to-glossy reflections. On (1)
  // by default since it spares dielectric lights: at 10,000 lights, five
  // light sets, hall's median indirect relMSE falls 2.4x and no bundled scene
  // loses (docs/notebook/2026-12-03-lobe-floor.md, "The floor's lights").
  float lobeFloor = kDefaultLobeFloor;
  static constexpr float kDefaultLobeFloor = 1.0f;
  // Eye paths continue through pure metals whose GGX alpha is below this
  // along both axes, instead of gathering there (see "Gathering" above).
  // 0.02 (roughness < 0.14) by measurement: on cornell-glossy with a
  // roughness-0.1 metal box, 10,000 lights, five light sets, median indirect
  // relMSE VSL 0.0111 -> 0.0103 and clamped VPL 0.0155 -> 0.0118 against
  // gathering there (docs/notebook/2026-12-01-radius-and-first-comparisons.md).
  float continueAlpha = kDefaultContinueAlpha;
  static constexpr float kDefaultContinueAlpha = 0.02f;
  // Lobe splitting (0 = off): at a gather point whose specular lobe is
  // narrower than this along both GGX axes, the diffuse lobe is
  // gathered there and the specular lobe continues the eye path to a second
  // gather point (a metal, which has no diffuse lobe, continues whole). A
  // lobe narrower than the VSL cones sees each light's sphere as a bright
  // disk; continuing it gathers where the lobe lands instead. See "Gathering"
  // above.
  float splitAlpha = kDefaultSplitAlpha;
  static constexpr float kDefaultSplitAlpha = 0.0f;
  // The lobe gather (0 = off; core/lobe_gather.h): VSL's estimate of the
  // specular lobe of a receiver narrower than lobeGatherAlpha along either
  // GGX axis (near-mirrors and brushed metals; not split) comes from
  // lobeGatherRays directions drawn from that lobe (multi-jittered, see
  // Gatherer::lobeGather) and a second light set of
  // lobeGather lights (its own seed), the kLobeGatherK nearest of which give
  // the radiance where each direction lands; the light set gathers only the
  // diffuse lobe there. At least kLobeGatherK lights. Brute force or MRCS;
  // its cost (the second set too) is VSL's own time.
  // Off by default; K and the rays were chosen by measurement
  // (docs/notebook/2026-12-04-lobe-gather.md, "Brushed receivers, 32 lights").
  uint32_t lobeGather = 0;
  int lobeGatherRays = kDefaultLobeGatherRays;
  static constexpr int kDefaultLobeGatherRays = 128;
  static constexpr int kMaxLobeGatherRays = 1024;
  static constexpr int kLobeGatherK = 32;
  static constexpr float kLobeGatherAlpha = 0.05f;
  static constexpr float kMinLobeGatherAlpha = 0.001f;  // lobeGatherAlpha in [this, 1]
  // Path regularisation in the lobe gather's chains of narrow lobes: where a
  // direction lands on a narrow surface, the punctual lights that surface
  // reflects are found by next-event estimation through its specular lobe
  // widened to at least this GGX alpha on each axis, and where the path
  // continued from there lands, the map's lights are evaluated with lobes at
  // least this wide. A highlight seen through two narrow lobes is otherwise
  // a rare spike: one tableau pixel held 28% of a light set's squared error,
  // 9.98 where the reference has 0.11. Chosen by measurement, 0.1 of 0.05,
  // 0.1 and 0.2 (docs/notebook/2026-12-05-tableau-worst-sets.md).
  static constexpr float kLobeGatherChainAlpha = 0.1f;
  // Receivers narrower than this GGX alpha (either axis) are lobe-gathered.
  // The default takes near-mirrors and brushed metals; on hall 0.15, which
  // takes its metal walls (alpha 0.12) too, is better at equal time
  // (docs/notebook/2026-12-05-lobe-gather-search-and-hall-walls.md). Where a
  // direction lands, a surface counts as narrow (continued) below kLobeGatherAlpha
  // whatever this is.
  float lobeGatherAlpha = kLobeGatherAlpha;
  // The pair roulette (0 = off): before its shadow ray and transfers, a pair
  // whose contribution is estimated (Gatherer::pairEstimate: from above for
  // VSL, exactly for VPL before clamping) at less than pairRoulette x the
  // mean contribution per pair offered in earlier batches is kept with
  // probability estimate / threshold and weighted by its inverse (unbiased
  // for each estimator; the first batch plays none). Most pairs on glossy
  // scenes carry almost nothing (hall, VSL: 80% of the pairs hold 3% of the
  // light); the roulette spends the rays and samples on the rest. Both
  // estimators, so that equal-time comparisons give each the same help; where
  // both are gathered, the estimate is the larger of the two and the mean is
  // that of both summed. Brute force only (MRCS samples its rows and columns
  // already; the CLI and the studio refuse the pair). At most 100.
  float pairRoulette = 0;
  VslOptions vslOptions() const {
    // 90 degrees takes every cone, the hemisphere of a receiver inside the sphere too.
    const double omc = vslSgMaxAngle >= 90.0f ? 1.0 : 1.0 - std::cos(double(vslSgMaxAngle) * M_PI / 180.0);
    return {vslSamples, clippedDisk, vslCount, vslIntegral, omc};
  }
  // VPL
  float clamp = -1;          // bound on the luminance of T; < 0 auto, +inf off
  bool diffuseOnly = false;  // diffuse-only emission for "the" VPL image
  // Which estimators to evaluate (both share the visibility ray); layers of
  // a skipped estimator stay black.
  bool computeVsl = true, computeVpl = true;
  // Success, or the first invalid setting: "setting: reason (got value)".
  Result<void> validate() const;
  // The settings as CLI options; withGrid false leaves out --lights and
  // --radius-scale (a sweep's grid sets them per configuration).
  std::string describe(bool withGrid = true) const;
};

// Layers the gather accumulates, per pair.
enum GatherLayer { kVslLayer, kVplFull, kVplFullClamped, kVplDiffuse, kVplDiffuseClamped, kGatherLayers };

// Layers, all linear RGB. Indirect layers exclude direct light.
struct ManyLightImages {
  Image direct;
  Image vsl;             // VSL indirect
  Image vpl;             // VPL indirect with the chosen clamp and emission
  Image vplUnclamped;    // full-BRDF unclamped VPL indirect
  Image vplDiffuse;      // diffuse-only unclamped VPL indirect
  Image lostToClamping;  // unclamped - clamped (with the chosen emission)
  Image lostToDiffuse;   // full-BRDF unclamped - diffuse-only unclamped
};

// The images from a gather's indirect layers (each already holding the light
// found on the eye paths): VSL's, "the" VPL (clamped, with diffuse-only
// emission when diffuseOnly), the unclamped and diffuse-only VPLs, and the
// lost layers as their differences. The layers are moved from.
ManyLightImages imagesFromLayers(Image (&layer)[kGatherLayers], Image direct, bool diffuseOnly);

struct ManyLightStats {
  std::atomic<uint64_t> pairs{0};  // (pixel, light) pairs considered (with the pair roulette: dropped ones too)
  std::atomic<uint64_t> shadowRays{0};
  std::atomic<uint64_t> vslEvaluations{0};
  std::atomic<uint64_t> rouletteDropped{0};  // pairs the pair roulette dropped
  std::atomic<uint64_t> nonFinite{0};        // contributions rejected where they arose
  double gatherSeconds = 0;                  // wall time of the gathers (both methods together)
  // Each method's own gather time: what it would have taken alone. Shared
  // work (eye paths, direct light, shadow rays) is charged to both; VSL's
  // quadrature only to VSL and VPL's transfer only to VPL.
  double vslSeconds = 0, vplSeconds = 0;
};

// What a brute-force batch costs, as three parts measured on the batches
// done: per-pixel work (direct-light samples and eye paths, in units of one
// of either), the lobe gather's directions, and the lights. A batch's time
// is predicted as the sum of each part's units times its measured cost per
// unit. The first batch holds few lights (one of 2,303 shares at 16 batches)
// but every pixel's eye path, so a rate in lights per second alone predicts
// hours where seconds are left (the studio said "~1.8 h left" there).
struct BatchCostModel {
  struct Units {
    double pixel = 0, lobe = 0, lights = 0;
    Units& operator+=(const Units& o) {
      pixel += o.pixel;
      lobe += o.lobe;
      lights += o.lights;
      return *this;
    }
  };
  // One batch's measured wall seconds of each part and its units.
  void add(const Units& seconds, const Units& units);
  // Seconds for work of these units at the measured costs; a part not yet
  // measured (zero units so far) counts as free.
  double predict(const Units& units) const;
  bool measured() const { return batches_ > 0; }

 private:
  Units seconds_, units_;
  int batches_ = 0;
};

class ManyLightRenderer {
 public:
  // The light set and radii (one per light, VSL_CHECK) must outlive the
  // renderer. `stop` ends the lobe gather's light tracing early (a renderer
  // made while it was set is not to be used). lobeMaps: where the lobe
  // gather's map comes from if it is kept (the context's), else it is built.
  ManyLightRenderer(const Scene& scene, const Accel& accel, const LightSampler& lights, const VirtualLightSet& set,
                    const std::vector<float>& radii, const ManyLightSettings& settings,
                    const std::atomic<bool>* stop = nullptr, LobeGatherCache* lobeMaps = nullptr);
  ~ManyLightRenderer();

  int width() const { return width_; }
  int height() const { return height_; }
  int batchCount() const { return int(batchEnd_.size()); }
  // Lights in batch b.
  size_t batchLights(int b) const { return batchEnd_[size_t(b)] - (b > 0 ? batchEnd_[size_t(b) - 1] : 0); }
  // The lobe gather's directions per point in batch b: the first of several
  // batches takes an eighth of lobeGatherRays (at least one), so that the
  // first picture comes at about the cost of a batch without the lobe gather
  // (128 directions made the studio's first picture about a second late at
  // 256 px); the others share the rest, so that the render's total is still
  // lobeGatherRays per batch (the first takes more where the others would
  // need more than kMaxLobeGatherRays each).
  int lobeRays(int b) const;
  static constexpr int kFirstBatchLobeRaysDivisor = 8;
  bool lobeGathering() const { return lobeFilm_.has_value(); }
  float clampBound() const { return clamp_; }
  size_t lightsProcessed() const { return processed_; }
  // Wall seconds the batches not yet done should take, from what the done
  // ones cost (BatchCostModel); nullopt before the first batch, 0 when done.
  std::optional<double> remainingSeconds() const;
  // The same for the next batch alone (nullopt also when every batch is done).
  std::optional<double> nextBatchSeconds() const;
  // Adds batch b (0-based, in order). Returns false if *stop was set, in which
  // case the batch is discarded and the renderer keeps its previous state.
  bool renderBatch(int b, const std::atomic<bool>* stop = nullptr);
  ManyLightImages images() const;
  const ManyLightStats& stats() const { return stats_; }

 private:
  struct Batch;
  struct Tile;
  void gatherTile(Batch& batch, const Gatherer& gatherer, const std::atomic<bool>* stop, int x0, int y0, int x1,
                  int y1);
  // gatherTile's parts: the tile's eye paths, its gather points against the
  // batch's lights (false if stopped), its results into the batch's buffers,
  // and its times and counts.
  void traceTileEyePaths(Batch& batch, const Gatherer& gatherer, Tile& tile) const;
  bool gatherTileLights(Batch& batch, const Gatherer& gatherer, const std::atomic<bool>* stop, Tile& tile) const;
  void writeTile(Batch& batch, const Tile& tile) const;
  void countTile(Batch& batch, const Tile& tile, double tileSeconds);
  void mergeBatch(const Batch& batch, double wallSeconds);
  // The eye paths batch b traces per pixel for its shared light.
  int sharedEyes(int b) const;
  // Batch b's work in BatchCostModel's units.
  BatchCostModel::Units batchUnits(int b) const;

  const Scene& scene_;
  const Accel& accel_;
  const VirtualLightSet& set_;
  std::shared_ptr<const LobeGatherMap> lobeMap_;  // settings.lobeGather > 0
  const std::vector<float>& radii_;
  ManyLightSettings settings_;
  PathTracer direct_;
  int width_, height_;
  float clamp_;
  std::vector<uint32_t> order_;   // random permutation of light indices
  std::vector<size_t> batchEnd_;  // cumulative light counts
  std::vector<int> directEnd_;    // cumulative direct samples
  std::vector<int> sharedEnd_;    // cumulative eye paths for the shared light (Gatherer::kSharedEyePaths)
  size_t processed_ = 0;
  int batchesDone_ = 0;
  BatchCostModel costs_;  // over the batches merged
  // The pair roulette's measure: the luminance VSL and unclamped VPL gathered
  // (roulette weights applied) and the pairs offered to it (gathered or
  // dropped), over the batches merged.
  double rouletteLuminance_ = 0;
  uint64_t roulettePairs_ = 0;
  Film directFilm_, sharedFilm_;  // per-pass averages
  // The lobe gather's estimates (VSL only), one per batch's eye sample,
  // each weighted by its directions (lobeRays), as the eye paths' own
  // (shared) light is by its eye paths (sharedEyes): they do not depend on
  // the batch's lights (weighting them by the batch's share of lights, as
  // the gathered layers are, had 1.4x their variance at 8 batches).
  std::optional<Film> lobeFilm_;  // only with the lobe gather's light set
  std::vector<Film> gather_;      // kGatherLayers films: batch estimates weighted by batch share
  // A batch's per-pixel results, merged into the films only if the batch
  // completes. Kept from batch to batch (every tile overwrites its pixels),
  // so that no batch allocates and clears full-image buffers.
  std::vector<Vec3> batchDirect_, batchShared_, batchLobe_, batchLayers_[kGatherLayers];
  ManyLightStats stats_;
};

// Consistent progressive VSL (after progressive photon mapping): pass i
// (0-based) traces an independent light set and scales every radius by
// sqrt(prod_{k=1..i} (k + alpha) / (k + 1)), so r^2_{i+1} = r^2_i (i + alpha)/(i + 1)
// and the mean of the passes converges to the unbiased image as passes grow.
// alpha in (0, 1); 0.7 is customary.
float progressiveRadiusFactor(int pass, float alpha);

// The VPL clamp bound for these settings: settings.clamp if >= 0, else the
// scene-relative default 1/(pi^2 (0.1 R)^2).
float manyLightClampBound(const Scene& scene, const ManyLightSettings& settings);

// Convenience: trace lights, compute radii and render every batch.
struct ManyLightRun {
  VirtualLightSet set;
  std::vector<float> radii;
  double knnSeconds = 0;
};
ManyLightRun prepareManyLights(const Scene& scene, const Accel& accel, const LightSampler& lights,
                               const ManyLightSettings& settings, const std::atomic<bool>* stop = nullptr);

}  // namespace vsl
