// Sections: [1] settings and the public interface  [2] the worker loop
//           [3] scenes  [4] preparing a job  [5] rendering and snapshots
#include "core/session.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <new>
#include <sstream>

#include "core/compare.h"
#include "core/log.h"
#include "core/memory_budget.h"

namespace vsl {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// The path depth of the live path tracer and of the references it looks up.
const int kReferenceDepth = RenderSettings().maxDepth;

}  // namespace

// describe() covers the user-facing settings; the rest are compared by hand.
bool sameImageSettings(const StudioSettings& a, const StudioSettings& b) {
  return a.scene == b.scene && a.maxReferenceSpp == b.maxReferenceSpp && a.many.describe() == b.many.describe() &&
         a.many.lightMaxDepth == b.many.lightMaxDepth && a.many.computeVsl == b.many.computeVsl &&
         a.many.computeVpl == b.many.computeVpl;
}

// A render in progress: its light set, renderers and bookkeeping. Heap-held
// so that the renderer's references into `prep` stay valid.
struct Session::Job {
  StudioSettings settings;
  ManyLightRun prep;
  std::unique_ptr<ManyLightRenderer> ml;
  int batch = 0;
  double mlSeconds = 0;  // light tracing, k-NN and gathering
  double ptStart = 0;    // the reference's compute time when the job began
  int sppStart = 0;      // and its sample count
  float radiusMin = 0, radiusMedian = 0, radiusMax = 0;
  Clock::time_point t0;  // wall clock at the job's start
  std::vector<ErrorSample> history;
  int backgroundSpp = 0;
};

// Worker-owned state: the current scene survives failed loads, and the
// reference (keyed by scene and resolution) survives restarts.
struct Session::Worker {
  std::shared_ptr<const Scene> scene;
  std::unique_ptr<Accel> accel;
  std::unique_ptr<LightSampler> lights;
  std::string scenePath;
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

// ---- [1] Settings and the public interface ------------------------------------------

Result<void> StudioSettings::validate() const {
  if (scene.empty()) return Error("scene: no scene path given");
  if (maxReferenceSpp < 1 || maxReferenceSpp > (1 << 20))
    return Error("reference spp: must be in [1,1048576] (got " + std::to_string(maxReferenceSpp) + ")");
  if (backgroundReferenceSpp < 0 || backgroundReferenceSpp > (1 << 20))
    return Error("background reference spp: must be in [0,1048576] (got " + std::to_string(backgroundReferenceSpp) +
                 ")");
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
  Result<void> m = checkStudioMemory(s.many.lights, width, height, available);
  if (m) return {};
  return Error("memory: " + std::to_string(s.many.lights) + " lights at " + std::to_string(width) + "x" +
               std::to_string(height) + " " + m.error());
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
  s.stageSeconds = since(stageStart_);
  return s;
}

void Session::setStage(const std::string& stage, uint32_t lightsTarget) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (status_.stage != stage) stageStart_ = Clock::now();
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
    latest_ = std::move(s);
  }
  ++version_;
  return true;
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
        std::string idle = w.scene ? "done" : "idle";
        if (status_.stage != idle) stageStart_ = Clock::now(), ++version_;
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
  resolveResolution(*w.scene, width, height);
  if (Result<void> fits = checkMemory(s, width, height); !fits) {
    reportRunError("settings refused (the previous render goes on): " + fits.error());
    if (!w.job) return;
    s = w.job->settings;  // keep the render that fits
  }
  if (w.job && (fromScratch || !sameImageSettings(w.job->settings, s))) w.job.reset();
  if (!w.job) w.job = prepare(w, s);
  if (!w.job) return;  // stopped while preparing
  // Settings that change no image (the reference) apply to a resumed job.
  w.job->settings.referencePath = s.referencePath;
  w.job->settings.backgroundReferenceSpp = s.backgroundReferenceSpp;
  chooseReference(w, *w.job);
  render(w, *w.job, gen);
}

// ---- [3] Scenes ----------------------------------------------------------------------

