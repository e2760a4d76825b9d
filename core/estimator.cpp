// Sections: [1] names and settings  [2] light sets  [3] brute force  [4] MRCS
//           [5] the factory
#include "core/estimator.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/settings.h"
#include "core/stopwatch.h"

namespace vsl {

// ---- [1] Names and settings ---------------------------------------------------------

namespace {
constexpr std::pair<Method, const char*> kMethodNames[] = {
    {Method::Pt, "pt"}, {Method::Vsl, "vsl"}, {Method::Vpl, "vpl"}, {Method::All, "all"}};
constexpr std::pair<EstimatorKind, const char*> kEstimatorNames[] = {{EstimatorKind::BruteForce, "brute-force"},
                                                                     {EstimatorKind::Mrcs, "mrcs"}};
template <class E, size_t N>
std::optional<E> byName(const std::pair<E, const char*> (&table)[N], std::string_view name) {
  for (auto [e, n] : table)
    if (name == n) return e;
  return std::nullopt;
}

template <class E, size_t N>
const char* nameOf(const std::pair<E, const char*> (&table)[N], E value) {
  for (auto [e, n] : table)
    if (e == value) return n;
  return "?";
}
}  // namespace

std::optional<Method> parseMethod(std::string_view name) { return byName(kMethodNames, name); }
const char* methodName(Method m) { return nameOf(kMethodNames, m); }
std::optional<EstimatorKind> parseEstimatorKind(std::string_view name) { return byName(kEstimatorNames, name); }
const char* estimatorName(EstimatorKind k) { return nameOf(kEstimatorNames, k); }

bool parseMrcsText(const std::string& spec, MrcsSettings& out) {
  size_t pos = 0;
  if (!readInt(spec, pos, out.rows) || pos >= spec.size() || spec[pos++] != ',' || !readInt(spec, pos, out.clusters))
    return false;
  if (pos == spec.size()) return true;
  if (spec[pos] != ',') return false;
  const char* mix = spec.c_str() + pos + 1;
  int usedMix = 0;
  return std::sscanf(mix, "%lf%n", &out.uniformMix, &usedMix) == 1 && mix[usedMix] == 0;
}

Result<void> EstimatorSettings::validateWith(const ManyLightSettings& many) const {
  if (kind == EstimatorKind::Mrcs && many.pairRoulette > 0)
    return Error("pair-roulette: brute force only, not with MRCS");
  return {};
}

Result<void> EstimatorSettings::validate() const {
  if (kind == EstimatorKind::Mrcs)
    if (Result<void> m = mrcs.validate(); !m) return m;
  if (progressiveRadius && !(alpha > 0 && alpha < 1)) {
    std::ostringstream e;
    e << "progressive radius alpha: must be in (0,1) (got " << alpha << ")";
    return Error(e.str());
  }
  return {};
}

std::string EstimatorSettings::describe() const {
  std::ostringstream s;
  s << estimatorName(kind);
  if (kind == EstimatorKind::Mrcs) {
    s << " --mrcs " << mrcs.rows << "," << mrcs.clusters << "," << mrcs.uniformMix;
    if (mrcs.spreadVslRadius) s << " --mrcs-spread";
  }
  if (progressiveRadius) s << " --progressive-radius " << alpha;
  return s.str();
}

// ---- [2] Light sets --------------------------------------------------------------------

LightSetSettings lightSetSettings(const ManyLightSettings& base, const EstimatorSettings& est, int k, int sets) {
  LightSetSettings out{base, est};
  if (est.kind == EstimatorKind::Mrcs && sets > 1)
    out.many.directSamples = std::max(1, (base.directSamples + sets - 1) / sets);
  out.many.seed = base.seed + uint64_t(k);
  if (est.progressiveRadius) {
    const float f = progressiveRadiusFactor(k, est.alpha);
    out.many.radiusScale *= f;
    out.many.globalRadius *= f;
  }
  out.estimator.mrcs.seed = out.many.seed;
  return out;
}

ManyLightRun prepareManyLights(const RenderContext& ctx, const ManyLightSettings& settings,
                               const std::atomic<bool>* stop) {
  return prepareManyLights(ctx.scene(), ctx.accel(), ctx.lights(), settings, stop);
}

// ---- [3] Brute force: progressive light batches ------------------------------------

namespace {

class BruteForceEstimator final : public ManyLightEstimator {
 public:
  BruteForceEstimator(const RenderContext& ctx, ManyLightRun run, const ManyLightSettings& many,
                      const std::atomic<bool>* stop)
      : ManyLightEstimator(std::move(run)),
        renderer_(ctx.scene(), ctx.accel(), ctx.lights(), run_.set, run_.radii, many, stop, &ctx.lobeGatherMaps()) {}
  EstimatorKind kind() const override { return EstimatorKind::BruteForce; }
  bool step(const std::atomic<bool>* stop) override {
    if (done()) return false;
    if (!renderer_.renderBatch(done_, stop)) return false;
    ++done_;
    return true;
  }
  ManyLightImages images() const override { return renderer_.images(); }
  int stepsDone() const override { return done_; }
  int stepCount() const override { return renderer_.batchCount(); }
  std::optional<double> nextStepSeconds() const override { return renderer_.nextBatchSeconds(); }
  std::optional<double> remainingSeconds() const override { return renderer_.remainingSeconds(); }
  size_t lightsProcessed() const override { return renderer_.lightsProcessed(); }
  const ManyLightStats& stats() const override { return renderer_.stats(); }
  int width() const override { return renderer_.width(); }
  int height() const override { return renderer_.height(); }
  float clampBound() const override { return renderer_.clampBound(); }

