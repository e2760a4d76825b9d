// Session: the studio's background renderer. One worker thread loads scenes
// (a RenderContext), traces virtual lights, and interleaves the steps of a
// many-light estimator (estimator_registry.h: brute-force batches, or one MRCS render
// per light set; VSL and VPL from shared passes) with path-traced reference
// passes, publishing an immutable Snapshot after each step. The UI calls restart() with a settings value and
// pulls the newest snapshot once per frame with latest(); neither call waits
// for rendering.
//
// Generations: every restart() bumps the generation. The worker checks a stop
// flag between tiles, between chunks of light paths and between chunks of
// k-NN queries, so a restart takes effect within one such step of work, and
// publish() drops any snapshot whose generation is no longer current: after
// restart() returns generation g, latest() never returns a snapshot older
// than g.
// Work that is kept: a render interrupted by a restart whose settings turn out
// to be the same (a failed load, settings refused for memory, a value changed
// and changed back) resumes where it stopped instead of starting over, and
// publishes under the new generation at once. A scene that fails to load or
// has no emitters leaves the previous scene and its render in place; the
// error is reported through status() and the log.
// Bounded work: restart() refuses settings whose memory estimate
// (memory_budget.h) does not fit, and the worker checks again once the
// scene's resolution is known. An exception in the worker or on any of its
// parallelFor threads (std::bad_alloc included) is reported through status()
// and never escapes; the last picture stays with the UI.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/environment.h"
#include "core/estimator.h"
#include "core/many_light.h"
#include "core/reference.h"
#include "core/stopwatch.h"

