// Sections: [1] settings and the public interface  [2] the worker loop
//           [3] scenes  [4] preparing a job  [5] rendering and snapshots
#include "core/session.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <new>
#include <sstream>

#include "core/compare.h"
#include "core/estimator_registry.h"
#include "core/log.h"
#include "core/memory_budget.h"
#include "core/parallel.h"
#include "core/params.h"

namespace vsl {

namespace {

// The path depth of the live path tracer and of the references it looks up.
const int kReferenceDepth = RenderSettings().maxDepth;

// "12.34 s", for the log's stage timings.
std::string secondsText(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f s", s);
  return text;
}

}  // namespace

// describe() covers the user-facing settings; the rest are compared by hand.
bool sameImageSettings(const StudioSettings& a, const StudioSettings& b) {
  const bool sameEstimator = a.estimator.sameEstimate(b.estimator);
  return a.scene == b.scene && a.env == b.env && a.maxReferenceSpp == b.maxReferenceSpp &&
         a.many.describe() == b.many.describe() && a.many.lightMaxDepth == b.many.lightMaxDepth &&
         a.many.computeVsl == b.many.computeVsl && a.many.computeVpl == b.many.computeVpl && sameEstimator;
}

namespace {

// The work of completed light sets, summed.
struct SetTotals {
  double tracingSeconds = 0, knnSeconds = 0, gatherSeconds = 0, vslSeconds = 0, vplSeconds = 0;
  // Each method's own time over the sets it gathers: VSL's tracing, k-NN
  // radii and its share of the gather, VPL's tracing and its share.
  double vslOwnSeconds = 0, vplOwnSeconds = 0;
  uint64_t pairs = 0, vslEvaluations = 0, nonFinite = 0, rouletteDropped = 0;
  size_t lights = 0;  // traced and gathered
};

// The many-light layers averaged over light sets, in the order of
// ManyLightImages; the four indirect layers (kIndirectLayers) also keep each
// set's image for biasVariance.
constexpr int kLayers = 7, kIndirectLayers = 4;
Image ManyLightImages::*const kLayer[kLayers] = {&ManyLightImages::vsl,          &ManyLightImages::vpl,
                                                 &ManyLightImages::vplUnclamped, &ManyLightImages::vplDiffuse,
                                                 &ManyLightImages::direct,       &ManyLightImages::lostToClamping,
                                                 &ManyLightImages::lostToDiffuse};

// The layers a method alone makes: VSL's image, or clamped VPL's and its
// variants' (the direct light is shared).
bool methodLayer(StudioMethod method, int l) {
  const Image ManyLightImages::*m = kLayer[l];
  if (method == StudioMethod::Vsl) return m == &ManyLightImages::vsl;
  return method == StudioMethod::Vpl &&
         (m == &ManyLightImages::vpl || m == &ManyLightImages::vplUnclamped || m == &ManyLightImages::vplDiffuse ||
          m == &ManyLightImages::lostToClamping || m == &ManyLightImages::lostToDiffuse);
}

// An indirect image with the direct light added: the full component, which a
// full-only reference is compared on (Snapshot::comparesFull). Unchanged when
// the direct image has no picture of that size yet.
Image withDirect(const Image& direct, const Image& indirect) {
  if (direct.width != indirect.width || direct.height != indirect.height) return indirect;
  return sum(direct, indirect);
}

// Both times left in wall-clock time (manyLeft: the many-light methods'
// compute seconds): the reference and the many-light methods take turns
// (equal time, Session::render()), so while neither is done each advances at
// about half its own rate.
void wallClockTimesLeft(double manyLeft, Snapshot& snap) {
  const double many = snap.manyLightDone ? 0.0 : manyLeft;
  const double reference = snap.referenceDone ? 0.0 : snap.referenceRemainingSeconds;
  snap.manyRemainingSeconds = many + std::min(many, reference);
  snap.referenceRemainingSeconds = reference + std::min(many, reference);
}

}  // namespace

// A render in progress: its light sets, estimators and bookkeeping.
struct Session::Job {
  StudioSettings settings;
  int width = 0, height = 0, batchCount = 0;
  float clampBound = 0;
  // The light set in progress, number `set` (seed settings.many.seed + set);
  // ml is null between sets and once all are done.
  int set = 0;
  std::unique_ptr<ManyLightEstimator> ml;  // the set in progress (it owns its lights), if any
  int batch = 0;
  // The set count the render began with: each set's share of the direct
  // samples follows it (lightSetSettings) and stays fixed if the count
  // changes later, so that every set's direct light has as many samples.
  int directShareSets = 1;
  // The completed sets: their count, work, per-pixel sums (double, in set
  // order) and the indirect images of each (biasVariance needs them all).
  int setsDone = 0;
  SetTotals done;
  std::vector<double> sum[kLayers];
  std::vector<Image> setImages[kIndirectLayers];
  ManyLightImages mean;                                  // sum / setsDone, once a set is done
  double mlSeconds = 0;                                  // light tracing, k-NN and gathering, every set
  double ptStart = 0;                                    // the reference's compute time when the job began
  int sppStart = 0;                                      // and its sample count
  float radiusMin = 0, radiusMedian = 0, radiusMax = 0;  // of the newest set
  Stopwatch clock;                                       // wall clock since the job's start
  std::vector<ErrorSample> history;
  int backgroundSpp = 0;
  // The newest completed set's estimator statistics (ManyLightEstimator::statistics).
  std::vector<std::pair<std::string, double>> lastStats;
  // One method's completed sets taken over from the job this one replaced,
  // whose settings differed only in the other method's parameters
  // (unchangedFor, docs/USAGE.md "One-method restarts"): sets [0, keptSets)
  // are gathered for the other method alone, and the kept method's layers,
  // already in sum, setImages and mean, are the kept ones. keptLayerSets
  // counts the sets in those layers' sums. kept is Pt when nothing is kept.
  StudioMethod kept = StudioMethod::Pt;
  int keptSets = 0, keptLayerSets = 0;
  double keptSeconds = 0;  // the kept method's own time in the job it replaced
  bool keptLayer(int l) const { return methodLayer(kept, l); }
  bool gathers(StudioMethod m, int k) const { return m != kept || k >= keptSets; }
  // Sets in layer l's sums.
  int layerSets(int l) const { return keptLayer(l) ? keptLayerSets : setsDone; }
  // A method's own clock: the kept time, the sets retired, the set in progress.
  double ownSeconds(StudioMethod m) const {
    double current = 0;
    if (ml && gathers(m, set)) {
      const ManyLightRun& run = ml->run();
      current = m == StudioMethod::Vsl ? run.set.seconds + run.knnSeconds + ml->stats().vslSeconds
                                       : run.set.seconds + ml->stats().vplSeconds;
    }
    const double retired = m == StudioMethod::Vsl ? done.vslOwnSeconds : done.vplOwnSeconds;
    return (m == kept ? keptSeconds : 0) + retired + current;
  }
};

bool unchangedFor(StudioMethod m, const StudioSettings& a, const StudioSettings& b) {
  if (m == StudioMethod::Pt || !a.many.computeVsl || !b.many.computeVsl || !a.many.computeVpl || !b.many.computeVpl ||
      a.many.pairRoulette > 0 || b.many.pairRoulette > 0)
    return false;
  const EstimatorInfo* info = findEstimator(b.estimator.name);
  if (!info || info->wholeSetPerStep || info->methodsShareChoices) return false;
  // b with the other method's parameters set back to a's.
  const std::string_view other = m == StudioMethod::Vpl ? "VSL" : "VPL";
  StudioSettings bAsA = b;
  for (const Param<ManyLightSettings>& p : manyLightParams().all())
    if (std::string_view(p.spec.appliesTo) == other) p.set(bAsA.many, p.get(a.many));
  return sameImageSettings(a, bAsA) && !sameImageSettings(a, b);
}

// Worker-owned state: the current scene survives failed loads, and the
// reference (keyed by scene and resolution) survives restarts.
struct Session::Worker {
  std::unique_ptr<RenderContext> ctx;  // scene, BVH and light sampler
  std::string scenePath;
  EnvironmentSettings env;  // the environment ctx was built with
  // The live path tracer (seed 0): pass p goes to half p % 2 (reference.h).
  struct Reference {
    std::string key;  // scene and resolution
    std::unique_ptr<ReferenceRenderer> pt;
  } ref;
  // The converged reference in use, what it was chosen for, and its noise.
  std::shared_ptr<const vsl::Reference> converged;
  std::string convergedFor;
  double convergedNoise = -1;
  std::string cacheKey, cacheKeyFor;  // the scene's cache key and what it was computed for
  std::unique_ptr<ReferenceRenderer> background;
  std::string backgroundKey;
  std::unique_ptr<Job> job;  // destroyed before the scene it points into
};

// ---- [0] Equal time -------------------------------------------------------------------

double ownSeconds(const ErrorSample& e, StudioMethod m) {
  return m == StudioMethod::Vsl ? e.vslSeconds : m == StudioMethod::Vpl ? e.vplSeconds : e.ptSeconds;
}

double ownError(const ErrorSample& e, StudioMethod m) {
  return m == StudioMethod::Vsl ? e.vsl : m == StudioMethod::Vpl ? e.vpl : e.pt;
}

double equalTimeBudget(const std::vector<ErrorSample>& history) {
  if (history.empty()) return 0;
  double t = INFINITY;
  for (StudioMethod m : {StudioMethod::Vsl, StudioMethod::Vpl, StudioMethod::Pt})
    t = std::min(t, ownSeconds(history.back(), m));
  return t;
}

double errorAtOwnTime(const std::vector<ErrorSample>& history, StudioMethod m, double t) {
  for (size_t i = 0; i < history.size(); ++i) {
    const double ti = ownSeconds(history[i], m);
    if (ti < t) continue;
    if (ti == t) return ownError(history[i], m);
    if (i == 0) return NAN;  // before its first point
    const double t0 = ownSeconds(history[i - 1], m), f = ti > t0 ? (t - t0) / (ti - t0) : 1.0;
    return ownError(history[i - 1], m) + f * (ownError(history[i], m) - ownError(history[i - 1], m));
  }
  return NAN;
}

// The live path tracer's samples per pixel to reach: maxSpp (the setting),
// and past it, while the live path tracer is the reference in use, the
// count at which its own noise, falling as 1/spp, is a fifth of the smallest
// method error measured (docs/REFERENCE.md, "References"), at most
// kLiveReferenceSppFactor x maxSpp.
int liveReferenceTarget(int spp, int maxSpp, double noise, const std::vector<ErrorSample>& history) {
  if (spp < maxSpp || history.empty() || !(noise > 0)) return maxSpp;
  const ErrorSample& e = history.back();
  const double smallest = std::min(e.vsl, e.vpl) + e.referenceNoise;  // before the noise was subtracted
  if (!(smallest > 0)) return maxSpp;
  const double wanted = std::ceil(double(spp) * noise / (smallest / 5));
  return int(std::clamp(wanted, double(maxSpp), double(maxSpp) * kLiveReferenceSppFactor));
}

Image comparedImage(const Snapshot& s, const Image& direct, const Image& indirect) {
  return s.comparesFull ? withDirect(direct, indirect) : indirect;
}

// ---- [1] Settings and the public interface ------------------------------------------

Result<void> StudioSettings::validate() const {
  if (scene.empty()) return Error("scene: no scene path given");
  if (maxReferenceSpp < 1 || maxReferenceSpp > (1 << 20))
    return Error("reference spp: must be in [1,1048576] (got " + std::to_string(maxReferenceSpp) + ")");
  if (lightSets < 1 || lightSets > kMaxLightSets)
    return Error("light sets: must be in [1," + std::to_string(kMaxLightSets) + "] (got " + std::to_string(lightSets) +
                 ")");
  if (Result<void> m = checkParamValue(runParam("reference-method"), referenceMethod); !m) return Error(m.error());
  if (backgroundReferenceSpp < 0 || backgroundReferenceSpp > (1 << 20))
    return Error("background reference spp: must be in [0,1048576] (got " + std::to_string(backgroundReferenceSpp) +
                 ")");
  if (Result<void> e = env.validate(); !e) return e;
  if (Result<void> e = estimator.validate(); !e) return e;
  // The replay command would be refused by `vsl render` too.
  if (Result<void> e = estimator.validateWith(many); !e) return Error(e.error() + " (set it to off first)");
  return many.validate();
}

Session::Session() : worker_([this] { run(); }) {}

Session::~Session() {
  shutdown(1e9);
  worker_.join();
}

bool Session::shutdown(double seconds) {
  std::unique_lock<std::mutex> lock(mutex_);
  quit_ = true;
  stop_.store(true);
  wake_.notify_all();
  return exitedCv_.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return exited_; });
}

