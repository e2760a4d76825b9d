// The studio's exports: the shown view as PNG, and exportAll's folder (EXR
// layers, PNGs, error and FLIP maps, crops, metrics.json).
// Sections: [1] saving the view  [2] helpers  [3] exportAll and its parts
//           [4] crop files and figure
#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <thread>
#include <utility>

#include <imgui.h>

#include "core/estimator_json.h"
#include "core/flip.h"
#include "core/image_io.h"
#include "core/log.h"
#include "core/memory_budget.h"
#include "core/parallel.h"
#include "core/params_json.h"
#include "core/presets.h"
#include "ui/headless_gl.h"
#include "ui/studio.h"
#include "ui/studio_internal.h"

namespace vsl::ui {

namespace studio_detail {

Image errorMap(const Image& test, const Image& ref, ErrorMetric metric) {
  Image m(test.width, test.height);
  const float eps = mapEpsilon(ref);
  for (size_t i = 0; i + 2 < test.rgb.size(); i += 3) {
    float e = 0;
    for (int c = 0; c < 3; ++c) {
      float r = ref.rgb[i + c], d = test.rgb[i + c] - r;
      float v = metricError(d, r, metric, eps);
      e += std::isfinite(v) ? v / 3 : 0.0f;
    }
    m.rgb[i] = m.rgb[i + 1] = m.rgb[i + 2] = e;
  }
  return m;
}

}  // namespace studio_detail

using namespace studio_detail;

// ---- [1] Saving the view -------------------------------------------------------------

void Studio::afterRender(int fbWidth, int fbHeight) {
  if (!savePngPending_) return;
  savePngPending_ = false;
  // The panels as drawn (titles, images, legend), not the empty room around them.
  int x0 = std::max(0, int(std::floor(panelsMin_.x))), y0 = std::max(0, int(std::floor(panelsMin_.y)));
  int x1 = std::min(fbWidth, int(std::ceil(panelsMax_.x))), y1 = std::min(fbHeight, int(std::ceil(panelsMax_.y)));
  if (x1 <= x0 || y1 <= y0) return;
  std::vector<uint8_t> px = readFramebuffer(x0, y0, x1 - x0, y1 - y0, fbHeight);
  if (Result<void> saved = writePngRgb8(savePngPath_, x1 - x0, y1 - y0, px)) {
    messagePath_ = savePngPath_;
    message_ = "wrote " + savePngPath_;
    log::info(message_);
  } else {
    errorDialog_ = "Saving the view failed; existing files are untouched.\n\n" + saved.error();
  }
}

// ---- [2] Helpers ---------------------------------------------------------------------

namespace {

const char* kMetricSlugs[] = {"abs", "relabs", "sq", "relsq"};

// 8-bit RGB pixels of an image as the view's tone map shows it
// (toneMapPixel; the linear one through toSrgb8, byte for byte as writePng).
std::vector<uint8_t> toneMappedBytes(const Image& img, float exposure, ToneMap t) {
  std::vector<uint8_t> px(size_t(img.width) * img.height * 3);
  const float s = std::exp2(exposure);
  for (size_t i = 0; i < px.size(); ++i) {
    if (t == ToneMap::Linear) {
      px[i] = toSrgb8(img.rgb[i] * s);
      continue;
    }
    if (i % 3) continue;
    const Vec3 c = toneMapPixel(Vec3(img.rgb[i], img.rgb[i + 1], img.rgb[i + 2]), exposure, t);
    for (int k = 0; k < 3; ++k) px[i + k] = uint8_t(std::clamp(c[k], 0.0f, 1.0f) * 255 + 0.5f);
  }
  return px;
}

// ---- Labelled colour bars (issue 49, item 6: labels of 5 px that did not
// name the metric). Their text is the studio's own font, ImGui's default
// (ProggyClean, a 13-px bitmap font), from its font atlas, every pixel drawn
// as kLabelScale x kLabelScale (digits 16 px tall, '|' 24 px); without an
// ImGui context the bar has no labels.
constexpr int kLabelScale = 2;

const ImFont* labelFont() {
  if (!ImGui::GetCurrentContext() || ImGui::GetIO().Fonts->Fonts.empty()) return nullptr;
  return ImGui::GetIO().Fonts->Fonts[0];
}

int labelWidth(const std::string& t) {
  const ImFont* font = labelFont();
  float x = 0;
  for (char c : t)
    if (const ImFontGlyph* g = font ? font->FindGlyph(ImWchar(c)) : nullptr) x += g->AdvanceX;
  return int(std::ceil(x)) * kLabelScale;
}

int labelLineHeight() { return labelFont() ? kLabelScale * int(std::ceil(labelFont()->FontSize)) + 2 : 0; }

// Draws t with its top-left corner at (x, y) in light grey over the pixels
// (w wide, h tall), clipped to them.
void drawLabel(std::vector<uint8_t>& px, int w, int h, int x, int y, const std::string& t) {
  const ImFont* font = labelFont();
  if (!font) return;
  unsigned char* atlas = nullptr;
  int aw = 0, ah = 0;
  ImGui::GetIO().Fonts->GetTexDataAsRGBA32(&atlas, &aw, &ah);
  float pen = 0;  // in font pixels
  for (char c : t) {
    const ImFontGlyph* g = font->FindGlyph(ImWchar(c));
    if (!g) continue;
    const int gw = int(std::lround((g->U1 - g->U0) * aw)), gh = int(std::lround((g->V1 - g->V0) * ah));
    const int u0 = int(std::lround(g->U0 * aw)), v0 = int(std::lround(g->V0 * ah));
    for (int gy = 0; gy < gh * kLabelScale; ++gy)
      for (int gx = 0; gx < gw * kLabelScale; ++gx) {
        const int X = x + int(pen + g->X0) * kLabelScale + gx, Y = y + int(g->Y0) * kLabelScale + gy;
        const int a = atlas[(size_t(v0 + gy / kLabelScale) * aw + size_t(u0 + gx / kLabelScale)) * 4 + 3];
        if (X < 0 || X >= w || Y < 0 || Y >= h || a == 0) continue;
        uint8_t* q = &px[(size_t(Y) * w + X) * 3];
        for (int k = 0; k < 3; ++k) q[k] = uint8_t(q[k] + (235 - q[k]) * a / 255);
      }
    pen += g->AdvanceX;
  }
}

// The words of t in lines no wider than w pixels (a longer word alone).
std::vector<std::string> wrapLabel(const std::string& t, int w) {
  std::vector<std::string> lines(1);
  size_t a = 0;
  while (a < t.size()) {
    size_t b = t.find(' ', a);
    if (b == std::string::npos) b = t.size();
    const std::string word = t.substr(a, b - a);
    const std::string longer = lines.back().empty() ? word : lines.back() + " " + word;
    if (!lines.back().empty() && labelWidth(longer) > w)
      lines.push_back(word);
    else
      lines.back() = longer;
    a = b + 1;
  }
  return lines;
}

// Appends under w x h pixels a colour bar: a dark gap of 4 rows, the ramp's
// 12, then lo at the left and hi at the right, then the name (the metric and
// its units) wrapped to the width. Returns the new height.
int appendLabelledBar(std::vector<uint8_t>& px, int w, int h, Vec3 (*colour)(float), const std::string& lo,
                      const std::string& hi, const std::string& name) {
  const std::vector<std::string> lines = wrapLabel(name, w - 2);
  const int line = labelLineHeight(), rows = h + 4 + 12 + 2 + line * int(1 + lines.size()) + 2;
  px.resize(size_t(w) * rows * 3, 20);
  for (int y = h + 4; y < h + 16; ++y)
    for (int x = 0; x < w; ++x) {
      const Vec3 c = colour((x + 0.5f) / float(w));
      uint8_t* q = &px[(size_t(y) * w + x) * 3];
      for (int k = 0; k < 3; ++k) q[k] = uint8_t(std::clamp(c[k], 0.0f, 1.0f) * 255 + 0.5f);
    }
  const int y = h + 18;
  drawLabel(px, w, rows, 1, y, lo);
  if (labelWidth(lo) + labelWidth(hi) + 8 <= w) drawLabel(px, w, rows, w - 1 - labelWidth(hi), y, hi);
  for (size_t i = 0; i < lines.size(); ++i) drawLabel(px, w, rows, 1, y + line * int(i + 1), lines[i]);
  return rows;
}

std::string numberLabel(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// A map (values in the R channel, as errorMap and FLIP make them) through a
// colour ramp over [0, vmax], with its labelled bar below.
std::vector<uint8_t> mapWithBar(const Image& map, Vec3 (*colour)(float), float vmax, const std::string& name,
                                int* rows) {
  std::vector<uint8_t> px(size_t(map.width) * map.height * 3);
  const float scale = 1.0f / std::max(vmax, 1e-12f);
  for (size_t i = 0; i < px.size(); i += 3) {
    const Vec3 c = colour(map.rgb[i] * scale);
    for (int k = 0; k < 3; ++k) px[i + k] = uint8_t(std::clamp(c[k], 0.0f, 1.0f) * 255 + 0.5f);
  }
  *rows = appendLabelledBar(px, map.width, map.height, colour, "0", numberLabel(vmax), name);
  return px;
}

std::string firstLineOf(const char* path, const std::string& key) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(key, 0) == 0) {
      size_t c = line.find(':');
      std::string v = c == std::string::npos ? line : line.substr(c + 1);
      v.erase(0, v.find_first_not_of(" \t"));
      return v;
    }
  return "";
}

nlohmann::json machineJson() {
  return {{"cpu", firstLineOf("/proc/cpuinfo", "model name")},
          {"hardwareThreads", std::thread::hardware_concurrency()},
          {"renderThreads", threadCount()},
          {"memory", firstLineOf("/proc/meminfo", "MemTotal")}};
}

std::string utcStamp() {
  std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%SZ", &tm);
  return buf;
}

}  // namespace