namespace vsl {

struct StudioSettings {
  std::string scene;        // path of a .gltf or .glb
  EnvironmentSettings env;  // light from far away (core/environment.h); none by default
  ManyLightSettings many;   // lights, radii, clamp, seed, resolution, batches
  int maxReferenceSpp = 4096;
  // A converged reference (reference.h): an EXR of the render's size with an
  // `indirect` layer. Empty: a matching entry of the reference cache, if any.
  // Without either, errors are measured against the live path tracer.
  std::string referencePath;
  // > 0: once the live render is done, render a converged reference of this
  // many samples per pixel into the cache (saved as it doubles), then measure
  // every error against it.
  int backgroundReferenceSpp = 0;
  // The renderer of that reference, and of the cache entry looked up
  // (ReferenceMethod: 0 the path tracer, 1 BDPT; run parameter
  // `reference-method`).
  int referenceMethod = 0;
  // Independent light sets (seeds many.seed, many.seed + 1, ...), rendered
  // one after another: the many-light images are the mean over the
  // completed sets, and from two on each method's bias and noise are
  // measured (BiasNoise). In [1, kMaxLightSets]; 1 renders one set.
  int lightSets = 8;
  static constexpr int kMaxLightSets = 64;
  // How each light set is gathered (brute-force batches or MRCS, whose rows
  // and clusters are drawn with the set's seed) and whether the VSL radii
  // shrink from set to set (the consistent progressive VSL); estimator.h,
  // lightSetSettings() gives set k's settings.
  EstimatorSettings estimator;
  Result<void> validate() const;
};

// True when a and b produce the same images (the same scene and every
// setting that changes a pixel). The light-set count is not one of them: a
// render with more sets goes on from the sets it has.
bool sameImageSettings(const StudioSettings& a, const StudioSettings& b);

// Error of each method's indirect image at one moment, as relMSE (compare.h)
// against the reference in use with that reference's own noise subtracted:
// for a test image T independent of the reference R,
// E[relMSE(T, R)] = relMSE(T, truth) + relMSE(R, truth), and relMSE(R, truth)
// is estimated from R's two independent halves as relMSE(A, B) / 4
// (reference.h). The values can dip below zero where the noise estimate
// exceeds the difference.
struct ErrorSample {
  double manySeconds;  // wall time of the many-light work so far (both methods)
  double vslSeconds;   // VSL's own time: light tracing, k-NN radii, its gather share
  double vplSeconds;   // VPL's own time: light tracing, its gather share
  double vsl, vpl;
  double ptSeconds;       // compute time of the live path tracer so far
  double pt;              // its error: against a converged reference, else its own noise estimate
  double referenceNoise;  // what was subtracted (0 if unknown)
  // What the verdict weighs a difference of errors against (verdict.h): the
  // light sets complete, and one light set's variance of each method
  // (BiasNoise::variance, relMSE units; negative before two sets).
  int lightSetsDone = 0;
  double vslSetVariance = -1, vplSetVariance = -1;
};

// The live path tracer's samples per pixel to reach, given its samples so
// far, the setting (maxSpp) and its own noise: maxSpp, or past it the count
// at which its noise (falling as 1/spp) is a fifth of the smallest method
// error of the history's last point, at most kLiveReferenceSppFactor x maxSpp.
constexpr int kLiveReferenceSppFactor = 64;
int liveReferenceTarget(int spp, int maxSpp, double noise, const std::vector<ErrorSample>& history);

// Equal time: each method's error at the same amount of its own time.
enum class StudioMethod { Vsl, Vpl, Pt };

// True when a and b differ, but only in parameters method m (VSL or VPL)
// never reads: those declared for the other method alone (ParamSpec::
// appliesTo "VSL" or "VPL"), so that m's images are the same bit for bit. A
// restart from a to b keeps m's completed light sets and renders the other
// method alone for them (docs/USAGE.md, "One-method restarts"). False under
// the pair roulette, whose choice of pairs reads both methods' bounds, with
// an estimator that gathers a light set in one step (its VSL and VPL share
// the step), and when either method is off.
bool unchangedFor(StudioMethod m, const StudioSettings& a, const StudioSettings& b);

// The method's own time and error in one history entry.
double ownSeconds(const ErrorSample& e, StudioMethod m);
double ownError(const ErrorSample& e, StudioMethod m);
// The largest budget every method has reached: the smallest of their latest
// own times (0 for an empty history).
double equalTimeBudget(const std::vector<ErrorSample>& history);
// The method's error after t seconds of its own time, interpolated linearly
// between the history's points; NaN outside the times it has reached.
double errorAtOwnTime(const std::vector<ErrorSample>& history, StudioMethod m, double t);

// Bias against noise of one method's indirect image: compare.h's
// biasVariance over the method's independent estimates (the completed light
// sets; the path tracer's two halves) against the reference in use, averaged
// over the channels. "One render" is one light set, or one half of the path
// tracer. The reference's own noise is not subtracted here (it adds to
// bias2; the studio subtracts Snapshot::referenceNoise where it is known).
struct BiasNoise {
  int renders = 0;  // independent estimates; < 2: not measured
  double bias2 = 0, variance = 0, relMse = 0;
};
// Rows of Snapshot::biasNoise.
enum class BiasNoiseRow : int { Vsl, Vpl, VplUnclamped, VplDiffuse, Pt, Count };

struct Snapshot {
  uint64_t generation = 0;
  uint64_t serial = 0;  // increases with every publish
  StudioSettings settings;
  int width = 0, height = 0;
  // The mean over the completed light sets (the first set's progressive
  // estimate until it completes; a set in progress after that is not in it).
  ManyLightImages many;
  int lightSets = 1;      // asked for (settings.lightSets)
  int lightSetsDone = 0;  // completed: `many` is their mean
  // Completed sets in VSL's and in the VPL layers: lightSetsDone, or more
  // for the method whose sets were kept across a restart while the other
  // renders them again (unchangedFor).
  int vslLightSetsDone = 0, vplLightSetsDone = 0;
  int directSamplesPerSet = 0;  // each set's direct-light samples (lightSetSettings)
  // The estimator's statistics (ManyLightEstimator::statistics): the set in
  // progress once it has a step, else the newest completed set's.
  std::vector<std::pair<std::string, double>> estimatorStats;
  BiasNoise biasNoise[int(BiasNoiseRow::Count)];  // the path tracer's against a converged reference only
  Image ptDirect, ptIndirect;                     // the live path tracer (mean of its two halves)
  int ptSpp = 0;
  // The reference every error is measured against: a converged one (file or
  // cache) when there is one, else the live path tracer.
  Image refDirect, refIndirect;
  bool convergedReference = false;
  // The reference is another renderer's full image only (reference.h,
  // Reference::fullOnly): the history, bias and noise compare the full
  // component, and refIndirect is that image less the live direct light.
  bool comparesFull = false;
  std::string referenceSource;            // "live path tracer", a file path, or "cache: KEY"
  int referenceSpp = 0;                   // its samples per pixel (0: unknown)
  double referenceNoise = -1;             // its estimated relMSE against the truth; < 0: unknown
  int backgroundSpp = 0;                  // the background reference's progress (0: none)
  double vslSeconds = 0, vplSeconds = 0;  // each method's own time (ErrorSample)
  // Lights gathered and to gather over all sets (the sets not yet traced
  // counted at the size of the last one); batches of the set in progress.
  size_t lightsProcessed = 0, lightsTotal = 0;
  int batchesDone = 0, batchCount = 0;
  double seconds = 0;  // wall time since the job started (a resumed job keeps its clock)
  double lightTracingSeconds = 0, knnSeconds = 0, gatherSeconds = 0;  // summed over the sets
  double referenceSeconds = 0;                                        // compute time in the reference, across restarts
  // Resolved settings: the VPL clamp bound in use, radii of the VSLs, and
  // the VSL samples actually drawn (auto grows with the cone angle).
  float clampBound = 0;
  float sceneRadius = 0;  // bounding radius R
  float radiusMin = 0, radiusMedian = 0, radiusMax = 0;
  uint64_t pairs = 0, vslEvaluations = 0;
  uint64_t rouletteDropped = 0;  // pairs the pair roulette dropped (ManyLightSettings::pairRoulette)
  double pairsPerSecond = 0;
  // Progress. A brute-force batch costs its lights and, whatever its lights,
  // every pixel's eye path and direct samples (the first of 16 batches holds
  // one light), so the work's fraction done is in time: the time spent
  // (tracing, k-NN, gathers) over that plus the time left, which the batches
  // done predict part by part (BatchCostModel); lightsProcessed counts
  // lights.
  double lightsPerSecond = 0;  // gathered per second of gather time
  // The times left are wall-clock: until one of the many-light methods and
  // the reference is done, they take turns (equal time), each at about half
  // its own rate.
  double manyRemainingSeconds = 0;  // 0 when done or not known yet
  double manyFractionDone = 0;      // in [0, 1]; 1 when done
  double referenceSppPerSecond = 0;
  double referenceRemainingSeconds = 0;  // wall-clock, as above; 0 when done or not known yet
  // When the session published it (the times left count down from here).
  std::chrono::steady_clock::time_point publishedAt{};
  uint64_t nonFinite = 0;
  std::vector<ErrorSample> history;
  bool manyLightDone = false;  // every light set is done
  bool referenceDone = false;
  // The live path tracer's samples per pixel to reach: the setting, or more
  // while it is the reference in use and its noise is above a fifth of the
  // smallest method error (liveReferenceTarget).
  int referenceTargetSpp = 0;
  // The first light set's VSL image is complete but its VPL image is not: an
  // MRCS light set publishes its VSL picture before VPL's columns are
  // rendered (StepProgress::onVslImage). The VPL layers are black
  // until then, the set's work (pairs, seconds, lights gathered) is counted
  // once it completes, and no point is added to the history.
  bool vplPending = false;
};

// The component every error, bias and equal-time number of s is measured on:
// indirect, or full against a full-only reference (Snapshot::comparesFull).
inline Component comparedComponent(const Snapshot& s) { return s.comparesFull ? Component::Full : Component::Indirect; }
// An image (direct and indirect parts) in the component compared: the
// indirect part, or both summed (the indirect part alone where the direct
// one has no picture of its size yet).
Image comparedImage(const Snapshot& s, const Image& direct, const Image& indirect);

class Session {
 public:
  Session();
  ~Session();  // cancels and joins the worker
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  // Starts (or restarts) rendering with these settings; returns the new
  // generation (> 0). Invalid settings, and settings whose memory estimate
  // does not fit, are rejected: an error with the reason (and the estimate),
  // and the current render goes on. fromScratch: never resume an interrupted
  // render with the same settings.
  Result<uint64_t> restart(const StudioSettings& settings, bool fromScratch = false);
  // While the reference catches up with a many-light step's time (it takes
  // turns with the many-light methods), a snapshot goes out this often: each
  // costs image copies and comparisons here and the studio's FLIP maps,
  // which share the cores with the reference's passes.
  static constexpr double kCatchUpShowSeconds = 2.0;
  // The newest snapshot of the current generation if its serial is greater
  // than `haveSerial`, else null.
  std::shared_ptr<const Snapshot> latest(uint64_t haveSerial) const;