Result<void> Session::checkMemory(const StudioSettings& s, int width, int height) const {
  uint64_t available = memoryForTesting_.load();
  if (available == 0) available = availableMemoryBytes();
  const std::string what =
      std::to_string(s.many.lights) + " lights at " + std::to_string(width) + "x" + std::to_string(height);
  // What the estimator holds beyond brute force's buffers (EstimatorInfo::memory).
  const ExtraMemory extra = estimatorMemory(s.estimator, uint64_t(std::max(width, 0)) * uint64_t(std::max(height, 0)));
  if (Result<void> m = checkStudioMemory(s.many.lights, width, height, available, 0.75, extra); !m)
    return Error("memory: " + what + " " + m.error());
  // What checkStudioMemory does not count, per pixel: the light sets' double
  // sums (7 layers), their mean, biasVariance's 3 temporary images, the live
  // path tracer's scratch films, and each set's 4 indirect layers (kept for
  // biasVariance). Checked against the same 75% of what is available.
  const uint64_t pixels = uint64_t(std::max(width, 0)) * uint64_t(std::max(height, 0));
  const uint64_t fixed = kLayers * 3 * sizeof(double) + (kLayers + 3) * 3 * sizeof(float) + 4 * 4 * sizeof(double);
  const uint64_t perSet = kIndirectLayers * 3 * sizeof(float);
  const bool lobe = s.many.lobeGather > 0 && s.many.computeVsl;
  const uint64_t lobeBytes = lobe ? lobeGatherBytes(s.many.lobeGather) : 0;
  const uint64_t base = estimateStudioMemory(s.many.lights, width, height, extra).total() + lobeBytes;
  const uint64_t budget = uint64_t(0.75 * double(available));
  const uint64_t need = base + pixels * (fixed + perSet * uint64_t(s.lightSets));
  if (available == 0 || need <= budget) return {};
  if (lobeBytes > 0 && lobeBytes + pixels * fixed >= budget / 2)
    return Error("memory: the lobe gather's " + std::to_string(s.many.lobeGather) + " lights need about " +
                 formatBytes(lobeBytes) + "; " + formatBytes(budget) + " may be used, " + what + " need " +
                 formatBytes(need - lobeBytes) + ": fewer lobe-gather lights");
  const int64_t fit =
      budget > base + pixels * fixed ? int64_t((budget - base - pixels * fixed) / (pixels * perSet)) : 0;
  return Error("memory: " + what + " with " + std::to_string(s.lightSets) + " light sets needs about " +
               formatBytes(need) + " (each set keeps " + formatBytes(pixels * perSet) + " of images); " +
               formatBytes(budget) + " may be used; " +
               (fit >= 1 ? "at most " + std::to_string(fit) + " light sets fit" : "fewer lights or a smaller width"));
}