 private:
  ManyLightRenderer renderer_;  // refers into run_, constructed after it
  int done_ = 0;
};

// ---- [4] MRCS: one step ------------------------------------------------------------------

class MrcsEstimator final : public ManyLightEstimator {
 public:
  MrcsEstimator(const RenderContext& ctx, ManyLightRun run, const ManyLightSettings& many, const MrcsSettings& mrcs,
                MrcsProgress* progress)
      : ManyLightEstimator(std::move(run)), ctx_(ctx), many_(many), mrcs_(mrcs), progress_(progress) {
    width_ = many.width;
    height_ = many.height;
    resolveResolution(ctx.scene(), width_, height_);
    clamp_ = manyLightClampBound(ctx.scene(), many);
  }
  EstimatorKind kind() const override { return EstimatorKind::Mrcs; }
  // The whole of renderMrcs; a stopped render is discarded.
  bool step(const std::atomic<bool>* stop) override {
    if (done()) return false;
    MrcsResult r =
        renderMrcs(ctx_.scene(), ctx_.accel(), ctx_.lights(), run_.set, run_.radii, many_, mrcs_, stop, progress_);
    if (r.stopped) return false;
    images_ = std::move(r.images);
    mrcsStats_ = {r.rowSeconds,     r.clusterSeconds, r.columnSeconds, r.lobeSeconds,
                  r.zeroColumnsVsl, r.zeroColumnsVpl, r.rowsUsed,      r.clustersUsed};
    const double seconds = r.rowSeconds + r.clusterSeconds + r.columnSeconds;
    stats_.pairs = r.pairs;
    stats_.nonFinite = r.nonFinite;
    stats_.gatherSeconds = seconds + r.lobeSeconds;
    stats_.vslSeconds = many_.computeVsl ? seconds + r.lobeSeconds : 0;
    stats_.vplSeconds = many_.computeVpl ? seconds : 0;
    done_ = true;
    return true;
  }
  // Black layers until the step is done.
  ManyLightImages images() const override {
    if (done_) return images_;
    ManyLightImages black;
    for (Image* img : {&black.direct, &black.vsl, &black.vpl, &black.vplUnclamped, &black.vplDiffuse,
                       &black.lostToClamping, &black.lostToDiffuse})
      *img = Image(width_, height_);
    return black;
  }
  int stepsDone() const override { return done_ ? 1 : 0; }
  int stepCount() const override { return 1; }
  // Its one step is not measured before it ends.
  std::optional<double> remainingSeconds() const override { return done_ ? std::optional<double>(0.0) : std::nullopt; }
  size_t lightsProcessed() const override { return done_ ? run_.set.lights.size() : 0; }
  const ManyLightStats& stats() const override { return stats_; }
  MrcsStats mrcsStats() const override { return mrcsStats_; }
  int width() const override { return width_; }
  int height() const override { return height_; }
  float clampBound() const override { return clamp_; }

 private:
  const RenderContext& ctx_;
  ManyLightSettings many_;
  MrcsSettings mrcs_;
  MrcsProgress* progress_;
  int width_ = 0, height_ = 0;
  float clamp_ = 0;
  bool done_ = false;
  ManyLightImages images_;
  ManyLightStats stats_;
  MrcsStats mrcsStats_;
};

}  // namespace

// ---- [5] The factory ----------------------------------------------------------------------

std::unique_ptr<ManyLightEstimator> makeEstimator(const RenderContext& ctx, ManyLightRun run,
                                                  const ManyLightSettings& many, const EstimatorSettings& est,
                                                  MrcsProgress* progress, const std::atomic<bool>* stop) {
  VSL_CHECK(many.validate().ok());
  VSL_CHECK(est.validate().ok());
  if (est.kind == EstimatorKind::Mrcs)
    return std::make_unique<MrcsEstimator>(ctx, std::move(run), many, est.mrcs, progress);
  return std::make_unique<BruteForceEstimator>(ctx, std::move(run), many, stop);
}

}  // namespace vsl
