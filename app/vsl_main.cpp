// `vsl`: the command-line front end. Subcommands: render, compare, info, bench.
// Exit codes: 0 success, 1 bad input (scene, image, I/O), 2 bad arguments.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "app/bench.h"
#include "app/sweep.h"
#include "core/compare.h"
#include "core/flip.h"
#include "core/image_io.h"
#include "core/log.h"
#include "core/many_light.h"
#include "core/mrcs.h"
#include "core/pathtracer.h"
#include "core/reference.h"

using namespace vsl;
using json = nlohmann::json;

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A progress bar on stderr: redrawn in place on a terminal, one line per 10%
// otherwise (logs stay readable).
class Progress {
 public:
  explicit Progress(const char* label) : label_(label), tty_(isatty(STDERR_FILENO)) {}
  void update(double fraction, const std::string& detail) {
    fraction = std::min(std::max(fraction, 0.0), 1.0);
    if (tty_) {
      auto now = Clock::now();
      if (fraction < 1 && now - last_ < std::chrono::milliseconds(100)) return;
      last_ = now;
      int filled = int(fraction * 30);
      std::fprintf(stderr, "\r%s [%s%s] %3d%% %s   ", label_, std::string(filled, '#').c_str(),
                   std::string(30 - filled, ' ').c_str(), int(fraction * 100), detail.c_str());
    } else {
      int decile = int(fraction * 10);
      if (decile <= lastDecile_) return;
      lastDecile_ = decile;
      std::fprintf(stderr, "%s %3d%% %s\n", label_, decile * 10, detail.c_str());
    }
    std::fflush(stderr);
  }
  void finish() {
    if (tty_) std::fprintf(stderr, "\n");
  }

 private:
  const char* label_;
  bool tty_;
  Clock::time_point last_{};
  int lastDecile_ = -1;
};