Result<uint64_t> Session::restart(const StudioSettings& settings, bool fromScratch) {
  std::string e = settings.validate().error();
  if (e.empty()) {
    // The resolution as the worker will resolve it, with the scene's aspect
    // if it is the current scene (else square; the worker checks again).
    Status st = status();
    int w = settings.many.width > 0 ? settings.many.width : RenderSettings::kDefaultResolution;
    int h = settings.many.height;
    float aspect = st.scene == settings.scene && st.sceneAspect > 0 ? st.sceneAspect : 1.0f;
    if (h <= 0) h = std::max(1, int(std::lround(w / aspect)));
    e = checkMemory(settings, w, h).error();
  }
  if (!e.empty()) return Error(e);
  uint64_t g;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    next_ = settings;
    pending_ = true;
    pendingFromScratch_ = fromScratch;
    g = generation_.fetch_add(1) + 1;
    status_.generation = g;
    stop_.store(true);  // the worker stops at its next check
  }
  ++version_;
  wake_.notify_all();
  return g;
}

std::shared_ptr<const Snapshot> Session::latest(uint64_t haveSerial) const {
  std::lock_guard<std::mutex> lock(mutex_);
  // Only the current generation's snapshots are handed out.
  if (latest_ && latest_->serial > haveSerial && latest_->generation == generation_.load()) return latest_;
  return nullptr;
}

Session::Status Session::status() const {
  std::lock_guard<std::mutex> lock(mutex_);
  Status s = status_;
  s.stageSeconds = stageClock_.seconds();
  if (s.stage == "rendering") s.stepProgress = stepProgress_.text();
  return s;
}

// Only a change bumps the version: each bump makes the UI draw a frame, which
// under software GL costs ~50 ms of a core that a restart's first batch wants.
void Session::setStage(const std::string& stage, uint32_t lightsTarget) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (status_.stage == stage && status_.lightsTarget == lightsTarget) return;
    if (status_.stage != stage) stageClock_.reset();
    status_.stage = stage;
    status_.lightsTarget = lightsTarget;
  }
  ++version_;
}

void Session::reportRunError(const std::string& message) {
  log::error(message);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status_.runError = message;
    ++status_.runErrorSerial;
  }
  ++version_;
}

bool Session::publish(std::shared_ptr<Snapshot> s) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // A snapshot of an older generation is stale: drop it.
    if (s->generation != generation_.load()) return false;
    s->serial = ++serial_;
    s->publishedAt = std::chrono::steady_clock::now();
    if (publishHook_) publishHook_(*s);
    latest_ = std::move(s);
  }
  ++version_;
  return true;
}

void Session::setPublishHookForTesting(std::function<void(const Snapshot&)> hook) {
  std::lock_guard<std::mutex> lock(mutex_);
  publishHook_ = std::move(hook);
}

// ---- [2] The worker loop -------------------------------------------------------------

void Session::run() {
  Worker w;
  while (true) {
    StudioSettings s;
    uint64_t gen;
    bool fromScratch;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (!pending_ && !quit_) {
        std::string idle = w.ctx ? "done" : "idle";
        if (status_.stage != idle) {
          stageClock_.reset();
          ++version_;
        }
        status_.stage = idle;
      }
      wake_.wait(lock, [&] { return quit_ || pending_; });
      if (quit_) break;
      s = next_;
      fromScratch = pendingFromScratch_;
      pending_ = false;
      gen = generation_.load();
      stop_.store(false);
    }
    // Nothing escapes the worker: a failure is reported and the UI keeps its
    // last picture. The job and the reference may be half-updated, so both go.
    try {
      step(w, s, gen, fromScratch);
    } catch (const std::bad_alloc&) {
      w.job.reset();
      w.ref = {};
      reportRunError("out of memory while rendering (" + s.many.describe() +
                     "); the render stopped and the last picture stays. Try fewer lights or a smaller width.");
    } catch (const std::exception& e) {
      w.job.reset();
      w.ref = {};
      reportRunError(std::string("the render failed: ") + e.what());
    } catch (...) {
      w.job.reset();
      w.ref = {};
      reportRunError("the render failed: unknown exception");
    }
  }
  w.job.reset();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    exited_ = true;
  }
  exitedCv_.notify_all();
}

// One generation: the scene, a memory check at the real resolution, then a
// new or resumed job.
void Session::step(Worker& w, StudioSettings s, uint64_t gen, bool fromScratch) {
  if (!ensureScene(w, s) || stopped()) return;
  int width = s.many.width, height = s.many.height;
  resolveResolution(w.ctx->scene(), width, height);
  if (Result<void> fits = checkMemory(s, width, height); !fits) {
    reportRunError("settings refused (the previous render goes on): " + fits.error());
    if (!w.job) return;
    s = w.job->settings;  // keep the render that fits
  }
  // A job with more completed light sets than now asked for starts over;
  // fewer, and it goes on to the new count.
  std::unique_ptr<Job> replaced;
  if (w.job && (fromScratch || !sameImageSettings(w.job->settings, s) || w.job->setsDone > s.lightSets))
    replaced = std::move(w.job);
  if (replaced && fromScratch) replaced.reset();
  if (!w.job) {
    if (replaced) replaced->ml.reset();  // its lights
    returnFreeMemory();                  // what the previous job (or scene) held
    w.job = prepare(w, s, replaced.get());
  }
  if (!w.job) return;  // stopped while preparing
  // Settings that change no image (the reference, the set count) apply to a resumed job.
  w.job->settings.referencePath = s.referencePath;
  w.job->settings.backgroundReferenceSpp = s.backgroundReferenceSpp;
  w.job->settings.referenceMethod = s.referenceMethod;
  w.job->settings.lightSets = s.lightSets;
  if (w.job->ml && w.job->setsDone >= s.lightSets) retireSet(*w.job, false);  // beyond the new count
  chooseReference(w, *w.job);
  render(w, *w.job, gen);
}

