// Sections: [1] set-up  [2] snapshots and textures  [3] controls  [4] views
//           [5] metrics and plot  [6] log  [7] (export: studio_export.cpp)
//           [8] crop insets  [9] the last session
#include "ui/studio.h"

#include <imgui_stdlib.h>

#include <algorithm>
#include <array>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <thread>

#include "core/estimator_json.h"
#include "core/flip.h"
#include "core/image_io.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/params.h"
#include "core/params_json.h"
#include "core/presets.h"
#include "core/verdict.h"
#include "ui/gl.h"
#include "ui/headless_gl.h"
#include "ui/param_widgets.h"
#include "ui/studio_internal.h"

namespace vsl::ui {

using namespace studio_detail;

const char* sourceName(Source s) {
  switch (s) {
    case Source::Vsl:
      return "VSL";
    case Source::Vpl:
      return "VPL (clamped)";
    case Source::Reference:
      return "Reference";
    case Source::VplUnclamped:
      return "VPL unclamped";
    case Source::VplDiffuse:
      return "VPL diffuse-only";
    case Source::LostClamping:
      return "Lost to clamping";
    case Source::LostDiffuse:
      return "Lost to diffuse-only";
    case Source::Pinned:
      return "Pinned VSL";
    case Source::Count:
      break;
  }
  return "?";
}

std::string sourceSlug(Source s) {
  switch (s) {
    case Source::Vsl:
      return "vsl";
    case Source::Vpl:
      return "vpl-clamped";
    case Source::Reference:
      return "reference";
    case Source::VplUnclamped:
      return "vpl-unclamped";
    case Source::VplDiffuse:
      return "vpl-diffuse";
    case Source::LostClamping:
      return "lost-to-clamping";
    case Source::LostDiffuse:
      return "lost-to-diffuse";
    case Source::Pinned:
      return "vsl-pinned";
    case Source::Count:
      break;
  }
  return "image";
}

const char* toneMapName(ToneMap t) {
  switch (t) {
    case ToneMap::Linear:
      return "linear sRGB";
    case ToneMap::Filmic:
      return "filmic (ACES)";
    case ToneMap::FalseColour:
      return "false colour";
  }
  return "?";
}

std::string panelTitle(Source s, Component c) {
  // The lost-energy maps are differences of indirect images whatever the component.
  const char* comp = s == Source::LostClamping || s == Source::LostDiffuse ? "indirect" : componentName(c);
  return std::string(sourceName(s)) + " (" + comp + ")";
}

namespace {
const char* kComponentNames[] = {"full", "direct", "indirect"};
const char* kModeNames[] = {"Single", "Side by side (2)", "Side by side (3)", "Wipe"};

void sectionTitle(const char* title) {
  ImGui::Spacing();
  ImGui::Separator();
  ImGui::TextUnformatted(title);
}

// ImGui::SetTooltip, wrapped at 36 times the font's height (about 65
// characters): the long help texts ran off the right of a 1280-pixel window
// on one line. Like SetTooltip it is one call per item (a second call in the
// same frame adds to the same tooltip).
void tip(const char* fmt, ...) IM_FMTARGS(1);
void tip(const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  ImGui::BeginTooltip();
  ImGui::PushTextWrapPos(ImGui::GetFontSize() * 36.0f);
  ImGui::TextV(fmt, args);
  ImGui::PopTextWrapPos();
  ImGui::EndTooltip();
  va_end(args);
}
}  // namespace

namespace studio_detail {

// One pixel's error under a metric. eps follows the reference as relMSE's
// does (compare.h: 0.01 x the reference's mean luminance squared) for the
// squared metrics, and its square root for the absolute ones.
float metricError(float d, float r, ErrorMetric metric, float eps) {
  switch (metric) {
    case ErrorMetric::Absolute:
      return std::abs(d);
    case ErrorMetric::RelativeAbsolute:
      return std::abs(d) / (std::abs(r) + std::sqrt(eps));
    case ErrorMetric::Squared:
      return d * d;
    case ErrorMetric::RelativeSquared:
      return d * d / (r * r + eps);
  }
  return d;
}

float mapEpsilon(const Image& ref) { return float(RelMseEpsilon().resolve(ref)); }

Image add(const Image& a, const Image& b) {
  Image r = a;
  for (size_t i = 0; i < r.rgb.size() && i < b.rgb.size(); ++i) r.rgb[i] += b.rgb[i];
  return r;
}

float percentile99(const Image& img) {
  std::vector<float> v;
  v.reserve(img.rgb.size() / 3);
  for (size_t i = 0; i + 2 < img.rgb.size(); i += 3) {
    float m = std::abs((img.rgb[i] + img.rgb[i + 1] + img.rgb[i + 2]) / 3);
    if (std::isfinite(m)) v.push_back(m);
  }
  if (v.empty()) return 1;
  size_t k = size_t(0.99 * (v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return std::max(v[k], 1e-12f);
}

float acesFilmic(float x) {
  x *= 0.6f;
  const float a = 2.51f, b = 0.03f, c = 2.43f, d = 0.59f, e = 0.14f;
  return std::clamp(x * (a * x + b) / (x * (c * x + d) + e), 0.0f, 1.0f);
}

Vec3 toneMapPixel(Vec3 linear, float exposure, ToneMap t) {
  const Vec3 v = linear * std::exp2(exposure);
  auto srgb = [](float x) {
    x = std::clamp(std::isfinite(x) ? x : 0.0f, 0.0f, 1.0f);
    return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1 / 2.4f) - 0.055f;
  };
  switch (t) {
    case ToneMap::Linear:
      return Vec3(srgb(v.x), srgb(v.y), srgb(v.z));
    case ToneMap::Filmic:
      return Vec3(srgb(acesFilmic(v.x)), srgb(acesFilmic(v.y)), srgb(acesFilmic(v.z)));
    case ToneMap::FalseColour: {
      const float lum = 0.2126f * v.x + 0.7152f * v.y + 0.0722f * v.z;
      const float lo = kFalseColourDecades[0], hi = kFalseColourDecades[1];
      return falseColour(lum > 0 ? (std::log10(lum) - lo) / (hi - lo) : 0.0f);
    }
  }
  return v;
}

ReferenceProgressText referenceProgressText(int spp, int maxSpp) {
  ReferenceProgressText r;
  maxSpp = std::max(maxSpp, 1);
  r.fraction = std::clamp(float(spp) / float(maxSpp), 0.0f, 1.0f);
  char buf[96];
  if (spp > maxSpp) {
    r.overlay = "reference 100%";
    std::snprintf(buf, sizeof buf, "refining past %d spp (%d spp)", maxSpp, spp);
  } else {
    std::snprintf(buf, sizeof buf, "reference %.0f%%", std::floor(100 * r.fraction));
    r.overlay = buf;
    std::snprintf(buf, sizeof buf, "%d / %d spp", spp, maxSpp);
  }
  r.count = buf;
  return r;
}

float imageScale(float panelW, float panelH, int imageW, int imageH) {
  if (!(panelW > 0 && panelH > 0) || imageW <= 0 || imageH <= 0) return 0;
  const float fit = std::min(panelW / float(imageW), panelH / float(imageH));
  return fit >= 1 ? std::floor(fit) : fit;
}

ImageStats imageStats(const Image& img) {
  ImageStats st;
  std::vector<double> lum;
  lum.reserve(img.rgb.size() / 3);
  for (size_t i = 0; i + 2 < img.rgb.size(); i += 3) {
    const double l = luminance(Vec3(img.rgb[i], img.rgb[i + 1], img.rgb[i + 2]));
    if (std::isfinite(l))
      lum.push_back(l);
    else
      ++st.nonFinite;
  }
  st.pixels = lum.size();
  if (lum.empty()) return st;
  double sum = 0;
  for (double l : lum) sum += l;
  st.mean = sum / double(lum.size());
  std::sort(lum.begin(), lum.end());
  auto at = [&](double q) { return lum[size_t(std::floor(q * double(lum.size() - 1) + 0.5))]; };
  st.min = lum.front();
  st.max = lum.back();
  st.p01 = at(0.01);
  st.p50 = at(0.5);
  st.p99 = at(0.99);
  const auto positive = std::upper_bound(lum.begin(), lum.end(), 0.0);
  st.zeroOrNegative = size_t(positive - lum.begin());
  if (positive == lum.end()) return st;
  st.logMin = std::log10(*positive);
  st.logMax = std::max(std::log10(lum.back()), st.logMin + 1e-6);
  st.histogram.assign(ImageStats::kStatsBins, 0.0f);
  for (auto it = positive; it != lum.end(); ++it) {
    const double t = (std::log10(*it) - st.logMin) / (st.logMax - st.logMin);
    ++st.histogram[size_t(std::clamp(int(t * ImageStats::kStatsBins), 0, ImageStats::kStatsBins - 1))];
  }
  return st;
}

}  // namespace studio_detail

// ---- [1] Set-up --------------------------------------------------------------------

Studio::Studio(const StudioOptions& options) : options_(options), settings_(options.settings) {
  settings_.scene = options.scene;
  scenePath_ = options.scene;
  exportDir_ = options.exportDir;
  referencePathInput_ = settings_.referencePath;  // --reference FILE shows in its field
  envPathInput_ = settings_.env.map;
  if (options.startSession) session_ = std::make_unique<Session>();
  restart();
}

Studio::~Studio() = default;

void Studio::restart(bool fromScratch) {
  if (!session_) {
    accepted_ = settings_;
    return;
  }
  Result<uint64_t> started = session_->restart(settings_, fromScratch);
  if (!started) {
    const std::string& err = started.error();
    // Shown next to the control it names ("lights: ..."), or next to the
    // control last changed for a memory refusal; the render goes on.
    size_t colon = err.find(':');
    settingsErrorKey_ = colon != std::string::npos && colon < 20 ? err.substr(0, colon) : lastControl_;
    if (settingsErrorKey_ == "memory") settingsErrorKey_ = lastControl_;
    settingsError_ = err;
    log::warning("settings rejected: " + err);
    return;
  }
  if (!changeTimed_) sinceChange_.reset();
  changeTimed_ = false;
  restartGeneration_ = *started;
  accepted_ = settings_;
  settingsError_.clear();
  settingsErrorKey_.clear();
}

bool Studio::restartPending() const { return restartAt_ != std::chrono::steady_clock::time_point(); }

double Studio::secondsToRestart() const {
  if (!restartPending()) return 0;
  if (ImGui::GetIO().WantTextInput) return 0.25;  // typed text restarts when it is entered
  return std::max(0.0, std::chrono::duration<double>(restartAt_ - std::chrono::steady_clock::now()).count());
}

bool Studio::restartIfDue() {
  if (!restartPending() || std::chrono::steady_clock::now() < restartAt_ || ImGui::GetIO().WantTextInput) return false;
  restartAt_ = {};
  restart();
  return true;
}

void Studio::applySettings(const StudioSettings& settings) {
  settings_ = settings;
  scenePath_ = settings.scene;
  referencePathInput_ = settings.referencePath;
  envPathInput_ = settings.env.map;
  restart();
}

void Studio::openScene(const std::string& path) {
  scenePath_ = path;
  settings_.scene = path;
  restart();
}

void Studio::openEnvironment(const std::string& path) {
  envPathInput_ = path;
  settings_.env.map = path;
  restart();
}

void Studio::setSnapshotForTesting(std::shared_ptr<const Snapshot> s) { takeSnapshot(std::move(s)); }

// A picture of another scene starts clean: the crop and the last export's
// message belonged to the scene before.
void Studio::takeSnapshot(std::shared_ptr<const Snapshot> s) {
  if (snap_ && s && s->settings.scene != snap_->settings.scene) {
    view_.crop = {};
    message_.clear();
    messagePath_.clear();
  }
  snap_ = std::move(s);
  texturesDirty_ = true;
}

// ---- [2] Snapshots and textures -----------------------------------------------------

void Studio::pullSnapshot() {
  if (!session_) return;
  drawnVersion_ = session_->version();  // read first: a change after this is seen next frame
  if (auto s = session_->latest(serial_)) {
    serial_ = s->serial;
    if (s->generation != firstPictureGeneration_ && s->generation == restartGeneration_) {
      // The first picture of this generation: how long the user waited.
      firstPictureGeneration_ = s->generation;
      restartToPictureMs_ = 1000 * sinceChange_.seconds();
      if (launchToPictureMs_ < 0) {
        launchToPictureMs_ = 1000 * sinceLaunch_.seconds();
        log::info("first picture " + std::to_string(int(launchToPictureMs_)) + " ms after launch");
      }
      log::info("generation " + std::to_string(s->generation) + ": first picture " +
                std::to_string(int(restartToPictureMs_)) + " ms after the settings changed");
    }
    // Against a full-only reference only the full component is measured:
    // show it when such a reference comes into use.
    if (s->comparesFull && !(snap_ && snap_->comparesFull)) view_.component = Component::Full;
    takeSnapshot(std::move(s));
  }
  Session::Status st = session_->status();
  noteSceneWarnings(st.scene, st.sceneWarnings);
  if (st.loadErrorSerial > seenLoadErrors_) {
    seenLoadErrors_ = st.loadErrorSerial;
    // The loader's message is shown as it is (it names the file, the element
    // and the reason, e.g. an unsupported required extension).
    if (st.environmentFailed)
      errorDialog_ = "Could not set the environment light; the previous one stays.\n\n" + st.loadError;
    else if (st.scene.empty())
      errorDialog_ = "Could not load the scene.\n\n" + st.loadError;
    else if (st.noEmitters)
      errorDialog_ = "This scene has no emitters, so there is nothing to compare; " +
                     std::filesystem::path(st.scene).filename().string() + " stays open and keeps rendering.\n\n" +
                     st.loadError;
    else
      errorDialog_ = "Could not load the scene; " + std::filesystem::path(st.scene).filename().string() +
                     " stays open and keeps rendering.\n\n" + st.loadError;
    // The scene still open goes on; the field keeps the path typed, so that
    // a typo can be corrected in place.
    if (!st.scene.empty()) {
      settings_.scene = accepted_.scene = st.scene;
      settings_.env = accepted_.env = st.env;
    }
  }
  if (st.runErrorSerial > seenRunErrors_) {
    seenRunErrors_ = st.runErrorSerial;
    errorDialog_ = st.runError;
  }
}

// A scene loaded with warnings says so under the scene field, naming the
// count and the first, until another scene is loaded (issue: the loader's
// warnings were only in the Log tab).
void Studio::noteSceneWarnings(const std::string& scene, const std::vector<std::string>& warnings) {
  if (scene == warningsScene_ && warnings.size() == sceneWarnings_.size()) return;
  warningsScene_ = scene;
  sceneWarnings_ = warnings;
}

bool Studio::busy() const { return session_ && session_->status().busy(); }

bool Studio::pictureArrived() const { return session_ && session_->latest(serial_) != nullptr; }

bool Studio::wantsFrame() const {
  const bool flipDone = flipTask_.valid() && flipTask_.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
  return !session_ || session_->version() != drawnVersion_ || restartPending() || flipDone;
}

std::optional<std::vector<double>> Studio::flipMeans() const {
  if (!flipMatchesView() || !snap_ || flip_->serial != snap_->serial) return std::nullopt;
  return std::vector<double>(std::begin(flip_->mean), std::end(flip_->mean));
}

bool Studio::flipMatchesView() const {
  return flip_ && flip_->component == view_.component && flip_->exposure == view_.exposure;
}

const Image* Studio::flipMap(Source s, bool* fresh) const {
  const Source* it = std::find(std::begin(kMetricSources), std::end(kMetricSources), s);
  if (!flipMatchesView() || it == std::end(kMetricSources)) return nullptr;
  const Image& map = flip_->map[it - std::begin(kMetricSources)];
  if (map.rgb.empty()) return nullptr;
  if (fresh) *fresh = snap_ && flip_->serial == snap_->serial;
  return &map;
}

// One FLIP task at a time, on its own thread: a new one starts when the
// snapshot, the component or the exposure changed since the last result.
void Studio::updateFlip() {
  if (flipTask_.valid()) {
    if (flipTask_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
    flip_ = flipTask_.get();
    ++flipVersion_;
  }
  if (!snap_ || snap_->width == 0 || snap_->refIndirect.rgb.empty()) return;
  if (flip_ && flip_->serial == snap_->serial && flip_->component == view_.component &&
      flip_->exposure == view_.exposure)
    return;
  std::shared_ptr<const Snapshot> snap = snap_;
  const Component c = view_.component;
  const float exposure = view_.exposure;
  flipTask_ = std::async(std::launch::async, [snap, c, exposure] { return computeFlip(*snap, c, exposure); });
}

Studio::FlipNumbers Studio::computeFlip(const Snapshot& s, Component c, float exposure) {
  auto pick = [c](const Image& d, const Image& i) {
    return c == Component::Direct ? d : c == Component::Indirect ? i : add(d, i);
  };
  const Image ref = toSrgbImage(pick(s.refDirect, s.refIndirect), exposure);
  const Image* indirect[5] = {&s.many.vsl, &s.many.vpl, &s.many.vplUnclamped, &s.many.vplDiffuse, &s.ptIndirect};
  FlipNumbers f;
  f.serial = s.serial;
  f.component = c;
  f.exposure = exposure;
  for (int i = 0; i < 5; ++i) {
    const Image& direct = i == 4 ? s.ptDirect : s.many.direct;
    FlipResult r = flipLdr(toSrgbImage(pick(direct, *indirect[i]), exposure), ref);
    f.mean[i] = r.mean;
    f.map[i] = std::move(r.map);
  }
  return f;
}

std::string Studio::fatalError() const {
  if (!session_) return "";
  Session::Status st = session_->status();
  if (st.scene.empty() && st.loadErrorSerial > 0) return st.loadError;
  return "";
}

bool Studio::firstSceneSettled() const {
  if (!session_) return true;
  Session::Status st = session_->status();
  return !st.scene.empty() || st.loadErrorSerial > 0;
}

std::string Studio::referenceError() const {
  if (!session_ || accepted_.referencePath.empty()) return "";
  return session_->status().referenceError;
}

bool Studio::sourceStale(Source s) const {
  if (!snap_) return false;
  const StudioSettings& a = snap_->settings;
  if (s == Source::Pinned) return false;  // kept as it was
  if (s == Source::Reference)             // the reference belongs to the scene and the resolution only
    return a.scene != accepted_.scene || a.many.width != accepted_.many.width || a.many.height != accepted_.many.height;
  // A method's pictures hold across a change of the other's parameters (unchangedFor).
  if (vplSource(s)) return !sameImageSettings(a, accepted_) && !unchangedFor(StudioMethod::Vpl, a, accepted_);
  if (s == Source::Vsl) return !sameImageSettings(a, accepted_) && !unchangedFor(StudioMethod::Vsl, a, accepted_);
  return !sameImageSettings(a, accepted_);
}

double Studio::lightsPerSet() const { return double(snap_->lightsTotal) / std::max(snap_->lightSets, 1); }

bool Studio::keptSetsShown(Source s) const {
  return snap_ && ((vplSource(s) && snap_->vplLightSetsDone > 0) || (s == Source::Vsl && snap_->vslLightSetsDone > 0));
}

bool Studio::roughPicture() const {
  if (!snap_ || snap_->lightSetsDone > 0 || snap_->manyLightDone) return false;
  return double(snap_->lightsProcessed) < kRoughShare * lightsPerSet();
}

std::string Studio::roughText() const {
  char text[96];
  std::snprintf(text, sizeof text, "ROUGH - %zu of %.0f lights", snap_->lightsProcessed, lightsPerSet());
  return text;
}

bool Studio::vslPictureCurrent() const { return snap_ && !sourceStale(Source::Vsl) && snap_->many.vsl.width > 0; }

bool Studio::panelStale(int i) const {
  if (view_.mode == ViewMode::Wipe && i < 2) return sourceStale(view_.panels[0]) || sourceStale(view_.panels[1]);
  return sourceStale(view_.panels[std::clamp(i, 0, 2)]);
}

bool studio_detail::snapshotHasPicture(const Snapshot& s, Source src, Component c) {
  // An estimator without the VPL variants renders direct, VSL and clamped VPL only (MRCS).
  const EstimatorInfo* info = findEstimator(s.settings.estimator.name);
  const bool twoMethods = info && !info->vplVariants;
  // The lost-energy images are the same in every component (no direct part).
  if (twoMethods && (src == Source::LostClamping || src == Source::LostDiffuse)) return false;
  if (c == Component::Direct || src == Source::Vsl || src == Source::Reference) return true;
  if (twoMethods && src != Source::Vpl) return false;
  return !s.vplPending;
}

bool Studio::hasPicture(Source s, Component c) const {
  if (s == Source::Pinned) return snap_ && pinnedFits();
  return snap_ && snapshotHasPicture(*snap_, s, c);
}

bool Studio::pinnedFits() const {
  return pinned_ && snap_ && pinned_->indirect.width == snap_->refIndirect.width &&
         pinned_->indirect.height == snap_->refIndirect.height && pinned_->settings.scene == snap_->settings.scene;
}

std::string Studio::missingPictureText(Source s) const {
  const std::string name = snap_ ? snap_->settings.estimator.name : std::string("the estimator");
  return s == Source::Vpl ? "waiting for its " + name + " step's clamped VPL (VSL's comes first)"
                          : "not rendered by " + name + " (VSL and clamped VPL only)";
}

bool Studio::metricShown(int i) const { return hasPicture(kMetricSources[i], Component::Indirect); }

const Image* Studio::referenceImage(Component c, Image& scratch) const {
  const Snapshot& s = *snap_;
  switch (c) {
    case Component::Direct:
      return &s.refDirect;
    case Component::Indirect:
      return &s.refIndirect;
    case Component::Full:
      scratch = add(s.refDirect, s.refIndirect);
      return &scratch;
  }
  return nullptr;
}

Studio::SourceParts Studio::sourceParts(Source src) const {
  const Snapshot& s = *snap_;
  switch (src) {
    case Source::Reference:
      return {nullptr, &s.refDirect, &s.refIndirect};
    case Source::LostClamping:
      return {&s.many.lostToClamping, nullptr, nullptr};
    case Source::LostDiffuse:
      return {&s.many.lostToDiffuse, nullptr, nullptr};
    case Source::Vsl:
      return {nullptr, &s.many.direct, &s.many.vsl};
    case Source::Vpl:
      return {nullptr, &s.many.direct, &s.many.vpl};
    case Source::VplUnclamped:
      return {nullptr, &s.many.direct, &s.many.vplUnclamped};
    case Source::VplDiffuse:
      return {nullptr, &s.many.direct, &s.many.vplDiffuse};
    case Source::Pinned:
      if (pinnedFits()) return {nullptr, &pinned_->direct, &pinned_->indirect};
      break;
    case Source::Count:
      break;
  }
  return {};
}

const Image* Studio::componentImage(Source src, Component c, Image& scratch) const {
  if (src == Source::Reference) return referenceImage(c, scratch);
  SourceParts p = sourceParts(src);
  if (p.whole || !p.indirect) return p.whole;
  if (c == Component::Direct) return p.direct;
  if (c == Component::Indirect) return p.indirect;
  scratch = add(*p.direct, *p.indirect);
  return &scratch;
}

void Studio::updateTextures() {
  const bool flipView = view_.display == Display::Flip;
  bool viewChanged = uploaded_.display != view_.display || uploaded_.metric != view_.metric ||
                     uploaded_.component != view_.component ||
                     (flipView && (flipUploaded_ != flipVersion_ || uploaded_.exposure != view_.exposure));
  if (!snap_ || (!texturesDirty_ && !viewChanged)) return;
  flipUploaded_ = flipVersion_;
  Image refScratch;
  const Image* ref = referenceImage(view_.component, refScratch);
  mapEps_ = mapEpsilon(*ref);
  for (int i = 0; i < int(Source::Count); ++i) {
    Source src = Source(i);
    Image scratch;
    const Image* img = componentImage(src, view_.component, scratch);
    if (!img || img->width == 0) continue;
    bool isMethod = src != Source::Reference && src != Source::LostClamping && src != Source::LostDiffuse;
    if (view_.display == Display::Image || !isMethod) {
      textures_[i].upload(*img);
      autoScale_[i] = percentile99(*img);
      continue;
    }
    if (flipView) {  // the newest FLIP map, if any (viewsPanel says when there is none)
      if (const Image* f = flipMap(src)) textures_[i].upload(*f);
      autoScale_[i] = 1;  // FLIP lies in [0, 1]
      continue;
    }
    // Per-pixel error map or signed difference against the reference.
    Image map(img->width, img->height);
    for (size_t k = 0; k < map.rgb.size(); ++k) {
      float r = ref->rgb[k], d = img->rgb[k] - r;
      float v = view_.display == Display::Error ? metricError(d, r, view_.metric, mapEps_) : d;
      map.rgb[k] = std::isfinite(v) ? v : 0.0f;
    }
    textures_[i].upload(map);
    autoScale_[i] = percentile99(map);
  }
  uploaded_ = view_;
  texturesDirty_ = false;
}

// ---- Frame ---------------------------------------------------------------------------

void Studio::frame() {
  Stopwatch frameClock;
  beginFrame();
  pullSnapshot();
  updateFlip();
  updateTextures();
  drawn_.clear();

  const ImGuiViewport* vp = ImGui::GetMainViewport();
  ImGui::SetNextWindowPos(vp->WorkPos);
  ImGui::SetNextWindowSize(vp->WorkSize);
  ImGui::Begin("vsl-studio", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoBringToFrontOnFocus |
                   ImGuiWindowFlags_NoSavedSettings);
  ImGui::BeginChild("controls", ImVec2(330, 0), true);
  controlsPanel();
  ImGui::EndChild();
  restartIfDue();
  ImGui::SameLine();
  ImGui::BeginChild("right", ImVec2(0, 0), false);
  // The views take what their images need, up to all but the bottom's
  // least; the metrics below get the rest.
  const ImVec2 right = ImGui::GetContentRegionAvail();
  const float viewsH = viewsHeight(right.x, right.y - std::min(260.0f, right.y * 0.4f));
  ImGui::BeginChild("views", ImVec2(0, viewsH), true,
                    ImGuiWindowFlags_NoScrollbar | ImGuiWindowFlags_NoScrollWithMouse);
  viewsPanel();
  ImGui::EndChild();
  // A new crop (drawn, or given on the command line) brings up the Crops tab.
  if (!cropDragging_ && !view_.crop.empty() && !(view_.crop == shownCrop_)) cropMade_ = true;
  if (!cropDragging_) shownCrop_ = view_.crop;
  ImGui::BeginChild("bottom", ImVec2(0, 0), true);
  if (ImGui::BeginTabBar("tabs")) {
    if (ImGui::BeginTabItem("Metrics")) {
      metricsPanel();
      ImGui::EndTabItem();
    }
    if (ImGui::BeginTabItem("Crops", nullptr, cropMade_ ? ImGuiTabItemFlags_SetSelected : 0)) {
      cropsPanel();
      ImGui::EndTabItem();
    }
    cropMade_ = false;
    if (ImGui::BeginTabItem("Stats")) {
      statsPanel();
      ImGui::EndTabItem();
    }
    // The tab counts the warnings and errors (a loader's warnings were easy
    // to miss); "###Log" keeps the tab the same one as the count changes.
    size_t warnings = 0;
    for (const LogEntry& e : log::entries()) warnings += e.level >= LogLevel::Warning;
    const std::string logTab = warnings > 0 ? "Log (" + std::to_string(warnings) + " warnings)###Log" : "Log###Log";
    if (ImGui::BeginTabItem(logTab.c_str(), nullptr, showLog_ ? ImGuiTabItemFlags_SetSelected : 0)) {
      logPanel();
      ImGui::EndTabItem();
    }
    showLog_ = false;
    ImGui::EndTabBar();
  }
  ImGui::EndChild();
  ImGui::EndChild();

  shortcutsOverlay();
  // One dialog gathers failures (tev); Esc and Enter close it like OK.
  if (!errorDialog_.empty() && !ImGui::IsPopupOpen("Error")) ImGui::OpenPopup("Error");
  if (ImGui::BeginPopupModal("Error", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::PushTextWrapPos(600);
    ImGui::TextUnformatted(errorDialog_.c_str());
    ImGui::PopTextWrapPos();
    const bool key = ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Escape)) ||
                     ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Enter)) ||
                     ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_KeyPadEnter));
    if (ImGui::Button("OK") || key || errorDialog_.empty()) {
      errorDialog_.clear();
      ImGui::CloseCurrentPopup();
    }
    ImGui::EndPopup();
  }
  ImGui::End();
  lastFrameMs_ = 1000 * frameClock.seconds();
}