std::string Studio::exportStem() const {
  std::string scene = snap_ ? snap_->settings.scene : settings_.scene;
  return std::filesystem::path(scene).stem().string() + "-" + utcStamp();
}

std::string Studio::uniquePath(const std::string& dir, const std::string& stem, const std::string& ext) {
  std::filesystem::path p = std::filesystem::path(dir) / (stem + ext);
  for (int k = 2; std::filesystem::exists(p); ++k)
    p = std::filesystem::path(dir) / (stem + "-" + std::to_string(k) + ext);
  return p.string();
}

// ---- [3] exportAll and its parts -------------------------------------------------------

namespace {

// A word for a POSIX shell: as it is if it holds only safe characters, else
// in single quotes (a quote inside as '\'').
std::string shellWord(const std::string& w) {
  const bool safe = !w.empty() && w.find_first_not_of(
                                      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
                                      "0123456789_-+./=:,@%") == std::string::npos;
  if (safe) return w;
  std::string q = "'";
  for (char c : w) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// A new folder per export under dir; create_directory fails if it exists, so
// two exports in the same second (or two studios) never share one.
Result<std::filesystem::path> makeExportFolder(const std::string& dir, const std::string& stem) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Error(dir + ": cannot create the directory (" + ec.message() + ")");
  std::filesystem::path folder;
  for (int k = 1;; ++k) {
    folder = std::filesystem::path(dir) / (k == 1 ? stem : stem + "-" + std::to_string(k));
    if (std::filesystem::create_directory(folder, ec)) break;
    if (ec) return Error(folder.string() + ": cannot create the directory (" + ec.message() + ")");
    if (k > 1000) return Error(folder.string() + ": too many exports with this name");
  }
  return folder;
}

// Every layer the snapshot holds, linear, in one EXR: not the layers MRCS
// never renders, nor clamped VPL's while its columns are pending
// (snapshotHasPicture), which would be black.
Result<void> writeLayersExr(const Snapshot& s, const std::string& path) {
  Image ptFull = add(s.ptDirect, s.ptIndirect), vslFull = add(s.many.direct, s.many.vsl);
  // The error layers are of the component compared (Snapshot::comparesFull).
  const Image refFull = add(s.refDirect, s.refIndirect);
  const Image& ref = s.comparesFull ? refFull : s.refIndirect;
  ErrorImages ev = errorImages(comparedImage(s, s.many.direct, s.many.vsl), ref);
  std::vector<Layer> layers = {{"", vslFull},
                               {"vsl-full", vslFull},
                               {"vsl-indirect", s.many.vsl},
                               {"direct", s.many.direct},
                               {"pt-full", ptFull},
                               {"pt-direct", s.ptDirect},
                               {"pt-indirect", s.ptIndirect},
                               {"reference-full", refFull},
                               {"reference-indirect", s.refIndirect},
                               {"error-vsl-signed", ev.signedDiff},
                               {"error-vsl-relsq", ev.relSquared}};
  auto has = [&](Source src) { return snapshotHasPicture(s, src, Component::Indirect); };
  if (has(Source::Vpl)) {
    ErrorImages ep = errorImages(comparedImage(s, s.many.direct, s.many.vpl), ref);
    layers.insert(layers.end(), {{"vpl-full", add(s.many.direct, s.many.vpl)},
                                 {"vpl-indirect", s.many.vpl},
                                 {"error-vpl-signed", ep.signedDiff},
                                 {"error-vpl-relsq", ep.relSquared}});
  }
  const std::pair<Source, Layer> variants[] = {{Source::VplUnclamped, {"vpl-unclamped-indirect", s.many.vplUnclamped}},
                                               {Source::VplDiffuse, {"vpl-diffuse-indirect", s.many.vplDiffuse}},
                                               {Source::LostClamping, {"lost-to-clamping", s.many.lostToClamping}},
                                               {Source::LostDiffuse, {"lost-to-diffuse", s.many.lostToDiffuse}}};
  for (const auto& [src, layer] : variants)
    if (has(src)) layers.push_back(layer);
  return writeExr(path, layers,
                  {{"vsl.version", VSL_VERSION},
                   {"vsl.scene", s.settings.scene},
                   {"vsl.settings", s.settings.many.describe()},
                   {"vsl.estimator", s.settings.estimator.describe()}});
}

const char* comparedName(const Snapshot& s) { return componentName(comparedComponent(s)); }

nlohmann::json finiteOrNull(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json historyJson(const std::vector<ErrorSample>& history) {
  nlohmann::json hist = nlohmann::json::array();
  for (const ErrorSample& e : history)
    hist.push_back({{"manySeconds", e.manySeconds},
                    {"vslSeconds", e.vslSeconds},
                    {"vplSeconds", e.vplSeconds},
                    {"vsl", e.vsl},
                    {"vpl", e.vpl},
                    {"ptSeconds", e.ptSeconds},
                    {"pt", e.pt},
                    {"referenceNoiseSubtracted", e.referenceNoise},
                    {"lightSetsDone", e.lightSetsDone},
                    {"vslSetVariance", e.vslSetVariance},
                    {"vplSetVariance", e.vplSetVariance}});
  return hist;
}

// The reference every number is measured against, and its own noise.
nlohmann::json referenceJson(const Snapshot& s) {
  return {{"source", s.referenceSource},
          {"converged", s.convergedReference},
          {"spp", s.referenceSpp},
          {"component", comparedName(s)},
          {std::string(comparedName(s)) + "NoiseRelMSE",
           s.referenceNoise >= 0 ? nlohmann::json(s.referenceNoise) : nlohmann::json(nullptr)},
          {"noiseEstimate", "relMSE(A, B) / 4 from two independent halves; subtracted from errorHistory"},
          {"livePathTracerSpp", s.ptSpp}};
}

nlohmann::json equalTimeJson(const Snapshot& s) {
  const double budget = equalTimeBudget(s.history);
  return {{"budgetSeconds", budget},
          {"vsl", finiteOrNull(errorAtOwnTime(s.history, StudioMethod::Vsl, budget))},
          {"vpl", finiteOrNull(errorAtOwnTime(s.history, StudioMethod::Vpl, budget))},
          {"pt", finiteOrNull(errorAtOwnTime(s.history, StudioMethod::Pt, budget))}};
}

// Bias against noise of each method's indirect image (session.h,
// BiasNoise), where measured: null for a method with fewer than two
// independent estimates.
nlohmann::json biasNoiseJson(const Snapshot& s) {
  nlohmann::json biasNoise = {
      {"definition",
       "compare.h biasVariance over K independent estimates (light sets; the path tracer's two halves) against the "
       "reference: bias2 = mean(w ((m - ref)^2 - s^2/K)), variance = mean(w s^2) of one estimate, relMSE of their "
       "mean; w = 1/(ref^2 + eps), the component compared"},
      {"component", comparedName(s)},
      {"referenceNoise", s.referenceNoise >= 0 ? nlohmann::json(s.referenceNoise) : nlohmann::json(nullptr)},
      {"lightSetsDone", s.lightSetsDone}};
  const char* biasRows[] = {"VSL", "VPL (clamped)", "VPL unclamped", "VPL diffuse-only", "Path tracer (live)"};
  // The rows' sources; the live path tracer is always rendered.
  const Source rowSources[] = {Source::Vsl, Source::Vpl, Source::VplUnclamped, Source::VplDiffuse, Source::Reference};
  static_assert(std::size(rowSources) == size_t(BiasNoiseRow::Count), "a source per row");
  for (int i = 0; i < int(BiasNoiseRow::Count); ++i) {
    const BiasNoise& b = s.biasNoise[i];
    biasNoise["methods"][biasRows[i]] =
        b.renders < 2 || !snapshotHasPicture(s, rowSources[i], Component::Indirect)
            ? nlohmann::json(nullptr)
            : nlohmann::json(
                  {{"renders", b.renders},
                   {"bias2", b.bias2},
                   {"variance", b.variance},
                   {"relMSE", b.relMse},
                   {"bias2MinusReferenceNoise",
                    s.referenceNoise >= 0 ? nlohmann::json(b.bias2 - s.referenceNoise) : nlohmann::json(nullptr)}});
  }
  return biasNoise;
}

// The many-light estimator (estimator_registry.h): its name, its parameters
// as resolved (defaults included) and its statistics (the newest light
// set's, Snapshot::estimatorStats).
nlohmann::json estimatorJson(const EstimatorSettings& e, const std::vector<std::pair<std::string, double>>& stats) {
  nlohmann::json j = {{"name", e.name},
                      {"describe", e.describe()},
                      {"parameters", estimatorValuesJson(e)},
                      {"seed", "per light set: seed + set"},
                      {"statistics", estimatorStatsJson(stats)}};
  j["progressiveRadius"] = e.progressiveRadius ? nlohmann::json({{"alpha", e.alpha}}) : nlohmann::json(nullptr);
  return j;
}

// The render's settings: the preset, every registered parameter under its
// key (core/params_json.h), what the render resolved them to (the radii,
// the clamp's bound, VSL's samples per pair, the pairs the roulette
// dropped), and the settings that are not parameters.
nlohmann::json settingsJson(const Snapshot& s) {
  const ManyLightSettings& m = s.settings.many;
  nlohmann::json j = paramsToJson(manyLightParams(), m);
  nlohmann::json resolved = {
      {"radius",
       {{"mode", m.globalRadius > 0 ? "global" : "knn"},
        {"sceneRadius", s.sceneRadius},
        {"min", s.radiusMin},
        {"median", s.radiusMedian},
        {"max", s.radiusMax}}},
      {"clampBound", std::isinf(m.clamp) ? nlohmann::json(nullptr) : nlohmann::json(s.clampBound)},
      {"vslSamplesPerPair", s.pairs ? double(s.vslEvaluations) / double(s.pairs) : 0.0},
      {"pairsDropped", s.rouletteDropped},
      {"directSamplesPerLightSet", s.directSamplesPerSet}};
  j.update({{"preset", matchingPreset(m)},
            {"resolved", resolved},
            {"seed", m.seed},
            {"maxReferenceSpp", s.settings.maxReferenceSpp},
            {"lightSets", s.settings.lightSets},
            {"estimator", estimatorJson(s.settings.estimator, s.estimatorStats)}});
  return j;
}

// How far the render got, and what it took. lightsPlanned counts every light
// set's lights, the sets not yet traced included.
nlohmann::json samplesJson(const Snapshot& s) {
  return {{"lightSetsDone", s.lightSetsDone},  {"lightSets", s.lightSets},
          {"lightsPlanned", s.lightsTotal},    {"lightsGathered", s.lightsProcessed},
          {"batchesDone", s.batchesDone},      {"batchCount", s.batchCount},
          {"referenceSpp", s.ptSpp},           {"pairs", s.pairs},
          {"vslEvaluations", s.vslEvaluations}};
}

nlohmann::json timingsJson(const Snapshot& s) {
  return {{"wallSeconds", s.seconds},
          {"lightTracingSeconds", s.lightTracingSeconds},
          {"knnSeconds", s.knnSeconds},
          {"gatherSeconds", s.gatherSeconds},
          {"vslOwnSeconds", s.vslSeconds},
          {"vplOwnSeconds", s.vplSeconds},
          {"referenceSeconds", s.referenceSeconds},
          {"pairsPerSecond", s.pairsPerSecond}};
}

}  // namespace

// Every image at the render's resolution, the shown component and exposure,
// then the error maps of each method on one shared scale (set by hand, or the
// largest 99th percentile), with a colour bar. Returns that scale.
Result<float> Studio::exportPictures(const std::string& folder, std::vector<std::string>* files) const {
  auto path = [&](const std::string& name) { return (std::filesystem::path(folder) / name).string(); };
  const char* comp = componentName(view_.component);
  for (int i = 0; i < int(Source::Count); ++i) {
    if (!hasPicture(Source(i), view_.component)) continue;  // never rendered, or pending: not a black PNG
    Image scratch;
    const Image* img = componentImage(Source(i), view_.component, scratch);
    std::string name = sourceSlug(Source(i)) + "-" + comp + ".png";
    std::vector<uint8_t> px = toneMappedBytes(*img, view_.exposure, view_.toneMap);
    int rows = img->height;
    if (view_.toneMap == ToneMap::FalseColour) {
      const double s = std::exp2(-view_.exposure);
      rows = appendLabelledBar(
          px, img->width, img->height, falseColour, numberLabel(s * std::pow(10.0, kFalseColourDecades[0])),
          numberLabel(s * std::pow(10.0, kFalseColourDecades[1])), "luminance (Rec. 709, log scale, radiance)");
    }
    if (Result<void> w = writePngRgb8(path(name), img->width, rows, px); !w) return Error(w.error());
    files->push_back(path(name));
  }
  Image refScratch;
  const Image* ref = referenceImage(view_.component, refScratch);
  std::vector<Image> maps;
  std::vector<Source> mapped;  // the methods with a picture in this component
  float vmax = view_.errorScale, autoMax = 0;
  for (Source m : kMetricSources) {
    if (!hasPicture(m, view_.component)) continue;
    Image scratch;
    maps.push_back(errorMap(*componentImage(m, view_.component, scratch), *ref, view_.metric));
    mapped.push_back(m);
    autoMax = std::max(autoMax, percentile99(maps.back()));
  }
  if (!(vmax > 0)) vmax = autoMax > 0 ? autoMax : 1.0f;
  for (size_t i = 0; i < maps.size(); ++i) {
    int rows = 0;
    std::vector<uint8_t> px = mapWithBar(maps[i], falseColour, vmax, metricLabel(view_.metric), &rows);
    std::string name = "error-" + sourceSlug(mapped[i]) + "-" + kMetricSlugs[int(view_.metric)] + "-" + comp + ".png";
    if (Result<void> w = writePngRgb8(path(name), snap_->width, rows, px); !w) return Error(w.error());
    files->push_back(path(name));
  }
  return vmax;
}

// FLIP maps through magma with a bar: the asynchronous ones when they
// belong to this picture, component and exposure, else computed here (an
// export may take a moment; a frame never does). Returns their description
// and means.
Result<nlohmann::json> Studio::exportFlipMaps(const std::string& folder, std::vector<std::string>* files) const {
  const Snapshot& s = *snap_;
  const char* comp = componentName(view_.component);
  const FlipNumbers flip = flipMeans() ? *flip_ : computeFlip(s, view_.component, view_.exposure);
  nlohmann::json flipJson = {{"metric", "LDR-FLIP, mean pooled"},
                             {"component", comp},
                             {"exposure", view_.exposure},
                             {"pixelsPerDegree", kFlipPixelsPerDegree}};
  for (size_t i = 0; i < std::size(kMetricSources); ++i) {
    if (!hasPicture(kMetricSources[i], view_.component)) continue;
    int rows = 0;
    std::vector<uint8_t> px = mapWithBar(flip.map[i], magma, 1, "LDR-FLIP per pixel (unitless, 0 = identical)", &rows);
    std::string name = "flip-" + sourceSlug(kMetricSources[i]) + "-" + comp + ".png";
    const std::string path = (std::filesystem::path(folder) / name).string();
    if (Result<void> w = writePngRgb8(path, s.width, rows, px); !w) return Error(w.error());
    files->push_back(path);
    flipJson["mean"][sourceName(kMetricSources[i])] = flip.mean[i];
  }
  if (s.convergedReference) flipJson["mean"]["Path tracer (live)"] = flip.mean[4];
  return flipJson;
}

// metrics.json: the settings, the samples and timings, and every number
// measured against the reference.

// A source's mean, RMSE and relMSE against the reference, full and indirect
// (not indirect against a full-only reference, which has no indirect image).
nlohmann::json Studio::sourceMetricsJson(Source src) const {
  nlohmann::json j;
  for (Component c : {Component::Full, Component::Indirect}) {
    if (snap_->comparesFull && c == Component::Indirect) continue;
    Image sc, rs;
    CompareResult r = compareImages(*componentImage(src, c, sc), *referenceImage(c, rs));
    j[componentName(c)] = {{"mean", r.average.meanTest}, {"rmse", r.average.rmse}, {"relMSE", r.average.relMse}};
  }
  return j;
}

nlohmann::json Studio::exportMetricsJson(float errorMapMax, const nlohmann::json& flipJson,
                                         const nlohmann::json& cropJson) const {
  const Snapshot& s = *snap_;
  nlohmann::json metrics, notRendered = nlohmann::json::object();
  for (Source src : kMetricSources) {
    if (!hasPicture(src, Component::Indirect)) {
      // Scored against the reference, a black layer would look like a method.
      metrics[sourceName(src)] = nullptr;
      notRendered[sourceName(src)] = missingPictureText(src);
      continue;
    }
    metrics[sourceName(src)] = sourceMetricsJson(src);
  }
  // A pinned VSL picture ("Compare presets"): measured the same way, with
  // the settings that made it.
  if (hasPicture(Source::Pinned, Component::Indirect)) {
    nlohmann::json pinned = sourceMetricsJson(Source::Pinned);
    pinned["name"] = pinned_->name;
    pinned["preset"] = matchingPreset(pinned_->settings.many);
    pinned["settings"] = pinned_->settings.many.describe();
    metrics[sourceName(Source::Pinned)] = pinned;
  }
  // The first light set as the CLI renders it (an MRCS set's share of the
  // direct samples).
  ManyLightSettings firstSet = s.settings.many;
  if (s.directSamplesPerSet > 0) firstSet.directSamples = s.directSamplesPerSet;
  return {{"version", VSL_VERSION},
          {"scene", s.settings.scene},
          {"exportedUtc", utcStamp()},
          {"replay", "vsl render " + shellWord(s.settings.scene) + " --method all " + firstSet.describe() +
                         " --estimator " + s.settings.estimator.name + s.settings.estimator.describeParams() +
                         s.settings.env.options() + " -o first-light-set.exr"},
          {"environment", s.settings.env.describe()},
          {"replayRenders", "the first of the " + std::to_string(s.lightSets) + " light sets (seeds " +
                                std::to_string(s.settings.many.seed) + " to " +
                                std::to_string(s.settings.many.seed + uint64_t(std::max(s.lightSets, 1)) - 1) +
                                ") whose mean the studio shows"},
          {"settings", settingsJson(s)},
          {"width", s.width},
          {"height", s.height},
          {"samples", samplesJson(s)},
          {"timings", timingsJson(s)},
          {"machine", machineJson()},
          {"complete", {{"manyLight", s.manyLightDone}, {"reference", s.referenceDone}}},
          {"nonFiniteRejected", s.nonFinite},
          {"sceneWarnings", sceneWarnings_},
          {"view",
           {{"component", componentName(view_.component)},
            {"exposure", view_.exposure},
            {"toneMap", toneMapName(view_.toneMap)},
            {"errorMetric", kMetricNames[int(view_.metric)]},
            {"errorMapMax", errorMapMax}}},
          {"metricsAgainstReference", metrics},
          {"notRendered", notRendered},
          {"relMseEpsilon", mapEps_},
          {"relMseEpsilonMode", "relative: 0.01 x the reference's mean luminance^2"},
          {"crop", cropJson},
          {"reference", referenceJson(s)},
          {"comparedComponent", comparedName(s)},
          {s.comparesFull ? "equalTimeFull" : "equalTimeIndirect", equalTimeJson(s)},
          {"flip", flipJson},
          {s.comparesFull ? "biasNoiseFull" : "biasNoiseIndirect", biasNoiseJson(s)},
          {"errorHistory", historyJson(s.history)}};
}

Result<void> Studio::exportAll(const std::string& dir, std::vector<std::string>* written, std::string* folderOut) {
  if (!snap_ || snap_->width == 0) return Error("nothing to export yet");
  const Snapshot& s = *snap_;
  Result<std::filesystem::path> made = makeExportFolder(dir, exportStem());
  if (!made) return Error(made.error());
  const std::filesystem::path folder = *made;
  // An export that fails part-way leaves nothing behind: its new folder goes,
  // with whatever was written into it, and the message says so.
  auto fail = [&folder](const std::string& e) -> Result<void> {
    std::error_code ec;
    std::filesystem::remove_all(folder, ec);
    return Error(e + (ec ? " (and " + folder.string() + " could not be removed: " + ec.message() + ")"
                         : " (nothing was exported)"));
  };
  std::vector<std::string> files;
  auto path = [&](const std::string& name) { return (folder / name).string(); };

  if (Result<void> w = writeLayersExr(s, path("images.exr")); !w) return fail(w.error());
  files.push_back(path("images.exr"));
  Result<float> errorMapMax = exportPictures(folder.string(), &files);
  if (!errorMapMax) return fail(errorMapMax.error());
  Result<nlohmann::json> flipJson = exportFlipMaps(folder.string(), &files);
  if (!flipJson) return fail(flipJson.error());
  nlohmann::json figureJson = nullptr, cropJson = nullptr;
  if (Result<void> w = exportFigure(folder.string(), &figureJson, &files); !w) return fail(w.error());
  if (!view_.crop.empty()) {
    Image full;
    const Image* refFull = referenceImage(view_.component, full);
    if (Result<void> w = exportCrops(folder.string(), *refFull, &cropJson, &files); !w) return fail(w.error());
  }

  nlohmann::json j = exportMetricsJson(*errorMapMax, *flipJson, cropJson);
  j["figure"] = figureJson;
  if (Result<void> w = writeTextFile(path("metrics.json"), j.dump(2) + "\n"); !w) return fail(w.error());
  files.push_back(path("metrics.json"));
  if (written) *written = files;
  if (folderOut) *folderOut = folder.string();
  log::info("exported " + std::to_string(files.size()) + " files to " + folder.string());
  returnFreeMemory();  // the export's buffers (core/memory_budget.h)
  return {};
}

// ---- [4] Crop files and figure ---------------------------------------------------------

namespace {

// 8-bit RGB pictures for the crop files and figure.
struct Rgb8 {
  int w = 0, h = 0;
  std::vector<uint8_t> px;
  Rgb8(int width, int height, uint8_t fill = 20) : w(width), h(height), px(size_t(width) * height * 3, fill) {}
  uint8_t* at(int x, int y) { return &px[(size_t(y) * w + x) * 3]; }
  const uint8_t* at(int x, int y) const { return &px[(size_t(y) * w + x) * 3]; }
};

Rgb8 toneMapped(const Image& img, float exposure, ToneMap t) {
  Rgb8 out(img.width, img.height);
  out.px = toneMappedBytes(img, exposure, t);
  return out;
}

Rgb8 falseColoured(const Image& map, float vmax) {
  Rgb8 out(map.width, map.height);
  for (int y = 0; y < map.height; ++y)
    for (int x = 0; x < map.width; ++x) {
      Vec3 m = map.at(x, y);
      Vec3 c = falseColour((m.x + m.y + m.z) / 3 / std::max(vmax, 1e-12f));
      uint8_t* q = out.at(x, y);
      q[0] = uint8_t(std::clamp(c.x, 0.0f, 1.0f) * 255 + 0.5f);
      q[1] = uint8_t(std::clamp(c.y, 0.0f, 1.0f) * 255 + 0.5f);
      q[2] = uint8_t(std::clamp(c.z, 0.0f, 1.0f) * 255 + 0.5f);
    }
  return out;
}

// Nearest neighbour: every pixel becomes an f x f block.
Rgb8 magnified(const Rgb8& in, int f) {
  Rgb8 out(in.w * f, in.h * f);
  for (int y = 0; y < out.h; ++y)
    for (int x = 0; x < out.w; ++x) std::copy_n(in.at(x / f, y / f), 3, out.at(x, y));
  return out;
}

void blit(Rgb8& dst, const Rgb8& src, int x0, int y0) {
  for (int y = 0; y < src.h; ++y)
    for (int x = 0; x < src.w; ++x)
      if (x0 + x < dst.w && y0 + y < dst.h) std::copy_n(src.at(x, y), 3, dst.at(x0 + x, y0 + y));
}

// A frame `t` pixels wide just outside the rectangle (inside where it meets
// the image's border).
void outline(Rgb8& img, const CropRect& r, int t) {
  const int x0 = std::max(r.x - t, 0), y0 = std::max(r.y - t, 0);
  const int x1 = std::min(r.x + r.w + t, img.w), y1 = std::min(r.y + r.h + t, img.h);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const bool inside = x >= std::max(r.x, t) && x < std::min(r.x + r.w, img.w - t) && y >= std::max(r.y, t) &&
                          y < std::min(r.y + r.h, img.h - t);
      if (inside) continue;
      uint8_t* q = img.at(x, y);
      q[0] = 255;
      q[1] = 210;
      q[2] = 0;
    }
}

}  // namespace