// ---- [3] Scenes ----------------------------------------------------------------------

// Loads s.scene unless it is the current scene. On failure (including a scene
// without emitters) the previous scene stays and s.scene is set back to it;
// returns false only when there is no scene at all.
bool Session::ensureScene(Worker& w, StudioSettings& s) {
  if (w.ctx && s.scene == w.scenePath && s.env == w.env) return true;
  // Only the environment changed: a bad file keeps the scene and the previous environment.
  const bool envOnly = w.ctx && s.scene == w.scenePath;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status_.loading = s.scene;
  }
  setStage("loading");
  Result<std::unique_ptr<RenderContext>> loaded = RenderContext::load(s.scene, {}, s.env);
  std::unique_ptr<RenderContext> ctx = loaded ? std::move(loaded).value() : nullptr;
  std::string err = loaded.error();
  bool noEmitters = false;
  if (ctx && !ctx->hasEmitters()) {
    noEmitters = true;
    err = s.scene +
          ": the scene has no emitters (no emissive material and no punctual light), so every method renders black; "
          "set an environment light (a sky, a sun or a map) first";
    for (const std::string& warning : ctx->scene().warnings) err += "\n" + warning;  // e.g. an unsupported extension
  }
  if (!ctx || noEmitters) {
    log::error("cannot load scene: " + err);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      status_.loadError = err;
      status_.noEmitters = noEmitters;
      status_.environmentFailed = envOnly;
      ++status_.loadErrorSerial;
    }
    ++version_;
    if (!w.ctx) return false;
    s.scene = w.scenePath;  // keep rendering the previous scene with the other new settings
    s.env = w.env;
    return true;
  }
  w.job.reset();  // it and the live path tracer point into the old scene
  w.ref = {};
  w.ctx = std::move(ctx);
  w.scenePath = s.scene;
  w.env = s.env;
  const Scene& scene = w.ctx->scene();
  for (const std::string& warning : scene.warnings) log::warning(warning);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status_.loadError.clear();
    status_.scene = w.scenePath;
    status_.env = w.env;
    status_.sceneAspect = scene.camera.aspect > 0 ? scene.camera.aspect : 1.0f;
    status_.sceneWarnings = scene.warnings;
  }
  ++version_;
  return true;
}

// ---- [4] Preparing a job -------------------------------------------------------------

// A new job: its first light set and the live path tracer for its
// resolution. Null if stopped.
std::unique_ptr<Session::Job> Session::prepare(Worker& w, const StudioSettings& s, Job* replaced) {
  auto job = std::make_unique<Job>();
  job->settings = s;
  job->directShareSets = s.lightSets;
  job->clock.reset();
  if (replaced) keepMethod(*replaced, *job);
  if (!prepareSet(w, *job)) return nullptr;
  job->width = job->ml->width();
  job->height = job->ml->height();
  job->batchCount = job->ml->stepCount();
  job->clampBound = job->ml->clampBound();

  // The reference depends only on the scene and the resolution: it keeps
  // converging across restarts that change the many-light settings.
  std::string refKey =
      w.scenePath + "|" + w.env.describe() + "|" + std::to_string(job->width) + "x" + std::to_string(job->height);
  if (w.ref.key != refKey || !w.ref.pt) {
    RenderSettings rs;
    rs.width = job->width;
    rs.height = job->height;
    rs.seed = 0;
    w.ref.key = refKey;
    w.ref.pt = std::make_unique<ReferenceRenderer>(w.ctx->scene(), w.ctx->accel(), w.ctx->lights(), rs);
  }
  job->ptStart = w.ref.pt->seconds();
  job->sppStart = w.ref.pt->spp();
  return job;
}

// Moves one method's completed sets from the job being replaced into the new
// one when the new settings leave that method's images unchanged
// (unchangedFor): their sums, images and mean, and the method's own time.
void Session::keepMethod(Job& from, Job& to) {
  StudioMethod m = StudioMethod::Pt;
  for (StudioMethod k : {StudioMethod::Vpl, StudioMethod::Vsl})
    if (unchangedFor(k, from.settings, to.settings)) m = k;
  const int sets = m == from.kept ? from.keptLayerSets : from.setsDone;
  if (m == StudioMethod::Pt || sets == 0 || sets > to.settings.lightSets) return;
  to.kept = m;
  to.keptSets = to.keptLayerSets = sets;
  to.keptSeconds = from.ownSeconds(m);
  for (int l = 0; l < kLayers; ++l) {
    if (!to.keptLayer(l)) continue;
    to.sum[l] = std::move(from.sum[l]);
    to.mean.*kLayer[l] = std::move(from.mean.*kLayer[l]);
    if (l < kIndirectLayers) to.setImages[l] = std::move(from.setImages[l]);
  }
  const bool vpl = m == StudioMethod::Vpl;
  log::info(std::string(vpl ? "clamped VPL" : "VSL") + " keeps its " + std::to_string(sets) + " light set(s): only " +
            (vpl ? "VSL" : "VPL") + "'s parameters changed");
}