// ---- [3] Controls --------------------------------------------------------------------

void Studio::errorField(const char* key) {
  if (settingsError_.empty() || settingsErrorKey_ != key) return;
  ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1, 0.45f, 0.4f, 1));
  ImGui::TextWrapped("%s", settingsError_.c_str());
  ImGui::PopStyleColor();
}

namespace {
void warningText(const char* text) {
  ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1, 0.8f, 0.3f, 1));
  ImGui::TextWrapped("%s", text);
  ImGui::PopStyleColor();
}
}  // namespace

// Records which control changed, so that a refusal is shown beside it;
// returns c.
bool Studio::track(const char* key, bool c) {
  if (c) lastControl_ = key;
  return c;
}

namespace {
// What each bundled scene shows, for the scene menu (the measurements behind
// each line: docs/RESULTS.md).
const char* bundledSceneNote(const std::string& stem) {
  static const std::pair<const char*, const char*> notes[] = {
      {"kitchen", "the paper's kitchen: clamped VPL loses about 22% of the indirect light, VSL keeps it"},
      {"hall", "pure-metal walls: diffuse-only VPLs get none of their light, clamped VPL loses about 10%"},
      {"tableau",
       "clamped VPL loses about 61%, yet VSL loses at equal time: narrow anisotropic lobes make its "
       "error heavy-tailed"},
      {"cornell-glossy",
       "clamping loses only 4-7%: little for VSL to win back, and clamped VPL's lower variance "
       "wins"},
      {"furnace", "an analytic check: radiance Le/(1-a) = 2 everywhere"},
      {"waterbottle",
       "a real asset: Khronos's normal-mapped WaterBottle (CC0, Microsoft) on a glossy table; clamped VPL "
       "loses about a quarter of the indirect light"}};
  for (const auto& [name, note] : notes)
    if (stem == name) return note;
  return nullptr;
}
}  // namespace

void Studio::sceneControls() {
  ImGui::TextUnformatted("Scene");
  ImGui::SetNextItemWidth(-60);
  bool enter = ImGui::InputText("##path", &scenePath_, ImGuiInputTextFlags_EnterReturnsTrue);
  ImGui::SameLine();
  if (ImGui::Button("Load") || enter) openScene(scenePath_);
  if (ImGui::IsItemHovered()) tip("Or drop a .gltf/.glb on the window");
  if (!options_.bundled.empty()) {
    // The combo names the current scene if it is bundled, else asks for one.
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path scene = fs::absolute(settings_.scene, ec).lexically_normal();
    const bool isBundled = std::any_of(options_.bundled.begin(), options_.bundled.end(), [&](const std::string& b) {
      std::error_code e;
      return fs::absolute(b, e).lexically_normal() == scene;
    });
    const std::string label =
        isBundled ? "bundled: " + std::filesystem::path(settings_.scene).stem().string() : "bundled scenes...";
    ImGui::SetNextItemWidth(-1);
    if (ImGui::BeginCombo("##bundled", label.c_str())) {
      for (const std::string& b : options_.bundled) {
        std::string name = std::filesystem::path(b).stem().string();
        if (ImGui::Selectable(name.c_str(), isBundled && fs::absolute(b, ec).lexically_normal() == scene)) openScene(b);
        if (const char* note = bundledSceneNote(name)) {
          ImGui::SameLine(130);
          ImGui::TextDisabled("%s", note);
        }
      }
      ImGui::EndCombo();
    }
    const char* note = isBundled ? bundledSceneNote(fs::path(settings_.scene).stem().string()) : nullptr;
    if (note) {
      ImGui::PushStyleColor(ImGuiCol_Text, ImGui::GetStyleColorVec4(ImGuiCol_TextDisabled));
      ImGui::TextWrapped("%s", note);
      ImGui::PopStyleColor();
    }
  }
  errorField("scene");
  if (!sceneWarnings_.empty()) {
    char head[96];
    std::snprintf(head, sizeof head, "Loaded with %zu warning%s: ", sceneWarnings_.size(),
                  sceneWarnings_.size() == 1 ? "" : "s");
    warningText((head + sceneWarnings_.front()).c_str());
    if (ImGui::SmallButton("show the log")) showLog_ = true;
  }
}

namespace {
// path made absolute and normal (a message names a file wherever the studio
// was started from); as it is when that fails.
std::string absolutePath(const std::string& path) {
  std::error_code ec;
  const std::filesystem::path p = std::filesystem::absolute(path, ec);
  return ec ? path : p.lexically_normal().string();
}
}  // namespace

// The controls below return whether a setting changed.

// The preset (core/presets.h): "custom" once a method parameter differs
// from both; choosing one sets every method parameter.
bool Studio::presetControl() {
  bool changed = false;
  ManyLightSettings& m = settings_.many;
  const std::string current = matchingPreset(m);
  if (ImGui::BeginCombo("preset", current.c_str())) {
    for (Preset p : {Preset::Default, Preset::Paper}) {
      if (!ImGui::Selectable(presetName(p), current == presetName(p))) continue;
      applyPreset(p, m);
      changed |= track("preset", true);
    }
    ImGui::EndCombo();
  }
  if (ImGui::IsItemHovered())
    tip("paper: VSL and clamped VPL as Hasan et al. 2009 published them (the authors' sample count, k-NN radii, no "
        "heuristic of this project); default: the measured best (lobe-aware count, lobe floor 1, eye paths continued "
        "through near-mirror metals). docs/REFERENCE.md, \"Presets\"");
  return changed;
}

