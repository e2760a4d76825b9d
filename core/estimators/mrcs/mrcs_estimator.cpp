// Matrix row-column sampling as an estimator: Hasan, Pellacini, Bala,
// "Matrix Row-Column Sampling for the Many-Light Problem" (SIGGRAPH 2007),
// for the VSL and clamped VPL gathers (renderMrcs, core/mrcs.h). One step
// renders a whole light set: rows, clusters and representative columns.
//
// Parameters (docs/REFERENCE.md, "MRCS and progressive radius"):
//   mrcs-rows      300  pixels computed against every light
//   mrcs-clusters  900  clusters, one representative column each
//   mrcs-mix       0    uniform share of the representative choice (ours)
//   mrcs-spread    off  VSL representatives get radius r sqrt(weight) (ours)
// Shorthand: --mrcs ROWS,CLUSTERS[,MIX]. Its random choices are seeded by
// EstimatorSettings::seed (per light set, lightSetSettings).
// Bias: lights dark at every sampled row are dropped; otherwise unbiased
// over the representative choice for a fixed clustering. It refuses the
// pair roulette (its rows and columns sample the pairs already).
#include "core/estimators/mrcs/mrcs_estimator.h"

#include <cstdio>
#include <sstream>

#include "core/estimator_registry.h"
#include "core/gather.h"
#include "core/settings.h"

namespace vsl {

MrcsSettings mrcsSettings(const EstimatorSettings& est) {
  MrcsSettings m;
  m.rows = int(est.value("mrcs-rows"));
  m.clusters = int(est.value("mrcs-clusters"));
  m.uniformMix = est.value("mrcs-mix");
  m.spreadVslRadius = est.value("mrcs-spread") != 0;
  m.seed = est.seed;
  return m;
}

EstimatorSettings mrcsEstimatorSettings(const MrcsSettings& m) {
  EstimatorSettings e;
  e.name = "mrcs";
  e.values = {{"mrcs-rows", m.rows},
              {"mrcs-clusters", m.clusters},
              {"mrcs-mix", m.uniformMix},
              {"mrcs-spread", m.spreadVslRadius ? 1.0 : 0.0}};
  e.seed = m.seed;
  return e;
}

namespace {

std::string secondsText(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f s", s);
  return text;
}

// ---- The estimator: one step per light set ----------------------------------------------

class MrcsEstimator final : public ManyLightEstimator, private StepProgressSource {
 public:
  MrcsEstimator(const RenderContext& ctx, ManyLightRun run, const ManyLightSettings& many, const MrcsSettings& mrcs,
                StepProgress* progress)
      : ManyLightEstimator(std::move(run)), ctx_(ctx), many_(many), mrcs_(mrcs), progress_(progress) {
    width_ = many.width;
    height_ = many.height;
    resolveResolution(ctx.scene(), width_, height_);
    clamp_ = manyLightClampBound(ctx.scene(), many);
    if (progress_) progress_->attach(this);
  }
  ~MrcsEstimator() override {
    if (progress_) progress_->detach(this);
  }
  const std::string& name() const override {
    static const std::string kName = "mrcs";
    return kName;
  }
  bool step(const std::atomic<bool>* stop) override;
  ManyLightImages images() const override;
  int stepsDone() const override { return done_ ? 1 : 0; }
  int stepCount() const override { return 1; }
  // Its one step is not measured before it ends.
  std::optional<double> remainingSeconds() const override { return done_ ? std::optional<double>(0.0) : std::nullopt; }
  size_t lightsProcessed() const override { return done_ ? run_.set.lights.size() : 0; }
  const ManyLightStats& stats() const override { return stats_; }
  std::vector<std::pair<std::string, double>> statistics() const override;
  StepReport stepReport(double stepSeconds) const override;
  int width() const override { return width_; }
  int height() const override { return height_; }
  float clampBound() const override { return clamp_; }

 private:
  std::string progressText() const override { return mp_.text(); }
  double progressShare() const override { return mp_.overall(); }

