// The many-light estimator seam: one interface over the ways of gathering a
// virtual light set into images. Nori's Integrator is the model: a
// preprocess (here prepareManyLights: light tracing and VSL radii, on a
// RenderContext) and then an estimator that advances in steps.
//
// Estimators are plug-ins (core/estimator_registry.h), chosen by their
// registered name; nothing outside a plug-in's folder (core/estimators/NAME/)
// knows which estimator it drives. Today's: "brute-force" (every (pixel,
// light) pair in progressive light batches, ManyLightRenderer) and "mrcs"
// (matrix row-column sampling in one step per light set, renderMrcs).
// Progressive variants (independent light sets averaged pass by pass, the
// VSL radius optionally shrinking per pass, progressiveRadiusFactor) are a
// sequence of estimators, one per light set; lightSetSettings() gives pass
// k's settings so that the studio and the sweep agree on them.
//
// Thread-safety: an estimator is driven from one thread; step() itself runs
// in parallel (parallel.h) and checks its stop flag often (every 16 lights
// within a tile for brute force; per light, representative and image row
// for MRCS).
#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/many_light.h"
#include "core/render_context.h"

namespace vsl {

// What a front end renders: the path-traced reference, or a gather of one
// virtual light set as VSL, as clamped VPL, or both (with every VPL layer).
enum class Method { Pt, Vsl, Vpl, All };
std::optional<Method> parseMethod(std::string_view name);  // "pt", "vsl", "vpl", "all"
const char* methodName(Method m);

// The estimator and its settings; a plain value with named defaults. The
// parameters are held generically, by name, and declared by the plug-ins
// (estimatorParams(), estimator_registry.h).
struct EstimatorSettings {
  static constexpr const char* kDefaultName = "brute-force";
  std::string name = kDefaultName;  // a registered estimator
  // Parameter values by parameter name ("mrcs-rows"); one not here has its
  // registered default. Another estimator's values may stay here (the studio
  // keeps them while that one is not chosen); they are ignored.
  std::map<std::string, double> values;
  // The estimator's own random choices (MRCS's rows and representatives):
  // used as given (the CLI keeps 0; the sweep and the studio derive it per
  // light set, lightSetSettings).
  uint64_t seed = 0;
  // Progressive passes (studio light sets, sweep passes): pass k's VSL radii
  // are scaled by progressiveRadiusFactor(k, alpha), the consistent
  // progressive VSL. Off: every pass has the same radii.
  bool progressiveRadius = false;
  float alpha = kDefaultAlpha;
  static constexpr float kDefaultAlpha = 0.7f;
  // A parameter's value: values' entry or its registered default. The
  // parameter must be registered (VSL_CHECK).
  double value(std::string_view param) const;
  // The first invalid setting: an unknown name, a parameter of the chosen
  // estimator out of range (or refused by its own check), the alpha.
  Result<void> validate() const;
  // What the chosen estimator refuses of the many-light settings (MRCS: the
  // pair roulette, "pair-roulette: brute force only, not with MRCS"). One
  // rule for the CLI, the sweep, the studio's command line and its session.
  Result<void> validateWith(const ManyLightSettings& many) const;
  // e.g. "mrcs --mrcs 300,900,0 --progressive-radius 0.7".
  std::string describe() const;
  // The chosen estimator's parameters alone, as options (" --mrcs 300,900,0").
  std::string describeParams() const;
  // The same estimator with the same parameter values and progressive
  // radius (values of estimators not chosen do not count).
  bool sameEstimate(const EstimatorSettings& other) const;
};

// Light set k of a progressive run of `sets` light sets (0-based): seed
// base.seed + k, radii shrunk per EstimatorSettings::progressiveRadius, and
// the estimator seeded with the set's seed. An estimator that renders a
// whole set in one step (EstimatorInfo::wholeSetPerStep: MRCS) also gives
// each set its share of the direct-light samples,
// ceil(base.directSamples / sets): it renders a set's direct light in one
// step before its picture (MRCS at 512x512: 64 samples per pixel took 4.6 s
// of a 27 s first picture), where brute force spreads them over its
// batches; the mean of `sets` sets then has base.directSamples or more. The studio fixes `sets` when a render begins (a
// later change of the set count keeps each set's share). Both the studio's Session and tests use it.
struct LightSetSettings {
  ManyLightSettings many;
  EstimatorSettings estimator;
};
LightSetSettings lightSetSettings(const ManyLightSettings& base, const EstimatorSettings& est, int k, int sets = 1);

// Light tracing and radii on a context (prepareManyLights, many_light.h).
ManyLightRun prepareManyLights(const RenderContext& ctx, const ManyLightSettings& settings,
                               const std::atomic<bool>* stop = nullptr);

// A long step's progress (an MRCS light set: seconds to minutes), for a
// caller that shows it while step() runs on another thread. The caller owns
// it and hands it to makeEstimator; an estimator with such steps attaches
// its own report (a StepProgressSource) while it lives. Read from any thread.
class StepProgressSource {
 public:
  virtual std::string progressText() const = 0;  // "MRCS columns 43%"; "" when idle or done
  virtual double progressShare() const = 0;      // the step's share done, in [0, 1]
 protected:
  ~StepProgressSource() = default;
};

class StepProgress {
 public:
  std::string text() const;  // the attached source's, or ""
  double share() const;      // the attached source's, or 0
  // Optional: called on the stepping thread by a step whose VSL image is
  // complete before its VPL image (MRCS, mrcs.h MrcsProgress::onVslImage),
  // with the direct and vsl layers set and the others black. Set and cleared
  // by the caller between steps.
  std::function<void(const ManyLightImages&)> onVslImage;
  // The estimator's, from its making to its end. detach() leaves a source
  // attached since in place (an estimator made before another ended).
  void attach(const StepProgressSource* source);
  void detach(const StepProgressSource* source);

 private:
  mutable std::mutex mutex_;
  const StepProgressSource* source_ = nullptr;
};

// What a step has to say, for the CLI's stderr and the studio's log: its
// stages' times, and what it did otherwise than asked (MRCS: rows capped at
// the pixels).
struct StepReport {
  std::vector<std::string> info, warnings;
};

class ManyLightEstimator {
 public:
  virtual ~ManyLightEstimator() = default;
  virtual const std::string& name() const = 0;  // the registered name
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
  // The estimator's own statistics as key/value pairs ("rowsUsed", 300), for
  // metrics.json and render's JSON; empty for none.
  virtual std::vector<std::pair<std::string, double>> statistics() const { return {}; }
  // What the last step has to say, given its wall time (which may include a
  // caller's work in StepProgress::onVslImage).
  virtual StepReport stepReport(double stepSeconds) const { return {}; }
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
// it, by est.name (estimator_registry.h). many and est must be valid,
// together too (VSL_CHECK). An estimator with long steps reports them to
// `progress` (which must outlive it). `stop` ends the preparation some
// estimators do (the lobe gather's second light set); an estimator made
// while it was set is not to be used.
std::unique_ptr<ManyLightEstimator> makeEstimator(const RenderContext& ctx, ManyLightRun run,
                                                  const ManyLightSettings& many, const EstimatorSettings& est,
                                                  StepProgress* progress = nullptr,
                                                  const std::atomic<bool>* stop = nullptr);

}  // namespace vsl