// Loads s.scene unless it is the current scene. On failure (including a scene
// without emitters) the previous scene stays and s.scene is set back to it;
// returns false only when there is no scene at all.
bool Session::ensureScene(Worker& w, StudioSettings& s) {
  if (w.scene && s.scene == w.scenePath) return true;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status_.loading = s.scene;
  }
  setStage("loading");
  SceneResult r = loadScene(s.scene);
  std::shared_ptr<const Scene> scene = r.valueOr(nullptr);
  std::unique_ptr<Accel> accel;
  std::unique_ptr<LightSampler> lights;
  std::string err = r.error();
  bool noEmitters = false;
  if (scene) {
    Result<std::unique_ptr<Accel>> built = Accel::build(*scene);
    if (built) {
      accel = std::move(built).value();
    } else {
      err = built.error();
    }
  }
  if (accel) {
    lights = std::make_unique<LightSampler>(*scene);
    if (lights->empty()) {
      noEmitters = true;
      err = s.scene +
            ": the scene has no emitters (no emissive material and no KHR_lights_punctual light), so every method "
            "renders black";
      for (const std::string& warning : scene->warnings) err += "\n" + warning;  // e.g. an unsupported extension
    }
  }
  if (!scene || !accel || noEmitters) {
    log::error("cannot load scene: " + err);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      status_.loadError = err;
      status_.noEmitters = noEmitters;
      ++status_.loadErrorSerial;
    }
    ++version_;
    if (!w.scene) return false;
    s.scene = w.scenePath;  // keep rendering the previous scene with the other new settings
    return true;
  }
  w.job.reset();  // it and the live path tracer point into the old scene
  w.ref = {};
  w.scene = scene;
  w.accel = std::move(accel);
  w.lights = std::move(lights);
  w.scenePath = s.scene;
  for (const std::string& warning : w.scene->warnings) log::warning(warning);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status_.loadError.clear();
    status_.scene = w.scenePath;
    status_.sceneAspect = w.scene->camera.aspect > 0 ? w.scene->camera.aspect : 1.0f;
    status_.sceneWarnings = w.scene->warnings;
  }
  ++version_;
  return true;
}

// ---- [4] Preparing a job -------------------------------------------------------------

// Light tracing and radii, as prepareManyLights does, but with the stop flag
// reaching the k-NN step too. Null if stopped.
std::unique_ptr<Session::Job> Session::prepare(Worker& w, const StudioSettings& s) {
  auto job = std::make_unique<Job>();
  job->settings = s;
  job->t0 = Clock::now();
  setStage("tracing lights", s.many.lights);
  LightTracingSettings lt;
  lt.count = s.many.lights;
  lt.seed = s.many.seed;
  lt.maxDepth = s.many.lightMaxDepth;
  job->prep.set = traceVirtualLights(*w.scene, *w.accel, *w.lights, lt, &stop_);
  if (stopped()) return nullptr;
  setStage("k-NN radii", s.many.lights);
  auto tk = Clock::now();
  const float R = std::max(w.scene->boundingRadius(), 1e-6f);
  if (s.many.globalRadius > 0)
    job->prep.radii.assign(job->prep.set.lights.size(), s.many.globalRadius * R);
  else
    job->prep.radii = knnRadii(job->prep.set.lights, s.many.knn, s.many.radiusScale, 0.1f * R, 1e-9f * R, &stop_);
  if (stopped()) return nullptr;
  job->prep.knnSeconds = since(tk);
  if (!job->prep.radii.empty()) {
    std::vector<float> r = job->prep.radii;
    std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
    job->radiusMedian = r[r.size() / 2];
    auto [lo, hi] = std::minmax_element(r.begin(), r.end());
    job->radiusMin = *lo;
    job->radiusMax = *hi;
  }
  job->ml = std::make_unique<ManyLightRenderer>(*w.scene, *w.accel, *w.lights, job->prep.set, job->prep.radii, s.many);

  // The reference depends only on the scene and the resolution: it keeps
  // converging across restarts that change the many-light settings.
  RenderSettings rs;
  rs.width = job->ml->width();
  rs.height = job->ml->height();
  rs.seed = 0;
  std::string refKey = w.scenePath + "|" + std::to_string(rs.width) + "x" + std::to_string(rs.height);
  if (w.ref.key != refKey || !w.ref.pt) {
    w.ref.key = refKey;
    w.ref.pt = std::make_unique<ReferenceRenderer>(*w.scene, *w.accel, *w.lights, rs);
  }
  job->mlSeconds = job->prep.set.seconds + job->prep.knnSeconds;
  job->ptStart = w.ref.pt->seconds();
  job->sppStart = w.ref.pt->spp();
  return job;
}

// ---- [5] Rendering and snapshots -----------------------------------------------------

