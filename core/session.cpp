#include "core/session.h"

#include <chrono>
#include <sstream>

#include "core/compare.h"
#include "core/log.h"

namespace vsl {

std::string StudioSettings::validate() const {
  if (scene.empty()) return "scene: no scene path given";
  if (maxReferenceSpp < 1 || maxReferenceSpp > (1 << 20))
    return "reference spp: must be in [1,1048576] (got " + std::to_string(maxReferenceSpp) + ")";
  return many.validate();
}

Session::Session() : worker_([this] { run(); }) {}

Session::~Session() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    quit_ = true;
    stop_.store(true);
  }
  wake_.notify_all();
  worker_.join();
}

uint64_t Session::restart(const StudioSettings& settings, std::string* error) {
  if (std::string e = settings.validate(); !e.empty()) {
    if (error) *error = e;
    return 0;
  }
  uint64_t g;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    next_ = settings;
    pending_ = true;
    g = generation_.fetch_add(1) + 1;
    status_.generation = g;
    stop_.store(true);  // the worker stops between tiles
  }
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
  return status_;
}

void Session::setStage(const std::string& stage) {
  std::lock_guard<std::mutex> lock(mutex_);
  status_.stage = stage;
}

bool Session::publish(std::shared_ptr<Snapshot> s) {
  std::lock_guard<std::mutex> lock(mutex_);
  // A snapshot of an older generation is stale: drop it.
  if (s->generation != generation_.load()) return false;
  s->serial = ++serial_;
  latest_ = std::move(s);
  return true;
}

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

double grey(const Image& img, size_t i) {
  return (double(img.rgb[3 * i]) + img.rgb[3 * i + 1] + img.rgb[3 * i + 2]) / 3;
}

}  // namespace