// Light set number job.set (lightSetSettings: seed settings.many.seed + set,
// the radii of the progressive VSL): light tracing and radii, as
// prepareManyLights does but with the stage shown between them, then its
// estimator. False, with no set in the job, if stopped.
bool Session::prepareSet(Worker& w, Job& job) {
  const StudioSettings& s = job.settings;
  job.ml.reset();
  job.batch = 0;
  LightSetSettings set = lightSetSettings(s.many, s.estimator, job.set, job.directShareSets);
  if (!job.gathers(StudioMethod::Vpl, job.set)) set.many.computeVpl = false;  // a kept set: the other method alone
  if (!job.gathers(StudioMethod::Vsl, job.set)) set.many.computeVsl = false;
  const ManyLightSettings& many = set.many;
  const Scene& scene = w.ctx->scene();
  setStage("tracing lights", many.lights);
  LightTracingSettings lt;
  lt.count = many.lights;
  lt.seed = many.seed;
  lt.maxDepth = many.lightMaxDepth;
  ManyLightRun prep;
  prep.set = traceVirtualLights(scene, w.ctx->accel(), w.ctx->lights(), lt, &stop_);
  if (stopped()) return false;
  if (prep.set.lights.empty() && job.setsDone == 0)
    log::warning(
        "no light path met a surface, so there is no virtual light and no indirect light: every many-light "
        "image is the direct light alone");
  const double tracingSeconds = prep.set.seconds;
  setStage("k-NN radii", many.lights);
  Stopwatch knnClock;
  const float R = std::max(scene.boundingRadius(), 1e-6f);
  if (many.globalRadius > 0)
    prep.radii.assign(prep.set.lights.size(), many.globalRadius * R);
  else
    prep.radii = knnRadii(prep.set.lights, many.knn, many.radiusScale, 0.1f * R, 1e-9f * R, &stop_);
  if (stopped()) return false;
  prep.knnSeconds = knnClock.seconds();
  if (!prep.radii.empty()) {
    std::vector<float> r = prep.radii;
    std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
    job.radiusMedian = r[r.size() / 2];
    auto [lo, hi] = std::minmax_element(r.begin(), r.end());
    job.radiusMin = *lo;
    job.radiusMax = *hi;
  }
  const double prepSeconds = prep.set.seconds + prep.knnSeconds;
  // A light set in one step is a long render: its stages go to the log (logStep).
  const EstimatorInfo& info = *findEstimator(set.estimator.name);
  if (info.wholeSetPerStep)
    log::info("light set " + std::to_string(job.set + 1) + ": " + std::to_string(prep.set.lights.size()) +
              " lights traced in " + secondsText(tracingSeconds) + ", k-NN radii in " + secondsText(prep.knnSeconds));
  // An estimator that steps in batches traces the lobe gather's lights when made.
  if (many.lobeGather > 0 && many.computeVsl && !info.wholeSetPerStep)
    setStage("tracing lobe-gather lights", many.lobeGather);
  job.ml = makeEstimator(*w.ctx, std::move(prep), many, set.estimator, &stepProgress_, &stop_);
  if (stopped()) {  // its second light set may be incomplete: a resumed job prepares the set again
    job.ml.reset();
    return false;
  }
  job.mlSeconds += prepSeconds;
  setStage("rendering");
  return true;
}

// Retires the set in progress: a completed one's images join the sums and
// the mean and its lights the totals; either way its work stays on the
// methods' clocks (they never run backwards), and its lights and renderer
// are freed. A set dropped unfinished (fewer sets asked for) keeps its
// number, so set k always has seed + k.
void Session::retireSet(Job& job, bool completed) {
  const ManyLightStats& st = job.ml->stats();
  const ManyLightRun& prep = job.ml->run();
  const int k = job.set;  // before a completed set moves it on
  const bool keptSet = k < job.keptSets;
  if (completed) {
    const ManyLightImages im = job.ml->images();
    const size_t n = im.vsl.rgb.size();
    ++job.setsDone;
    if (!keptSet) ++job.keptLayerSets;
    for (int l = 0; l < kLayers; ++l) {
      if (job.keptLayer(l) && keptSet) continue;  // the kept set's layers are in already
      const Image& img = im.*kLayer[l];
      std::vector<double>& sum = job.sum[l];
      if (sum.empty()) sum.assign(n, 0.0);
      for (size_t i = 0; i < n; ++i) sum[i] += img.rgb[i];
      // The mean as biasVariance computes it (a double sum in set order over
      // K), so that it equals biasVariance's mean bit for bit.
      const int K = job.layerSets(l);
      Image& mean = job.mean.*kLayer[l];
      mean = Image(im.vsl.width, im.vsl.height);
      for (size_t i = 0; i < n; ++i) mean.rgb[i] = float(sum[i] / K);
      if (l < kIndirectLayers) job.setImages[l].push_back(img);
    }
    job.done.lights += prep.set.lights.size();
    job.lastStats = job.ml->statistics();
    ++job.set;
  }
  SetTotals& d = job.done;
  d.tracingSeconds += prep.set.seconds;
  d.knnSeconds += prep.knnSeconds;
  d.gatherSeconds += st.gatherSeconds;
  d.vslSeconds += st.vslSeconds;
  d.vplSeconds += st.vplSeconds;
  // A kept set's shared work is the other method's.
  if (job.gathers(StudioMethod::Vsl, k)) d.vslOwnSeconds += prep.set.seconds + prep.knnSeconds + st.vslSeconds;
  if (job.gathers(StudioMethod::Vpl, k)) d.vplOwnSeconds += prep.set.seconds + st.vplSeconds;
  d.pairs += st.pairs;
  d.vslEvaluations += st.vslEvaluations;
  d.rouletteDropped += st.rouletteDropped;
  d.nonFinite += st.nonFinite + prep.set.nonFiniteRejected;
  job.ml.reset();
  job.batch = 0;
}

// ---- [5] Rendering and snapshots -----------------------------------------------------

// Interleaves equal compute time for the many-light methods (one batch, or
// the next light set's preparation, per step) and the reference, publishing
// after each step, until all are done or stopped.
//
// The first picture of a render (the first with a batch or a light set in
// it) is due, checked after every step, once the reference has a pass or a
// converged reference is used, so that no error is measured against a black
// image. After a many-light step it goes out at once and the reference
// catches up after it (a change that keeps the scene and the resolution
// keeps the reference's samples); when the reference had no samples, it goes
// out after one reference pass, not after the reference has caught up with
// a long step (a light set in one step: tens of seconds).
// Such a light set's VSL image may be complete well before its VPL image
// (StepProgress::onVslImage): the first set's goes out from inside the step
// (showVslFirst), after that one reference pass if the reference has none,
// and the whole picture at once when the step ends. The live path tracer
// never runs beside that step's work.
void Session::render(Worker& w, Job& job, uint64_t gen) {
  setStage("rendering");
  ReferenceRenderer& ref = *w.ref.pt;
  auto hasManyLight = [&] { return job.batch > 0 || job.setsDone > 0; };
  bool firstPicture = !hasManyLight();  // owed until a picture shows many-light work
  auto firstPictureDue = [&] { return firstPicture && hasManyLight() && (w.converged || ref.spp() > 0); };
  auto show = [&] {
    publish(makeSnapshot(w, job, gen));
    if (hasManyLight()) firstPicture = false;
  };
  // Called by a step (StepProgress::onVslImage) on this thread; cleared however render() ends.
  Stopwatch stepClock;
  double vslFirstSeconds = 0;  // spent in it (the reference pass and the snapshot)
  stepProgress_.onVslImage = [&](const ManyLightImages& vslImages) {
    if (!firstPicture || job.setsDone > 0) return;  // a later set: the completed sets' mean is shown
    Stopwatch hookClock;
    showVslFirst(w, job, gen, vslImages, stepClock.seconds());
    vslFirstSeconds += hookClock.seconds();
  };
  struct ClearHook {
    StepProgress& progress;
    ~ClearHook() { progress.onVslImage = nullptr; }
  } clearHook{stepProgress_};
  // A resumed job shows its picture under the new generation at once.
  if (!firstPicture) show();
  while (!stopped()) {
    bool progressed = false;
    if (job.setsDone < job.settings.lightSets) {
      if (!job.ml) {
        // The next independent light set (its preparation is many-light time).
        if (!prepareSet(w, job)) break;
      } else {
        stepClock.reset();
        vslFirstSeconds = 0;
        if (!job.ml->step(&stop_)) break;
        // The reference pass the VSL picture waited for is the reference's time.
        const double stepSeconds = stepClock.seconds() - vslFirstSeconds;
        job.mlSeconds += stepSeconds;
        logStep(job, stepSeconds);
        ++job.batch;
        if (job.ml->done()) retireSet(job, true);
      }
      progressed = true;
    }
    if (firstPictureDue()) show();
    // Once the many-light methods are done, a requested background reference
    // goes first (the live path tracer waits), then the live path tracer.
    if (!progressed && renderBackgroundReference(w, job, gen)) {
      if (stopped()) break;
      setStage("rendering");
    }
    // The reference catches up to the many-light methods' compute time (at
    // least one pass per step), so the error-vs-time plot compares equal time.
    // A long catch-up (after a light set in one step: seconds) shows the reference
    // refining every kCatchUpShowSeconds instead of only at its end.
    bool ptStep = false;
    Stopwatch sinceShown;
    while (ref.spp() < liveTarget(w, job) && !stopped() && (!ptStep || ref.seconds() - job.ptStart < job.mlSeconds)) {
      if (!ref.stepPass(&stop_)) break;
      ptStep = progressed = true;
      if (firstPictureDue()) break;  // it goes out below
      if (!firstPicture && sinceShown.seconds() >= kCatchUpShowSeconds) {
        show();
        sinceShown.reset();
      }
    }
    if (stopped() || !progressed) break;
    show();
  }
}