// Interleaves equal compute time for the many-light methods and the
// reference, publishing after each step, until both are done or stopped.
void Session::render(Worker& w, Job& job, uint64_t gen) {
  setStage("rendering");
  // A resumed job shows its picture under the new generation at once.
  if (job.batch > 0) publish(makeSnapshot(w, job, gen));
  ReferenceRenderer& ref = *w.ref.pt;
  while (!stopped()) {
    bool progressed = false;
    if (job.batch < job.ml->batchCount()) {
      auto tb = Clock::now();
      if (!job.ml->renderBatch(job.batch, &stop_)) break;
      job.mlSeconds += since(tb);
      ++job.batch;
      progressed = true;
    }
    // Once the many-light methods are done, a requested background reference
    // goes first (the live path tracer waits), then the live path tracer.
    if (!progressed && renderBackgroundReference(w, job, gen)) {
      if (stopped()) break;
      setStage("rendering");
    }
    // The reference catches up to the many-light methods' compute time (at
    // least one pass per step), so the error-vs-time plot compares equal time.
    bool ptStep = false;
    while (ref.spp() < job.settings.maxReferenceSpp && !stopped() &&
           (!ptStep || ref.seconds() - job.ptStart < job.mlSeconds)) {
      if (!ref.stepPass(&stop_)) break;
      ptStep = progressed = true;
    }
    if (stopped() || !progressed) break;
    publish(makeSnapshot(w, job, gen));
  }
}

// ---- [5b] References ------------------------------------------------------------------

// The converged reference for this job: the settings' file, else a matching
// cache entry, else none (the live path tracer). A file that cannot be used
// is reported and the render goes on against the live path tracer.
void Session::chooseReference(Worker& w, Job& job) {
  const int width = job.ml->width(), height = job.ml->height();
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  if (w.cacheKeyFor != w.scenePath + "|" + size) {
    w.cacheKey = referenceKey(*w.scene, width, height, kReferenceDepth);
    w.cacheKeyFor = w.scenePath + "|" + size;
  }
  const std::string& file = job.settings.referencePath;
  std::string want = file.empty() ? "cache:" + w.cacheKey : "file:" + file + "|" + size;
  if (file.empty() && w.converged && w.convergedFor == want) return;
  if (!file.empty() && w.convergedFor == want) return;
  std::shared_ptr<const vsl::Reference> chosen;
  if (!file.empty()) {
    Result<vsl::Reference> r = readReference(file, width, height);
    if (r)
      chosen = std::make_shared<vsl::Reference>(std::move(r).value());
    else
      reportRunError("reference not used: " + r.error() + "; errors are measured against the live path tracer");
  } else {
    chosen = findCachedReference(w.cacheKey, width, height);
  }
  if (chosen && !file.empty()) log::info("reference: " + file);
  if (chosen && file.empty()) log::info("reference: the cached " + referenceCachePath(w.cacheKey));
  w.convergedFor = want;
  if (!chosen && !w.converged) return;
  w.converged = std::move(chosen);
  w.convergedNoise = w.converged ? w.converged->indirectNoise() : -1;
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
    rs.width = job.ml->width();
    rs.height = job.ml->height();
    rs.seed = kReferenceSeed;
    w.background = std::make_unique<ReferenceRenderer>(*w.scene, *w.accel, *w.lights, rs);
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
  auto lastPublish = Clock::now();
  int saveAt = 64;
  while (!stopped() && bg.spp() < target) {
    if (!bg.step(&stop_)) break;
    if (bg.spp() >= saveAt && bg.spp() < target) {
      save();
      saveAt *= 2;
    }
    if (since(lastPublish) > 1.0) {
      lastPublish = Clock::now();
      job.backgroundSpp = bg.spp();
      publish(makeSnapshot(w, job, gen));
    }
  }
  job.backgroundSpp = bg.spp();
  if (bg.spp() < target) return true;  // stopped: resumes with the next restart
  vsl::Reference r = save();
  w.converged = std::make_shared<vsl::Reference>(std::move(r));
  w.convergedFor = "cache:" + w.cacheKey;
  w.convergedNoise = w.converged->indirectNoise();
  w.background.reset();
  job.history.clear();
  log::info("reference: rendered " + std::to_string(target) + " spp into " + referenceCachePath(w.cacheKey));
  publish(makeSnapshot(w, job, gen));
  return true;
}