namespace {

// The crop figure: a band of titles on top (the reference, each column's
// image), the reference magnified `scale` times with the crop outlined on
// the left, and right of it the crops at the largest integer factor *fig
// that fits two rows in its height (at least 1x): the reference and the
// methods, then, below a band with errorTitle (the metric, its units and
// scale), the methods' error maps (issue 49, item 6: "the crop figure has
// no labels").
Rgb8 cropFigure(const Rgb8& whole, int scale, const std::vector<Rgb8>& tiles,
                const std::vector<Studio::CropItem>& items, const CropRect& r, const std::string& errorTitle,
                int* fig) {
  const int gap = 8, band = labelLineHeight() + 4;
  const int fullW = whole.w * scale, fullH = whole.h * scale;
  *fig = std::max(1, (fullH - std::max(band, gap)) / (2 * r.h));
  const int cw = r.w * *fig, ch = r.h * *fig, columns = 1 + int(std::size(kMetricSources));
  const int mid = std::max(band, gap);  // between the rows: the error maps' title
  Rgb8 figure(fullW + gap + columns * (cw + gap), band + std::max(fullH, 2 * ch + mid));
  blit(figure, magnified(whole, scale), 0, band);
  // A title cut to its column's width.
  auto title = [&](int x, int y, std::string t, int width) {
    while (!t.empty() && labelWidth(t) > width) t.pop_back();
    drawLabel(figure.px, figure.w, figure.h, x, y, t);
  };
  title(0, 2, "reference, crop outlined", fullW);
  for (size_t i = 0; i < tiles.size(); ++i) {
    const int col = items[i].error ? int(i) - columns + 1 : int(i), row = items[i].error ? 1 : 0;
    const int x = fullW + gap + col * (cw + gap);
    blit(figure, magnified(tiles[i], *fig), x, band + row * (ch + mid));
    if (row == 0) title(x, 2, sourceName(items[i].source), cw + gap - 2);
  }
  title(fullW + gap, band + ch + (mid - labelLineHeight()) / 2, errorTitle, figure.w - fullW - gap);
  return figure;
}

}  // namespace