// The first light set's VSL picture, while its step goes on to VPL:
// after one reference pass if the reference has none (as render() does for
// any first picture), with the VPL layers black (Snapshot::vplPending).
void Session::showVslFirst(Worker& w, Job& job, uint64_t gen, const ManyLightImages& vslImages, double stepSeconds) {
  log::info("light set " + std::to_string(job.set + 1) + ": VSL image after " + secondsText(stepSeconds));
  ReferenceRenderer& ref = *w.ref.pt;
  if (!w.converged && ref.spp() == 0) {
    Stopwatch passClock;
    if (!ref.stepPass(&stop_)) return;
    log::info("reference: first pass in " + secondsText(passClock.seconds()));
  }
  if (!stopped()) publish(makeSnapshot(w, job, gen, &vslImages));
}

// What the step has to say (ManyLightEstimator::stepReport), in the log: its
// information for every set, its warnings for the first only (every set
// would repeat them).
void Session::logStep(const Job& job, double stepSeconds) const {
  const StepReport report = job.ml->stepReport(stepSeconds);
  for (const std::string& line : report.info) log::info("light set " + std::to_string(job.set + 1) + ": " + line);
  if (job.set == 0)
    for (const std::string& line : report.warnings) log::warning(line);
}

// ---- [5b] References ------------------------------------------------------------------

// The converged reference for this job: the settings' file, else a matching
// cache entry, else none (the live path tracer). A file that cannot be used
// is reported and the render goes on against the live path tracer.
void Session::chooseReference(Worker& w, Job& job) {
  const int width = job.width, height = job.height;
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  const auto method = ReferenceMethod(job.settings.referenceMethod);
  const std::string keyFor = w.scenePath + "|" + w.env.describe() + "|" + size + "|" + referenceMethodName(method);
  if (w.cacheKeyFor != keyFor) {
    w.cacheKey = referenceKey(w.ctx->scene(), width, height, kReferenceDepth, w.env, method);
    w.cacheKeyFor = keyFor;
  }
  const std::string& file = job.settings.referencePath;
  std::string want = file.empty() ? "cache:" + w.cacheKey : "file:" + file + "|" + size;
  if (file.empty() && w.converged && w.convergedFor == want) return;
  if (!file.empty() && w.convergedFor == want) return;
  std::shared_ptr<const vsl::Reference> chosen;
  std::string refused;
  if (!file.empty()) {
    Result<vsl::Reference> r = readReference(file, width, height);
    Result<void> same = r ? checkReferenceScene(*r, w.ctx->scene(), file, w.env) : Result<void>{};
    if (r && same)
      chosen = std::make_shared<vsl::Reference>(std::move(r).value());
    else
      refused = "reference not used: " + (r ? same.error() : r.error());
  } else {
    chosen = findCachedReferenceAnyMethod(w.ctx->scene(), width, height, kReferenceDepth, w.env, method);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status_.referenceError = refused;
  }
  if (!refused.empty()) reportRunError(refused + "; errors are measured against the live path tracer");
  if (chosen && !file.empty()) log::info("reference: " + file);
  if (chosen && file.empty()) log::info("reference: " + chosen->source);
  w.convergedFor = want;
  if (!chosen && !w.converged) return;
  w.converged = std::move(chosen);
  w.convergedNoise = w.converged ? w.converged->comparedNoise() : -1;
  job.history.clear();  // earlier errors were measured against another reference
}

// After the live render: a converged reference into the cache, saved each
// time its sample count doubles (so a quit loses little), then used.
// Returns false when there is nothing to do.
bool Session::renderBackgroundReference(Worker& w, Job& job, uint64_t gen) {
  const int target = job.settings.backgroundReferenceSpp;
  if (target <= 0 || (w.converged && w.converged->spp >= target && w.convergedFor == "cache:" + w.cacheKey))
    return false;
  if (!job.settings.referencePath.empty()) return false;  // the user chose a reference
  if (!w.background || w.backgroundKey != w.cacheKey) {
    RenderSettings rs;
    rs.width = job.width;
    rs.height = job.height;
    rs.seed = kReferenceSeed;
    w.background = std::make_unique<ReferenceRenderer>(w.ctx->scene(), w.ctx->accel(), w.ctx->lights(), rs,
                                                       ReferenceMethod(job.settings.referenceMethod));
    w.backgroundKey = w.cacheKey;
  }
  setStage("reference");
  ReferenceRenderer& bg = *w.background;
  auto save = [&] {
    vsl::Reference r = bg.result();
    r.key = w.cacheKey;
    if (Result<std::string> stored = storeCachedReference(r, w.scenePath); !stored)
      reportRunError("reference cache: " + stored.error());
    return r;
  };
  Stopwatch sincePublish;
  int saveAt = 64;
  while (!stopped() && bg.spp() < target) {
    if (!bg.step(&stop_)) break;
    if (bg.spp() >= saveAt && bg.spp() < target) {
      save();
      saveAt *= 2;
    }
    if (sincePublish.seconds() > 1.0) {
      sincePublish.reset();
      job.backgroundSpp = bg.spp();
      publish(makeSnapshot(w, job, gen));
    }
  }
  job.backgroundSpp = bg.spp();
  if (bg.spp() < target) return true;  // stopped: resumes with the next restart
  vsl::Reference r = save();
  w.converged = std::make_shared<vsl::Reference>(std::move(r));
  w.convergedFor = "cache:" + w.cacheKey;
  w.convergedNoise = w.converged->comparedNoise();
  w.background.reset();
  job.history.clear();
  log::info("reference: rendered " + std::to_string(target) + " spp into " + referenceCachePath(w.cacheKey));
  publish(makeSnapshot(w, job, gen));
  return true;
}