std::shared_ptr<Snapshot> Session::makeSnapshot(const Worker& w, Job& job, uint64_t gen) const {
  const ManyLightRenderer& ml = *job.ml;
  const ReferenceRenderer& ref = *w.ref.pt;
  auto snap = std::make_shared<Snapshot>();
  snap->generation = gen;
  snap->settings = job.settings;
  snap->width = ml.width();
  snap->height = ml.height();
  snap->many = ml.images();
  snap->ptDirect = ref.meanDirect();
  snap->ptIndirect = ref.meanIndirect();
  snap->ptSpp = ref.spp();
  snap->lightsProcessed = ml.lightsProcessed();
  snap->lightsTotal = job.prep.set.lights.size();
  snap->batchesDone = job.batch;
  snap->batchCount = ml.batchCount();
  snap->seconds = since(job.t0);
  snap->lightTracingSeconds = job.prep.set.seconds;
  snap->knnSeconds = job.prep.knnSeconds;
  snap->gatherSeconds = ml.stats().gatherSeconds;
  snap->referenceSeconds = ref.seconds();
  snap->clampBound = ml.clampBound();
  snap->sceneRadius = w.scene->boundingRadius();
  snap->radiusMin = job.radiusMin;
  snap->radiusMedian = job.radiusMedian;
  snap->radiusMax = job.radiusMax;
  snap->pairs = ml.stats().pairs.load();
  snap->vslEvaluations = ml.stats().vslEvaluations.load();
  snap->pairsPerSecond = ml.stats().pairs / std::max(ml.stats().gatherSeconds, 1e-9);
  snap->nonFinite = ml.stats().nonFinite + job.prep.set.nonFiniteRejected + ref.rejected();
  // Progress: rates over compute time, remaining time at those rates.
  if (ml.stats().gatherSeconds > 0) {
    snap->lightsPerSecond = double(snap->lightsProcessed) / ml.stats().gatherSeconds;
    snap->manyRemainingSeconds =
        double(snap->lightsTotal - snap->lightsProcessed) / std::max(snap->lightsPerSecond, 1e-9);
  }
  if (double t = ref.seconds() - job.ptStart; t > 0 && ref.spp() > job.sppStart) {
    snap->referenceSppPerSecond = (ref.spp() - job.sppStart) / t;
    snap->referenceRemainingSeconds =
        std::max(job.settings.maxReferenceSpp - ref.spp(), 0) / snap->referenceSppPerSecond;
  }
  snap->vslSeconds = job.prep.set.seconds + job.prep.knnSeconds + ml.stats().vslSeconds;
  snap->vplSeconds = job.prep.set.seconds + ml.stats().vplSeconds;
  snap->backgroundSpp = job.backgroundSpp;
  // The reference in use and its own noise (session.h, ErrorSample).
  const double liveNoise = ref.indirectNoise();
  if (w.converged) {
    snap->convergedReference = true;
    snap->refIndirect = w.converged->indirect;
    snap->refDirect = w.converged->direct.rgb.empty() ? snap->ptDirect : w.converged->direct;
    const bool cached = w.convergedFor.rfind("cache:", 0) == 0;
    const std::string& src = w.converged->source.empty() ? referenceCachePath(w.converged->key) : w.converged->source;
    snap->referenceSource = cached ? "cache: " + src : src;
    snap->referenceSpp = w.converged->spp;
    snap->referenceNoise = w.convergedNoise;
  } else {
    snap->refIndirect = snap->ptIndirect;
    snap->refDirect = snap->ptDirect;
    snap->referenceSource = "live path tracer";
    snap->referenceSpp = ref.spp();
    snap->referenceNoise = liveNoise;
  }
  const double noise = std::max(snap->referenceNoise, 0.0);
  ErrorSample e;
  e.manySeconds = job.mlSeconds;
  e.vslSeconds = snap->vslSeconds;
  e.vplSeconds = snap->vplSeconds;
  e.ptSeconds = ref.seconds();
  e.referenceNoise = noise;
  e.vsl = compareImages(snap->many.vsl, snap->refIndirect).average.relMse - noise;
  e.vpl = compareImages(snap->many.vpl, snap->refIndirect).average.relMse - noise;
  e.pt = w.converged ? compareImages(snap->ptIndirect, snap->refIndirect).average.relMse - noise
                     : std::max(liveNoise, 0.0);
  // The history is the job's; a resumed job republishes without a new point.
  std::vector<ErrorSample>& history = job.history;
  if (history.empty() || history.back().manySeconds != e.manySeconds || history.back().ptSeconds != e.ptSeconds)
    history.push_back(e);
  snap->history = history;
  snap->manyLightDone = job.batch >= ml.batchCount();
  snap->referenceDone = ref.spp() >= job.settings.maxReferenceSpp;
  return snap;
}

}  // namespace vsl