// The VSL variant by its preset and cone integral: "VSL", "VSL [paper]",
// "VSL [closed form]", "VSL [paper, closed form]" (core/presets.h,
// core/vsl_sg.h).
namespace {
// The preset the parameters match, VSL's cone integral apart (the default
// preset's is the closed form, the paper's the quadrature).
std::string presetApartFromIntegral(const ManyLightSettings& m) {
  ManyLightSettings other = m;
  for (VslIntegral i : {VslIntegral::Sg, VslIntegral::Quadrature}) {
    other.vslIntegral = i;
    if (const std::string p = matchingPreset(other); p != "custom") return p;
  }
  return "custom";
}

std::string vslVariantName(const ManyLightSettings& m) {
  std::string tags;
  const std::string preset = presetApartFromIntegral(m);
  if (preset != "default") tags = preset;
  if (m.vslIntegral == VslIntegral::Sg) tags += (tags.empty() ? "" : ", ") + std::string("closed form");
  return tags.empty() ? "VSL" : "VSL [" + tags + "]";
}
}  // namespace

// "Compare presets" and "Compare the cone integrals": each keeps the VSL
// picture shown (Source::Pinned, its own row in the table) and renders VSL
// with the other preset, or the other cone integral, the two side by side
// with the reference (docs/REFERENCE.md, "Presets"; docs/RESULTS.md,
// "Closed-form VSL by spherical Gaussians"). VPL keeps its light sets
// where only VSL's parameters changed (docs/USAGE.md, "One-method restarts").
bool Studio::compareButton() {
  const std::string current = matchingPreset(settings_.many);
  const Preset other = current == presetName(Preset::Paper) ? Preset::Default : Preset::Paper;
  const std::string label = std::string("Compare with the ") + presetName(other) + " preset";
  const bool sg = settings_.many.vslIntegral == VslIntegral::Sg;
  const char* integralLabel = sg ? "Compare with the quadrature" : "Compare with the closed form";
  const bool can = vslPictureCurrent();
  if (!can) ImGui::BeginDisabled();
  const bool clicked = ImGui::Button(label.c_str());
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
    tip("Pins the VSL picture shown (as \"Pinned VSL\", with its own row in the table) and renders VSL with the %s "
        "preset beside it: VSL as published against this project's measured best, on the same scene and "
        "reference.",
        presetName(other));
  const bool integralClicked = ImGui::Button(integralLabel);
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
    tip("Pins the VSL picture shown and renders VSL again from the same light sets with the cone integral %s: the "
        "quadrature (Monte Carlo, the paper's) against the closed form by spherical Gaussians (no samples per pair), "
        "their bias against their speed. docs/RESULTS.md, \"Closed-form VSL by spherical Gaussians\"",
        sg ? "by the quadrature" : "in closed form");
  if (!can) ImGui::EndDisabled();
  if (pinned_) {
    ImGui::SameLine();
    if (ImGui::SmallButton("unpin")) pinned_.reset();
  }
  // Each restarts: no settings change to report.
  if (clicked) comparePresets();
  if (integralClicked) compareIntegrals();
  return false;
}

bool Studio::pinVslAndRestart(const char* control, const std::function<void(ManyLightSettings&)>& change) {
  if (!vslPictureCurrent()) return false;
  pinned_ = PinnedVsl{vslVariantName(settings_.many), snap_->many.direct, snap_->many.vsl, snap_->settings};
  change(settings_.many);
  view_.mode = ViewMode::SideBySide3;
  view_.panels[0] = Source::Vsl;
  view_.panels[1] = Source::Pinned;
  view_.panels[2] = Source::Reference;
  texturesDirty_ = true;
  metricsFor_ = nullptr;
  lastControl_ = control;
  restart();
  return true;
}

bool Studio::comparePresets() {
  const Preset other = matchingPreset(settings_.many) == presetName(Preset::Paper) ? Preset::Default : Preset::Paper;
  return pinVslAndRestart("preset", [other](ManyLightSettings& m) { applyPreset(other, m); });
}

bool Studio::compareIntegrals() {
  return pinVslAndRestart("vsl-integral", [](ManyLightSettings& m) {
    m.vslIntegral = m.vslIntegral == VslIntegral::Sg ? VslIntegral::Quadrature : VslIntegral::Sg;
  });
}

// One control per registered parameter of the tier (core/params.h), each
// with its refusal beside it; a parameter that needs another (the lobe
// gather's rays) is hidden while that one is off.
bool Studio::paramControls(ParamTier tier) {
  bool changed = false;
  const ParamTable<ManyLightSettings>& table = manyLightParams();
  for (const Param<ManyLightSettings>& p : table.all()) {
    if (p.spec.tier != tier) continue;
    if (table.needUnmet(p, settings_.many)) continue;
    changed |= track(p.spec.name, paramWidget(p, settings_.many, paramMemory_));
    errorField(p.spec.name);
  }
  return changed;
}

// The experimental heuristics whose value is not the paper's.
int Studio::heuristicsOn() const {
  ManyLightSettings paper = settings_.many;
  applyPreset(Preset::Paper, paper);
  int on = 0;
  for (const Param<ManyLightSettings>& p : manyLightParams().all())
    on += p.spec.tier == ParamTier::Experimental && p.get(settings_.many) != p.get(paper);
  return on;
}

// What the numbers do: VSL radii that blur everything, the automatic clamp's
// bound, the pairs the roulette dropped.
void Studio::methodNotes() const {
  const ManyLightSettings& m = settings_.many;
  // Values that make VSL meaningless: spheres as large as the scene blur
  // everything into a dim wash, or go black when they swallow the receivers.
  if (snap_ && !sourceStale(Source::Vsl) && snap_->sceneRadius > 0 && snap_->radiusMedian > 0.5f * snap_->sceneRadius) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "VSL radii (median %.3g) exceed half the scene's radius (%.3g): VSL is blurred out or black. "
                  "Lower the radius.",
                  snap_->radiusMedian, snap_->sceneRadius);
    warningText(buf);
  } else if (m.globalRadius <= 0 && m.radiusScale > 20) {
    warningText("A radius scale this large makes VSL spheres larger than most scenes: VSL goes dark or black.");
  }
  if (snap_ && m.clamp < 0) ImGui::TextDisabled("automatic clamp bound = %.4g", snap_->clampBound);
}

// The preset, the method parameters, then the experimental heuristics in a
// section that starts collapsed (docs/REFERENCE.md, "Parameters").
bool Studio::methodControls() {
  bool changed = presetControl();
  changed |= compareButton();
  sectionTitle("Method parameters");
  changed |= paramControls(ParamTier::Method);
  methodNotes();
  ImGui::Spacing();
  const std::string header = "Experimental heuristics (" + std::to_string(heuristicsOn()) + " on)###Experimental";
  if (ImGui::CollapsingHeader(header.c_str())) {
    changed |= paramControls(ParamTier::Experimental);
    if (snap_ && settings_.many.pairRoulette > 0)
      ImGui::TextDisabled("pairs dropped: %llu", (unsigned long long)snap_->rouletteDropped);
  }
  if (ImGui::IsItemHovered())
    tip("This project's heuristics, measured in docs/REFERENCE.md \"Parameters\"; the paper preset turns "
        "every one off.");
  return changed;
}

// The estimator: a registered one (estimator_registry.h) and its
// parameters, and the progressive radius.
bool Studio::estimatorControls() {
  bool changed = false;
  sectionTitle("Estimator");
  EstimatorSettings& e = settings_.estimator;
  const std::vector<EstimatorInfo>& all = estimators();
  int chosen = 0;
  for (size_t i = 0; i < all.size(); ++i)
    if (all[i].name == e.name) chosen = int(i);
  auto label = [](void* data, int i, const char** out) {
    *out = (*static_cast<const std::vector<EstimatorInfo>*>(data))[size_t(i)].label.c_str();
    return true;
  };
  if (ImGui::Combo("estimator", &chosen, label, const_cast<std::vector<EstimatorInfo>*>(&all), int(all.size()))) {
    e.name = all[size_t(chosen)].name;
    changed |= track("estimator", true);
  }
  if (ImGui::IsItemHovered()) {
    std::string help;
    for (const EstimatorInfo& info : all) help += (help.empty() ? "" : "\n") + info.label + ": " + info.help + ".";
    tip("%s\nWith several light sets, each set is one estimate and the sets are averaged.", help.c_str());
  }
  // The chosen estimator's parameters (param_widgets.h).
  for (const EstimatorParam& p : all[size_t(chosen)].params) {
    const Param<EstimatorSettings>* bound = estimatorParams().find(p.spec.name);
    double v = bound->get(e);
    if (track("estimator", paramWidget(p.spec, &v, p.defaultValue, paramMemory_))) {
      bound->set(e, v);
      changed = true;
    }
  }
  double alpha = e.progressiveRadius ? e.alpha : 0;
  if (track("estimator", paramWidget(runParam("progressive-radius"), &alpha, 0, paramMemory_))) {
    e.progressiveRadius = alpha > 0;
    if (alpha > 0) e.alpha = float(alpha);
    changed = true;
  }
  errorField("estimator");
  return changed;
}

bool Studio::renderControls() {
  bool changed = false;
  sectionTitle("Render");
  ManyLightSettings& m = settings_.many;
  int seed = int(m.seed);
  if (ImGui::InputInt("seed", &seed)) {
    m.seed = uint64_t(std::max(seed, 0));
    changed |= track("seed", true);
  }
  int width = m.width > 0 ? m.width : 256;
  if (ImGui::SliderInt("width", &width, 32, 2048, "%d px", ImGuiSliderFlags_Logarithmic)) {
    m.width = width;
    m.height = 0;  // from the camera's aspect
    changed |= track("width", true);
  }
  errorField("width");
  double sets = settings_.lightSets;
  if (track("light sets", paramWidget(runParam("light-sets"), &sets, StudioSettings().lightSets, paramMemory_))) {
    settings_.lightSets = int(sets);
    changed = true;
  }
  errorField("light sets");
  changed |= track("reference spp", ImGui::SliderInt("reference spp", &settings_.maxReferenceSpp, 16, 65536, "%d",
                                                     ImGuiSliderFlags_Logarithmic));
  errorField("reference spp");
  return changed;
}

bool Studio::referenceControls() {
  bool changed = false;
  sectionTitle("Reference");
  ImGui::SetNextItemWidth(-110);
  bool refEnter = ImGui::InputText("##reference", &referencePathInput_, ImGuiInputTextFlags_EnterReturnsTrue);
  ImGui::SameLine();
  if (ImGui::Button("Load reference") || refEnter) {
    settings_.referencePath = referencePathInput_;
    changed |= track("reference", true);
  }
  if (ImGui::IsItemHovered())
    tip("An EXR of the render's size: with an 'indirect' layer (vsl reference writes one) the methods' indirect "
        "light is compared; another renderer's full image alone compares the full component. Empty: a matching "
        "cached reference, else the live path tracer");
  if (!settings_.referencePath.empty() && ImGui::Button("Use cache / live path tracer")) {
    settings_.referencePath.clear();
    referencePathInput_.clear();
    changed |= track("reference", true);
  }
  bool background = settings_.backgroundReferenceSpp > 0;
  if (ImGui::Checkbox("render reference in background", &background)) {
    settings_.backgroundReferenceSpp = background ? backgroundSpp_ : 0;
    changed |= track("reference", true);
  }
  if (ImGui::IsItemHovered())
    tip("Once the methods are done, render a converged reference into the cache (kept for the next "
        "session), then measure every error against it");
  if (ImGui::SliderInt("background spp", &backgroundSpp_, 64, 65536, "%d", ImGuiSliderFlags_Logarithmic) &&
      background) {
    settings_.backgroundReferenceSpp = backgroundSpp_;
    changed |= track("reference", true);
  }
  double method = settings_.referenceMethod;
  if (paramWidget(runParam("reference-method"), &method, StudioSettings().referenceMethod, paramMemory_)) {
    settings_.referenceMethod = int(method);
    changed |= track("reference", true);
  }
  errorField("reference");
  return changed;
}

void Studio::viewControls() {
  sectionTitle("View");
  ImGui::TextDisabled("layout, component, display: above the images");
  int panels = view_.mode == ViewMode::Single ? 1 : view_.mode == ViewMode::SideBySide3 ? 3 : 2;
  for (int i = 0; i < panels; ++i) {
    int src = int(view_.panels[i]);
    std::string label = view_.mode == ViewMode::Wipe ? (i == 0 ? "left" : "right") : "panel " + std::to_string(i + 1);
    std::vector<const char*> names;
    for (int k = 0; k < int(Source::Count); ++k) names.push_back(sourceName(Source(k)));
    if (ImGui::Combo(label.c_str(), &src, names.data(), int(names.size()))) view_.panels[i] = Source(src);
    if (ImGui::IsItemHovered()) tip("The image in this panel; keys 1-8 put one in panel 1, T swaps VSL and VPL");
  }
  if (view_.display == Display::Error) {
    int metric = int(view_.metric);
    if (ImGui::Combo("metric", &metric, kMetricNames, 4)) view_.metric = ErrorMetric(metric);
    if (ImGui::IsItemHovered())
      tip("t = method, r = reference (same component), eps = %.2g (0.01 x the reference's mean luminance^2; its "
          "square root for the absolute metric).\nColours: black 0 -> blue -> magenta -> yellow -> white max.",
          mapEps_);
  }
  // FLIP compares the tone-mapped images: the exposure matters for its map too.
  if (view_.display == Display::Image || view_.display == Display::Flip)
    ImGui::SliderFloat("exposure", &view_.exposure, -10, 10, "%.1f stops");
  if (view_.display != Display::Image) {
    const char* autoText = view_.display == Display::Flip ? "auto (1)" : "auto (99th pct)";
    ImGui::SliderFloat("map max", &view_.errorScale, 0, 10, view_.errorScale > 0 ? "%.4g" : autoText,
                       ImGuiSliderFlags_Logarithmic);
  }
  if (ImGui::Button("Fit")) {
    view_.zoom = 1;
    view_.center = ImVec2(0.5f, 0.5f);
  }
  ImGui::SameLine();
  ImGui::TextDisabled("zoom %.2fx (wheel), pan (drag)", view_.zoom);
  ImGui::Checkbox("crop tool", &view_.cropTool);
  if (ImGui::IsItemHovered())
    tip("On: a drag on an image draws the crop rectangle. Off: Shift+drag does; Shift+click clears it.");
  ImGui::SameLine();
  ImGui::TextDisabled(view_.cropTool ? "drag: crop inset" : "Shift+drag: crop inset");
  if (!view_.crop.empty()) {
    ImGui::SameLine();
    if (ImGui::SmallButton("clear")) view_.crop = {};
  }
}

// The export folder; the buttons are in the toolbar above the images.
void Studio::exportControls() {
  sectionTitle("Export");
  ImGui::SetNextItemWidth(-1);
  ImGui::InputText("##dir", &exportDir_);
  if (ImGui::IsItemHovered())
    tip("The folder \"Save view\" and \"Export images\" (above the images) write into; each export makes a new "
        "folder in it");
}

void Studio::saveView() {
  std::error_code ec;
  std::filesystem::create_directories(exportDir_, ec);
  savePngPath_ = absolutePath(uniquePath(exportDir_, exportStem() + "-view", ".png"));
  savePngPending_ = true;
}

void Studio::exportFromControls() {
  std::string folder;
  std::vector<std::string> written;
  if (Result<void> exported = exportAll(exportDir_, &written, &folder)) {
    messagePath_ = absolutePath(folder);
    message_ = "wrote " + std::to_string(written.size()) + " files to " + messagePath_;
  } else {
    errorDialog_ = "Export failed; existing files are untouched.\n\n" + exported.error();
  }
}

void Studio::copyMessagePath() const { ImGui::SetClipboardText(messagePath_.c_str()); }

