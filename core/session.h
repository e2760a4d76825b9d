// Session: the studio's background renderer. One worker thread loads scenes,
// traces virtual lights, and interleaves many-light batches (VSL and VPL from
// shared passes) with path-traced reference passes, publishing an immutable
// Snapshot after each step. The UI calls restart() with a settings value and
// pulls the newest snapshot once per frame with latest(); neither call waits
// for rendering.
//
// Generations: every restart() bumps the generation. The worker checks a stop
// flag between tiles, so a restart takes effect within one tile of work, and
// publish() drops any snapshot whose generation is no longer current: after
// restart() returns generation g, latest() never returns a snapshot older
// than g.
// A scene that fails to load leaves the previous scene in place; the error is
// reported through status() and the log.
#pragma once

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/many_light.h"

namespace vsl {

struct StudioSettings {
  std::string scene;       // path of a .gltf or .glb
  ManyLightSettings many;  // lights, radii, clamp, seed, resolution, batches
  int maxReferenceSpp = 4096;
  std::string validate() const;
};

// Error of each method's indirect image against the reference at one moment.
struct ErrorSample {
  double manySeconds;  // compute time spent on the many-light methods so far
  double vsl, vpl;     // relMSE (eps = 1e-2) of their indirect images against the reference's
  double ptSeconds;    // compute time spent on the reference so far
  double pt;           // the reference's own expected relMSE, from its per-pixel sample variance
};

struct Snapshot {
  uint64_t generation = 0;
  uint64_t serial = 0;  // increases with every publish
  StudioSettings settings;
  int width = 0, height = 0;
  ManyLightImages many;
  Image ptDirect, ptIndirect;  // the progressive path-traced reference
  int ptSpp = 0;
  size_t lightsProcessed = 0, lightsTotal = 0;
  int batchesDone = 0, batchCount = 0;
  double seconds = 0;  // since the generation started
  double lightTracingSeconds = 0;
  double pairsPerSecond = 0;
  uint64_t nonFinite = 0;
  std::vector<ErrorSample> history;
  bool manyLightDone = false, referenceDone = false;
};

class Session {
 public:
  Session();
  ~Session();  // cancels and joins the worker
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  // Starts (or restarts) rendering with these settings; returns the new
  // generation. Invalid settings are rejected (returns 0, error in *error).
  uint64_t restart(const StudioSettings& settings, std::string* error = nullptr);
  // The newest snapshot of the current generation if its serial is greater
  // than `haveSerial`, else null.
  std::shared_ptr<const Snapshot> latest(uint64_t haveSerial) const;

  struct Status {
    uint64_t generation = 0;
    std::string scene;             // the scene being rendered
    std::string loadError;         // the last failed load ("" if none); cleared by a successful load
    uint64_t loadErrorSerial = 0;  // increases with every failed load
    std::string stage;             // "idle", "loading", "tracing lights", "rendering", "done"
    std::vector<std::string> sceneWarnings;
  };
  Status status() const;
  uint64_t generation() const { return generation_.load(); }

 private:
  void run();
  bool publish(std::shared_ptr<Snapshot> s);
  void setStage(const std::string& stage);

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool quit_ = false;
  bool pending_ = false;
  StudioSettings next_;
  std::atomic<uint64_t> generation_{0};
  std::atomic<bool> stop_{false};
  std::shared_ptr<const Snapshot> latest_;
  uint64_t serial_ = 0;
  Status status_;
  std::thread worker_;
};

}  // namespace vsl