void Session::run() {
  // Worker-owned state: the current scene survives failed loads.
  std::shared_ptr<const Scene> scene;
  std::unique_ptr<Accel> accel;
  std::unique_ptr<LightSampler> lights;
  std::string scenePath;
  struct Reference {
    std::string key;  // scene and resolution
    Film direct, indirect;
    std::vector<double> squares;
    int spp = 0;
    double seconds = 0;
  } ref;

  while (true) {
    StudioSettings s;
    uint64_t gen;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (!pending_ && !quit_) status_.stage = scene ? "done" : "idle";
      wake_.wait(lock, [&] { return quit_ || pending_; });
      if (quit_) return;
      s = next_;
      pending_ = false;
      gen = generation_.load();
      stop_.store(false);
    }
    auto stopped = [&] { return stop_.load(std::memory_order_relaxed); };

    // ---- Scene: load off the UI thread; keep the previous one on failure.
    if (!scene || s.scene != scenePath) {
      setStage("loading");
      LoadResult r = loadScene(s.scene);
      std::unique_ptr<Accel> a;
      std::string err = r.error;
      if (r.scene) {
        a = Accel::build(*r.scene, &err);
      }
      if (!r.scene || !a) {
        log::error("cannot load scene: " + err);
        {
          std::lock_guard<std::mutex> lock(mutex_);
          status_.loadError = err;
          ++status_.loadErrorSerial;
        }
        if (!scene) continue;
        s.scene = scenePath;  // keep rendering the previous scene with the new settings
      } else {
        scene = r.scene;
        accel = std::move(a);
        lights = std::make_unique<LightSampler>(*scene);
        scenePath = s.scene;
        for (const std::string& w : scene->warnings) log::warning(w);
        std::lock_guard<std::mutex> lock(mutex_);
        status_.loadError.clear();
        status_.scene = scenePath;
        status_.sceneWarnings = scene->warnings;
      }
    }
    if (stopped()) continue;
    if (lights->empty()) {
      log::error(scenePath + ": the scene has no lights");
      continue;
    }

    // ---- Virtual lights.
    auto t0 = Clock::now();
    setStage("tracing lights");
    ManyLightRun prep = prepareManyLights(*scene, *accel, *lights, s.many, &stop_);
    if (stopped()) continue;
    ManyLightRenderer ml(*scene, *accel, *lights, prep.set, prep.radii, s.many);
    // The reference depends only on the scene and the resolution: it keeps
    // converging across restarts that change the many-light settings.
    RenderSettings rs;
    rs.width = ml.width();
    rs.height = ml.height();
    rs.seed = 0;
    std::string refKey = scenePath + "|" + std::to_string(rs.width) + "x" + std::to_string(rs.height);
    if (ref.key != refKey) {
      ref = Reference();
      ref.key = refKey;
      ref.direct = Film(rs.width, rs.height);
      ref.indirect = Film(rs.width, rs.height);
      ref.squares.assign(size_t(rs.width) * rs.height, 0.0);
    }
    PathTracer pt(*scene, *accel, *lights, rs);
    Film& ptDirect = ref.direct;
    Film& ptIndirect = ref.indirect;
    std::vector<double>& ptSquares = ref.squares;
    PtCounters ptCounters;
    setStage("rendering");

    // ---- Interleave: equal time for the many-light methods and the reference.
    std::vector<ErrorSample> history;
    double mlSeconds = prep.set.seconds + prep.knnSeconds, ptStart = ref.seconds;
    double& ptSeconds = ref.seconds;
    int& spp = ref.spp;
    int batch = 0;
    while (!stopped()) {
      bool progressed = false;
      if (batch < ml.batchCount()) {
        auto tb = Clock::now();
        if (!ml.renderBatch(batch, &stop_)) break;
        mlSeconds += since(tb);
        ++batch;
        progressed = true;
      }
      // The reference catches up to the many-light methods' compute time (at
      // least one pass per step), so the error-vs-time plot compares equal time.
      bool ptStep = false;
      while (spp < s.maxReferenceSpp && !stopped() && (!ptStep || ptSeconds - ptStart < mlSeconds)) {
        auto tp = Clock::now();
        if (!pt.renderPass(spp, ptDirect, ptIndirect, ptCounters, &stop_, &ptSquares)) {
          ++spp;  // some pixels have this sample: never reuse its index
          break;
        }
        ptSeconds += since(tp);
        ++spp;
        ptStep = progressed = true;
      }
      if (stopped() || !progressed) break;

      auto snap = std::make_shared<Snapshot>();
      snap->generation = gen;
      snap->settings = s;
      snap->width = ml.width();
      snap->height = ml.height();
      snap->many = ml.images();
      snap->ptDirect = ptDirect.image();
      snap->ptIndirect = ptIndirect.image();
      snap->ptSpp = spp;
      snap->lightsProcessed = ml.lightsProcessed();
      snap->lightsTotal = prep.set.lights.size();
      snap->batchesDone = batch;
      snap->batchCount = ml.batchCount();
      snap->seconds = since(t0);
      snap->lightTracingSeconds = prep.set.seconds;
      snap->pairsPerSecond = ml.stats().pairs / std::max(ml.stats().gatherSeconds, 1e-9);
      snap->nonFinite = ml.stats().nonFinite + ptCounters.nonFinite + prep.set.nonFiniteRejected;
      // Errors against the reference's indirect image; the reference's own
      // expected relMSE comes from its per-pixel sample variance.
      ErrorSample e;
      e.manySeconds = mlSeconds;
      e.ptSeconds = ptSeconds;
      // The same relMSE as `vsl compare` and the studio's metrics table.
      e.vsl = compareImages(snap->many.vsl, snap->ptIndirect).average.relMse;
      e.vpl = compareImages(snap->many.vpl, snap->ptIndirect).average.relMse;
      double ptErr = 0;
      size_t np = ptSquares.size();
      for (size_t i = 0; i < np && spp > 0; ++i) {
        // Per-pixel sample counts can differ by one after a cancelled pass.
        double n = std::max(ptIndirect.weight(int(i % rs.width), int(i / rs.width)), 1.0);
        double m = grey(snap->ptIndirect, i);
        double var = std::max(ptSquares[i] / n - m * m, 0.0) / n;
        ptErr += var / (m * m + 1e-2);
      }
      e.pt = np ? ptErr / double(np) : 0;
      history.push_back(e);
      snap->history = history;
      snap->manyLightDone = batch >= ml.batchCount();
      snap->referenceDone = spp >= s.maxReferenceSpp;
      publish(std::move(snap));
    }
  }
}

}  // namespace vsl
