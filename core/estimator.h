// The many-light estimator seam: one interface over the ways of gathering a
// virtual light set into images, chosen by an enum class, never by name.
// Nori's Integrator is the model: a preprocess (here prepareManyLights:
// light tracing and VSL radii, on a RenderContext) and then an estimator
// that advances in steps.
//
// Estimators (EstimatorKind)
//   BruteForce  every (pixel, light) pair, in progressive light batches of
//               growing size (ManyLightRenderer, many_light.h); one step is
//               one batch, and after each step the images are an unbiased
//               estimate of the all-lights image.
//   Mrcs        matrix row-column sampling (renderMrcs, mrcs.h); one step
//               renders rows, clusters and representative columns. Bias:
//               lights dark at every sampled row are dropped.
// Progressive variants (independent light sets averaged pass by pass, the
// VSL radius optionally shrinking per pass, progressiveRadiusFactor) are a
// sequence of estimators, one per light set; lightSetSettings() gives pass
// k's settings so that the studio and the sweep agree on them.
//
// Thread-safety: an estimator is driven from one thread; step() itself runs
// in parallel (parallel.h). Its stop flag is checked every 16 lights within
// a tile (brute force), and per light (rows) and per representative and
// image row (columns) in MRCS.
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "core/many_light.h"
#include "core/mrcs.h"
#include "core/render_context.h"

namespace vsl {

// What a front end renders: the path-traced reference, or a gather of one
// virtual light set as VSL, as clamped VPL, or both (with every VPL layer).
enum class Method { Pt, Vsl, Vpl, All };
std::optional<Method> parseMethod(std::string_view name);  // "pt", "vsl", "vpl", "all"
const char* methodName(Method m);

// How the gather is estimated.
enum class EstimatorKind { BruteForce, Mrcs };
std::optional<EstimatorKind> parseEstimatorKind(std::string_view name);  // "brute-force", "mrcs"
const char* estimatorName(EstimatorKind k);

// The text of `--mrcs`: ROWS,CLUSTERS then optionally ,MIX, and nothing after
// ("10,20x" is refused). Fills out's rows, clusters and mix; true when the
// text has that form (the values are checked by MrcsSettings::validate()).
bool parseMrcsText(const std::string& text, MrcsSettings& out);

// The estimator and its settings; a plain value with named defaults.
struct EstimatorSettings {
  EstimatorKind kind = EstimatorKind::BruteForce;
  // Kind Mrcs: rows, clusters, representative choice. mrcs.seed is used as
  // given (the CLI keeps 0; the sweep and the studio derive it per light set).
  MrcsSettings mrcs;
  // Progressive passes (studio light sets, sweep passes): pass k's VSL radii
  // are scaled by progressiveRadiusFactor(k, alpha), the consistent
  // progressive VSL. Off: every pass has the same radii.
  bool progressiveRadius = false;
  float alpha = kDefaultAlpha;
  static constexpr float kDefaultAlpha = 0.7f;
  Result<void> validate() const;  // the first invalid setting
  // What this estimator refuses of the many-light settings: MRCS samples its
  // rows and columns already, so the pair roulette is brute force's only
  // ("pair-roulette: brute force only, not with MRCS"). One rule for the
  // CLI, the sweep, the studio's command line and its session.
  Result<void> validateWith(const ManyLightSettings& many) const;
  std::string describe() const;  // e.g. "mrcs --mrcs 300,900,0 --progressive-radius 0.7"
};

// Light set k of a progressive run of `sets` light sets (0-based): seed
// base.seed + k, radii shrunk per EstimatorSettings::progressiveRadius, and
// MRCS seeded with the set's seed. An MRCS set also gets its share of the
// direct-light samples, ceil(base.directSamples / sets): MRCS renders a set's
// direct light in one step before its picture (at 512x512, 64 samples per
// pixel took 4.6 s of a 27 s first picture), where brute force spreads them
// over its batches; the mean of `sets` sets then has base.directSamples or
// more. The studio fixes `sets` when a render begins (a later change of the
// set count keeps each set's share).
// Both the studio's Session and tests use it.
struct LightSetSettings {
  ManyLightSettings many;
  EstimatorSettings estimator;
};
LightSetSettings lightSetSettings(const ManyLightSettings& base, const EstimatorSettings& est, int k, int sets = 1);

// Light tracing and radii on a context (prepareManyLights, many_light.h).
ManyLightRun prepareManyLights(const RenderContext& ctx, const ManyLightSettings& settings,
                               const std::atomic<bool>* stop = nullptr);

// Statistics particular to MRCS (zero for brute force).
struct MrcsStats {
  double rowSeconds = 0, clusterSeconds = 0, columnSeconds = 0;
  double lobeSeconds = 0;  // the lobe gather's (MrcsResult::lobeSeconds), part of the eye paths' time
  size_t zeroColumnsVsl = 0, zeroColumnsVpl = 0;
  int rowsUsed = 0, clustersUsed = 0;  // MrcsResult's: the settings' capped at the pixels and the lights
};

class ManyLightEstimator {
 public:
  virtual ~ManyLightEstimator() = default;
  virtual EstimatorKind kind() const = 0;
  // Advances by one step. False, with the estimator as it was before the
  // step, if *stop was set or every step is done.
  virtual bool step(const std::atomic<bool>* stop = nullptr) = 0;
  // The current images (all seven layers, each of width() x height(); a
  // layer an estimator does not compute is black).
  virtual ManyLightImages images() const = 0;
  virtual int stepsDone() const = 0;
  virtual int stepCount() const = 0;
  // Wall seconds the next step should take, from what the done ones cost
  // (what a caller with a time budget asks before it steps again); nullopt
  // while nothing is measured or when every step is done.
  virtual std::optional<double> nextStepSeconds() const { return std::nullopt; }
  bool done() const { return stepsDone() >= stepCount(); }
  // Wall seconds the steps not yet done should take, from what the done ones
  // cost; nullopt while nothing is measured, 0 when done.
  virtual std::optional<double> remainingSeconds() const = 0;
  // Lights gathered so far, of run().set.lights.size().
  virtual size_t lightsProcessed() const = 0;
  // Work so far. MRCS charges its whole time to both methods' own seconds
  // (rows, clustering and columns are done for VSL and VPL together).
  virtual const ManyLightStats& stats() const = 0;
  virtual MrcsStats mrcsStats() const { return {}; }
  virtual int width() const = 0;
  virtual int height() const = 0;
  virtual float clampBound() const = 0;
  // The light set being gathered (owned by the estimator).
  const ManyLightRun& run() const { return run_; }

 protected:
  explicit ManyLightEstimator(ManyLightRun run) : run_(std::move(run)) {}
  ManyLightRun run_;
};

// An estimator of the light set `run` (moved in) on ctx, which must outlive
// it. many and est must be valid, together too (VSL_CHECK). An MRCS
// estimator reports its stages to `progress` (which must outlive it) while a
// step runs. `stop` ends the preparation some estimators do (the lobe
// gather's second light set); an estimator made while it was set is not to
// be used.
std::unique_ptr<ManyLightEstimator> makeEstimator(const RenderContext& ctx, ManyLightRun run,
                                                  const ManyLightSettings& many, const EstimatorSettings& est,
                                                  MrcsProgress* progress = nullptr,
                                                  const std::atomic<bool>* stop = nullptr);

}  // namespace vsl