  const RenderContext& ctx_;
  ManyLightSettings many_;
  MrcsSettings mrcs_;
  StepProgress* progress_;
  MrcsProgress mp_;  // the render's stages, shown through progress_
  int width_ = 0, height_ = 0;
  float clamp_ = 0;
  bool done_ = false;
  ManyLightImages images_;
  ManyLightStats stats_;
  MrcsResult last_;  // its timings and counts (images moved out)
};

// The whole of renderMrcs; a stopped render is discarded. The caller's VSL
// hook (StepProgress::onVslImage) is passed on for the step.
bool MrcsEstimator::step(const std::atomic<bool>* stop) {
  if (done()) return false;
  mp_.onVslImage = progress_ ? progress_->onVslImage : nullptr;
  MrcsResult r = renderMrcs(ctx_.scene(), ctx_.accel(), ctx_.lights(), run_.set, run_.radii, many_, mrcs_, stop, &mp_);
  mp_.onVslImage = nullptr;
  if (r.stopped) return false;
  images_ = std::move(r.images);
  const double seconds = r.rowSeconds + r.clusterSeconds + r.columnSeconds;
  stats_.pairs = r.pairs;
  stats_.nonFinite = r.nonFinite;
  stats_.gatherSeconds = seconds + r.lobeSeconds;
  stats_.vslSeconds = many_.computeVsl ? seconds + r.lobeSeconds : 0;
  stats_.vplSeconds = many_.computeVpl ? seconds : 0;
  last_ = std::move(r);
  done_ = true;
  return true;
}

// Black layers until the step is done.
ManyLightImages MrcsEstimator::images() const {
  if (done_) return images_;
  ManyLightImages black;
  for (Image* img : {&black.direct, &black.vsl, &black.vpl, &black.vplUnclamped, &black.vplDiffuse,
                     &black.lostToClamping, &black.lostToDiffuse})
    *img = Image(width_, height_);
  return black;
}

std::vector<std::pair<std::string, double>> MrcsEstimator::statistics() const {
  const MrcsResult& r = last_;
  return {{"rowSeconds", r.rowSeconds},
          {"clusterSeconds", r.clusterSeconds},
          {"columnSeconds", r.columnSeconds},
          {"lobeGatherSeconds", r.lobeSeconds},
          {"zeroColumnsVsl", double(r.zeroColumnsVsl)},
          {"zeroColumnsVpl", double(r.zeroColumnsVpl)},
          {"rowsUsed", r.rowsUsed},
          {"clustersUsed", r.clustersUsed}};
}

// The step's stages (the measured breakdown of an MRCS picture's wait;
// docs/notebook/2026-12-02-studio-interactivity.md), and the rows and
// clusters it could not use.
StepReport MrcsEstimator::stepReport(double stepSeconds) const {
  const MrcsResult& r = last_;
  StepReport out;
  if (!done_) return out;
  const double eye = std::max(stepSeconds - r.rowSeconds - r.clusterSeconds - r.columnSeconds, 0.0);
  out.info.push_back("MRCS " + secondsText(stepSeconds) + " (eye paths and direct light " + secondsText(eye) +
                     (r.lobeSeconds > 0 ? " with the lobe gather's " + secondsText(r.lobeSeconds) : std::string()) +
                     ", rows " + secondsText(r.rowSeconds) + ", clustering " + secondsText(r.clusterSeconds) +
                     ", columns " + secondsText(r.columnSeconds) + ")");
  if (r.rowsUsed < mrcs_.rows)
    out.warnings.push_back(std::to_string(mrcs_.rows) + " MRCS rows for " + std::to_string(width_ * height_) +
                           " pixels: " + std::to_string(r.rowsUsed) + " used (every pixel a row)");
  if (r.clustersUsed < mrcs_.clusters)
    out.warnings.push_back(std::to_string(mrcs_.clusters) + " MRCS clusters for " +
                           std::to_string(run_.set.lights.size()) + " lights: a cluster per light");
  return out;
}

// ---- Its parameters ---------------------------------------------------------------------

std::vector<EstimatorParam> mrcsParams() {
  constexpr ParamTier X = ParamTier::Experimental;
  return {
      {{.name = "mrcs-rows",
        .key = "mrcsRows",
        .kind = ParamKind::Int,
        .appliesTo = "VSL, VPL",
        .min = 1,
        .max = 100000,
        .unit = "rows",
        .help = "MRCS: sampled pixels computed against every light (capped at the pixels)",
        .why = "issue 5's scale target: 100,000 lights at 512x512 within 60 s took 19.6 s "
               "([RESULTS](RESULTS.md#scale-and-mrcs))",
        .uiMin = 10,
        .uiMax = 4000,
        .uiLog = true},
       300},
      {{.name = "mrcs-clusters",
        .key = "mrcsClusters",
        .kind = ParamKind::Int,
        .appliesTo = "VSL, VPL",
        .min = 1,
        .max = 1000000,
        .unit = "clusters",
        .help = "MRCS: light clusters, one representative column rendered each (capped at the lights)",
        .why = "issue 5's scale target: 100,000 lights at 512x512 within 60 s took 19.6 s "
               "([RESULTS](RESULTS.md#scale-and-mrcs))",
        .uiMin = 10,
        .uiMax = 20000,
        .uiLog = true},
       900},
      {{.name = "mrcs-mix",
        .key = "mrcsMix",
        .tier = X,
        .appliesTo = "VSL, VPL",
        .min = 0,
        .max = 1,
        .help = "MRCS: uniform share of the representative choice (0: the paper's norm-proportional choice)",
        .why = "a uniform share bounds a representative's weight; helped little (0.162 -> 0.144) "
               "([notebook](notebook/2026-11-22-scale-and-mrcs.md))",
        .quiet = 0,
        .uiMin = 0,
        .uiMax = 1},
       MrcsSettings::kDefaultUniformMix},
      {{.name = "mrcs-spread",
        .key = "mrcsSpread",
        .kind = ParamKind::Flag,
        .tier = X,
        .help = "MRCS: a VSL representative of weight w gets radius r sqrt(w) (fewer blobs; about 10% darker, "
                "slower)",
        .why = "fewer blobs but 9-11% darker and slower ([notebook](notebook/2026-11-22-scale-and-mrcs.md))",
        .quiet = 0},
       0},
  };
}

// --mrcs ROWS,CLUSTERS[,MIX], and nothing after ("10,20x" is refused); the
// values' ranges are checked by validate().
Result<void> parseShorthand(const std::string& spec, EstimatorSettings& out) {
  MrcsSettings m;
  size_t pos = 0;
  bool ok = readInt(spec, pos, m.rows) && pos < spec.size() && spec[pos++] == ',' && readInt(spec, pos, m.clusters);
  if (ok && pos < spec.size()) {
    const char* mix = spec.c_str() + pos + 1;
    int used = 0;
    ok = spec[pos] == ',' && std::sscanf(mix, "%lf%n", &m.uniformMix, &used) == 1 && mix[used] == 0;
  }
  if (!ok)
    return Error("--mrcs must be ROWS,CLUSTERS with positive integers, optionally ,MIX in [0,1] (got '" + spec + "')");
  out.name = "mrcs";
  out.values["mrcs-rows"] = m.rows;
  out.values["mrcs-clusters"] = m.clusters;
  // Read as --mrcs-mix reads it (core/params.h: a Real parameter's value is
  // a float's), so that both spellings give the same bits.
  out.values["mrcs-mix"] = double(float(m.uniformMix));
  return {};
}

// The shorthand as describe() has always printed it ("--mrcs 300,900,0").
std::string describeMrcs(const EstimatorSettings& e) {
  const MrcsSettings m = mrcsSettings(e);
  std::ostringstream s;
  s << " --mrcs " << m.rows << "," << m.clusters << "," << m.uniformMix;
  if (m.spreadVslRadius) s << " --mrcs-spread";
  return s.str();
}

// At its peak, the clustering: every light decoded (brute force counts a
// quarter), the reduced columns of both methods (rows floats each), and the
// clustering's column space (norm, index, 32-float projection) with its
// seeding and assignment arrays (~20 B). Per pixel, one eye sample (the
// gather points of the column stage) and its shared light.
ExtraMemory mrcsMemory(const EstimatorSettings& e, uint64_t pixels) {
  const uint64_t rows = uint64_t(mrcsSettings(e).rowsFor(pixels));
  return {sizeof(GatherLight) - sizeof(GatherLight) / 4 + 2 * rows * sizeof(float) + sizeof(double) + sizeof(uint32_t) +
              32 * sizeof(float) + 20,
          sizeof(EyeSample) + sizeof(Vec3)};
}

}  // namespace

namespace plugins {
EstimatorInfo mrcs();
}

// The registration function core/estimator_registry.cpp calls (its name is
// this folder's, from core/CMakeLists.txt's vsl_estimator(mrcs)).
EstimatorInfo plugins::mrcs() {
  EstimatorInfo e;
  e.name = "mrcs";
  e.label = "MRCS (row-column sampling)";
  e.help =
      "Matrix row-column sampling: ROWS sampled pixels against every light, the lights clustered into "
      "CLUSTERS, one representative column rendered per cluster; one step per light set";
  e.params = mrcsParams();
  e.wholeSetPerStep = true;
  e.vplVariants = false;
  e.countsNotKept = "MRCS counts its pairs, not its shadow rays or VSL quadrature draws";
  e.shorthand = "mrcs";
  e.shorthandHelp =
      "Matrix row-column sampling: ROWS,CLUSTERS[,MIX] (e.g. 300,900; MIX: uniform share of the representative "
      "choice); sets --mrcs-rows, --mrcs-clusters and --mrcs-mix";
  e.parseShorthand = parseShorthand;
  e.describe = describeMrcs;
  e.validate = [](const EstimatorSettings& s) { return mrcsSettings(s).validate(); };
  e.validateWith = [](const ManyLightSettings& many, const EstimatorSettings&) -> Result<void> {
    if (many.pairRoulette > 0) return Error("pair-roulette: brute force only, not with MRCS");
    return {};
  };
  e.memory = mrcsMemory;
  e.create = [](const RenderContext& ctx, ManyLightRun run, const ManyLightSettings& many, const EstimatorSettings& est,
                StepProgress* progress, const std::atomic<bool>*) -> std::unique_ptr<ManyLightEstimator> {
    return std::make_unique<MrcsEstimator>(ctx, std::move(run), many, mrcsSettings(est), progress);
  };
  return e;
}

}  // namespace vsl