// The live path tracer's target (liveReferenceTarget): the setting, or more
// while it is the reference in use and too noisy to rank the methods, once
// the many-light methods are done (before, the two take turns for equal
// time, and refining past the setting would halve the methods' pace).
int Session::liveTarget(const Worker& w, const Job& job) {
  const ReferenceRenderer& ref = *w.ref.pt;
  const int cap = job.settings.maxReferenceSpp;
  if (w.converged || ref.spp() < cap || job.setsDone < job.settings.lightSets) return cap;
  return liveReferenceTarget(ref.spp(), cap, ref.indirectNoise(), job.history);
}

std::shared_ptr<Snapshot> Session::makeSnapshot(const Worker& w, Job& job, uint64_t gen,
                                                const ManyLightImages* vslFirst) const {
  const ManyLightEstimator* ml = job.ml.get();  // the set in progress, if any
  static const ManyLightRun kNoSet;
  const ManyLightRun& prep = ml ? ml->run() : kNoSet;
  const ReferenceRenderer& ref = *w.ref.pt;
  const SetTotals& d = job.done;
  auto snap = std::make_shared<Snapshot>();
  snap->generation = gen;
  snap->settings = job.settings;
  snap->width = job.width;
  snap->height = job.height;
  const double liveNoise = snapshotImages(job, ref, vslFirst, *snap);
  snap->lightSets = job.settings.lightSets;
  snap->lightSetsDone = job.setsDone;
  snap->vslLightSetsDone = job.layerSets(0);
  snap->vplLightSetsDone = job.layerSets(1);
  snap->directSamplesPerSet =
      lightSetSettings(job.settings.many, job.settings.estimator, 0, job.directShareSets).many.directSamples;
  snap->estimatorStats = ml && ml->stepsDone() > 0 ? ml->statistics() : job.lastStats;
  snap->ptSpp = ref.spp();
  // Work over every set: the completed ones and the one in progress.
  ManyLightStats none;
  const ManyLightStats& st = ml ? ml->stats() : none;
  const size_t setSize = ml ? prep.set.lights.size() : job.setsDone > 0 ? d.lights / job.setsDone : 0;
  const int untraced = std::max(job.settings.lightSets - job.setsDone - (ml ? 1 : 0), 0);
  snap->lightsProcessed = d.lights + (ml ? ml->lightsProcessed() : 0);
  snap->lightsTotal = d.lights + (ml ? setSize : 0) + size_t(untraced) * setSize;
  snap->batchesDone = ml ? job.batch : job.batchCount;
  snap->batchCount = job.batchCount;
  snap->seconds = job.clock.seconds();
  snap->lightTracingSeconds = d.tracingSeconds + prep.set.seconds;
  snap->knnSeconds = d.knnSeconds + prep.knnSeconds;
  snap->gatherSeconds = d.gatherSeconds + st.gatherSeconds;
  snap->referenceSeconds = ref.seconds();
  snap->clampBound = job.clampBound;
  snap->sceneRadius = w.ctx->scene().boundingRadius();
  snap->radiusMin = job.radiusMin;
  snap->radiusMedian = job.radiusMedian;
  snap->radiusMax = job.radiusMax;
  snap->pairs = d.pairs + st.pairs.load();
  snap->vslEvaluations = d.vslEvaluations + st.vslEvaluations.load();
  snap->rouletteDropped = d.rouletteDropped + st.rouletteDropped.load();
  snap->pairsPerSecond = double(snap->pairs) / std::max(snap->gatherSeconds, 1e-9);
  snap->nonFinite = d.nonFinite + st.nonFinite + prep.set.nonFiniteRejected + ref.rejected();
  const double manyLeft = manyLightSecondsLeft(job, st, setSize, untraced, *snap);  // made wall-clock below
  const int target = liveTarget(w, job);
  referenceRate(job, ref, target, *snap);
  snap->vslSeconds = job.ownSeconds(StudioMethod::Vsl);
  snap->vplSeconds = job.ownSeconds(StudioMethod::Vpl);
  snap->backgroundSpp = job.backgroundSpp;
  useReference(w, liveNoise, *snap);
  biasNoise(w, job, *snap);
  snap->vplPending = vslFirst != nullptr;
  if (vslFirst)
    snap->history = job.history;  // VPL's error is not measured yet
  else
    recordError(w, job, liveNoise, *snap);
  snap->manyLightDone = job.setsDone >= job.settings.lightSets;
  if (snap->manyLightDone) snap->manyFractionDone = 1.0;
  snap->referenceTargetSpp = target;
  snap->referenceDone = ref.spp() >= target;
  wallClockTimesLeft(manyLeft, *snap);
  return snap;
}

// The images in parallel (a restart's first picture waits for them): the
// mean of the completed sets (the first set's progressive estimate until
// it completes), the live path tracer's, and its noise (returned).
double Session::snapshotImages(const Job& job, const ReferenceRenderer& ref, const ManyLightImages* vslFirst,
                               Snapshot& snap) {
  const ManyLightEstimator* ml = job.ml.get();
  double liveNoise = -1;
  parallelFor(4, [&](size_t k) {
    if (k == 0) {
      snap.many = vslFirst ? *vslFirst : job.setsDone > 0 ? job.mean : ml->images();
      if (!vslFirst && job.setsDone == 0 && job.keptLayerSets > 0)  // kept sets, before the other method's first
        for (int l = 0; l < kLayers; ++l)
          if (job.keptLayer(l)) snap.many.*kLayer[l] = job.mean.*kLayer[l];
    } else if (k == 1)
      snap.ptDirect = ref.meanDirect();
    else if (k == 2)
      snap.ptIndirect = ref.meanIndirect();
    else
      liveNoise = ref.indirectNoise();
  });
  return liveNoise;
}