  struct Status {
    uint64_t generation = 0;
    std::string scene;             // the scene being rendered ("" before the first successful load)
    float sceneAspect = 0;         // its camera's width / height (0 if unknown)
    std::string loadError;         // the last failed load ("" if none); cleared by a successful load
    uint64_t loadErrorSerial = 0;  // increases with every failed load
    bool noEmitters = false;       // the last failed load was a scene without emitters
    // The environment in use, and whether the last failed load was the
    // environment's alone (its file; the scene and the previous environment stay).
    EnvironmentSettings env;
    bool environmentFailed = false;
    std::string runError;         // the last refused or failed render ("out of memory ...")
    uint64_t runErrorSerial = 0;  // increases with every refused or failed render
    // Why the settings' reference file was refused (it names the file and the
    // reason: another size, no indirect layer, unreadable); "" when it is in
    // use or none was given. Errors are then measured against the live path tracer.
    std::string referenceError;
    // "idle", "loading", "tracing lights", "k-NN radii", "tracing lobe-gather
    // lights" (ManyLightSettings::lobeGather), "rendering", "done"
    std::string stage;
    std::string loading;        // the path being loaded while stage is "loading"
    double stageSeconds = 0;    // wall time since the stage began
    uint32_t lightsTarget = 0;  // the light count being traced
    // Within a long step while rendering: its stage and share done
    // (StepProgress::text; MRCS: "MRCS columns 43%"); "" otherwise.
    std::string stepProgress;
    std::vector<std::string> sceneWarnings;
    bool busy() const { return stage != "idle" && stage != "done"; }
  };
  Status status() const;
  uint64_t generation() const { return generation_.load(); }
  // Increases whenever a snapshot is published or the status changes: the UI
  // redraws only when it moved.
  uint64_t version() const { return version_.load(); }