// Above the images, visible at any scroll of the controls (issue 49: "View
// and Export sit below the fold at 1280x800"): the layout, component and
// display, Save view and Export; then the last export's path with a button
// that copies it, or the view's keys.
void Studio::viewToolbar() {
  ImGui::SetNextItemWidth(140);
  int mode = int(view_.mode);
  if (ImGui::Combo("##layout", &mode, kModeNames, 4)) view_.mode = ViewMode(mode);
  if (ImGui::IsItemHovered())
    tip("Layout. Keys: T swaps VSL and VPL; 1-8 put that image in panel 1; F1 lists every key");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(80);
  int comp = int(view_.component);
  if (ImGui::Combo("##component", &comp, kComponentNames, 3)) view_.component = Component(comp);
  if (ImGui::IsItemHovered()) tip("Component shown and measured: full, direct or indirect light");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(135);
  int disp = int(view_.display);
  const char* displays[] = {"image", "error map", "signed difference", "FLIP map"};
  if (ImGui::Combo("##display", &disp, displays, 4)) view_.display = Display(disp);
  if (ImGui::IsItemHovered())
    tip(view_.display == Display::Flip
            ? "LDR-FLIP (HPG 2020) of each method against the reference, both tone-mapped at this exposure, per "
              "pixel in [0,1]; computed off the UI thread with the table's FLIP column. Colours: magma."
            : "Display: the image, each method's error map against the reference (metric: left panel), the signed "
              "difference, or the LDR-FLIP map");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(115);
  if (ImGui::BeginCombo("##tonemap", toneMapName(view_.toneMap))) {
    for (ToneMap t : {ToneMap::Linear, ToneMap::Filmic, ToneMap::FalseColour})
      if (ImGui::Selectable(toneMapName(t), view_.toneMap == t)) view_.toneMap = t;
    ImGui::EndCombo();
  }
  if (ImGui::IsItemHovered())
    tip("Tone map of the images (not the error or FLIP maps): linear sRGB; filmic, the ACES curve fitted by "
        "Narkowicz 2015; false colour, log10 luminance over %g..%g decades with its bar. Applies to the panels, "
        "Save view and the exported PNGs (images and crops); the EXR stays linear and FLIP uses linear sRGB.",
        kFalseColourDecades[0], kFalseColourDecades[1]);
  ImGui::SameLine(0, 16);
  if (ImGui::Button("Save view (PNG)")) saveView();
  if (ImGui::IsItemHovered())
    tip("The panels as shown (titles, images, colour bar), in a new file in the export folder");
  ImGui::SameLine();
  if (ImGui::Button("Export images")) exportFromControls();
  if (ImGui::IsItemHovered())
    tip("A new folder in the export folder (left panel): EXR with every layer, PNGs at the render's resolution, JSON");
  if (message_.empty()) {
    ImGui::TextDisabled("wheel: zoom  drag: pan  Shift+drag: crop  E/Shift+E: exposure  R: reset  F1: keys");
    return;
  }
  if (!messagePath_.empty()) {
    if (ImGui::SmallButton("Copy path")) copyMessagePath();
    if (ImGui::IsItemHovered()) tip("Copies %s to the clipboard", messagePath_.c_str());
    ImGui::SameLine();
  }
  ImGui::TextUnformatted(message_.c_str());
}

void Studio::controlsPanel() {
  // Room for the longest label ("reference spp", "pair roulette") beside
  // every control.
  ImGui::PushItemWidth(-128);
  sceneControls();
  bool changed = environmentControls();
  changed |= methodControls();
  changed |= estimatorControls();
  changed |= renderControls();
  changed |= referenceControls();
  // A drag restarts when it pauses for kSettleMs, typed text when it is
  // entered (each restart throws away the light set); a click or a key
  // restarts at once, in this frame.
  if (changed) {
    const int settleMs = ImGui::IsMouseDragging(ImGuiMouseButton_Left) ? kSettleMs : 0;
    restartAt_ = std::chrono::steady_clock::now() + std::chrono::milliseconds(settleMs);
    sinceChange_.reset();  // change -> picture counts from the control's last change
    changeTimed_ = true;
  }
  if (ImGui::Button("Restart")) restart(true);
  if (ImGui::IsItemHovered()) tip("Render the current settings again from scratch");
  ImGui::SameLine();
  if (ImGui::Button("Reset to defaults")) {
    StudioSettings d = options_.defaults ? *options_.defaults : options_.settings;
    d.scene = settings_.scene;
    applySettings(d);
  }
  for (const char* k : {"seed", "global radius", "diffuse"}) errorField(k);

  viewControls();
  exportControls();
  ImGui::PopItemWidth();
}

// ---- [4] Views -----------------------------------------------------------------------

namespace {
std::string humanSeconds(double t) {
  char buf[32];
  if (t < 60)
    std::snprintf(buf, sizeof buf, "%.0f s", std::ceil(t));
  else if (t < 3600)
    std::snprintf(buf, sizeof buf, "%d min %02d s", int(t) / 60, int(t) % 60);
  else
    std::snprintf(buf, sizeof buf, "%.1f h", t / 3600);
  return buf;
}
}  // namespace

std::string timeLeftText(double predictedSeconds, double ageSeconds) {
  if (!(predictedSeconds > 0)) return "time left not known yet";
  const double left = predictedSeconds - std::max(ageSeconds, 0.0);
  // A second of grace: a prediction that ends between two snapshots is not
  // late yet.
  if (!(left > -1.0)) return "finishing";
  return "~" + humanSeconds(std::max(left, 0.0)) + " left";
}