namespace {

// The whole-image figure (issue 49, item 6: "a single figure export lays out
// reference, methods and error maps with labels"): two title lines over the
// top row (the reference, then each method and its relMSE against the
// reference; under the reference's title what it is), the methods' error maps in the row below, each under its
// method, with the metric named in the cell under the reference, and the
// maps' colour bar across the bottom. Every tile is magnified f times
// (nearest neighbour).
Rgb8 wholeFigure(const std::vector<Studio::CropItem>& items, const std::vector<Rgb8>& tiles, int f,
                 const std::string& referenceNote, const std::string& metric, float vmax) {
  const int gap = 8, line = labelLineHeight(), band = 2 * line + 4;
  const int tw = tiles.front().w * f, th = tiles.front().h * f;
  int columns = 0;
  for (const Studio::CropItem& c : items) columns += c.error ? 0 : 1;
  const int rowY[2] = {band, band + th + gap};
  Rgb8 figure(columns * tw + (columns - 1) * gap, rowY[1] + th);
  auto title = [&](int x, int y, std::string t) {
    while (!t.empty() && labelWidth(t) > tw) t.pop_back();
    drawLabel(figure.px, figure.w, figure.h, x, y, t);
  };
  for (size_t i = 0; i < tiles.size(); ++i) {
    const Studio::CropItem& c = items[i];
    const int col = c.error ? int(i) - columns + 1 : int(i), row = c.error ? 1 : 0;
    const int x = col * (tw + gap);
    blit(figure, magnified(tiles[i], f), x, rowY[row]);
    if (c.error) continue;
    title(x, 2, sourceName(c.source));
    title(x, 2 + line, c.hasMetrics ? "relMSE " + numberLabel(c.metrics.average.relMse) : referenceNote);
  }
  const std::vector<std::string> lines = wrapLabel("error maps: " + metric, tw - 4);
  for (size_t i = 0; i < lines.size(); ++i) title(2, rowY[1] + 4 + line * int(i), lines[i]);
  figure.h = appendLabelledBar(figure.px, figure.w, figure.h, falseColour, "0", numberLabel(vmax), metric);
  return figure;
}

}  // namespace