std::shared_ptr<const Scene> loadOrReport(const std::string& path, const std::string& camera) {
  LoadOptions opts;
  opts.cameraName = camera;
  SceneResult r = loadScene(path, opts);
  if (!r) {
    std::fprintf(stderr, "error: %s\n", r.error().c_str());
    return nullptr;
  }
  for (const std::string& w : (*r)->warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  return *r;
}

// Parses --mrcs ROWS,CLUSTERS[,MIX]; reports and returns false when malformed.
bool parseMrcsSpec(const std::string& spec, MrcsSettings& out) {
  char tail = 0;
  int n = std::sscanf(spec.c_str(), "%d,%d,%lf%c", &out.rows, &out.clusters, &out.uniformMix, &tail);
  if ((n == 2 || n == 3) && out.validate()) return true;
  std::fprintf(stderr,
               "error: --mrcs must be ROWS,CLUSTERS with positive integers, optionally ,MIX in [0,1] (got '%s')\n",
               spec.c_str());
  return false;
}

json metricsJson(const ChannelMetrics& m) {
  return {{"mean", m.meanTest}, {"meanReference", m.meanRef}, {"bias", m.bias}, {"mae", m.mae},
          {"rmse", m.rmse},     {"relMSE", m.relMse}};
}

Vec3 imageMean(const Image& img) {
  double s[3] = {0, 0, 0};
  for (size_t i = 0; i < img.rgb.size(); ++i) s[i % 3] += img.rgb[i];
  double n = std::max<size_t>(1, img.rgb.size() / 3);
  return {float(s[0] / n), float(s[1] / n), float(s[2] / n)};
}

// ---- render -------------------------------------------------------------------

struct RenderArgs {
  std::string scene, out, png, jsonPath, camera, component = "full";
  RenderSettings settings;
  ManyLightSettings many;
  std::string clamp = "auto", vslSamples = "auto", mrcsSpec;
  bool mrcsSpread = false;
  MrcsSettings mrcs{0, 0, 0};  // rows 0: no MRCS
  float exposure = 0;
};

int renderManyLights(RenderArgs& a, const Scene& scene, const Accel& accel, double loadSeconds);

int cmdRender(RenderArgs& a) {
  if (!parseComponent(a.component, &a.settings.component)) {
    std::fprintf(stderr, "error: --component must be full, direct or indirect (got '%s')\n", a.component.c_str());
    return 2;
  }
  if (Result<void> v = a.settings.validate(); !v) {
    std::fprintf(stderr, "error: %s\n", v.error().c_str());
    return 2;
  }
  const bool many = a.settings.method != "pt";
  if (many) {
    ManyLightSettings& m = a.many;
    m.seed = a.settings.seed;
    m.computeVsl = a.settings.method != "vpl";
    m.computeVpl = a.settings.method != "vsl";
    m.width = a.settings.width;
    m.height = a.settings.height;
    if (a.clamp == "off")
      m.clamp = INFINITY;
    else if (a.clamp == "auto")
      m.clamp = -1;
    else {
      char* end = nullptr;
      double c = std::strtod(a.clamp.c_str(), &end);
      if (end == a.clamp.c_str() || *end != 0 || !(c > 0)) {
        std::fprintf(stderr, "error: --clamp must be a positive number, 'auto' or 'off' (got '%s')\n", a.clamp.c_str());
        return 2;
      }
      m.clamp = float(c);
    }
    if (a.vslSamples == "auto")
      m.vslSamples = 0;
    else {
      char* end = nullptr;
      long n = std::strtol(a.vslSamples.c_str(), &end, 10);
      if (end == a.vslSamples.c_str() || *end != 0 || n < 1 || n > 4096) {
        std::fprintf(stderr, "error: --vsl-samples must be 'auto' or in [1,4096] (got '%s')\n", a.vslSamples.c_str());
        return 2;
      }
      m.vslSamples = int(n);
    }
    if (Result<void> v = m.validate(); !v) {
      std::fprintf(stderr, "error: %s\n", v.error().c_str());
      return 2;
    }
    if (!a.mrcsSpec.empty() && !parseMrcsSpec(a.mrcsSpec, a.mrcs)) return 2;
    a.mrcs.spreadVslRadius = a.mrcsSpread;
  }
  auto t0 = Clock::now();
  auto scene = loadOrReport(a.scene, a.camera);
  if (!scene) return 1;
  // The camera's aspect ratio fills in a missing side: the result must still
  // be within the resolution cap.
  int w0 = a.settings.width, h0 = a.settings.height;
  resolveResolution(*scene, w0, h0);
  if (w0 > RenderSettings::kMaxResolution || h0 > RenderSettings::kMaxResolution) {
    std::fprintf(stderr,
                 "error: %s: the camera's aspect ratio %g turns the requested size into %dx%d, over the limit of %d "
                 "a side; give both --width and --height\n",
                 a.scene.c_str(), scene->camera.aspect, w0, h0, RenderSettings::kMaxResolution);
    return 2;
  }
  Result<std::unique_ptr<Accel>> built = Accel::build(*scene);
  if (!built) {
    std::fprintf(stderr, "error: %s\n", built.error().c_str());
    return 1;
  }
  const std::unique_ptr<Accel>& accel = *built;
  double loadSeconds = secondsSince(t0);
  if (many) return renderManyLights(a, *scene, *accel, loadSeconds);
  LightSampler lights(*scene);
  PathTracer pt(*scene, *accel, lights, a.settings);
  int w = pt.width(), h = pt.height();
  Film direct(w, h), indirect(w, h);
  PtCounters counters;

  // Progressive passes: one sample per pixel each, until spp or time is reached.
  Progress progress("render");
  auto t1 = Clock::now();
  int passes = 0;
  const RenderSettings& s = a.settings;
  while (true) {
    // At least one pass: a time budget too short for one still renders one.
    if (passes > 0 && (s.timeLimit > 0 ? secondsSince(t1) >= s.timeLimit : passes >= s.spp)) break;
    pt.renderPass(passes, direct, indirect, counters);
    ++passes;
    double el = secondsSince(t1);
    double frac = s.timeLimit > 0 ? el / s.timeLimit : double(passes) / s.spp;
    char detail[128];
    std::snprintf(detail, sizeof detail, "%d spp, %.2f Mpaths/s, %.1f s", passes, counters.paths / el * 1e-6, el);
    progress.update(frac, detail);
  }
  progress.finish();
  double renderSeconds = secondsSince(t1);

  Image dImg = direct.image(), iImg = indirect.image(), fImg(w, h);
  for (size_t i = 0; i < fImg.rgb.size(); ++i) fImg.rgb[i] = dImg.rgb[i] + iImg.rgb[i];
  const Image& chosen = s.component == Component::Direct ? dImg : s.component == Component::Indirect ? iImg : fImg;

  std::map<std::string, std::string> attrs = {{"vsl.version", VSL_VERSION},
                                              {"vsl.scene", a.scene},
                                              {"vsl.settings", s.describe()},
                                              {"vsl.component", componentName(s.component)}};
  if (Result<void> written =
          writeExr(a.out, {{"", chosen}, {"full", fImg}, {"direct", dImg}, {"indirect", iImg}}, attrs);
      !written) {
    std::fprintf(stderr, "error: %s\n", written.error().c_str());
    return 1;
  }
  std::fprintf(stderr, "wrote %s (%dx%d, %d spp, layers: default=%s, full, direct, indirect)\n", a.out.c_str(), w, h,
               passes, componentName(s.component));
  if (!a.png.empty()) {
    if (Result<void> written = writePng(a.png, chosen, a.exposure); !written) {
      std::fprintf(stderr, "error: %s\n", written.error().c_str());
      return 1;
    }
    std::fprintf(stderr, "wrote %s\n", a.png.c_str());
  }
  uint64_t rejected = counters.nonFinite + direct.rejected() + indirect.rejected();
  if (rejected > 0) log::warning("rejected " + std::to_string(rejected) + " non-finite contributions");
  if (!a.jsonPath.empty()) {
    auto mean = [](const Image& im) {
      Vec3 m = imageMean(im);
      return json::array({m.x, m.y, m.z});
    };
    json j = {{"version", VSL_VERSION},
              {"scene", a.scene},
              {"camera", scene->camera.name},
              {"method", s.method},
              {"settings", s.describe()},
              {"width", w},
              {"height", h},
              {"spp", passes},
              {"seed", s.seed},
              {"maxDepth", s.maxDepth},
              {"component", componentName(s.component)},
              {"seconds", {{"load", loadSeconds}, {"render", renderSeconds}}},
              {"paths", counters.paths.load()},
              {"rays", counters.rays.load()},
              {"pathsPerSecond", counters.paths / std::max(renderSeconds, 1e-9)},
              {"raysPerSecond", counters.rays / std::max(renderSeconds, 1e-9)},
              {"nonFiniteRejected", rejected},
              {"mean", {{"full", mean(fImg)}, {"direct", mean(dImg)}, {"indirect", mean(iImg)}}},
              {"warnings", scene->warnings}};
    if (Result<void> written = writeTextFile(a.jsonPath, j.dump(2) + "\n"); !written) {
      std::fprintf(stderr, "error: %s\n", written.error().c_str());
      return 1;
    }
    std::fprintf(stderr, "wrote %s\n", a.jsonPath.c_str());
  }
  return 0;
}

// ---- reference ----------------------------------------------------------------

struct ReferenceArgs {
  std::string scene, out, camera;
  RenderSettings settings;  // width, height, spp, timeLimit, seed, maxDepth
  double target = 0;        // stop once the indirect noise estimate is at most this
  bool sppGiven = false, noCache = false;
};

std::string formatSeconds(double s) {
  char b[32];
  if (s < 90)
    std::snprintf(b, sizeof b, "%.0f s", s);
  else if (s < 5400)
    std::snprintf(b, sizeof b, "%.1f min", s / 60);
  else
    std::snprintf(b, sizeof b, "%.1f h", s / 3600);
  return b;
}

// Renders a converged reference as two independent halves (reference.h),
// writes it to -o and to the cache, and reports its own noise.
int cmdReference(ReferenceArgs& a) {
  RenderSettings& s = a.settings;
  if (Result<void> v = s.validate(); !v) {
    std::fprintf(stderr, "error: %s\n", v.error().c_str());
    return 2;
  }
  if (!(a.target >= 0) || a.target >= 1e3) {
    std::fprintf(stderr, "error: --target-relmse must be in (0, 1000) (got %g)\n", a.target);
    return 2;
  }
  // Without a time or noise target, --spp (default 1024) decides; with one,
  // --spp is an upper bound only when given.
  const bool bySpp = s.timeLimit <= 0 && a.target <= 0;
  const int maxSpp = bySpp || a.sppGiven ? std::max(2, s.spp + (s.spp & 1)) : (1 << 20);
  auto scene = loadOrReport(a.scene, a.camera);
  if (!scene) return 1;
  int w = s.width, h = s.height;
  resolveResolution(*scene, w, h);
  if (w > RenderSettings::kMaxResolution || h > RenderSettings::kMaxResolution) {
    std::fprintf(stderr,
                 "error: %s: the camera's aspect ratio turns the requested size into %dx%d; give both --width "
                 "and --height\n",
                 a.scene.c_str(), w, h);
    return 2;
  }
  s.width = w, s.height = h;
  Result<std::unique_ptr<Accel>> built = Accel::build(*scene);
  if (!built) {
    std::fprintf(stderr, "error: %s\n", built.error().c_str());
    return 1;
  }
  std::unique_ptr<Accel> accel = std::move(built).value();
  const std::string key = referenceKey(*scene, w, h, s.maxDepth);
  LightSampler lights(*scene);
  ReferenceRenderer rr(*scene, *accel, lights, s);
  std::fprintf(stderr, "reference: %s, %dx%d, max depth %d, cache key %s\n", a.scene.c_str(), w, h, s.maxDepth,
               key.c_str());
  Progress progress("reference");
  auto t0 = Clock::now();
  double noise = -1;
  while (true) {
    rr.step();
    double el = secondsSince(t0);
    const int spp = rr.spp();
    // The noise estimate costs one image comparison: check it every pass
    // pair when it decides, else every 16th.
    if (a.target > 0 || spp % 32 == 0) noise = rr.indirectNoise();
    const double perSpp = el / spp;
    double frac = double(spp) / maxSpp, remaining = (maxSpp - spp) * perSpp;
    if (s.timeLimit > 0) {
      frac = std::max(frac, el / s.timeLimit);
      remaining = std::min(remaining, s.timeLimit - el);
    }
    // The noise falls as 1/spp: the samples still needed follow from it.
    if (a.target > 0 && noise > 0 && spp >= 16) {
      double need = spp * noise / a.target;
      frac = std::max(frac, spp / std::max(need, double(spp)));
      remaining = std::min(remaining, std::max(need - spp, 0.0) * perSpp);
    }
    bool done = spp >= maxSpp || (s.timeLimit > 0 && el >= s.timeLimit) ||
                (a.target > 0 && spp >= 16 && noise >= 0 && noise <= a.target);
    char detail[160], noiseText[32] = "n/a";
    if (noise >= 0) std::snprintf(noiseText, sizeof noiseText, "%.2e", noise);
    std::snprintf(detail, sizeof detail, "%d spp, noise %s, %s, about %s left", spp, noiseText,
                  formatSeconds(el).c_str(), formatSeconds(std::max(remaining, 0.0)).c_str());
    progress.update(done ? 1.0 : std::min(frac, 0.999), detail);
    if (done) break;
  }
  progress.finish();
  Reference ref = rr.result();
  ref.key = key;
  noise = ref.indirectNoise();
  std::fprintf(stderr, "reference: %d spp in %s; own noise: indirect relMSE %.3g, full %.3g (relMSE(A, B) / 4)\n",
               ref.spp, formatSeconds(ref.seconds).c_str(), noise, ref.fullNoise());
  if (rr.rejected() > 0) log::warning("rejected " + std::to_string(rr.rejected()) + " non-finite contributions");
  if (!a.out.empty()) {
    if (Result<void> written = writeReference(a.out, ref, a.scene); !written) {
      std::fprintf(stderr, "error: %s\n", written.error().c_str());
      return 1;
    }
    std::fprintf(stderr, "wrote %s (layers: full, direct, indirect and halves A.*, B.*)\n", a.out.c_str());
  }
  if (!a.noCache) {
    Result<std::string> stored = storeCachedReference(ref, a.scene);
    if (!stored) {
      std::fprintf(stderr, "error: %s\n", stored.error().c_str());
      return 1;
    }
    const std::string& written = *stored;
    if (written.empty())
      std::fprintf(stderr, "cache: kept %s (it has at least as many samples)\n", referenceCachePath(key).c_str());
    else
      std::fprintf(stderr, "cache: stored %s\n", written.c_str());
  }
  return 0;
}

// ---- compare ------------------------------------------------------------------

struct CompareArgs {
  std::vector<std::string> images;  // TEST [TEST2 ...] REFERENCE
  std::string layer, refLayer, out, png, flipExr, flipPng;
  bool json = false, noFlip = false;
  double epsilon = kRelMseEpsilon;
  std::string epsilonMode = "relative";
  float exposure = 0;  // of the tone map before LDR-FLIP
};

const Image* findLayer(const std::vector<Layer>& layers, const std::string& name, bool explicitName) {
  for (const Layer& l : layers)
    if (l.name == name) return &l.image;
  if (!explicitName)  // no default layer: fall back to "full"
    for (const Layer& l : layers)
      if (l.name == "full") return &l.image;
  return nullptr;
}

// LDR-FLIP (after the PNG tone map at --exposure) and HDR-FLIP of a test image.
struct CompareFlip {
  FlipResult ldr, hdr;
};

CompareFlip compareFlip(const Image& t, const Image& r, float exposure) {
  return {flipLdr(toSrgbImage(t, exposure), toSrgbImage(r, exposure)), flipHdr(t, r)};
}

// FLIP is a colour metric: one value for the RGB image, in "flip" and in "average".
void addFlipJson(json& j, const CompareFlip& f, float exposure) {
  j["flip"] = {{"ldr", f.ldr.mean},
               {"hdr", f.hdr.mean},
               {"pixelsPerDegree", kFlipPixelsPerDegree},
               {"ldrToneMap", "linear x 2^exposure, clamped, sRGB"},
               {"ldrExposure", exposure},
               {"hdrStartExposure", f.hdr.startExposure},
               {"hdrStopExposure", f.hdr.stopExposure},
               {"hdrExposures", f.hdr.exposures}};
  j["average"]["flip"] = {{"ldr", f.ldr.mean}, {"hdr", f.hdr.mean}};
}

void addEpsilonJson(json& j, double resolved, const RelMseEpsilon& spec) {
  j["epsilon"] = resolved;
  j["epsilon_mode"] = spec.modeName();
  j["epsilon_factor"] = spec.value;
}

void printFlip(const CompareFlip& f, float exposure) {
  std::printf(
      "FLIP (mean over pixels, the RGB image as a whole, %.1f pixels/degree): LDR %.6g (tone map: exposure %g, "
      "clamped, sRGB), HDR %.6g (exposures %.2f to %.2f, %d steps)\n",
      kFlipPixelsPerDegree, f.ldr.mean, exposure, f.hdr.mean, f.hdr.startExposure, f.hdr.stopExposure, f.hdr.exposures);
}

// --flip-exr: layers default=ldr, ldr, hdr; --flip-png: magma with a colour
// bar, LDR to PATH and HDR to PATH's stem + "-hdr.png".
bool writeFlipMaps(const CompareArgs& a, const CompareFlip& f, std::string& err) {
  if (!a.flipExr.empty()) {
    if (Result<void> w = writeExr(a.flipExr, {{"", f.ldr.map}, {"ldr", f.ldr.map}, {"hdr", f.hdr.map}}); !w) {
      err = w.error();
      return false;
    }
    std::fprintf(stderr, "wrote %s (FLIP maps, layers: default=ldr, ldr, hdr)\n", a.flipExr.c_str());
  }
  if (!a.flipPng.empty()) {
    std::string stem = a.flipPng.size() > 4 && a.flipPng.substr(a.flipPng.size() - 4) == ".png"
                           ? a.flipPng.substr(0, a.flipPng.size() - 4)
                           : a.flipPng;
    for (auto [path, map] : {std::pair{a.flipPng, &f.ldr.map}, std::pair{stem + "-hdr.png", &f.hdr.map}}) {
      int rows = 0;
      std::vector<uint8_t> px = magmaWithBar(*map, &rows);
      if (Result<void> w = writePngRgb8(path, map->width, rows, px); !w) {
        err = w.error();
        return false;
      }
      std::fprintf(stderr, "wrote %s (FLIP, magma: black 0 ... light yellow 1, colour bar below)\n", path.c_str());
    }
  }
  return true;
}

int compareMany(const CompareArgs& a, const std::vector<const Image*>& tests, const Image& r, const RelMseEpsilon& eps);

// The test images and the reference, read and checked (layers, sizes).
struct CompareInputs {
  std::vector<std::vector<Layer>> testLayers;
  std::vector<Layer> refLayers;
  std::vector<const Image*> tests;
  const Image* ref = nullptr;
};

// Returns 0, or 1 after reporting what is wrong.
int loadCompareInputs(const CompareArgs& a, bool layerGiven, bool refLayerGiven, CompareInputs& in) {
  const std::string& refPath = a.images.back();
  const size_t K = a.images.size() - 1;
  in.testLayers.resize(K);
  for (size_t k = 0; k < K; ++k) {
    Result<std::vector<Layer>> read = readExr(a.images[k]);
    if (!read) {
      std::fprintf(stderr, "error: %s\n", read.error().c_str());
      return 1;
    }
    in.testLayers[k] = std::move(read).value();
  }
  Result<std::vector<Layer>> refRead = readExr(refPath);
  if (!refRead) {
    std::fprintf(stderr, "error: %s\n", refRead.error().c_str());
    return 1;
  }
  in.refLayers = std::move(refRead).value();
  const std::string& refName = refLayerGiven ? a.refLayer : a.layer;
  const Image* r = in.ref = findLayer(in.refLayers, refName, refLayerGiven || layerGiven);
  if (!r) {
    std::fprintf(stderr, "error: %s: no layer '%s'\n", refPath.c_str(), refName.c_str());
    return 1;
  }
  for (size_t k = 0; k < K; ++k) {
    const Image* t = findLayer(in.testLayers[k], a.layer, layerGiven);
    if (!t) {
      std::fprintf(stderr, "error: %s: no layer '%s'\n", a.images[k].c_str(), a.layer.c_str());
      return 1;
    }
    if (t->width != r->width || t->height != r->height) {
      std::fprintf(stderr, "error: sizes differ: %s is %dx%d, %s is %dx%d\n", a.images[k].c_str(), t->width, t->height,
                   refPath.c_str(), r->width, r->height);
      return 1;
    }
    in.tests.push_back(t);
  }
  return 0;
}

int cmdCompare(const CompareArgs& a, bool layerGiven, bool refLayerGiven) {
  CompareInputs in;
  if (int rc = loadCompareInputs(a, layerGiven, refLayerGiven, in); rc != 0) return rc;
  const std::string& refPath = a.images.back();
  const Image* r = in.ref;
  std::string err;
  const RelMseEpsilon eps = a.epsilonMode == "absolute" ? RelMseEpsilon(a.epsilon) : RelMseEpsilon::relative(a.epsilon);
  if (in.tests.size() > 1) return compareMany(a, in.tests, *r, eps);
  const Image* t = in.tests[0];
  const std::string& testPath = a.images[0];
  CompareResult c = compareImages(*t, *r, eps);
  CompareFlip flip;
  if (!a.noFlip) flip = compareFlip(*t, *r, a.exposure);
  if (a.json) {
    json j = {{"test", testPath},
              {"reference", refPath},
              {"layer", a.layer},
              {"pixels", c.pixels},
              {"nonFiniteTest", c.nonFiniteTest},
              {"nonFiniteReference", c.nonFiniteRef},
              {"R", metricsJson(c.channel[0])},
              {"G", metricsJson(c.channel[1])},
              {"B", metricsJson(c.channel[2])},
              {"average", metricsJson(c.average)}};
    addEpsilonJson(j, c.epsilon, eps);
    if (!a.noFlip) addFlipJson(j, flip, a.exposure);
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf("comparing %s against %s (layer '%s', %zu pixels)\n", testPath.c_str(), refPath.c_str(),
                a.layer.c_str(), c.pixels);
    std::printf(
        "relMSE = mean((t-r)^2 / (r^2 + eps)), eps = %s = %g (%s); non-finite pixels: test %zu, reference %zu\n",
        eps.describe().c_str(), c.epsilon, eps.modeName(), c.nonFiniteTest, c.nonFiniteRef);
    std::printf("%-8s %12s %12s %12s %12s %12s %12s\n", "channel", "mean", "mean(ref)", "bias", "MAE", "RMSE",
                "relMSE");
    const char* names[4] = {"R", "G", "B", "average"};
    for (int i = 0; i < 4; ++i) {
      const ChannelMetrics& m = i < 3 ? c.channel[i] : c.average;
      std::printf("%-8s %12.6g %12.6g %12.6g %12.6g %12.6g %12.6g\n", names[i], m.meanTest, m.meanRef, m.bias, m.mae,
                  m.rmse, m.relMse);
    }
    if (!a.noFlip) printFlip(flip, a.exposure);
  }
  if (!a.noFlip && !writeFlipMaps(a, flip, err)) {
    std::fprintf(stderr, "error: %s\n", err.c_str());
    return 1;
  }
  if (!a.out.empty() || !a.png.empty()) {
    ErrorImages e = errorImages(*t, *r, eps);
    if (!a.out.empty()) {
      if (Result<void> written = writeExr(a.out, {{"", e.absolute},
                                                  {"signed", e.signedDiff},
                                                  {"absolute", e.absolute},
                                                  {"squared", e.squared},
                                                  {"relSquared", e.relSquared}});
          !written) {
        std::fprintf(stderr, "error: %s\n", written.error().c_str());
        return 1;
      }
      std::fprintf(stderr, "wrote %s (layers: default=absolute, signed, absolute, squared, relSquared)\n",
                   a.out.c_str());
    }
    if (!a.png.empty()) {
      // False colour of the per-pixel relative squared error (channel mean),
      // scaled so that the 99th percentile maps to white.
      size_t n = size_t(t->width) * t->height;
      std::vector<float> v(n);
      for (size_t i = 0; i < n; ++i)
        v[i] = (e.relSquared.rgb[3 * i] + e.relSquared.rgb[3 * i + 1] + e.relSquared.rgb[3 * i + 2]) / 3;
      std::vector<float> sorted;
      for (float x : v)
        if (std::isfinite(x)) sorted.push_back(x);
      std::sort(sorted.begin(), sorted.end());
      float vmax = sorted.empty() ? 1.0f : std::max(sorted[size_t(0.99 * (sorted.size() - 1))], 1e-12f);
      std::vector<uint8_t> px(n * 3);
      for (size_t i = 0; i < n; ++i) {
        Vec3 col = falseColour(v[i] / vmax);
        px[3 * i] = uint8_t(col.x * 255), px[3 * i + 1] = uint8_t(col.y * 255), px[3 * i + 2] = uint8_t(col.z * 255);
      }
      if (Result<void> written = writePngRgb8(a.png, t->width, t->height, px); !written) {
        std::fprintf(stderr, "error: %s\n", written.error().c_str());
        return 1;
      }
      std::fprintf(stderr, "wrote %s (relative squared error, white = %.3g)\n", a.png.c_str(), vmax);
    }
  }
  return 0;
}

// K >= 2 independent renders of one method against the reference: bias2,
// variance and the relMSE of their mean (core/compare.h), FLIP of the mean.
int compareMany(const CompareArgs& a, const std::vector<const Image*>& tests, const Image& r,
                const RelMseEpsilon& eps) {
  BiasVarianceResult bv = biasVariance(tests, r, eps);
  CompareFlip flip;
  if (!a.noFlip) flip = compareFlip(bv.mean, r, a.exposure);
  auto bvJson = [](const BiasVarianceChannel& m) {
    return json{{"mean", m.meanTest},
                {"meanReference", m.meanRef},
                {"bias2", m.bias2},
                {"variance", m.variance},
                {"relMSE", m.relMse}};
  };
  const std::vector<std::string> testPaths(a.images.begin(), a.images.end() - 1);
  if (a.json) {
    json j = {{"tests", testPaths},         {"reference", a.images.back()}, {"layer", a.layer},
              {"renders", bv.renders},      {"pixels", bv.pixels},          {"R", bvJson(bv.channel[0])},
              {"G", bvJson(bv.channel[1])}, {"B", bvJson(bv.channel[2])},   {"average", bvJson(bv.average)}};
    addEpsilonJson(j, bv.epsilon, eps);
    if (!a.noFlip) addFlipJson(j, flip, a.exposure);
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf("comparing the mean of %d renders against %s (layer '%s', %zu pixels)\n", bv.renders,
                a.images.back().c_str(), a.layer.c_str(), bv.pixels);
    std::printf(
        "weights 1 / (r^2 + eps), eps = %s = %g (%s); bias2 = mean((mean_k - r)^2 - var_k / K), variance = "
        "mean(var_k) (one render's noise), relMSE of the mean = bias2 + variance / K\n",
        eps.describe().c_str(), bv.epsilon, eps.modeName());
    std::printf("%-8s %12s %12s %12s %12s %12s\n", "channel", "mean", "mean(ref)", "bias2", "variance", "relMSE");
    const char* names[4] = {"R", "G", "B", "average"};
    for (int i = 0; i < 4; ++i) {
      const BiasVarianceChannel& m = i < 3 ? bv.channel[i] : bv.average;
      std::printf("%-8s %12.6g %12.6g %12.6g %12.6g %12.6g\n", names[i], m.meanTest, m.meanRef, m.bias2, m.variance,
                  m.relMse);
    }
    if (!a.noFlip) printFlip(flip, a.exposure);
  }
  std::string err;
  if (!a.noFlip && !writeFlipMaps(a, flip, err)) {
    std::fprintf(stderr, "error: %s\n", err.c_str());
    return 1;
  }
  if (!a.out.empty()) {
    if (Result<void> written =
            writeExr(a.out, {{"", bv.bias}, {"bias", bv.bias}, {"noise", bv.noise}, {"mean", bv.mean}});
        !written) {
      std::fprintf(stderr, "error: %s\n", written.error().c_str());
      return 1;
    }
    std::fprintf(stderr,
                 "wrote %s (layers: default=bias, bias (mean - reference), noise (one render's standard "
                 "deviation), mean)\n",
                 a.out.c_str());
  }
  if (!a.png.empty()) std::fprintf(stderr, "warning: --png is for a single test image; not written\n");
  return 0;
}

// ---- tonemap ------------------------------------------------------------------

int cmdTonemap(const std::string& in, const std::string& layer, const std::string& out, float exposure) {
  Result<std::vector<Layer>> layers = readExr(in);
  if (!layers) {
    std::fprintf(stderr, "error: %s\n", layers.error().c_str());
    return 1;
  }
  const Image* img = findLayer(*layers, layer, !layer.empty());
  if (!img) {
    std::fprintf(stderr, "error: %s: no layer '%s'\n", in.c_str(), layer.c_str());
    return 1;
  }
  if (Result<void> written = writePng(out, *img, exposure); !written) {
    std::fprintf(stderr, "error: %s\n", written.error().c_str());
    return 1;
  }
  std::fprintf(stderr, "wrote %s\n", out.c_str());
  return 0;
}

// ---- info ---------------------------------------------------------------------

int cmdInfo(const std::string& path, const std::string& camera) {
  LoadOptions opts;
  opts.cameraName = camera;
  SceneResult r = loadScene(path, opts);
  if (!r) {
    std::fprintf(stderr, "error: %s\n", r.error().c_str());
    return 1;
  }
  const Scene& s = **r;
  LightSampler lights(s);
  std::printf("scene      %s\n", path.c_str());
  std::printf("triangles  %zu (%zu vertices)\n", s.triangleCount(), s.positions.size());
  std::printf("bounds     [%g %g %g] - [%g %g %g]\n", s.boundsMin.x, s.boundsMin.y, s.boundsMin.z, s.boundsMax.x,
              s.boundsMax.y, s.boundsMax.z);
  std::printf("materials  %zu (plus the glTF default)\n", s.materials.size() - 1);
  std::vector<size_t> useCount(s.materials.size(), 0);
  for (uint32_t m : s.triMaterial) ++useCount[m];
  for (size_t i = 0; i < s.materials.size(); ++i) {
    const Material& m = s.materials[i];
    if (i + 1 == s.materials.size() && useCount[i] == 0) continue;
    std::printf("  %-20s base (%.3g %.3g %.3g) metallic %.3g roughness %.3g", m.name.c_str(), m.baseColor.x,
                m.baseColor.y, m.baseColor.z, m.metallic, m.roughness);
    if (m.anisotropyStrength > 0) std::printf(" anisotropy %.3g rot %.3g", m.anisotropyStrength, m.anisotropyRotation);
    if (m.isEmissive()) std::printf(" emission (%.4g %.4g %.4g)", m.emission.x, m.emission.y, m.emission.z);
    std::printf(" [%zu triangles]\n", useCount[i]);
  }
  // Emitter power per emissive material.
  std::vector<double> power(s.materials.size(), 0.0);
  for (uint32_t t = 0; t < s.triangleCount(); ++t) {
    const Material& m = s.materials[s.triMaterial[t]];
    if (m.isEmissive())
      power[s.triMaterial[t]] += luminance(m.emission) * s.triangleArea(t) * kPi * (m.doubleSided ? 2 : 1);
  }
  std::printf("lights     %zu emissive triangles, %zu punctual; total power %.6g W (luminance)\n",
              lights.emissiveTriangleCount(), s.punctualLights.size(), lights.totalPower());
  for (size_t i = 0; i < s.materials.size(); ++i)
    if (power[i] > 0) std::printf("  emissive material %-20s power %.6g W\n", s.materials[i].name.c_str(), power[i]);
  for (const PunctualLight& L : s.punctualLights)
    std::printf("  %s %-20s at (%g %g %g) intensity (%.4g %.4g %.4g) power %.6g W\n",
                L.type == PunctualLight::Type::Spot ? "spot " : "point", L.name.c_str(), L.position.x, L.position.y,
                L.position.z, L.intensity.x, L.intensity.y, L.intensity.z, L.power());
  const Camera& c = s.camera;
  std::printf("camera     %s%s: position (%g %g %g) forward (%.3g %.3g %.3g) yfov %.4g rad", c.name.c_str(),
              s.cameraFromFile ? "" : " (generated)", c.position.x, c.position.y, c.position.z, c.forward.x,
              c.forward.y, c.forward.z, c.yfov);
  if (c.aspect > 0) std::printf(" aspect %.4g", c.aspect);
  std::printf("\n");
  std::printf("warnings   %zu\n", s.warnings.size());
  for (const std::string& w : s.warnings) std::printf("  %s\n", w.c_str());
  return 0;
}

// ---- render: many-light methods ---------------------------------------------------

int renderManyLights(RenderArgs& a, const Scene& scene, const Accel& accel, double loadSeconds) {
  const RenderSettings& s = a.settings;
  ManyLightSettings& m = a.many;
  LightSampler lights(scene);
  if (lights.empty()) {
    std::fprintf(stderr, "error: %s: the scene has no lights, so there is nothing to trace virtual lights from\n",
                 a.scene.c_str());
    return 1;
  }
  auto t0 = Clock::now();
  ManyLightRun run = prepareManyLights(scene, accel, lights, m);
  std::fprintf(stderr,
               "traced %zu virtual lights from %llu paths in %.2f s (%zu bytes each, %.1f MB); radii in %.2f s\n",
               run.set.lights.size(), (unsigned long long)run.set.paths, run.set.seconds, sizeof(VirtualLight),
               run.set.bytes() / 1e6, run.knnSeconds);
  ManyLightImages im;
  int w = 0, h = 0, done = 0;
  size_t lightsProcessed = 0;
  uint64_t pairs = 0, shadowRays = 0, vslEvaluations = 0, gatherNonFinite = 0;
  float clampBound = manyLightClampBound(scene, m);
  json mrcsJson;
  auto t1 = Clock::now();
  if (a.mrcs.rows > 0) {
    // Matrix row-column sampling: rows, clustering, representative columns.
    std::fprintf(stderr, "render: MRCS with %d rows and %d clusters (uniform mix %g) over %zu lights\n", a.mrcs.rows,
                 a.mrcs.clusters, a.mrcs.uniformMix, run.set.lights.size());
    MrcsResult mr = renderMrcs(scene, accel, lights, run.set, run.radii, m, a.mrcs);
    im = std::move(mr.images);
    w = im.direct.width;
    h = im.direct.height;
    pairs = mr.pairs;
    lightsProcessed = run.set.lights.size();
    done = 1;
    mrcsJson = {{"rows", a.mrcs.rows},
                {"clusters", a.mrcs.clusters},
                {"uniformMix", a.mrcs.uniformMix},
                {"spreadVslRadius", a.mrcs.spreadVslRadius},
                {"rowSeconds", mr.rowSeconds},
                {"clusterSeconds", mr.clusterSeconds},
                {"columnSeconds", mr.columnSeconds},
                {"zeroColumnsVsl", mr.zeroColumnsVsl},
                {"zeroColumnsVpl", mr.zeroColumnsVpl}};
    std::fprintf(stderr, "render: rows %.2f s, clustering %.2f s, columns %.2f s\n", mr.rowSeconds, mr.clusterSeconds,
                 mr.columnSeconds);
  } else {
    ManyLightRenderer r(scene, accel, lights, run.set, run.radii, m);
    Progress progress("render");
    for (int b = 0; b < r.batchCount(); ++b) {
      r.renderBatch(b);
      ++done;
      double el = secondsSince(t1);
      char detail[160];
      std::snprintf(detail, sizeof detail, "batch %d/%d, %zu lights, %.2f Mpairs/s, %.1f s", done, r.batchCount(),
                    r.lightsProcessed(), r.stats().pairs / std::max(el, 1e-9) * 1e-6, el);
      progress.update(double(r.lightsProcessed()) / std::max<size_t>(run.set.lights.size(), 1), detail);
      if (s.timeLimit > 0 && el >= s.timeLimit) break;
    }
    progress.finish();
    im = r.images();
    w = r.width();
    h = r.height();
    lightsProcessed = r.lightsProcessed();
    pairs = r.stats().pairs;
    shadowRays = r.stats().shadowRays;
    vslEvaluations = r.stats().vslEvaluations;
    gatherNonFinite = r.stats().nonFinite;
  }
  double gatherSeconds = secondsSince(t1);
  auto sum = [&](const Image& ind) {
    Image f(w, h);
    for (size_t i = 0; i < f.rgb.size(); ++i) f.rgb[i] = im.direct.rgb[i] + ind.rgb[i];
    return f;
  };
  auto pick = [&](const Image& ind, const Image& full) -> const Image& {
    return s.component == Component::Direct ? im.direct : s.component == Component::Indirect ? ind : full;
  };
  Image vslFull = sum(im.vsl), vplFull = sum(im.vpl);
  std::vector<Layer> layers;
  const Image* chosen;
  if (s.method == "all") {
    chosen = &pick(im.vsl, vslFull);
    layers = {{"", *chosen},         {"vsl-full", vslFull},    {"vsl-indirect", im.vsl},
              {"vpl-full", vplFull}, {"vpl-indirect", im.vpl}, {"direct", im.direct}};
    if (a.mrcs.rows == 0)  // MRCS renders the two methods only
      layers.insert(layers.end(), {{"vpl-unclamped-indirect", im.vplUnclamped},
                                   {"vpl-diffuse-indirect", im.vplDiffuse},
                                   {"lost-to-clamping", im.lostToClamping},
                                   {"lost-to-diffuse", im.lostToDiffuse}});
  } else {
    const Image& ind = s.method == "vsl" ? im.vsl : im.vpl;
    const Image& full = s.method == "vsl" ? vslFull : vplFull;
    chosen = &pick(ind, full);
    layers = {{"", *chosen}, {"full", full}, {"direct", im.direct}, {"indirect", ind}};
  }
  std::map<std::string, std::string> attrs = {{"vsl.version", VSL_VERSION},
                                              {"vsl.scene", a.scene},
                                              {"vsl.method", s.method},
                                              {"vsl.settings", m.describe()},
                                              {"vsl.component", componentName(s.component)}};
  if (Result<void> written = writeExr(a.out, layers, attrs); !written) {
    std::fprintf(stderr, "error: %s\n", written.error().c_str());
    return 1;
  }
  std::string names;
  for (const Layer& l : layers)
    names += (names.empty() ? "" : ", ") + (l.name.empty() ? std::string("default") : l.name);
  std::fprintf(stderr, "wrote %s (%dx%d, %s, layers: %s)\n", a.out.c_str(), w, h, s.method.c_str(), names.c_str());
  if (!a.png.empty()) {
    if (Result<void> written = writePng(a.png, *chosen, a.exposure); !written) {
      std::fprintf(stderr, "error: %s\n", written.error().c_str());
      return 1;
    }
    std::fprintf(stderr, "wrote %s\n", a.png.c_str());
  }
  uint64_t rejected = gatherNonFinite + run.set.nonFiniteRejected;
  if (rejected > 0) log::warning("rejected " + std::to_string(rejected) + " non-finite contributions");
  if (!a.jsonPath.empty()) {
    std::vector<float> radii = run.radii;
    std::sort(radii.begin(), radii.end());
    auto q = [&](double f) { return radii.empty() ? 0.0 : double(radii[size_t(f * (radii.size() - 1))]); };
    auto mean = [](const Image& img) {
      Vec3 v = imageMean(img);
      return json::array({v.x, v.y, v.z});
    };
    json j = {{"version", VSL_VERSION},
              {"scene", a.scene},
              {"method", s.method},
              {"settings", m.describe()},
              {"width", w},
              {"height", h},
              {"component", componentName(s.component)},
              {"lights", run.set.lights.size()},
              {"lightsProcessed", lightsProcessed},
              {"batches", done},
              {"lightPaths", run.set.paths},
              {"bytesPerLight", sizeof(VirtualLight)},
              {"clampBound", clampBound},
              {"radius", {{"min", q(0)}, {"median", q(0.5)}, {"max", q(1)}}},
              {"seconds",
               {{"load", loadSeconds},
                {"lightTracing", run.set.seconds},
                {"knn", run.knnSeconds},
                {"gather", gatherSeconds},
                {"total", secondsSince(t0)}}},
              {"pairs", pairs},
              {"pairsPerSecond", pairs / std::max(gatherSeconds, 1e-9)},
              {"shadowRays", shadowRays},
              {"vslEvaluations", vslEvaluations},
              {"nonFiniteRejected", rejected},
              {"mean",
               {{"direct", mean(im.direct)},
                {"vslIndirect", mean(im.vsl)},
                {"vplIndirect", mean(im.vpl)},
                {"vplUnclampedIndirect", mean(im.vplUnclamped)},
                {"vplDiffuseIndirect", mean(im.vplDiffuse)},
                {"lostToClamping", mean(im.lostToClamping)},
                {"lostToDiffuse", mean(im.lostToDiffuse)}}},
              {"warnings", scene.warnings}};
    if (!mrcsJson.is_null()) j["mrcs"] = mrcsJson;
    if (Result<void> written = writeTextFile(a.jsonPath, j.dump(2) + "\n"); !written) {
      std::fprintf(stderr, "error: %s\n", written.error().c_str());
      return 1;
    }
    std::fprintf(stderr, "wrote %s\n", a.jsonPath.c_str());
  }
  return 0;
}

// Options of the VSL gather shared by render and sweep.
void addVslOptions(CLI::App* cmd, ManyLightSettings& m) {
  cmd->add_flag("--clipped-disk", m.clippedDisk,
                "VSL: spread the flux over the part of the disk on the receiver's side of its tangent plane");
  cmd->add_option("--continue-alpha", m.continueAlpha,
                  "Eye paths continue through pure metals with GGX alpha below this instead of gathering there")
      ->default_str(std::to_string(ManyLightSettings().continueAlpha))
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--split-alpha", m.splitAlpha,
                  "Gather points whose specular lobe is narrower than this (GGX alpha, narrower axis) gather "
                  "their diffuse lobe and continue the eye path with the specular lobe; 0 = off")
      ->default_str(std::to_string(ManyLightSettings().splitAlpha))
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--lobe-radius", m.lobeRadius,
                  "VSL: radius at least F x distance x the light's GGX alpha (cone as wide as its lobe); 0 = off")
      ->default_str("0")
      ->check(CLI::Range(0.0, 100.0));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vsl: many-light rendering of glossy scenes (render, compare, inspect, benchmark)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(VSL_VERSION));

  RenderArgs ra;
  auto* render = app.add_subcommand("render", "Render a glTF scene to a multi-layer EXR (full, direct, indirect)");
  render->add_option("scene", ra.scene, "Scene file (.gltf or .glb)")->required();
  render
      ->add_option("--method", ra.settings.method,
                   "pt (path-traced reference), vsl, vpl, or all (VSL, clamped VPL and the missing-energy layers "
                   "from one light set)")
      ->check(CLI::IsMember({"pt", "vsl", "vpl", "all"}))
      ->default_str("pt");
  render->add_option("--lights", ra.many.lights, "Virtual lights (many-light methods)")->default_str("10000");
  render->add_option("--radius-scale", ra.many.radiusScale, "VSL radius = scale x distance to the k-th nearest light")
      ->default_str("1");
  render->add_option("--knn", ra.many.knn, "k for the VSL radius")->default_str("10");
  render->add_option("--radius", ra.many.globalRadius,
                     "One global VSL radius, as a fraction of the scene's bounding radius (replaces k-NN radii)");
  render->add_option("--vsl-samples", ra.vslSamples, "VSL cone-integral samples per strategy: auto or N")
      ->default_str("auto");
  render
      ->add_option("--clamp", ra.clamp,
                   "VPL clamp: bound on the luminance of f_x cos f_p cos / d^2 per light; auto (scene-relative) or "
                   "off")
      ->default_str("auto");
  render->add_flag("--diffuse-vpl", ra.many.diffuseOnly, "VPLs emit with their diffuse lobe only");
  addVslOptions(render, ra.many);
  render->add_option("--mrcs", ra.mrcsSpec,
                     "Matrix row-column sampling: ROWS,CLUSTERS[,MIX] (e.g. 300,900; MIX: uniform share of the "
                     "representative choice)");
  render->add_flag(
      "--mrcs-spread", ra.mrcsSpread,
      "MRCS: a VSL representative of weight w gets radius r sqrt(w) (fewer blobs; about 10% darker, slower)");
  render->add_option("--batches", ra.many.batches, "Progressive light batches (growing sizes)")->default_str("8");
  render->add_option("--direct-samples", ra.many.directSamples, "Direct-light samples per pixel (many-light methods)")
      ->default_str("64");
  auto* sppOpt = render->add_option("--spp", ra.settings.spp, "Samples per pixel (pt)")->default_str("64");
  render->add_option("--time", ra.settings.timeLimit, "Render for this many seconds instead of --spp")
      ->excludes(sppOpt);
  render->add_option("--width", ra.settings.width, "Image width (default: from the scene, or 512)");
  render->add_option("--height", ra.settings.height, "Image height (default: from the scene, or 512)");
  render->add_option("--seed", ra.settings.seed, "Random seed")->default_str("0");
  render->add_option("--max-depth", ra.settings.maxDepth, "Maximum scattering events per path")->default_str("64");
  render->add_option("--component", ra.component, "Component for the default EXR layer and the PNG")
      ->check(CLI::IsMember({"full", "direct", "indirect"}))
      ->default_str("full");
  render->add_option("--camera", ra.camera, "Camera name (default: the first perspective camera)");
  render->add_option("-o,--output", ra.out, "Output EXR")->required();
  render->add_option("--png", ra.png, "Also write a tone-mapped sRGB PNG");
  render->add_option("--exposure", ra.exposure, "PNG exposure in stops")->default_str("0");
  render->add_option("--json", ra.jsonPath, "Write statistics as JSON");

  ReferenceArgs rfa;
  rfa.settings.spp = 1024;
  rfa.settings.seed = kReferenceSeed;
  auto* reference = app.add_subcommand(
      "reference", "Render a converged path-traced reference in two independent halves, to a file and the cache");
  reference->add_option("scene", rfa.scene, "Scene file (.gltf or .glb)")->required();
  auto* refSpp =
      reference->add_option("--spp", rfa.settings.spp, "Samples per pixel (rounded up to even)")->default_str("1024");
  reference->add_option("--time", rfa.settings.timeLimit, "Stop after this many seconds");
  reference->add_option("--target-relmse", rfa.target,
                        "Stop once the reference's own indirect relMSE, estimated from its halves, is at most this");
  reference->add_option("--width", rfa.settings.width, "Image width (default: from the scene, or 512)");
  reference->add_option("--height", rfa.settings.height, "Image height (default: from the scene, or 512)");
  reference
      ->add_option("--seed", rfa.settings.seed,
                   "Random seed (default: one that neither the studio's live path tracer nor vsl sweep uses)")
      ->default_str(std::to_string(kReferenceSeed));
  reference->add_option("--max-depth", rfa.settings.maxDepth, "Maximum scattering events per path")->default_str("64");
  reference->add_option("--camera", rfa.camera, "Camera name (default: the first perspective camera)");
  reference->add_option("-o,--output", rfa.out, "Output EXR (the cache gets a copy either way)");
  reference->add_flag("--no-cache", rfa.noCache, "Do not store the result in the reference cache");

  CompareArgs ca;
  auto* compare = app.add_subcommand(
      "compare",
      "Compare an EXR against a reference EXR; with several test EXRs (independent renders of one method), "
      "split their error into bias and noise");
  compare
      ->add_option("images", ca.images,
                   "TEST.exr REFERENCE.exr, or TEST1.exr TEST2.exr ... REFERENCE.exr (the reference comes last)")
      ->required()
      ->expected(2, CLI::detail::expected_max_vector_size);
  auto* layerOpt = compare->add_option("--layer", ca.layer, "Layer name (default: the default layer, else 'full')");
  auto* refLayerOpt =
      compare->add_option("--ref-layer", ca.refLayer, "Layer of the reference (default: the same as --layer)");
  compare->add_option("-o,--output", ca.out,
                      "Write error images (EXR); with several tests: bias, noise and mean images");
  compare->add_option("--png", ca.png, "Write a false-colour relative squared error PNG (one test image)");
  compare->add_flag("--json", ca.json, "Print metrics as JSON");
  compare
      ->add_option("--epsilon", ca.epsilon,
                   "relMSE eps: a factor of the reference's mean luminance squared (relative), or eps itself "
                   "(absolute)")
      ->default_str("0.01")
      ->check(CLI::PositiveNumber);
  compare->add_option("--epsilon-mode", ca.epsilonMode, "relative (eps = factor x mean luminance^2) or absolute")
      ->check(CLI::IsMember({"relative", "absolute"}))
      ->default_str("relative");
  compare->add_option("--flip-exr", ca.flipExr, "Write the LDR- and HDR-FLIP maps (EXR)");
  compare->add_option("--flip-png", ca.flipPng,
                      "Write the LDR-FLIP map as a magma PNG with a colour bar (and PATH-hdr.png for HDR-FLIP)");
  compare->add_option("--exposure", ca.exposure, "Exposure (stops) of the tone map before LDR-FLIP")->default_str("0");
  compare->add_flag("--no-flip", ca.noFlip, "Skip FLIP (it costs about a second per megapixel and exposure)");

  std::string tmIn, tmLayer, tmOut;
  float tmExposure = 0;
  auto* tonemap = app.add_subcommand("tonemap", "Write one EXR layer as a tone-mapped sRGB PNG");
  tonemap->add_option("input", tmIn, "EXR file")->required();
  tonemap->add_option("--layer", tmLayer, "Layer name (default: the default layer)");
  tonemap->add_option("-o,--output", tmOut, "Output PNG")->required();
  tonemap->add_option("--exposure", tmExposure, "Exposure in stops")->default_str("0");

  std::string infoScene, infoCamera;
  auto* info = app.add_subcommand("info", "Print a scene's triangles, materials, lights, camera and warnings");
  info->add_option("scene", infoScene, "Scene file (.gltf or .glb)")->required();
  info->add_option("--camera", infoCamera, "Camera name");

  SweepArgs sw;
  auto* sweep = app.add_subcommand("sweep", "Error against time for a grid of methods, light counts and radii");
  sweep->add_option("scene", sw.scene, "Scene file (not with --merge)");
  sweep
      ->add_option("--methods", sw.methods,
                   "Methods: pt, vpl, vsl; vsl-progressive (independent light sets with shrinking radii); "
                   "vsl-mrcs, vpl-mrcs (independent light sets, each with matrix row-column sampling); "
                   "vsl-mrcs-progressive (both)")
      ->delimiter(',')
      ->check(CLI::IsMember({"pt", "vpl", "vsl", "vsl-progressive", "vsl-mrcs", "vpl-mrcs", "vsl-mrcs-progressive"}))
      ->default_str("pt,vpl,vsl");
  sweep->add_option("--lights", sw.lights, "Light counts, comma separated")
      ->delimiter(',')
      ->check(CLI::Range(1u, 50000000u))
      ->default_str("1000,10000");
  sweep->add_option("--radius-scale", sw.radiusScales, "VSL radius scales, comma separated")
      ->delimiter(',')
      ->check(CLI::Range(1e-6, 1e6))
      ->default_str("1");
  sweep->add_option("--time", sw.time, "Path-tracer budget and cap per run, seconds")
      ->default_str("30")
      ->check(CLI::Range(0.01, 1e6));
  sweep->add_option("--alpha", sw.alpha, "vsl-progressive: r^2 shrinks by (i+alpha)/(i+1) per pass")
      ->default_str("0.7")
      ->check(CLI::Range(0.01, 0.99));
  sweep->add_option("--batches", sw.batches, "Progressive batches per many-light run")
      ->default_str("8")
      ->check(CLI::Range(1, 64));
  std::string sweepMrcs;
  sweep->add_option("--mrcs", sweepMrcs, "ROWS,CLUSTERS[,MIX] for the -mrcs methods")->default_str("300,900");
  bool sweepSpread = false;
  sweep->add_flag("--mrcs-spread", sweepSpread, "-mrcs methods: VSL representatives get radius r sqrt(weight)");
  sweep->add_option("--seed", sw.seed, "Random seed (must differ from the reference's)")->default_str("1");
  sweep->add_option("--reference", sw.reference,
                    "Reference EXR with an 'indirect' layer (vsl reference writes one with halves that measure its "
                    "noise); default: the cached reference at --width");
  sweep->add_option("--width", sw.width, "Without --reference: the width of the cached reference to use")
      ->default_str("256")
      ->check(CLI::Range(8, 16384));
  sweep->add_option("--shard", sw.shard, "I/N: run only the configurations whose grid index is I mod N");
  sweep->add_option("--merge", sw.merge, "Join these shard output directories into -o (no scene needed)");
  sweep->add_option("--reference-b", sw.referenceB,
                    "A second reference with another seed: relMSE(B, A)/2 estimates the reference's own noise, "
                    "reported and subtracted in the column relmse_minus_ref_noise");
  sweep->add_option("-o,--output", sw.outDir, "Output directory")->required();
  sweep->add_option("--sets", sw.sets, "Independent light sets (or path-tracer seeds) per configuration")
      ->default_str("5")
      ->check(CLI::Range(1, 1000));
  sweep->add_option("--knn", sw.many.knn, "k for the VSL radius")->default_str("10")->check(CLI::Range(1, 1000));
  addVslOptions(sweep, sw.many);

  std::string benchScene, benchJson;
  double benchSeconds = 3;
  int benchSize = 256;
  auto* bench = app.add_subcommand("bench", "Path-tracer throughput against raw Embree occlusion on one scene");
  bench->add_option("scene", benchScene, "Scene file")->required();
  bench->add_option("--seconds", benchSeconds, "Seconds per measurement")
      ->default_str("3")
      ->check(CLI::Range(0.1, 600.0));
  bench->add_option("--size", benchSize, "Image size for the path tracer")
      ->default_str("256")
      ->check(CLI::Range(8, 4096));
  bench->add_option("--json", benchJson, "Write results as JSON");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "error: %s\n\n", e.what());
    CLI::App* sub = nullptr;
    for (CLI::App* s : app.get_subcommands()) sub = s;
    std::cerr << (sub ? sub->help() : app.help());
    return 2;
  }
  log::setEchoLevel(LogLevel::Warning);
  // Every subcommand runs inside one handler: running out of memory (or any
  // other exception a library throws) is reported and exits 1, never aborts.
  try {
    if (*render) return cmdRender(ra);
    if (*reference) {
      rfa.sppGiven = refSpp->count() > 0;
      return cmdReference(rfa);
    }
    if (*compare) return cmdCompare(ca, layerOpt->count() > 0, refLayerOpt->count() > 0);
    if (*tonemap) return cmdTonemap(tmIn, tmLayer, tmOut, tmExposure);
    if (*info) return cmdInfo(infoScene, infoCamera);
    if (*sweep) {
      if (!sweepMrcs.empty() && !parseMrcsSpec(sweepMrcs, sw.mrcs)) return 2;
      sw.mrcs.spreadVslRadius = sweepSpread;
      return runSweep(sw);
    }
    if (*bench) return runBench(benchScene, benchSeconds, benchSize, benchJson);
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "error: out of memory (the scene, image or settings need more than this machine has)\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 2;
}