namespace {
std::string humanCount(double v) {
  char buf[32];
  if (v >= 1e6)
    std::snprintf(buf, sizeof buf, "%.2fM", v * 1e-6);
  else if (v >= 1e4)
    std::snprintf(buf, sizeof buf, "%.1fk", v * 1e-3);
  else
    std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// What the worker is doing, for the status line: its stage, and while busy
// the stage's time and the step's progress.
std::string activityText(const Session::Status& st) {
  const bool busyNow = st.busy();
  std::string what;
  if (st.stage == "loading")
    what = "loading " + std::filesystem::path(st.loading).filename().string();
  else if (st.stage == "tracing lights")
    what = "tracing " + std::to_string(st.lightsTarget) + " virtual lights";
  else if (st.stage == "tracing lobe-gather lights")
    what = "tracing " + std::to_string(st.lightsTarget) + " lobe-gather lights";
  else if (st.stage == "k-NN radii")
    what = "k-NN radii of " + std::to_string(st.lightsTarget) + " lights";
  else
    what = st.stage.empty() ? "idle" : st.stage;
  if (busyNow && st.stage != "rendering") what += "  " + humanSeconds(st.stageSeconds);
  if (busyNow && !st.stepProgress.empty()) what += "  " + st.stepProgress;
  return what;
}

// The many-light methods' progress bar and line (age: seconds since the
// snapshot was published).
void manyLightProgress(const Snapshot& s, double age) {
  char overlay[64], detail[160];
  const float fm = float(std::clamp(s.manyFractionDone, 0.0, 1.0));
  if (s.vplPending) {
    // An MRCS light set shows VSL before its clamped-VPL columns: no rate or
    // time left is known for the set yet (the status line names the stage).
    ImGui::ProgressBar(0.5f, ImVec2(130, 0), "VSL in, VPL next");
    ImGui::SameLine();
    std::snprintf(detail, sizeof detail, "set %d / %d: VSL's MRCS picture is in, clamped VPL's columns follow",
                  std::min(s.lightSetsDone + 1, s.lightSets), s.lightSets);
  } else {
    std::snprintf(overlay, sizeof overlay, "VSL+VPL %.0f%%", 100 * fm);
    ImGui::ProgressBar(fm, ImVec2(130, 0), overlay);
    ImGui::SameLine();
    // No lights-per-second rate: the first batches hold few lights and every
    // pixel's eye path, so it contradicted the time left (predicted per part
    // of a batch, Snapshot::manyFractionDone); the throughput is in the
    // metrics tab (pairs/s).
    std::snprintf(detail, sizeof detail, "%zu / %zu lights  set %d / %d  %s", s.lightsProcessed, s.lightsTotal,
                  std::min(s.lightSetsDone + (s.manyLightDone ? 0 : 1), s.lightSets), s.lightSets,
                  s.manyLightDone ? "done" : timeLeftText(s.manyRemainingSeconds, age).c_str());
  }
  ImGui::TextUnformatted(detail);
  if (ImGui::IsItemHovered() && !s.vplPending)
    tip("Lights gathered over every light set. The bar is the many-light work's share done in its own compute "
        "time, predicted from what each part of the batches done cost (eye paths and direct light, the lobe "
        "gather's directions, the lights); the time left is wall-clock, with the reference's turns");
}
}  // namespace

// Two fixed lines above the images: what the worker is doing (with a busy
// mark), and progress of each method in work done, rate and time left.
void Studio::statusBar() {
  Session::Status st = session_ ? session_->status() : Session::Status();
  const bool busyNow = st.busy();
  const char* spin = "|/-\\";
  const char mark = busyNow ? spin[int(ImGui::GetTime() * 6) % 4] : ' ';
  const std::string what = activityText(st);
  bool anyStale = false;
  for (int i = 0; i < 3; ++i) anyStale |= snap_ && panelStale(i);
  if (busyNow)
    ImGui::TextColored(ImVec4(0.5f, 0.85f, 1, 1), "[%c] %s", mark, what.c_str());
  else
    ImGui::Text("[%c] %s", mark, what.c_str());
  if (anyStale) {
    ImGui::SameLine();
    ImGui::TextColored(ImVec4(1, 0.75f, 0.2f, 1), "  dimmed panels show the previous settings until their new picture");
  }
  const bool current = snap_ && !sourceStale(Source::Vsl);
  if (!current) {
    ImGui::TextDisabled(snap_ ? "waiting for the first picture of the current settings" : "no picture yet");
    return;
  }
  const Snapshot& s = *snap_;
  // Seconds since the session published it (a snapshot made for a test has
  // no time: its predictions are shown as made).
  const double age = s.publishedAt == std::chrono::steady_clock::time_point()
                         ? 0.0
                         : std::chrono::duration<double>(std::chrono::steady_clock::now() - s.publishedAt).count();
  manyLightProgress(s, age);
  referenceProgress(s, age);
}

// The reference's progress bar and line (age: seconds since the snapshot
// was published), after the many-light methods' where it fits.
void Studio::referenceProgress(const Snapshot& s, double age) {
  char detail[160];
  const ReferenceProgressText text = referenceProgressText(s.ptSpp, s.settings.maxReferenceSpp);
  std::snprintf(detail, sizeof detail, "%s  %s spp/s  %s", text.count.c_str(),
                humanCount(s.referenceSppPerSecond).c_str(),
                s.referenceDone ? "done" : timeLeftText(s.referenceRemainingSeconds, age).c_str());
  // The reference's half on the same line where it fits, else on the next
  // (a narrow window cut it off). Back on one line only with room to spare
  // (40 px), so that a time left that grows by a digit does not move the
  // panels by a line from one second to the next.
  const float needed = 24 + 130 + ImGui::GetStyle().ItemSpacing.x + ImGui::CalcTextSize(detail).x;
  const float room = ImGui::GetWindowPos().x + ImGui::GetWindowContentRegionMax().x - ImGui::GetItemRectMax().x;
  statusTwoLines_ = statusTwoLines_ ? room < needed + 40 : room < needed;
  if (!statusTwoLines_) ImGui::SameLine(0, 24);
  ImGui::ProgressBar(text.fraction, ImVec2(130, 0), text.overlay.c_str());
  ImGui::SameLine();
  ImGui::TextUnformatted(detail);
  if (ImGui::IsItemHovered())
    tip("The live path tracer takes turns with the many-light methods: after each of their steps it renders "
        "until it has had as much compute time as they have (so that the error plot compares equal time), so "
        "it pauses while a long step runs (an MRCS light set, a large batch). Its rate is over its own compute "
        "time; the time left is wall-clock, with those turns.");
}

namespace {
// The sources whose maps show an error (the methods), as opposed to the
// reference and the lost-energy images.
bool isMethod(Source s) { return s != Source::Reference && s != Source::LostClamping && s != Source::LostDiffuse; }

// A stale image is dimmed and badged until its first new picture.
void staleMark(ImDrawList* dl, ImVec2 p0, ImVec2 p1) {
  dl->AddRectFilled(p0, p1, IM_COL32(0, 0, 0, 150));
  const char* badge = "STALE - previous settings";
  ImVec2 ts = ImGui::CalcTextSize(badge);
  dl->AddRectFilled(ImVec2(p0.x + 4, p0.y + 4), ImVec2(p0.x + ts.x + 12, p0.y + ts.y + 8), IM_COL32(120, 80, 0, 230));
  dl->AddText(ImVec2(p0.x + 8, p0.y + 6), IM_COL32(255, 220, 120, 255), badge);
}

// A picture from a small share of its light set is marked as such: with a
// few lights it is a blotch, not yet the method's picture (issue: "a green
// single-light blotch, without a badge").
void roughMark(ImDrawList* dl, ImVec2 p0, const char* text) {
  ImVec2 ts = ImGui::CalcTextSize(text);
  dl->AddRectFilled(ImVec2(p0.x + 4, p0.y + 4), ImVec2(p0.x + ts.x + 12, p0.y + ts.y + 8), IM_COL32(40, 70, 120, 230));
  dl->AddText(ImVec2(p0.x + 8, p0.y + 6), IM_COL32(200, 225, 255, 255), text);
}

// A box in place of a picture, saying why. The text wraps inside the box (a
// panel can be narrower than one line) and is clipped to it.
void waitBox(ImDrawList* dl, ImVec2 p0, ImVec2 p1, const char* text) {
  dl->AddRect(p0, p1, IM_COL32(90, 90, 90, 255));
  const float wrap = std::max(p1.x - p0.x - 16, 40.0f);
  const ImVec4 clip(p0.x, p0.y, p1.x, p1.y);
  dl->AddText(ImGui::GetFont(), ImGui::GetFontSize(), ImVec2(p0.x + 8, p0.y + 8), IM_COL32(200, 200, 200, 255), text,
              nullptr, wrap, &clip);
}
}  // namespace

// How a panel draws a source: tone-mapped at the exposure, or (a method under
// a map display) through the map's colours scaled to mapMax.
DisplayParams Studio::displayParams(Source s, float mapMax) const {
  DisplayParams p;
  if (view_.display == Display::Image || !isMethod(s)) {
    p.mode = view_.toneMap == ToneMap::Filmic        ? DisplayMode::Filmic
             : view_.toneMap == ToneMap::FalseColour ? DisplayMode::LogFalseColour
                                                     : DisplayMode::Tonemap;
    p.scale = std::exp2(view_.exposure);
  } else {
    p.mode = view_.display == Display::Error  ? DisplayMode::FalseColour
             : view_.display == Display::Flip ? DisplayMode::Magma
                                              : DisplayMode::Signed;
    p.scale = 1.0f / std::max(mapMax, 1e-12f);
  }
  return p;
}

// The panels drawn side by side: 1, 2 or 3 (the wipe's two share one).
int Studio::panelCount() const {
  return view_.mode == ViewMode::SideBySide2 ? 2 : view_.mode == ViewMode::SideBySide3 ? 3 : 1;
}

// A colour bar under the images: the maps, and the false-colour tone map.
bool Studio::legendShown() const { return view_.display != Display::Image || view_.toneMap == ToneMap::FalseColour; }

// Each panel's image size on screen for a view area of avail (the titles
// and the legend included): imageScale of the render in one panel's room.
ImVec2 Studio::panelImageSize(ImVec2 avail, float* panelW) const {
  const int n = panelCount();
  if (legendShown()) avail.y -= kLegendH;
  *panelW = (avail.x - 8 * (n - 1)) / n;
  const float panelH = avail.y - ImGui::GetTextLineHeightWithSpacing();
  const float scale = imageScale(*panelW, panelH, snap_->width, snap_->height);
  return ImVec2(scale * float(snap_->width), scale * float(snap_->height));
}

// The views child's height for a width and at most maxH: the toolbar and
// status lines (as measured in the last frame), the titles, the images and
// the legend, so that the metrics below get the rest (issue 49: "the image
// area is half empty").
float Studio::viewsHeight(float width, float maxH) const {
  if (!snap_ || snap_->width == 0) return maxH;
  const ImVec2 pad = ImGui::GetStyle().WindowPadding;
  const float fixed = 2 * pad.y + chromeH_ + 2;
  float panelW = 0;
  const ImVec2 img = panelImageSize(ImVec2(width - 2 * pad.x, maxH - fixed), &panelW);
  const float needed = fixed + ImGui::GetTextLineHeightWithSpacing() + img.y + (legendShown() ? kLegendH : 0);
  return std::min(maxH, needed);
}

void Studio::viewsPanel() {
  viewToolbar();
  statusBar();
  ImVec2 origin = ImGui::GetCursorScreenPos(), avail = ImGui::GetContentRegionAvail();
  chromeH_ = origin.y - ImGui::GetWindowPos().y - ImGui::GetStyle().WindowPadding.y;
  viewMin_ = panelsMin_ = origin;
  viewMax_ = panelsMax_ = ImVec2(origin.x + avail.x, origin.y + avail.y);
  if (!snap_ || snap_->width == 0) return;
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const int n = panelCount();
  const float labelH = ImGui::GetTextLineHeightWithSpacing();
  float panelW = 0;
  const ImVec2 size = panelImageSize(avail, &panelW);
  const float w = size.x, h = size.y;
  handleViewInput(origin, avail, panelW, w, h, n);
  const float mapMax = mapScale(n);
  drawPanels(dl, origin, panelW, size, mapMax);
  drawCropOutline(dl);
  if (ImGui::IsItemHovered()) probe(ImGui::GetIO().MousePos);
  // What "Save view" writes: the titles, the images and the legend.
  panelsMin_ = ImVec2(drawn_.front().p0.x, origin.y);
  panelsMax_ = ImVec2(drawn_.back().p1.x, drawn_.back().p1.y);
  if (legendShown()) {
    ImGui::SetCursorScreenPos(ImVec2(panelsMin_.x, origin.y + labelH + h + 6));
    legend(mapMax);
    panelsMax_.y = origin.y + labelH + h + kLegendH;
    panelsMax_.x = std::max(panelsMax_.x, ImGui::GetItemRectMax().x);
  }
}

// The n panels' images (or why there is none), their titles and badges.
void Studio::drawPanels(ImDrawList* dl, ImVec2 origin, float panelW, ImVec2 size, float mapMax) {
  const float labelH = ImGui::GetTextLineHeightWithSpacing(), w = size.x, h = size.y;
  // Zoom and pan: the visible UV window.
  float half = 0.5f / view_.zoom;
  ImVec2 uv0(view_.center.x - half, view_.center.y - half), uv1(view_.center.x + half, view_.center.y + half);
  // The FLIP display shows a method only once a map for this view exists.
  auto flipPending = [&](Source s) { return view_.display == Display::Flip && isMethod(s) && !flipMap(s); };
  auto missing = [&](Source s) { return !hasPicture(s, view_.component); };
  auto params = [&](Source s) { return displayParams(s, mapMax); };
  const ImU32 staleTitle = IM_COL32(255, 190, 60, 255);
  for (int i = 0; i < panelCount(); ++i) {
    // On whole screen pixels: at a whole scale every texel is then s x s.
    ImVec2 p0(std::floor(origin.x + i * (panelW + 8) + (panelW - w) / 2), std::floor(origin.y + labelH));
    ImVec2 p1(p0.x + w, p0.y + h);
    if (view_.mode == ViewMode::Wipe) {
      Source a = view_.panels[0], b = view_.panels[1];
      float sx = p0.x + view_.wipe * w, su = uv0.x + view_.wipe * (uv1.x - uv0.x);
      if (missing(a))
        waitBox(dl, p0, ImVec2(sx, p1.y), missingPictureText(a).c_str());
      else if (!flipPending(a))
        drawImage(dl, textures_[int(a)], p0, ImVec2(sx, p1.y), uv0, ImVec2(su, uv1.y), params(a));
      if (missing(b))
        waitBox(dl, ImVec2(sx, p0.y), p1, missingPictureText(b).c_str());
      else if (!flipPending(b))
        drawImage(dl, textures_[int(b)], ImVec2(sx, p0.y), p1, ImVec2(su, uv0.y), uv1, params(b));
      drawn_.push_back({p0, ImVec2(sx, p1.y), uv0, ImVec2(su, uv1.y), a});
      drawn_.push_back({ImVec2(sx, p0.y), p1, ImVec2(su, uv0.y), uv1, b});
      if (sourceStale(a)) staleMark(dl, p0, ImVec2(sx, p1.y));
      if (sourceStale(b)) staleMark(dl, ImVec2(sx, p0.y), p1);
      dl->AddLine(ImVec2(sx, p0.y), ImVec2(sx, p1.y), IM_COL32(255, 255, 255, 200), 1.5f);
      dl->AddText(ImVec2(p0.x, origin.y), panelStale(0) ? staleTitle : IM_COL32_WHITE,
                  (panelTitle(a, view_.component) + "  |  " + panelTitle(b, view_.component)).c_str());
      continue;
    }
    Source s = view_.panels[i];
    if (missing(s))
      waitBox(dl, p0, p1, missingPictureText(s).c_str());
    else if (flipPending(s))  // no FLIP map for this view yet: never an old texture in its place
      waitBox(dl, p0, p1, "computing FLIP ...");
    else
      drawImage(dl, textures_[int(s)], p0, p1, uv0, uv1, params(s));
    drawn_.push_back({p0, p1, uv0, uv1, s});
    bool stale = sourceStale(s);
    if (stale)
      staleMark(dl, p0, p1);
    else if (isMethod(s) && s != Source::Pinned && roughPicture() && !keptSetsShown(s))
      roughMark(dl, p0, roughText().c_str());
    dl->AddText(ImVec2(p0.x, origin.y), stale ? staleTitle : IM_COL32_WHITE,
                (panelTitle(s, view_.component) + (stale ? "  [stale]" : "")).c_str());
  }
}

// One colour scale for every map on screen (n panels), so panels compare
// fairly: the map maximum set by hand, else the largest automatic one.
float Studio::mapScale(int n) const {
  float sharedMax = 0;
  for (int i = 0; i < (view_.mode == ViewMode::Wipe ? 2 : n); ++i)
    if (isMethod(view_.panels[i]) && hasPicture(view_.panels[i], view_.component))
      sharedMax = std::max(sharedMax, autoScale_[int(view_.panels[i])]);
  return view_.errorScale > 0 ? view_.errorScale : std::max(sharedMax, 1e-12f);
}

// Wheel zooms about the cursor, a drag pans, and in wipe mode a drag that
// starts on the split line moves it (decided once, when the button goes
// down). Keys: T swaps VSL and VPL without ever showing one method twice;
// 1-7 put that image in panel 1 (swapping with a panel that shows it).
void Studio::handleViewInput(const ImVec2& origin, const ImVec2& avail, float panelW, float w, float h, int n) {
  ImGuiIO& io = ImGui::GetIO();
  const float labelH = ImGui::GetTextLineHeightWithSpacing();
  auto imageX0 = [&](int i) { return std::floor(origin.x + i * (panelW + 8) + (panelW - w) / 2); };  // as drawPanels
  ImGui::SetCursorScreenPos(origin);
  ImGui::InvisibleButton("viewarea", ImVec2(std::max(avail.x, 1.0f), std::max(avail.y, 1.0f)));
  const bool hovered = ImGui::IsItemHovered();
  const float splitX = imageX0(0) + view_.wipe * w;
  if (hovered && io.MouseWheel != 0) {
    float zoom = std::clamp(view_.zoom * std::pow(1.15f, io.MouseWheel), 1.0f, 64.0f);
    for (int i = 0; i < n; ++i) {
      float fx = (io.MousePos.x - imageX0(i)) / w, fy = (io.MousePos.y - origin.y - labelH) / h;
      if (fx < 0 || fx > 1 || fy < 0 || fy > 1) continue;
      // Keep the image point under the cursor where it is.
      float oldHalf = 0.5f / view_.zoom, newHalf = 0.5f / zoom;
      float u = view_.center.x - oldHalf + fx * 2 * oldHalf, v = view_.center.y - oldHalf + fy * 2 * oldHalf;
      view_.center = ImVec2(u + newHalf - fx * 2 * newHalf, v + newHalf - fy * 2 * newHalf);
    }
    view_.zoom = zoom;
  }
  // The panel under a screen point (-1: none), and the image point there in pixels.
  auto panelAt = [&](const ImVec2& m) {
    for (int i = 0; i < n; ++i)
      if (m.x >= imageX0(i) && m.x < imageX0(i) + w && m.y >= origin.y + labelH && m.y < origin.y + labelH + h)
        return i;
    return -1;
  };
  auto toPixel = [&](const ImVec2& m, int i) {
    const float half = 0.5f / view_.zoom;
    float u = view_.center.x - half + (m.x - imageX0(i)) / w * 2 * half;
    float v = view_.center.y - half + (m.y - origin.y - labelH) / h * 2 * half;
    return ImVec2(std::clamp(u, 0.0f, 1.0f) * float(snap_->width), std::clamp(v, 0.0f, 1.0f) * float(snap_->height));
  };
  if (ImGui::IsItemActivated()) {
    cropDragging_ = (io.KeyShift || view_.cropTool) && panelAt(io.MouseClickedPos[0]) >= 0;
    wipeGrabbed_ = !cropDragging_ && view_.mode == ViewMode::Wipe && std::abs(io.MouseClickedPos[0].x - splitX) < 16;
  }
  if (ImGui::IsItemActive() && cropDragging_) {
    // The rectangle covers every pixel the drag touches, on the panel it began in.
    const int i = panelAt(io.MouseClickedPos[0]);
    ImVec2 a = toPixel(io.MouseClickedPos[0], i), b = toPixel(io.MousePos, i);
    CropRect r;
    r.x = int(std::floor(std::min(a.x, b.x)));
    r.y = int(std::floor(std::min(a.y, b.y)));
    r.w = std::min(int(std::ceil(std::max(a.x, b.x))), snap_->width) - r.x;
    r.h = std::min(int(std::ceil(std::max(a.y, b.y))), snap_->height) - r.y;
    r.imageW = snap_->width;
    r.imageH = snap_->height;
    view_.crop = r;
  } else if (ImGui::IsItemActive() && wipeGrabbed_) {
    view_.wipe = std::clamp((io.MousePos.x - imageX0(0)) / w, 0.0f, 1.0f);
  } else if (ImGui::IsItemActive() && ImGui::IsMouseDragging(ImGuiMouseButton_Left)) {
    view_.center.x -= io.MouseDelta.x / w / view_.zoom;
    view_.center.y -= io.MouseDelta.y / h / view_.zoom;
  }
  if (!ImGui::IsItemActive()) {
    if (cropDragging_) {
      // A click without a drag (under 2 pixels a side) clears the crop.
      if (view_.crop.w < 2 || view_.crop.h < 2) view_.crop = {};
      cropDragging_ = false;
    }
    wipeGrabbed_ = false;
  }
  if (view_.mode == ViewMode::Wipe && (wipeGrabbed_ || (hovered && std::abs(io.MousePos.x - splitX) < 16)))
    ImGui::SetMouseCursor(ImGuiMouseCursor_ResizeEW);
  const float half = 0.5f / view_.zoom;
  view_.center.x = std::clamp(view_.center.x, half, 1 - half);
  view_.center.y = std::clamp(view_.center.y, half, 1 - half);

  handleViewKeys();
}

// The keys the studio knows (kShortcuts lists them for the F1 overlay). ImGui
// 1.86 indexes keys by GLFW's codes: letters and digits are their ASCII
// codes, F1 is 290 and '/' 47.
constexpr int kKeyF1 = 290, kKeySlash = 47;
const char* const kShortcuts[][2] = {{"T", "swap VSL and VPL (or the first two panels)"},
                                     {"1 - 8", "put that image in panel 1 (VSL, VPL, reference, ..., pinned VSL)"},
                                     {"E / Shift+E", "exposure up / down half a stop"},
                                     {"R", "reset the view: zoom 1, centred"},
                                     {"wheel, drag", "zoom about the cursor, pan"},
                                     {"Shift+drag, Shift+click", "draw a crop inset, clear it"},
                                     {"F1 or ?", "show or hide this list"}};

// Keys over the views (kShortcuts). Not while text is typed or a popup is open.
void Studio::handleViewKeys() {
  ImGuiIO& io = ImGui::GetIO();
  if (io.WantTextInput || ImGui::IsPopupOpen("", ImGuiPopupFlags_AnyPopupId)) return;
  if (ImGui::IsKeyPressed('E', false))
    view_.exposure = std::clamp(view_.exposure + (io.KeyShift ? -0.5f : 0.5f), -10.0f, 10.0f);
  if (ImGui::IsKeyPressed('R', false)) {
    view_.zoom = 1;
    view_.center = ImVec2(0.5f, 0.5f);
  }
  if (ImGui::IsKeyPressed(kKeyF1, false) || (io.KeyShift && ImGui::IsKeyPressed(kKeySlash, false)))
    showShortcuts_ = !showShortcuts_;
  Source* p = view_.panels;
  const int shown = view_.mode == ViewMode::SideBySide3 ? 3 : view_.mode == ViewMode::Single ? 1 : 2;
  if (ImGui::IsKeyPressed('T')) {
    if (shown == 1)
      p[0] = p[0] == Source::Vsl ? Source::Vpl : Source::Vsl;
    else
      std::swap(p[0], p[1]);
  }
  for (int k = 0; k < int(Source::Count); ++k) {
    if (!ImGui::IsKeyPressed('1' + k)) continue;
    for (int i = 1; i < shown; ++i)
      if (p[i] == Source(k)) p[i] = p[0];
    p[0] = Source(k);
  }
}

// The Stats tab: luminance statistics and a histogram of panel 1's image in
// the shown component, or of its crop when there is one (tev's histogram).
void Studio::statsPanel() {
  const Source src = view_.panels[0];
  Image scratch;
  const Image* img =
      snap_ && hasPicture(src, view_.component) ? componentImage(src, view_.component, scratch) : nullptr;
  if (!img || img->width == 0) {
    ImGui::TextDisabled("No picture of %s yet.", sourceName(src));
    return;
  }
  const CropRect r = view_.crop.resolved(img->width, img->height);
  const Image region = r.empty() ? *img : cropImage(*img, r);
  const ImageStats st = imageStats(region);
  ImGui::Text("%s, %s component, %s: %zu pixels", sourceName(src), componentName(view_.component),
              r.empty() ? "whole image" : "crop", st.pixels);
  ImGui::Text("luminance  mean %.5g   min %.4g   max %.4g", st.mean, st.min, st.max);
  ImGui::Text("percentiles  1%% %.4g   50%% %.4g   99%% %.4g", st.p01, st.p50, st.p99);
  ImGui::TextDisabled("zero or negative %zu, non-finite %zu (panel 1's image; keys 1-8 choose it)", st.zeroOrNegative,
                      st.nonFinite);
  if (st.histogram.empty()) return;
  char overlay[96];
  std::snprintf(overlay, sizeof overlay, "log10 luminance %.2f .. %.2f", st.logMin, st.logMax);
  ImGui::PlotHistogram("##histogram", st.histogram.data(), int(st.histogram.size()), 0, overlay, 0.0f, FLT_MAX,
                       ImVec2(std::min(ImGui::GetContentRegionAvail().x, 640.0f), 110));
}

// The keys, in a window over the views (F1 or ? shows and hides it).
void Studio::shortcutsOverlay() {
  if (!showShortcuts_) return;
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowPos(ImVec2(display.x * 0.5f, display.y * 0.4f), ImGuiCond_Always, ImVec2(0.5f, 0.5f));
  ImGui::SetNextWindowBgAlpha(0.92f);
  if (ImGui::Begin(
          "Shortcuts (F1 or ? to close)", &showShortcuts_,
          ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoCollapse | ImGuiWindowFlags_NoSavedSettings)) {
    if (ImGui::BeginTable("keys", 2, ImGuiTableFlags_SizingFixedFit)) {
      for (const auto& [key, what] : kShortcuts) {
        ImGui::TableNextRow();
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(key);
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(what);
      }
      ImGui::EndTable();
    }
  }
  ImGui::End();
}

bool Studio::pixelValue(Source src, Component c, int x, int y, Vec3* out) const {
  auto at = [&](const Image* im) { return im && x < im->width && y < im->height ? im->at(x, y) : Vec3(0.0f); };
  SourceParts p = sourceParts(src);
  if (p.whole) {
    *out = at(p.whole);
    return true;
  }
  if (!p.indirect) return false;
  *out = c == Component::Direct     ? at(p.direct)
         : c == Component::Indirect ? at(p.indirect)
                                    : at(p.direct) + at(p.indirect);
  return true;
}

// The pixel probe: the value of every shown image under the cursor, and each
// method's error there against the reference (the map's metric).
void Studio::probe(const ImVec2& mouse) {
  for (const DrawnImage& d : drawn_) {
    if (mouse.x < d.p0.x || mouse.x >= d.p1.x || mouse.y < d.p0.y || mouse.y >= d.p1.y) continue;
    float u = d.uv0.x + (mouse.x - d.p0.x) / (d.p1.x - d.p0.x) * (d.uv1.x - d.uv0.x);
    float v = d.uv0.y + (mouse.y - d.p0.y) / (d.p1.y - d.p0.y) * (d.uv1.y - d.uv0.y);
    int x = std::clamp(int(u * snap_->width), 0, snap_->width - 1);
    int y = std::clamp(int(v * snap_->height), 0, snap_->height - 1);
    Vec3 ref;
    pixelValue(Source::Reference, view_.component, x, y, &ref);
    // Inside the window: left of the cursor where the last probe's width does
    // not fit on its right, above it where its height does not fit below.
    const ImVec2 display = ImGui::GetIO().DisplaySize;
    ImVec2 at(mouse.x + 16, mouse.y + 16);
    if (at.x + probeSize_.x > display.x) at.x = std::max(0.0f, mouse.x - 16 - probeSize_.x);
    if (at.y + probeSize_.y > display.y) at.y = std::max(0.0f, mouse.y - 16 - probeSize_.y);
    ImGui::SetNextWindowPos(at);
    ImGui::BeginTooltip();
    ImGui::Text("pixel (%d, %d), %s component", x, y, componentName(view_.component));
    std::vector<Source> listed;
    const int shown = view_.mode == ViewMode::SideBySide3 ? 3 : view_.mode == ViewMode::Single ? 1 : 2;
    for (int i = 0; i < shown; ++i)
      if (std::find(listed.begin(), listed.end(), view_.panels[i]) == listed.end()) listed.push_back(view_.panels[i]);
    if (std::find(listed.begin(), listed.end(), Source::Reference) == listed.end()) listed.push_back(Source::Reference);
    for (Source src : listed) {
      Vec3 val;
      pixelValue(src, view_.component, x, y, &val);
      ImGui::Text("%-22s %.4g %.4g %.4g", sourceName(src), val.x, val.y, val.z);
      if (src == Source::Reference || src == Source::LostClamping || src == Source::LostDiffuse) continue;
      float t = (val.x + val.y + val.z) / 3, r = (ref.x + ref.y + ref.z) / 3, dd = t - r;
      float e = metricError(dd, r, view_.metric, mapEps_);
      ImGui::SameLine();
      ImGui::TextDisabled("  error %.3g (%s), signed %+.3g", e, kMetricNames[int(view_.metric)], dd);
      if (const Image* f = view_.display == Display::Flip ? flipMap(src) : nullptr) {
        ImGui::SameLine();
        ImGui::TextDisabled("  FLIP %.3f", f->at(x, y).x);
      }
    }
    probeMin_ = ImGui::GetWindowPos();
    probeSize_ = ImGui::GetWindowSize();
    ImGui::EndTooltip();
    return;
  }
}

void Studio::legend(float vmax) {
  ImDrawList* dl = ImGui::GetWindowDrawList();
  ImVec2 p = ImGui::GetCursorScreenPos();
  const float W = 240, H = 12;
  const int steps = 48;
  bool signedMap = view_.display == Display::Signed, flipView = view_.display == Display::Flip;
  for (int i = 0; i < steps; ++i) {
    float t = (i + 0.5f) / steps;
    Vec3 c;
    if (signedMap) {
      float v = 2 * t - 1;
      c = v < 0 ? lerp(-v, Vec3(1.0f), Vec3(0.15f, 0.35f, 1.0f)) : lerp(v, Vec3(1.0f), Vec3(1.0f, 0.2f, 0.1f));
    } else {
      c = flipView ? magma(t) : falseColour(t);
    }
    dl->AddRectFilled(ImVec2(p.x + W * i / steps, p.y), ImVec2(p.x + W * (i + 1) / steps, p.y + H),
                      IM_COL32(int(c.x * 255), int(c.y * 255), int(c.z * 255), 255));
  }
  char buf[128];
  const bool toneBar = view_.display == Display::Image;  // the false-colour tone map's bar
  if (toneBar) {
    const float s = std::exp2(-view_.exposure);
    std::snprintf(buf, sizeof buf, "%.3g ... %.3g   luminance (Rec. 709, log scale) at %+.1f stops",
                  s * std::pow(10.0f, kFalseColourDecades[0]), s * std::pow(10.0f, kFalseColourDecades[1]),
                  view_.exposure);
  } else if (signedMap) {
    std::snprintf(buf, sizeof buf, "%.3g   0   +%.3g   (method - reference)", -vmax, vmax);
  } else if (flipView) {
    bool fresh = true;
    const bool any = flipMap(Source::Vsl, &fresh) != nullptr;
    std::snprintf(buf, sizeof buf, "0 ... %.3g   LDR-FLIP at %+.1f stops%s", vmax, view_.exposure,
                  !any    ? "  (computing ...)"
                  : fresh ? ""
                          : "  (updating: from an earlier picture)");
  } else {
    std::snprintf(buf, sizeof buf, "0 ... %.3g   %s", vmax, metricLabel(view_.metric).c_str());
  }
  dl->AddText(ImVec2(p.x + W + 8, p.y - 2), IM_COL32_WHITE, buf);
  ImGui::Dummy(ImVec2(W, H));
  if (ImGui::IsItemHovered() && toneBar)
    tip("False colour: log10 of the luminance times 2^exposure, black at %g and white at %g decades; the exposure "
        "slides the range",
        kFalseColourDecades[0], kFalseColourDecades[1]);
  else if (ImGui::IsItemHovered() && flipView)
    tip("LDR-FLIP per pixel, mean-pooled in the table's FLIP column; the maximum is %s",
        view_.errorScale > 0 ? "set by hand" : "1, FLIP's largest value");
  else if (ImGui::IsItemHovered())
    tip("eps = %.2g (squared; 0.01 x the reference's mean luminance^2); the maximum is %s", mapEps_,
        view_.errorScale > 0 ? "set by hand" : "the 99th percentile");
}

// ---- [5] Metrics and plot -------------------------------------------------------------

void Studio::updateMetrics() {
  if (metricsFor_ == snap_.get() && metricsComponent_ == view_.component) return;
  metricsFor_ = snap_.get();
  metricsComponent_ = view_.component;
  Image refScratch;
  const Image* ref = referenceImage(view_.component, refScratch);
  for (int i = 0; i < 4; ++i) {
    Image scratch;
    metrics_[i] = compareImages(*componentImage(kMetricSources[i], view_.component, scratch), *ref);
  }
  referenceMean_ = metrics_[0].average.meanRef;
  const Snapshot& s = *snap_;
  Image live = view_.component == Component::Direct     ? s.ptDirect
               : view_.component == Component::Indirect ? s.ptIndirect
                                                        : add(s.ptDirect, s.ptIndirect);
  livePtMetrics_ = compareImages(live, *ref);
  if (pinnedFits()) {
    Image scratch;
    pinnedMetrics_ = compareImages(*componentImage(Source::Pinned, view_.component, scratch), *ref);
  }
}

// The metrics panel's first lines: scene, size and component, throughput,
// and the UI's own responsiveness.
void Studio::metricsSummary(const Snapshot& s, bool stale) {
  ImGui::PushTextWrapPos(ImGui::GetCursorPosX() + 480);
  ImGui::Text("%s  |  %dx%d  |  %s component", std::filesystem::path(s.settings.scene).filename().c_str(), s.width,
              s.height, kComponentNames[int(view_.component)]);
  if (stale) {
    ImGui::SameLine();
    ImGui::TextColored(ImVec4(1, 0.75f, 0.2f, 1), "[stale]");
    if (ImGui::IsItemHovered()) tip("These numbers belong to the previous settings");
  }
  // No gather time yet (an MRCS step counts its pairs when it ends): no rate.
  char rate[32] = "-";
  if (s.gatherSeconds > 0) std::snprintf(rate, sizeof rate, "%.2f", s.pairsPerSecond * 1e-6);
  ImGui::TextWrapped("gather %s M pairs/s  tracing %.2f s  k-NN %.2f s  non-finite %llu", rate, s.lightTracingSeconds,
                     s.knnSeconds, (unsigned long long)s.nonFinite);
  ImGui::TextWrapped("UI frame %.1f ms  change->picture %.0f ms  launch->picture %.0f ms", lastFrameMs_,
                     restartToPictureMs_, launchToPictureMs_);
  ImGui::PopTextWrapPos();
}

// Which reference, and how noisy it is.
void Studio::metricsReferenceNotes(const Snapshot& s) {
  ImGui::PushTextWrapPos(ImGui::GetCursorPosX() + 660);
  ImGui::TextWrapped("light sets: %d of %d done; VSL and VPL show their mean%s; estimator: %s", s.lightSetsDone,
                     s.lightSets,
                     s.lightSetsDone == 0 ? " (the first set's progressive estimate until it is done)" : "",
                     s.settings.estimator.describe().c_str());
  char noiseText[48] = "unknown (no halves)";
  if (s.referenceNoise >= 0) std::snprintf(noiseText, sizeof noiseText, "%.3g", s.referenceNoise);
  ImGui::TextWrapped("reference: %s, %d spp, own noise %s (%s relMSE, subtracted)", s.referenceSource.c_str(),
                     s.referenceSpp, noiseText, kComponentNames[int(comparedComponent(s))]);
  if (s.backgroundSpp > 0 && !s.convergedReference)
    ImGui::TextWrapped("background reference: %d / %d spp", s.backgroundSpp, s.settings.backgroundReferenceSpp);
  ImGui::PopTextWrapPos();
}

// The table of each method's error against the reference: mean, RMSE,
// relMSE, relMSE at equal time, bias^2 and noise, FLIP.
// What every row of the metrics table is compared against: relMSE as
// compare.h computes it, less the reference's own noise where it is known
// (the indirect component: relMSE(A, B) / 4 from the reference's halves,
// session.h); the equal-time column interpolates each method's history at
// the same amount of its own time. The best value of each column is green.
struct Studio::TableState {
  // The view shows the component that errors are measured on (indirect, or
  // full against a full-only reference: Snapshot::comparesFull).
  bool compared = false;
  double noise = 0, budget = 0, ptEqual = NAN;
  double best[3] = {INFINITY, INFINITY, INFINITY};  // RMSE, relMSE, equal time
  // FLIP: the newest result for this component and exposure (greyed while a
  // newer snapshot's is being computed).
  bool flipHere = false, flipFresh = false;
  double bestFlip = INFINITY;
  // The best bias^2 (less the reference's noise) is the least one above
  // zero; NaN (none) where any shown is below zero, within the noise.
  double bestBias = INFINITY, bestNoise = INFINITY;
  double atEqualTime(const Snapshot& s, int i) const {
    if (!compared || i > 1) return double(NAN);
    return errorAtOwnTime(s.history, i == 0 ? StudioMethod::Vsl : StudioMethod::Vpl, budget);
  }
};

namespace {
void cell(double v, double bestV, const char* fmt) {
  if (!std::isfinite(v))
    ImGui::TextDisabled("-");
  else if (v == bestV)
    ImGui::TextColored(ImVec4(0.45f, 0.95f, 0.45f, 1), fmt, v);
  else
    ImGui::Text(fmt, v);
}
// A relMSE less the reference's own noise (now, or when the history's point
// was taken) that is not above zero: the method's error cannot be told from
// the reference's noise yet (a young live reference), so it has no number
// and is never the best.
bool belowNoise(double v) { return std::isfinite(v) && v <= 0; }
void errorCell(double v, double bestV) {
  if (!belowNoise(v)) return cell(v, bestV, "%.4g");
  ImGui::TextDisabled("< noise");
  if (ImGui::IsItemHovered())
    tip("relMSE less the reference's own noise is %.3g: this error is within the reference's noise, so it cannot be "
        "measured or ranked yet; it can once the reference has converged further",
        v);
}
}  // namespace

Studio::TableState Studio::metricsTableState(const Snapshot& s) const {
  TableState t;
  t.compared = view_.component == comparedComponent(s);
  t.noise = t.compared && s.referenceNoise > 0 ? s.referenceNoise : 0;
  t.budget = equalTimeBudget(s.history);
  // An error within the reference's noise cannot be ranked, and then no
  // error of its column is marked the best (hall's first seconds showed a
  // black-ish diffuse-only image's -13.9 in green; ranked by the raw relMSE
  // instead, a noisy reference can prefer a dark image).
  auto least = [](double& best, double v) {
    if (belowNoise(v) || std::isnan(best))
      best = NAN;
    else if (std::isfinite(v))
      best = std::min(best, v);
  };
  for (int i = 0; i < 4; ++i) {
    if (!metricShown(i)) continue;
    t.best[0] = std::min(t.best[0], metrics_[i].average.rmse);
    least(t.best[1], metrics_[i].average.relMse - t.noise);
    least(t.best[2], t.atEqualTime(s, i));
  }
  if (pinnedFits()) {
    t.best[0] = std::min(t.best[0], pinnedMetrics_.average.rmse);
    least(t.best[1], pinnedMetrics_.average.relMse - t.noise);
  }
  if (s.convergedReference) {
    t.best[0] = std::min(t.best[0], livePtMetrics_.average.rmse);
    least(t.best[1], livePtMetrics_.average.relMse - t.noise);
  }
  t.ptEqual = t.compared ? errorAtOwnTime(s.history, StudioMethod::Pt, t.budget) : NAN;
  if (s.convergedReference || t.ptEqual > 0) least(t.best[2], t.ptEqual);
  t.flipHere = flip_ && flip_->component == view_.component && flip_->exposure == view_.exposure;
  t.flipFresh = t.flipHere && flip_->serial == s.serial;
  // The rows shown: the methods with a picture, and the live path tracer
  // against a converged reference.
  auto rowShown = [&](int i) { return i < 4 ? metricShown(i) : s.convergedReference; };
  if (t.flipHere)
    for (int i = 0; i < 5; ++i)
      if (rowShown(i)) t.bestFlip = std::min(t.bestFlip, flip_->mean[i]);
  // Bias and noise of the rows shown (BiasNoiseRow follows the same order). A
  // bias that cannot be told from the noise (below zero) is not ranked, and
  // then none of its column is, as for relMSE (least).
  for (int i = 0; i < int(BiasNoiseRow::Count); ++i) {
    const BiasNoise& b = s.biasNoise[i];
    if (!rowShown(i) || b.renders < 2) continue;
    least(t.bestBias, b.bias2 - t.noise);
    t.bestNoise = std::min(t.bestNoise, b.variance);
  }
  return t;
}

void Studio::flipCell(const Snapshot& s, const TableState& t, int i) {
  if (!t.flipHere || (i == 4 && !s.convergedReference))
    ImGui::TextDisabled("-");
  else if (!t.flipFresh)
    ImGui::TextDisabled("%.4f", flip_->mean[i]);
  else
    cell(flip_->mean[i], t.bestFlip, "%.4f");
  if (ImGui::IsItemHovered())
    tip("LDR-FLIP (HPG 2020, mean pooled) of the tone-mapped images at this exposure, against the "
        "reference; computed off the UI thread%s",
        t.flipFresh ? "" : " (grey: from an earlier picture)");
}

// Bias against noise (session.h, BiasNoise): from the completed light sets
// (the path tracer's halves), for the indirect component; bias^2 less the
// reference's own noise where it is known, as relMSE.
void Studio::biasCells(const Snapshot& s, const TableState& t, BiasNoiseRow row) {
  const BiasNoise& b = s.biasNoise[int(row)];
  for (int k = 0; k < 2; ++k) {
    ImGui::TableNextColumn();
    if (!t.compared) {
      ImGui::TextDisabled("n/a");
    } else if (b.renders < 2) {
      ImGui::TextDisabled("-");
    } else if (k == 0 && belowNoise(b.bias2 - t.noise)) {
      ImGui::TextDisabled("< noise");
    } else {
      cell(k == 0 ? b.bias2 - t.noise : b.variance, k == 0 ? t.bestBias : t.bestNoise, "%.4g");
    }
    if (!ImGui::IsItemHovered()) continue;
    const bool pt = row == BiasNoiseRow::Pt;
    if (!t.compared)
      tip("Bias and noise are measured on the %s component", kComponentNames[int(comparedComponent(s))]);
    else if (b.renders < 2 && pt)
      tip("The path tracer's two halves are measured against a converged reference only");
    else if (b.renders < 2)
      tip("Needs two completed light sets (%d so far, of %d)", s.lightSetsDone, s.lightSets);
    else if (k == 0 && belowNoise(b.bias2 - t.noise))
      tip("bias^2%s is %.3g: this bias cannot be told from the noise of its own estimate%s yet, so it is not measured "
          "or ranked; it can be with more light sets%s",
          t.noise > 0 ? " less the reference's own noise" : "", b.bias2 - t.noise,
          t.noise > 0 ? " and of the reference" : "", t.noise > 0 ? " and a more converged reference" : "");
    else if (k == 0)
      tip("bias^2 = mean(w ((m - r)^2 - s^2/K)) over K = %d %s (compare.h biasVariance), w = 1/(r^2+eps)%s", b.renders,
          pt ? "halves" : "light sets",
          t.noise > 0 ? ", less the reference's own noise" : "; it includes the reference's own noise");
    else
      tip("noise = mean(w s^2): the variance of one %s (relMSE units); the mean of K has 1/K of it",
          pt ? "half" : "light set");
  }
}

void Studio::methodRow(const Snapshot& s, const TableState& t, int i) {
  const CompareResult& c = metrics_[i];
  ImGui::TableNextRow();
  ImGui::TableNextColumn();
  // The variant by its preset and VSL's cone integral: "VSL [paper]" against
  // "VSL" (vslVariantName).
  const std::string preset = presetApartFromIntegral(s.settings.many);
  const std::string name = kMetricSources[i] == Source::Vsl
                               ? vslVariantName(s.settings.many)
                               : sourceName(kMetricSources[i]) + (preset == "default" ? "" : " [" + preset + "]");
  ImGui::TextUnformatted(name.c_str());
  ImGui::TableNextColumn();
  ImGui::Text("%.5g", c.average.meanTest);
  ImGui::TableNextColumn();
  cell(c.average.rmse, t.best[0], "%.4g");
  ImGui::TableNextColumn();
  errorCell(c.average.relMse - t.noise, t.best[1]);
  if (ImGui::IsItemHovered() && !belowNoise(c.average.relMse - t.noise))
    tip("relMSE = mean((t-r)^2/(r^2+eps)), eps %.3g%s%s", c.epsilon,
        t.noise > 0 ? ", less the reference's own noise" : "; the reference's noise is not subtracted",
        std::isnan(t.best[1]) ? ". None is marked the best while an error of the column is within the reference's noise"
                              : "");
  ImGui::TableNextColumn();
  errorCell(t.atEqualTime(s, i), t.best[2]);
  biasCells(s, t, BiasNoiseRow(i));
  ImGui::TableNextColumn();
  flipCell(s, t, i);
}

// The pinned VSL picture against today's reference: its mean, RMSE and
// relMSE; its time, bias and noise belonged to its own render.
void Studio::pinnedRow(const TableState& t) {
  ImGui::TableNextRow();
  ImGui::TableNextColumn();
  ImGui::Text("%s (pinned)", pinned_->name.c_str());
  if (ImGui::IsItemHovered())
    tip("Kept from an earlier render of this scene and size (%s), measured against the reference the rows above use",
        pinned_->settings.many.describe().c_str());
  ImGui::TableNextColumn();
  ImGui::Text("%.5g", pinnedMetrics_.average.meanTest);
  ImGui::TableNextColumn();
  cell(pinnedMetrics_.average.rmse, t.best[0], "%.4g");
  ImGui::TableNextColumn();
  errorCell(pinnedMetrics_.average.relMse - t.noise, t.best[1]);
  for (int k = 0; k < 4; ++k) {
    ImGui::TableNextColumn();
    ImGui::TextDisabled("-");
  }
}

void Studio::livePtRow(const Snapshot& s, const TableState& t) {
  ImGui::TableNextRow();
  ImGui::TableNextColumn();
  ImGui::TextUnformatted(s.convergedReference ? "Path tracer (live)" : "Reference (live PT)");
  if (ImGui::IsItemHovered())
    tip("%s", s.convergedReference ? "The live path tracer, measured against the converged reference"
                                   : "The live path tracer is the reference: its value is its own "
                                     "noise, relMSE(A, B)/4 from two independent halves");
  ImGui::TableNextColumn();
  ImGui::Text("%.5g", s.convergedReference ? livePtMetrics_.average.meanTest : referenceMean_);
  ImGui::TableNextColumn();
  if (s.convergedReference)
    cell(livePtMetrics_.average.rmse, t.best[0], "%.4g");
  else
    ImGui::TextUnformatted("-");
  ImGui::TableNextColumn();
  // Against a converged reference the live path tracer is measured like the
  // methods; as the reference itself its value is its own noise, which is
  // estimated for the indirect component only.
  if (s.convergedReference) {
    errorCell(livePtMetrics_.average.relMse - t.noise, t.best[1]);
  } else if (t.compared && s.referenceNoise >= 0) {
    ImGui::Text("~%.3g", s.referenceNoise);
  } else if (t.compared) {
    // Its noise is measured from two halves, which the first pass lacks.
    ImGui::TextDisabled("?");
    if (ImGui::IsItemHovered()) tip("The reference's own noise is measured once it has two halves");
  } else {
    ImGui::TextDisabled("n/a");
    if (ImGui::IsItemHovered())
      tip("The path tracer's error is tracked for the %s component only", kComponentNames[int(comparedComponent(s))]);
  }
  ImGui::TableNextColumn();
  // As the reference, its error at equal time is its own noise, unknown (0
  // in the history) before it has two halves.
  if (!s.convergedReference && !(t.ptEqual > 0))
    ImGui::TextDisabled("-");
  else
    errorCell(t.ptEqual, t.best[2]);
  biasCells(s, t, BiasNoiseRow::Pt);
  ImGui::TableNextColumn();
  flipCell(s, t, 4);
}

// The table's header, each column's title explained in its tooltip.
void Studio::headerRow(const TableState& t) const {
  char budget[400];
  std::snprintf(budget, sizeof budget,
                "Each method's relMSE after %.3g s of its own time (the gather time charged to it alone; the path "
                "tracer's own passes), interpolated in its history. The budget is the largest every method has "
                "reached: the smallest of their latest own times.",
                t.budget);
  const char* tips[] = {
      "Each method's image against the reference, on this component",
      "The image's mean (per channel, then averaged): a method darker than the reference lost light",
      "Root mean squared error",
      t.noise > 0 ? "relMSE = mean((t-r)^2/(r^2+eps)), less the reference's own noise (relMSE(A, B)/4 of its halves)"
                  : "relMSE = mean((t-r)^2/(r^2+eps)); the reference's own noise is not known, so not subtracted",
      t.compared ? budget : "Equal time is measured on the compared component only",
      "bias^2 over the completed light sets (less the reference's own noise where known)",
      "The variance of one light set (relMSE units); the mean of K sets has 1/K of it",
      "LDR-FLIP (HPG 2020) of the tone-mapped images at this exposure"};
  ImGui::TableNextRow(ImGuiTableRowFlags_Headers);
  for (int c = 0; c < int(std::size(tips)); ++c) {
    ImGui::TableSetColumnIndex(c);
    ImGui::TableHeader(ImGui::TableGetColumnName(c));
    if (ImGui::IsItemHovered()) tip("%s", tips[c]);
  }
}

void Studio::metricsTable(const Snapshot& s) {
  const TableState t = metricsTableState(s);
  // A fixed outer width: the table's row lines end at the table, not under the plot.
  if (!ImGui::BeginTable("metrics", 8, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingFixedFit, ImVec2(660, 0)))
    return;
  // A full-only reference says so: its errors are of the full image.
  const std::string title = std::string("vs reference (") + kComponentNames[int(view_.component)] +
                            (s.comparesFull ? "; it has no indirect layer)" : ")");
  ImGui::TableSetupColumn(title.c_str(), ImGuiTableColumnFlags_WidthStretch);
  ImGui::TableSetupColumn("mean");
  ImGui::TableSetupColumn("RMSE");
  ImGui::TableSetupColumn(t.noise > 0 ? "relMSE-noise" : "relMSE");
  char eqTitle[32];
  std::snprintf(eqTitle, sizeof eqTitle, "@%.3gs", t.budget);
  ImGui::TableSetupColumn(t.compared ? eqTitle : "@equal t");
  ImGui::TableSetupColumn(t.noise > 0 ? "bias^2-noise" : "bias^2");
  ImGui::TableSetupColumn("noise");
  ImGui::TableSetupColumn("FLIP");
  headerRow(t);
  for (int i = 0; i < 4; ++i)
    if (metricShown(i)) methodRow(s, t, i);
  if (pinnedFits()) pinnedRow(t);
  livePtRow(s, t);
  ImGui::EndTable();
}

void Studio::metricsPanel() {
  if (!snap_ || snap_->width == 0) {
    ImGui::TextUnformatted("No picture yet.");
    return;
  }
  const Snapshot& s = *snap_;
  updateMetrics();
  const bool stale = sourceStale(Source::Vsl);
  ImGui::BeginGroup();
  metricsSummary(s, stale);
  // The verdict at equal time (core/verdict.h): a winner only once its lead
  // exceeds the reference's noise and the spread between light sets.
  const Verdict verdict = judge(s.history);
  const ImVec4 verdictColour = verdict.outcome == VerdictOutcome::VslWins   ? ImVec4(0.5f, 0.9f, 0.5f, 1)
                               : verdict.outcome == VerdictOutcome::VplWins ? ImVec4(0.95f, 0.75f, 0.4f, 1)
                                                                            : ImVec4(0.7f, 0.7f, 0.7f, 1);
  ImGui::PushTextWrapPos(ImGui::GetCursorPosX() + 660);
  ImGui::TextColored(verdictColour, "%s", verdictLine(verdict).c_str());
  // A live reference refining past its setting (session.h,
  // Snapshot::referenceTargetSpp): its noise still hides the differences.
  if (!s.convergedReference && !s.referenceDone && s.referenceTargetSpp > s.settings.maxReferenceSpp) {
    char left[32] = "";
    if (s.referenceRemainingSeconds > 0)
      std::snprintf(left, sizeof left, ", about %.0f s more", s.referenceRemainingSeconds);
    ImGui::TextColored(ImVec4(0.95f, 0.75f, 0.4f, 1),
                       "reference too noisy to rank yet: the live path tracer's noise %.3g is above a fifth of the "
                       "smallest method error; refining to %d spp%s",
                       s.referenceNoise, s.referenceTargetSpp, left);
  }
  ImGui::PopTextWrapPos();
  metricsTable(s);
  metricsReferenceNotes(s);
  ImGui::EndGroup();
  ImGui::SameLine(0, 12);
  plotErrors(
      ImVec2(std::max(ImGui::GetContentRegionAvail().x, 100.0f), std::max(ImGui::GetContentRegionAvail().y, 80.0f)));
}

namespace {
// Tick values for a log axis over [lo, hi]: decades, plus 2 and 5 when the
// range spans fewer than three decades.
std::vector<double> logTicks(double lo, double hi) {
  std::vector<double> t;
  const bool fine = hi / lo < 1e3;
  for (double d = std::pow(10.0, std::floor(std::log10(lo))); d <= hi * 1.0001; d *= 10)
    for (double m : {1.0, 2.0, 5.0}) {
      if (m != 1 && !fine) continue;
      double v = d * m;
      if (v >= lo * 0.9999 && v <= hi * 1.0001) t.push_back(v);
    }
  return t;
}
}  // namespace

namespace {
// The error plot's log-log axes: time along x, error along y, over the plot
// area [a, b] on screen.
struct LogAxes {
  ImVec2 a, b;
  double tMin, tMax, eMin, eMax;
  float X(double t) const {
    return a.x + float((std::log(t) - std::log(tMin)) / (std::log(tMax) - std::log(tMin))) * (b.x - a.x);
  }
  float Y(double e) const {
    return b.y - float((std::log(e) - std::log(eMin)) / (std::log(eMax) - std::log(eMin))) * (b.y - a.y);
  }
};

void drawLogTicks(ImDrawList* dl, const LogAxes& ax) {
  // Labelled ticks with faint grid lines.
  char buf[32];
  float lastLabelY = 1e9f;
  for (double v : logTicks(ax.eMin, ax.eMax)) {
    float y = ax.Y(v);
    if (y > lastLabelY - 13) continue;
    lastLabelY = y;
    dl->AddLine(ImVec2(ax.a.x, y), ImVec2(ax.b.x, y), IM_COL32(70, 70, 70, 255));
    std::snprintf(buf, sizeof buf, "%.3g", v);
    dl->AddText(ImVec2(ax.a.x - 6 - ImGui::CalcTextSize(buf).x, y - 7), IM_COL32_WHITE, buf);
  }
  float lastLabelEnd = -1e9f;
  for (double v : logTicks(ax.tMin, ax.tMax)) {
    float x = ax.X(v);
    dl->AddLine(ImVec2(x, ax.a.y), ImVec2(x, ax.b.y), IM_COL32(70, 70, 70, 255));
    std::snprintf(buf, sizeof buf, "%.3g s", v);
    float tw = ImGui::CalcTextSize(buf).x;
    if (x - tw / 2 < lastLabelEnd + 6) continue;  // labels never overlap: skip this one
    dl->AddText(ImVec2(x - tw / 2, ax.b.y + 2), IM_COL32_WHITE, buf);
    lastLabelEnd = x + tw / 2;
  }
}

// Each method's error against its own time, and the legend in the right margin.
void drawErrorSeries(ImDrawList* dl, const LogAxes& ax, const std::vector<ErrorSample>& h) {
  struct Series {
    const char* name;
    ImU32 colour;
    double (*t)(const ErrorSample&);
    double (*v)(const ErrorSample&);
  };
  const Series series[] = {
      {"VSL", IM_COL32(255, 120, 80, 255), [](const ErrorSample& e) { return e.vslSeconds; },
       [](const ErrorSample& e) { return e.vsl; }},
      {"VPL", IM_COL32(90, 160, 255, 255), [](const ErrorSample& e) { return e.vplSeconds; },
       [](const ErrorSample& e) { return e.vpl; }},
      {"PT", IM_COL32(120, 220, 120, 255), [](const ErrorSample& e) { return e.ptSeconds; },
       [](const ErrorSample& e) { return e.pt; }},
  };
  float ly = ax.a.y + 2;
  dl->PushClipRect(ax.a, ax.b, true);
  for (const Series& sr : series) {
    std::vector<ImVec2> pts;
    for (const ErrorSample& e : h)
      if (sr.t(e) > 0 && sr.v(e) > 0) pts.push_back(ImVec2(ax.X(sr.t(e)), ax.Y(sr.v(e))));
    if (pts.size() >= 2) dl->AddPolyline(pts.data(), int(pts.size()), sr.colour, 0, 2.0f);
    for (const ImVec2& q : pts) dl->AddCircleFilled(q, 2.5f, sr.colour);
  }
  dl->PopClipRect();
  // The legend sits in the right margin, outside the curves.
  for (const Series& sr : series) {
    dl->AddText(ImVec2(ax.b.x + 8, ly), sr.colour, sr.name);
    ly += 14;
  }
}
}  // namespace

void Studio::plotErrors(const ImVec2& size) {
  const auto& h = snap_->history;
  ImDrawList* dl = ImGui::GetWindowDrawList();
  ImVec2 p0 = ImGui::GetCursorScreenPos(), p1(p0.x + size.x, p0.y + size.y);
  ImGui::Dummy(size);
  // The title sits above the plot area, never over the curves; the longest
  // form that fits the plot's width (a narrow window cut the long one off).
  const char* title =
      snap_->comparesFull ? "relMSE (full) - ref. noise vs own time" : "relMSE (indirect) - ref. noise vs own time";
  for (const char* shorter : {"relMSE - ref. noise vs own time", "relMSE - noise vs time"})
    if (ImGui::CalcTextSize(title).x > size.x - 8) title = shorter;
  dl->AddText(ImVec2(p0.x + 4, p0.y), IM_COL32(200, 200, 200, 255), title);
  const float titleH = ImGui::GetTextLineHeight() + 4, padL = 56, padB = 18, padR = 56;
  ImVec2 a(p0.x + padL, p0.y + titleH + 4), b(p1.x - padR, p1.y - padB);
  dl->AddRect(ImVec2(a.x, a.y), ImVec2(b.x, b.y), IM_COL32(120, 120, 120, 255));
  if (h.empty() || b.x - a.x < 40 || b.y - a.y < 30) return;
  // Log-log axes over every series' range.
  double tMin = 1e30, tMax = 1e-30, eMin = 1e30, eMax = 1e-30;
  for (const ErrorSample& e : h) {
    for (double t : {e.vslSeconds, e.vplSeconds, e.ptSeconds})
      if (t > 0) {
        tMin = std::min(tMin, t);
        tMax = std::max(tMax, t);
      }
    for (double v : {e.vsl, e.vpl, e.pt})
      if (v > 0) {
        eMin = std::min(eMin, v);
        eMax = std::max(eMax, v);
      }
  }
  if (tMin > tMax || eMin > eMax) return;
  if (!(tMax > tMin * 1.5)) {
    tMin /= 1.5;
    tMax *= 1.5;
  }
  if (!(eMax > eMin * 1.5)) {
    eMin /= 1.5;
    eMax *= 1.5;
  }
  const LogAxes ax{a, b, tMin, tMax, eMin, eMax};
  drawLogTicks(dl, ax);
  // Equal time: the budget every method has reached.
  if (double tb = equalTimeBudget(h); tb > tMin && tb < tMax) {
    float x = ax.X(tb);
    for (float y = a.y; y < b.y; y += 8) dl->AddLine(ImVec2(x, y), ImVec2(x, std::min(y + 4, b.y)), IM_COL32_WHITE);
  }
  drawErrorSeries(dl, ax, h);
}

// ---- [6] Log ---------------------------------------------------------------------------

void Studio::logPanel() {
  std::vector<LogEntry> entries = log::entries();
  ImGui::BeginChild("logscroll");
  size_t start = entries.size() > 300 ? entries.size() - 300 : 0;
  for (size_t i = start; i < entries.size(); ++i) {
    ImVec4 col = entries[i].level >= LogLevel::Error     ? ImVec4(1, 0.4f, 0.4f, 1)
                 : entries[i].level == LogLevel::Warning ? ImVec4(1, 0.85f, 0.3f, 1)
                                                         : ImVec4(0.8f, 0.8f, 0.8f, 1);
    // Wrapped: a long warning ran past the panel's edge on one line.
    ImGui::PushStyleColor(ImGuiCol_Text, col);
    ImGui::TextWrapped("[%s] %s", log::levelName(entries[i].level), entries[i].message.c_str());
    ImGui::PopStyleColor();
  }
  if (ImGui::GetScrollY() >= ImGui::GetScrollMaxY()) ImGui::SetScrollHereY(1.0f);
  ImGui::EndChild();
}

// ---- [8] Crop insets -------------------------------------------------------------------

CropRect CropRect::resolved(int width, int height) const {
  CropRect r = *this;
  if (imageW > 0 && imageH > 0 && (imageW != width || imageH != height)) {
    // Made on an image of another size: the same part of the picture.
    const double sx = double(width) / imageW, sy = double(height) / imageH;
    r.x = int(std::floor(x * sx));
    r.y = int(std::floor(y * sy));
    r.w = std::max(1, int(std::lround(w * sx)));
    r.h = std::max(1, int(std::lround(h * sy)));
  }
  const int x1 = std::min(r.x + r.w, width), y1 = std::min(r.y + r.h, height);
  r.x = std::max(r.x, 0);
  r.y = std::max(r.y, 0);
  r.w = std::max(0, x1 - r.x);
  r.h = std::max(0, y1 - r.y);
  r.imageW = width;
  r.imageH = height;
  return r;
}

Image cropImage(const Image& img, const CropRect& r) {
  Image out(r.w, r.h);
  for (int y = 0; y < r.h; ++y)
    for (int x = 0; x < r.w; ++x) out.set(x, y, img.at(r.x + x, r.y + y));
  return out;
}

int cropMagnification(const CropRect& r) { return std::clamp(256 / std::max({r.w, r.h, 1}), 1, 32); }

std::vector<Studio::CropItem> Studio::buildCrops(const CropRect& rect, Component c, float* errorMax) const {
  std::vector<CropItem> out, maps;
  if (!snap_ || snap_->width == 0) return out;
  const CropRect r = rect.resolved(snap_->width, snap_->height);
  if (r.empty()) return out;
  Image refScratch;
  const Image* ref = referenceImage(c, refScratch);
  CropItem refItem{Source::Reference, false, cropImage(*ref, r), false, {}};
  out.push_back(refItem);
  // Each method's crop against the reference's crop; its error map is cut
  // from the full map, whose 99th percentile sets the shared colour scale
  // (as in the exported full-size maps).
  float autoMax = 0;
  for (Source m : kMetricSources) {
    if (!hasPicture(m, c)) continue;  // nothing to crop (MRCS)
    Image scratch;
    const Image* img = componentImage(m, c, scratch);
    CropItem item{m, false, cropImage(*img, r), true, {}};
    item.metrics = compareImages(item.image, refItem.image);
    Image full = errorMap(*img, *ref, view_.metric);
    autoMax = std::max(autoMax, percentile99(full));
    maps.push_back({m, true, cropImage(full, r), true, item.metrics});
    out.push_back(std::move(item));
  }
  if (errorMax) *errorMax = view_.errorScale > 0 ? view_.errorScale : autoMax > 0 ? autoMax : 1.0f;
  for (CropItem& m : maps) out.push_back(std::move(m));
  return out;
}

void Studio::updateCrops() {
  if (cropDragging_) return;  // rebuilt once the rectangle is let go
  const bool same = cropsFor_ == snap_.get() && cropsView_.component == view_.component &&
                    cropsView_.metric == view_.metric && cropsView_.errorScale == view_.errorScale &&
                    cropsView_.crop == view_.crop;
  if (same) return;
  cropsFor_ = snap_.get();
  cropsView_ = view_;
  crops_ = buildCrops(view_.crop, view_.component, &cropErrorMax_);
  for (size_t i = 0; i < crops_.size() && i < std::size(cropTextures_); ++i) cropTextures_[i].upload(crops_[i].image);
}

// The crop rectangle on every drawn image (clipped to it).
void Studio::drawCropOutline(ImDrawList* dl) {
  if (view_.crop.empty() || !snap_) return;
  const CropRect r = view_.crop.resolved(snap_->width, snap_->height);
  if (r.empty()) return;
  for (const DrawnImage& d : drawn_) {
    auto screen = [&](float px, float py) {
      float u = px / float(snap_->width), v = py / float(snap_->height);
      return ImVec2(d.p0.x + (u - d.uv0.x) / (d.uv1.x - d.uv0.x) * (d.p1.x - d.p0.x),
                    d.p0.y + (v - d.uv0.y) / (d.uv1.y - d.uv0.y) * (d.p1.y - d.p0.y));
    };
    dl->PushClipRect(d.p0, d.p1, true);
    dl->AddRect(screen(float(r.x), float(r.y)), screen(float(r.x + r.w), float(r.y + r.h)), IM_COL32(255, 210, 0, 255),
                0, 0, 2.0f);
    dl->PopClipRect();
  }
}

// Every image's crop, magnified to a common height, with its metrics: the
// relMSE of the method's crop against the reference's crop.
void Studio::cropsPanel() {
  updateCrops();
  if (view_.crop.empty() || crops_.empty()) {
    ImGui::TextWrapped(
        "No crop inset yet. Shift+drag a rectangle on an image (or tick \"crop tool\" under View and drag): every "
        "image and error map is shown here magnified, with the crop's own metrics, and exports include the crops "
        "and a crop figure. Shift+click clears it.");
    return;
  }
  const CropRect r = view_.crop.resolved(snap_->width, snap_->height);
  ImGui::Text("crop x %d  y %d  %d x %d px of %d x %d  |  %s component  |  exports magnify %dx", r.x, r.y, r.w, r.h,
              snap_->width, snap_->height, componentName(view_.component), cropMagnification(r));
  ImGui::SameLine();
  if (ImGui::SmallButton("Clear crop")) {
    view_.crop = {};
    return;
  }
  ImGui::BeginChild("cropstrip", ImVec2(0, 0), false, ImGuiWindowFlags_HorizontalScrollbar);
  const float line = ImGui::GetTextLineHeightWithSpacing();
  // As tall as the tab allows, narrow enough that every tile fits across
  // (a scroll bar only when that would make them smaller than 64 px).
  const float gap = 10, n = float(std::min(crops_.size(), std::size(cropTextures_)));
  const float aspect = float(r.w) / float(r.h);
  float th = std::max(48.0f, ImGui::GetContentRegionAvail().y - 2 * line - 14);
  float tw = std::min({th * aspect, 260.0f, (ImGui::GetContentRegionAvail().x - gap * (n - 1)) / n});
  tw = std::max(tw, std::min(64.0f, th * aspect));
  th = tw / aspect;
  for (size_t i = 0; i < crops_.size() && i < std::size(cropTextures_); ++i) {
    const CropItem& c = crops_[i];
    if (i > 0) ImGui::SameLine(0, gap);
    ImGui::BeginGroup();
    // The title is clipped to the tile (the full name in a tooltip).
    std::string title = c.error ? std::string("error ") + sourceName(c.source) : sourceName(c.source);
    ImVec2 p = ImGui::GetCursorScreenPos();
    const ImVec4 clip(p.x, p.y, p.x + tw, p.y + line);
    ImGui::GetWindowDrawList()->AddText(ImGui::GetFont(), ImGui::GetFontSize(), p, ImGui::GetColorU32(ImGuiCol_Text),
                                        title.c_str(), nullptr, 0.0f, &clip);
    ImGui::Dummy(ImVec2(tw, ImGui::GetTextLineHeight()));
    if (ImGui::IsItemHovered()) tip("%s", title.c_str());
    p = ImGui::GetCursorScreenPos();
    DisplayParams dp;
    if (c.error) {
      dp.mode = DisplayMode::FalseColour;
      dp.scale = 1.0f / std::max(cropErrorMax_, 1e-12f);
    } else {
      dp.scale = std::exp2(view_.exposure);
    }
    drawImage(ImGui::GetWindowDrawList(), cropTextures_[i], p, ImVec2(p.x + tw, p.y + th), ImVec2(0, 0), ImVec2(1, 1),
              dp);
    ImGui::Dummy(ImVec2(tw, th));
    if (c.error) {
      ImGui::TextDisabled("0 .. %.3g", cropErrorMax_);
      if (ImGui::IsItemHovered())
        tip("%s per pixel; the colour map's range (shared by every error map)", kMetricNames[int(view_.metric)]);
    } else if (c.hasMetrics) {
      ImGui::Text("relMSE %.3g", c.metrics.average.relMse);
      if (ImGui::IsItemHovered())
        tip("This crop against the reference's crop (%s, eps %.2g):\nmean %.5g (reference %.5g)\nRMSE "
            "%.4g\nMAE %.4g\nbias %+.4g",
            componentName(view_.component), c.metrics.epsilon, c.metrics.average.meanTest, c.metrics.average.meanRef,
            c.metrics.average.rmse, c.metrics.average.mae, c.metrics.average.bias);
    } else {
      ImGui::Text("mean %.3g", crops_[1].metrics.average.meanRef);
    }
    ImGui::EndGroup();
  }
  ImGui::EndChild();
}

}  // namespace vsl::ui