// Writes figure-<component>.png: wholeFigure at the magnification that makes
// each image at least 256 pixels tall (at most 4x), and describes it in *out.
Result<void> Studio::exportFigure(const std::string& folder, nlohmann::json* out,
                                  std::vector<std::string>* files) const {
  float vmax = 1;
  const std::vector<CropItem> items = buildCrops({0, 0, snap_->width, snap_->height}, view_.component, &vmax);
  if (items.size() < 3) return {};  // no method has a picture yet
  std::vector<Rgb8> tiles;
  for (const CropItem& c : items)
    tiles.push_back(c.error ? falseColoured(c.image, vmax) : toneMapped(c.image, view_.exposure, view_.toneMap));
  const int f = std::clamp((256 + snap_->height - 1) / snap_->height, 1, 4);
  const std::string refNote = std::string(snap_->convergedReference ? "converged" : "live path tracer") +
                              (snap_->referenceSpp > 0 ? ", " + std::to_string(snap_->referenceSpp) + " spp" : "");
  const Rgb8 figure = wholeFigure(items, tiles, f, refNote, metricLabel(view_.metric), vmax);
  const std::string name = std::string("figure-") + componentName(view_.component) + ".png";
  const std::string path = (std::filesystem::path(folder) / name).string();
  if (Result<void> w = writePngRgb8(path, figure.w, figure.h, figure.px); !w) return w;
  files->push_back(path);
  *out = {{"file", name},
          {"magnification", f},
          {"errorMapMax", vmax},
          {"layout",
           "top row: the reference, then each method titled with its relMSE against the reference (the shown "
           "component); bottom row: each method's error map under it; a colour bar of the error metric across the "
           "bottom; every image "
           "magnified `magnification` times. The same pictures are written one per file alongside."}};
  return {};
}