  // Asks the worker to stop and waits up to `seconds` for it to leave; true
  // if it has. Stages that cannot be interrupted (parsing a scene file,
  // building a k-d tree) may take longer; the caller decides what to do then.
  bool shutdown(double seconds);
  // Tests: pretend this many bytes are available (0: ask the system).
  void setAvailableMemoryForTesting(uint64_t bytes) { memoryForTesting_.store(bytes); }
  // Tests: called with every snapshot the worker publishes, in order, on the
  // worker thread and before latest() can return it (so a test sees even a
  // snapshot that is replaced at once). Null: none.
  void setPublishHookForTesting(std::function<void(const Snapshot&)> hook);

 private:
  struct Job;
  struct Worker;
  void run();
  void step(Worker& w, StudioSettings s, uint64_t gen, bool fromScratch);
  bool ensureScene(Worker& w, StudioSettings& s);
  std::unique_ptr<Job> prepare(Worker& w, const StudioSettings& s, Job* replaced);
  static void keepMethod(Job& from, Job& to);
  bool prepareSet(Worker& w, Job& job);
  void retireSet(Job& job, bool completed);
  void biasNoise(const Worker& w, const Job& job, Snapshot& snap) const;
  void render(Worker& w, Job& job, uint64_t gen);
  void showVslFirst(Worker& w, Job& job, uint64_t gen, const ManyLightImages& vslImages, double stepSeconds);
  void logStep(const Job& job, double stepSeconds) const;
  std::shared_ptr<Snapshot> makeSnapshot(const Worker& w, Job& job, uint64_t gen,
                                         const ManyLightImages* vslFirst = nullptr) const;
  // makeSnapshot's parts: the images (returns the live path tracer's noise),
  // the many-light methods' compute time left, and the reference's rate.
  static double snapshotImages(const Job& job, const ReferenceRenderer& ref, const ManyLightImages* vslFirst,
                               Snapshot& snap);
  static double manyLightSecondsLeft(const Job& job, const ManyLightStats& st, size_t setSize, int untraced,
                                     Snapshot& snap);
  static void referenceRate(const Job& job, const ReferenceRenderer& ref, int target, Snapshot& snap);
  static void useReference(const Worker& w, double liveNoise, Snapshot& snap);
  static void recordError(const Worker& w, Job& job, double liveNoise, Snapshot& snap);
  static int liveTarget(const Worker& w, const Job& job);
  void chooseReference(Worker& w, Job& job);
  bool renderBackgroundReference(Worker& w, Job& job, uint64_t gen);
  bool publish(std::shared_ptr<Snapshot> s);
  void setStage(const std::string& stage, uint32_t lightsTarget = 0);
  void reportRunError(const std::string& message);
  bool stopped() const { return stop_.load(std::memory_order_relaxed); }
  Result<void> checkMemory(const StudioSettings& s, int width, int height) const;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable exitedCv_;
  bool quit_ = false, exited_ = false;
  bool pending_ = false, pendingFromScratch_ = false;
  StudioSettings next_;
  std::atomic<uint64_t> version_{0}, memoryForTesting_{0};
  StepProgress stepProgress_;  // the long step in progress, if any
  Stopwatch stageClock_;       // since the stage began
  std::atomic<uint64_t> generation_{0};
  std::atomic<bool> stop_{false};
  std::shared_ptr<const Snapshot> latest_;
  std::function<void(const Snapshot&)> publishHook_;  // tests
  uint64_t serial_ = 0;
  Status status_;
  std::thread worker_;
};

}  // namespace vsl