namespace vsl::ui {

// ---- [9] The last session ---------------------------------------------------------------

std::string lastSessionPath() {
  std::filesystem::path base;
  // The XDG spec: a relative XDG_CONFIG_HOME is invalid and ignored.
  const char* xdg = std::getenv("XDG_CONFIG_HOME");
  const char* home = std::getenv("HOME");
  if (xdg && *xdg && std::filesystem::path(xdg).is_absolute())
    base = xdg;
  else if (home && *home)
    base = std::filesystem::path(home) / ".config";
  else
    return "";
  return (base / "vsl-studio" / "last-session.json").string();
}

Result<void> saveLastSession(const std::string& path, const StudioSettings& s, const ViewState& v) {
  // The methods' parameters under their registry keys (core/params_json.h),
  // then what is not a parameter.
  nlohmann::json settings = paramsToJson(manyLightParams(), s.many);
  settings.update({{"seed", s.many.seed},
                   {"width", s.many.width},
                   {"height", s.many.height},
                   {"maxReferenceSpp", s.maxReferenceSpp},
                   {"lightSets", s.lightSets},
                   {"estimator", s.estimator.name},
                   {"progressiveRadius", s.estimator.progressiveRadius},
                   {"progressiveAlpha", s.estimator.alpha}});
  nlohmann::json j = {{"version", kLastSessionVersion},
                      {"scene", std::filesystem::absolute(s.scene).lexically_normal().string()},
                      {"settings", settings},
                      {"view",
                       {{"mode", int(v.mode)},
                        {"panels", {int(v.panels[0]), int(v.panels[1]), int(v.panels[2])}},
                        {"component", int(v.component)},
                        {"display", int(v.display)},
                        {"metric", int(v.metric)},
                        {"exposure", v.exposure},
                        {"toneMap", int(v.toneMap)},
                        {"errorScale", v.errorScale}}}};
  // Every registered estimator's parameters under their keys, the chosen
  // one's and the others' (the studio keeps them while another is chosen).
  j["settings"].update(paramsToJson(estimatorParams(), s.estimator));
  const EnvironmentSettings& e = s.env;
  j["settings"]["environment"] = {{"map", e.map},
                                  {"scale", e.scale},
                                  {"sky", {e.sky.x, e.sky.y, e.sky.z}},
                                  {"sun", {e.sunDirection.x, e.sunDirection.y, e.sunDirection.z}},
                                  {"sunDiameter", e.sunDiameterDeg},
                                  {"sunIrradiance", e.sunIrradiance}};
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
  if (ec)
    return Error(std::filesystem::path(path).parent_path().string() + ": cannot create the directory (" + ec.message() +
                 ")");
  return writeTextFile(path, j.dump(2) + "\n");
}

namespace {
// Reads key into *out when present; a value of the wrong type throws.
template <typename T>
void readField(const nlohmann::json& j, const char* key, T* out) {
  if (j.contains(key)) *out = j.at(key).get<T>();
}
template <typename E>
void readEnum(const nlohmann::json& j, const char* key, E* out, int count) {
  int v = int(*out);
  readField(j, key, &v);
  if (v < 0 || v >= count) throw std::out_of_range(std::string(key) + " out of range");
  *out = E(v);
}

// The scene and the "settings" object of a last-session file j into s. A
// value of the wrong type throws.
void readSettings(const nlohmann::json& j, StudioSettings& s) {
  readField(j, "scene", &s.scene);
  const nlohmann::json& js = j.contains("settings") ? j.at("settings") : nlohmann::json::object();
  ManyLightSettings& m = s.many;
  readField(js, "seed", &m.seed);
  readField(js, "width", &m.width);
  readField(js, "height", &m.height);
  // Version 1 files were written while the floor was off by default: their
  // 0 is that default, not a choice, and gives way to today's.
  int version = 1;
  readField(j, "version", &version);
  const float lobeFloor = m.lobeFloor;
  if (Result<void> r = paramsFromJson(manyLightParams(), js, m); !r) throw std::out_of_range(r.error());
  if (version < 2 && m.lobeFloor == 0) m.lobeFloor = lobeFloor;
  readField(js, "maxReferenceSpp", &s.maxReferenceSpp);
  readField(js, "lightSets", &s.lightSets);
  if (js.contains("estimator")) {  // an estimator this version does not have: the default
    const std::string name = js.at("estimator").get<std::string>();
    s.estimator.name = findEstimator(name) ? name : EstimatorSettings::kDefaultName;
  }
  // Every registered estimator's parameters under their keys (version 2's
  // mrcsRows and mrcsClusters among them).
  if (Result<void> r = paramsFromJson(estimatorParams(), js, s.estimator); !r) throw std::out_of_range(r.error());
  readField(js, "progressiveRadius", &s.estimator.progressiveRadius);
  readField(js, "progressiveAlpha", &s.estimator.alpha);
  if (js.contains("environment")) {  // the environment light (none before it was saved)
    const nlohmann::json& je = js.at("environment");
    EnvironmentSettings& e = s.env;
    readField(je, "map", &e.map);
    readField(je, "scale", &e.scale);
    std::array<float, 3> sky{e.sky.x, e.sky.y, e.sky.z}, sun{e.sunDirection.x, e.sunDirection.y, e.sunDirection.z};
    readField(je, "sky", &sky);
    readField(je, "sun", &sun);
    e.sky = Vec3(sky[0], sky[1], sky[2]);
    e.sunDirection = Vec3(sun[0], sun[1], sun[2]);
    readField(je, "sunDiameter", &e.sunDiameterDeg);
    readField(je, "sunIrradiance", &e.sunIrradiance);
    if (Result<void> r = e.validate(); !r) throw std::out_of_range(r.error());
  }
}

// The "view" object of a last-session file into v. A value of the wrong type
// or out of range throws.
void readView(const nlohmann::json& jv, ViewState& v) {
  readEnum(jv, "mode", &v.mode, 4);
  readEnum(jv, "component", &v.component, 3);
  readEnum(jv, "display", &v.display, 4);
  readEnum(jv, "metric", &v.metric, 4);
  readEnum(jv, "toneMap", &v.toneMap, 3);
  readField(jv, "exposure", &v.exposure);
  readField(jv, "errorScale", &v.errorScale);
  if (jv.contains("panels")) {
    const nlohmann::json& p = jv.at("panels");
    if (!p.is_array() || p.size() != 3) throw std::out_of_range("panels must be three images");
    for (int i = 0; i < 3; ++i) {
      int k = p.at(size_t(i)).get<int>();
      if (k < 0 || k >= int(Source::Count)) throw std::out_of_range("panels out of range");
      v.panels[i] = Source(k);
    }
  }
  if (!std::isfinite(v.exposure) || !std::isfinite(v.errorScale))
    throw std::out_of_range("exposure and map maximum must be finite");
}
}  // namespace

bool loadLastSession(const std::string& path, StudioSettings* settings, ViewState* view, std::string* warning) {
  warning->clear();
  std::error_code ec;
  if (path.empty() || !std::filesystem::exists(path, ec)) return false;
  auto refuse = [&](const std::string& why) {
    *warning = path + ": " + why + "; starting with the defaults";
    return false;
  };
  if (!std::filesystem::is_regular_file(path, ec)) return refuse("not a regular file");
  if (std::filesystem::file_size(path, ec) > (1 << 20)) return refuse("larger than 1 MiB");
  std::ifstream in(path, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) return refuse("cannot be read");
  nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return refuse("not a valid last-session file (corrupt JSON)");
  StudioSettings s = *settings;
  ViewState v = *view;
  try {
    readSettings(j, s);
    if (j.contains("view")) readView(j.at("view"), v);
  } catch (const std::exception& e) {
    return refuse(std::string("a value of the wrong type or out of range (") + e.what() + ")");
  }
  if (std::string e = s.validate().error(); !e.empty()) return refuse("invalid settings (" + e + ")");
  *settings = s;
  *view = v;
  return true;
}

}  // namespace vsl::ui