// Writes crop-<image>-<component>.png (each image and error map, magnified
// by an integer factor, nearest neighbour) and crop-figure-<component>.png
// (the reference with the rectangle outlined, then the crops side by side:
// top row the reference and the methods, bottom row the methods' error
// maps; at least 512 pixels tall), and describes them, the rectangle and the crops' metrics in
// *out.
Result<void> Studio::exportCrops(const std::string& folder, const Image& full, nlohmann::json* out,
                                 std::vector<std::string>* files) const {
  const CropRect r = view_.crop.resolved(snap_->width, snap_->height);
  if (r.empty())
    return Error("crop " + std::to_string(view_.crop.x) + "," + std::to_string(view_.crop.y) + "," +
                 std::to_string(view_.crop.w) + "," + std::to_string(view_.crop.h) + " lies outside the " +
                 std::to_string(snap_->width) + "x" + std::to_string(snap_->height) + " image");
  if (r.w != view_.crop.w || r.h != view_.crop.h)
    log::warning("crop clipped to the image: " + std::to_string(r.x) + "," + std::to_string(r.y) + "," +
                 std::to_string(r.w) + "," + std::to_string(r.h));
  float vmax = 1;
  std::vector<CropItem> items = buildCrops(r, view_.component, &vmax);
  const int f = cropMagnification(r);
  const char* comp = componentName(view_.component);
  const std::string metricSlug = kMetricSlugs[int(view_.metric)];
  std::vector<Rgb8> tiles;
  nlohmann::json names = nlohmann::json::object();
  for (const CropItem& c : items) {
    tiles.push_back(c.error ? falseColoured(c.image, vmax) : toneMapped(c.image, view_.exposure, view_.toneMap));
    std::string name = c.error ? "crop-error-" + sourceSlug(c.source) + "-" + metricSlug + "-" + comp + ".png"
                               : "crop-" + sourceSlug(c.source) + "-" + comp + ".png";
    Rgb8 big = magnified(tiles.back(), f);
    const std::string path = (std::filesystem::path(folder) / name).string();
    if (Result<void> w = writePngRgb8(path, big.w, big.h, big.px); !w) return w;
    files->push_back(path);
    names[(c.error ? "error " : "") + std::string(sourceName(c.source))] = name;
  }
  const int scale = std::clamp((512 + full.height - 1) / full.height, 1, 8);
  Rgb8 whole = toneMapped(full, view_.exposure, view_.toneMap);
  outline(whole, r, scale > 1 ? 1 : 2);
  int fig = 1;
  const std::string errorTitle = "error maps: " + metricLabel(view_.metric) + "; 0 ... " + numberLabel(vmax);
  const Rgb8 figure = cropFigure(whole, scale, tiles, items, r, errorTitle, &fig);
  const std::string figName = std::string("crop-figure-") + comp + ".png";
  const std::string figPath = (std::filesystem::path(folder) / figName).string();
  if (Result<void> w = writePngRgb8(figPath, figure.w, figure.h, figure.px); !w) return w;
  files->push_back(figPath);

  // The crops' metrics for the full and indirect components (as the whole
  // image's), each method's crop against the reference's crop.
  nlohmann::json metrics;
  for (Component c : {Component::Full, Component::Indirect}) {
    for (const CropItem& item : buildCrops(r, c, nullptr)) {
      if (!item.hasMetrics || item.error) continue;
      const ChannelMetrics& a = item.metrics.average;
      metrics[sourceName(item.source)][componentName(c)] = {
          {"mean", a.meanTest}, {"meanReference", a.meanRef}, {"rmse", a.rmse}, {"relMSE", a.relMse}};
    }
  }
  *out = {{"x", r.x},
          {"y", r.y},
          {"width", r.w},
          {"height", r.h},
          {"imageWidth", snap_->width},
          {"imageHeight", snap_->height},
          {"magnification", f},
          {"component", comp},
          {"errorMetric", kMetricNames[int(view_.metric)]},
          {"errorMapMax", vmax},
          {"files", names},
          {"figure", figName},
          {"figureMagnification", fig},
          {"figureScale", scale},
          {"figureLayout",
           "titles on top; left: the reference (magnified figureScale times) with the crop outlined; right, "
           "magnified figureMagnification times, top row: the reference, VSL, VPL (clamped), VPL unclamped, VPL "
           "diffuse-only; then a band naming the error metric and its scale; bottom row: the methods' error maps"},
          {"metricsAgainstReferenceCrop", metrics}};
  return {};
}

}  // namespace vsl::ui