// Progress: rates over compute time, remaining time from what the work
// done cost: the set in progress from its estimator's own prediction (a
// brute-force batch's per-pixel work does not scale with its lights), each
// set not yet begun at the mean gather time of the sets done (or the one
// in progress, done plus left) and the mean preparation time of those
// prepared. Without a prediction, lights at the mean rate. Returns the
// many-light methods' compute seconds left (st: the set in progress's
// stats; setSize: a set's lights; untraced: the sets not yet begun).
double Session::manyLightSecondsLeft(const Job& job, const ManyLightStats& st, size_t setSize, int untraced,
                                     Snapshot& snap) {
  const ManyLightEstimator* ml = job.ml.get();
  const SetTotals& d = job.done;
  double manyLeft = 0;
  if (snap.gatherSeconds > 0) {
    snap.lightsPerSecond = double(snap.lightsProcessed) / snap.gatherSeconds;
    const double perLight = 1.0 / std::max(snap.lightsPerSecond, 1e-9);
    const int prepared = job.setsDone + (ml ? 1 : 0);
    const double prepSeconds = prepared > 0 ? (snap.lightTracingSeconds + snap.knnSeconds) / prepared : 0;
    const std::optional<double> left = ml ? ml->remainingSeconds() : std::optional<double>(0.0);
    const double current = left ? *left : double(setSize - ml->lightsProcessed()) * perLight;
    const double perSet = job.setsDone > 0 ? d.gatherSeconds / job.setsDone
                          : left           ? st.gatherSeconds + *left
                                           : double(setSize) * perLight;
    manyLeft = current + untraced * (perSet + prepSeconds);
    const double spent = snap.lightTracingSeconds + snap.knnSeconds + snap.gatherSeconds;
    snap.manyFractionDone = spent / std::max(spent + manyLeft, 1e-9);
  }
  return manyLeft;
}

// The live path tracer's rate since the job began and its time left to
// target (compute seconds; liveTarget).
void Session::referenceRate(const Job& job, const ReferenceRenderer& ref, int target, Snapshot& snap) {
  if (double t = ref.seconds() - job.ptStart; t > 0 && ref.spp() > job.sppStart) {
    snap.referenceSppPerSecond = (ref.spp() - job.sppStart) / t;
    snap.referenceRemainingSeconds = std::max(target - ref.spp(), 0) / snap.referenceSppPerSecond;
  }
}

// The reference in use and its own noise (session.h, ErrorSample): the
// converged one if the worker has it, else the live path tracer (whose noise
// is liveNoise). A full-only reference is compared on the full component
// (Snapshot::comparesFull); its direct layer is the live path tracer's and
// its indirect one the file's full image less that.
void Session::useReference(const Worker& w, double liveNoise, Snapshot& snap) {
  if (w.converged) {
    const Reference& c = *w.converged;
    snap.convergedReference = true;
    snap.comparesFull = c.fullOnly();
    snap.refDirect = c.direct.rgb.empty() ? snap.ptDirect : c.direct;
    snap.refIndirect = snap.comparesFull ? difference(c.full, snap.ptDirect) : c.indirect;
    const bool cached = w.convergedFor.rfind("cache:", 0) == 0;
    const std::string& src = w.converged->source.empty() ? referenceCachePath(w.converged->key) : w.converged->source;
    const std::string shippedDir = shippedReferenceDir();
    const bool shipped = cached && !shippedDir.empty() && src.rfind(shippedDir, 0) == 0;
    snap.referenceSource = shipped ? "shipped: " + src : cached ? "cache: " + src : src;
    snap.referenceSpp = w.converged->spp;
    snap.referenceNoise = w.convergedNoise;
  } else {
    snap.refIndirect = snap.ptIndirect;
    snap.refDirect = snap.ptDirect;
    snap.referenceSource = "live path tracer";
    snap.referenceSpp = w.ref.pt->spp();
    snap.referenceNoise = liveNoise;
  }
}

// The snapshot's point of the error history (relMSE less the reference's
// noise), appended to the job's history unless a resumed job republishes.
void Session::recordError(const Worker& w, Job& job, double liveNoise, Snapshot& snap) {
  const double noise = std::max(snap.referenceNoise, 0.0);
  ErrorSample e;
  e.manySeconds = job.mlSeconds;
  e.vslSeconds = snap.vslSeconds;
  e.vplSeconds = snap.vplSeconds;
  e.ptSeconds = w.ref.pt->seconds();
  e.referenceNoise = noise;
  // The comparisons in parallel (the first picture of a restart waits for
  // them), of the component compared (Snapshot::comparesFull).
  const Image* test[3] = {&snap.many.vsl, &snap.many.vpl, &snap.ptIndirect};
  const Image* ref = &snap.refIndirect;
  Image full[3];
  if (snap.comparesFull) {
    full[0] = withDirect(snap.many.direct, snap.many.vsl);
    full[1] = withDirect(snap.many.direct, snap.many.vpl);
    full[2] = withDirect(snap.ptDirect, snap.ptIndirect);
    for (int k = 0; k < 3; ++k) test[k] = &full[k];
    ref = &w.converged->full;
  }
  double relMse[3] = {0, 0, 0};
  parallelFor(w.converged ? 3 : 2, [&](size_t k) { relMse[k] = compareImages(*test[k], *ref).average.relMse; });
  e.vsl = relMse[0] - noise;
  e.vpl = relMse[1] - noise;
  e.pt = w.converged ? relMse[2] - noise : std::max(liveNoise, 0.0);
  auto variance = [](const BiasNoise& b) { return b.renders >= 2 ? b.variance : -1.0; };
  e.lightSetsDone = snap.lightSetsDone;
  e.vslSetVariance = variance(snap.biasNoise[int(BiasNoiseRow::Vsl)]);
  e.vplSetVariance = variance(snap.biasNoise[int(BiasNoiseRow::Vpl)]);
  // The history is the job's; a resumed job republishes without a new point.
  std::vector<ErrorSample>& history = job.history;
  if (history.empty() || history.back().manySeconds != e.manySeconds || history.back().ptSeconds != e.ptSeconds)
    history.push_back(e);
  snap.history = history;
}

// Bias and noise of each method's indirect image (session.h, BiasNoise):
// the many-light methods from their completed sets once there are two, the
// live path tracer from its two halves against a converged reference (as
// the reference itself it would be measured against itself).
void Session::biasNoise(const Worker& w, const Job& job, Snapshot& snap) const {
  auto summary = [](const BiasVarianceResult& r) {
    return BiasNoise{r.renders, r.average.bias2, r.average.variance, r.average.relMse};
  };
  // Compared on the full component, each set's indirect image carries the
  // mean direct light of the sets (its variance is the indirect light's).
  const bool full = snap.comparesFull;
  const Image& ref = full ? w.converged->full : snap.refIndirect;
  for (int l = 0; l < kIndirectLayers; ++l) {
    if (job.setImages[l].size() >= 2) {
      std::vector<Image> fullSets;
      if (full)
        for (const Image& img : job.setImages[l]) fullSets.push_back(withDirect(snap.many.direct, img));
      std::vector<const Image*> sets;
      for (const Image& img : full ? fullSets : job.setImages[l]) sets.push_back(&img);
      snap.biasNoise[l] = summary(biasVariance(sets, ref));
    }
  }
  if (w.converged && w.ref.pt->spp() >= 2) {
    const ReferenceRenderer& pt = *w.ref.pt;
    const Image a = full ? pt.halfFull(0) : pt.halfIndirect(0), b = full ? pt.halfFull(1) : pt.halfIndirect(1);
    snap.biasNoise[int(BiasNoiseRow::Pt)] = summary(biasVariance({&a, &b}, ref));
  }
}

}  // namespace vsl
