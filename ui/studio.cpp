// Sections: [1] set-up  [2] snapshots and textures  [3] controls  [4] views
//           [5] metrics and plot  [6] log  [7] export
#include "ui/studio.h"

#include <imgui_stdlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/image_io.h"
#include "core/log.h"
#include "ui/gl.h"
#include "ui/headless_gl.h"

namespace vsl::ui {

const char* sourceName(Source s) {
  switch (s) {
    case Source::Vsl:
      return "VSL";
    case Source::Vpl:
      return "VPL (clamped)";
    case Source::Reference:
      return "Reference (PT)";
    case Source::VplUnclamped:
      return "VPL unclamped";
    case Source::VplDiffuse:
      return "VPL diffuse-only";
    case Source::LostClamping:
      return "Lost to clamping";
    case Source::LostDiffuse:
      return "Lost to diffuse-only";
    case Source::Count:
      break;
  }
  return "?";
}

namespace {
const char* kMetricNames[] = {"absolute |t-r|", "relative absolute |t-r|/(r+eps)", "squared (t-r)^2",
                              "relative squared (t-r)^2/(r^2+eps)"};
const char* kComponentNames[] = {"full", "direct", "indirect"};
const char* kModeNames[] = {"Single", "Side by side (2)", "Side by side (3)", "Wipe"};
constexpr float kEps = 1e-2f;

void sectionTitle(const char* title) {
  ImGui::Spacing();
  ImGui::Separator();
  ImGui::TextUnformatted(title);
}

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
}  // namespace

// ---- [1] Set-up --------------------------------------------------------------------

Studio::Studio(const StudioOptions& options) : options_(options), settings_(options.settings) {
  settings_.scene = options.scene;
  scenePath_ = options.scene;
  exportDir_ = options.exportDir;
  if (options.startSession) {
    session_ = std::make_unique<Session>();
    restart();
  }
}

Studio::~Studio() = default;

void Studio::restart() {
  if (!session_) return;
  std::string err;
  settings_.many.clamp = clampOff_ ? INFINITY : (clampAuto_ ? -1.0f : clampValue_);
  if (!vslAuto_ && settings_.many.vslSamples == 0) settings_.many.vslSamples = 4;
  if (vslAuto_) settings_.many.vslSamples = 0;
  if (!globalRadius_)
    settings_.many.globalRadius = 0;
  else if (settings_.many.globalRadius <= 0)
    settings_.many.globalRadius = 0.02f;
  restartedAt_ = std::chrono::steady_clock::now();
  if ((restartGeneration_ = session_->restart(settings_, &err)) == 0) {
    message_ = "settings rejected: " + err;
    log::error(message_);
  }
}

void Studio::openScene(const std::string& path) {
  scenePath_ = path;
  settings_.scene = path;
  restart();
}

void Studio::setSnapshotForTesting(std::shared_ptr<const Snapshot> s) {
  snap_ = std::move(s);
  texturesDirty_ = true;
}

// ---- [2] Snapshots and textures -----------------------------------------------------

void Studio::pullSnapshot() {
  if (!session_) return;
  if (auto s = session_->latest(serial_)) {
    serial_ = s->serial;
    if (s->generation != firstPictureGeneration_ && s->generation == restartGeneration_) {
      // The first picture of this generation: how long the user waited.
      firstPictureGeneration_ = s->generation;
      auto now = std::chrono::steady_clock::now();
      restartToPictureMs_ = std::chrono::duration<double, std::milli>(now - restartedAt_).count();
      if (launchToPictureMs_ < 0) {
        launchToPictureMs_ = std::chrono::duration<double, std::milli>(now - created_).count();
        log::info("first picture " + std::to_string(int(launchToPictureMs_)) + " ms after launch");
      }
      log::info("generation " + std::to_string(s->generation) + ": first picture " +
                std::to_string(int(restartToPictureMs_)) + " ms after the settings changed");
    }
    snap_ = std::move(s);
    texturesDirty_ = true;
  }
  Session::Status st = session_->status();
  if (st.loadErrorSerial > seenLoadErrors_) {
    seenLoadErrors_ = st.loadErrorSerial;
    errorDialog_ = "Could not load the scene; the previous scene stays open.\n\n" + st.loadError;
    scenePath_ = st.scene.empty() ? scenePath_ : st.scene;
    settings_.scene = scenePath_;
  }
}

const Image* Studio::referenceImage(Component c, Image& scratch) const {
  const Snapshot& s = *snap_;
  switch (c) {
    case Component::Direct:
      return &s.ptDirect;
    case Component::Indirect:
      return &s.ptIndirect;
    case Component::Full:
      scratch = add(s.ptDirect, s.ptIndirect);
      return &scratch;
  }
  return nullptr;
}

const Image* Studio::componentImage(Source src, Component c, Image& scratch) const {
  const Snapshot& s = *snap_;
  const Image* indirect = nullptr;
  switch (src) {
    case Source::Reference:
      return referenceImage(c, scratch);
    case Source::LostClamping:
      return &s.many.lostToClamping;
    case Source::LostDiffuse:
      return &s.many.lostToDiffuse;
    case Source::Vsl:
      indirect = &s.many.vsl;
      break;
    case Source::Vpl:
      indirect = &s.many.vpl;
      break;
    case Source::VplUnclamped:
      indirect = &s.many.vplUnclamped;
      break;
    case Source::VplDiffuse:
      indirect = &s.many.vplDiffuse;
      break;
    case Source::Count:
      return nullptr;
  }
  if (c == Component::Direct) return &s.many.direct;
  if (c == Component::Indirect) return indirect;
  scratch = add(s.many.direct, *indirect);
  return &scratch;
}

void Studio::updateTextures() {
  bool viewChanged =
      uploaded_.display != view_.display || uploaded_.metric != view_.metric || uploaded_.component != view_.component;
  if (!snap_ || (!texturesDirty_ && !viewChanged)) return;
  Image refScratch;
  const Image* ref = referenceImage(view_.component, refScratch);
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
    // Per-pixel error map or signed difference against the reference.
    Image map(img->width, img->height);
    for (size_t k = 0; k < map.rgb.size(); ++k) {
      float t = img->rgb[k], r = ref->rgb[k], d = t - r;
      float v = d;
      if (view_.display == Display::Error) {
        switch (view_.metric) {
          case ErrorMetric::Absolute:
            v = std::abs(d);
            break;
          case ErrorMetric::RelativeAbsolute:
            v = std::abs(d) / (std::abs(r) + kEps);
            break;
          case ErrorMetric::Squared:
            v = d * d;
            break;
          case ErrorMetric::RelativeSquared:
            v = d * d / (r * r + kEps);
            break;
        }
      }
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
  auto t0 = std::chrono::steady_clock::now();
  beginFrame();
  pullSnapshot();
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
  ImGui::SameLine();
  ImGui::BeginChild("right", ImVec2(0, 0), false);
  float bottom = std::min(260.0f, ImGui::GetContentRegionAvail().y * 0.4f);
  ImGui::BeginChild("views", ImVec2(0, -bottom), true,
                    ImGuiWindowFlags_NoScrollbar | ImGuiWindowFlags_NoScrollWithMouse);
  viewsPanel();
  ImGui::EndChild();
  ImGui::BeginChild("bottom", ImVec2(0, 0), true);
  if (ImGui::BeginTabBar("tabs")) {
    if (ImGui::BeginTabItem("Metrics")) {
      metricsPanel();
      ImGui::EndTabItem();
    }
    if (ImGui::BeginTabItem("Log")) {
      logPanel();
      ImGui::EndTabItem();
    }
    ImGui::EndTabBar();
  }
  ImGui::EndChild();
  ImGui::EndChild();

  if (!errorDialog_.empty()) ImGui::OpenPopup("Error");
  if (ImGui::BeginPopupModal("Error", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::PushTextWrapPos(600);
    ImGui::TextUnformatted(errorDialog_.c_str());
    ImGui::PopTextWrapPos();
    if (ImGui::Button("OK")) {
      errorDialog_.clear();
      ImGui::CloseCurrentPopup();
    }
    ImGui::EndPopup();
  }
  ImGui::End();
  lastFrameMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// ---- [3] Controls --------------------------------------------------------------------

void Studio::controlsPanel() {
  bool changed = false;
  ImGui::TextUnformatted("Scene");
  ImGui::SetNextItemWidth(-60);
  bool enter = ImGui::InputText("##path", &scenePath_, ImGuiInputTextFlags_EnterReturnsTrue);
  ImGui::SameLine();
  if (ImGui::Button("Load") || enter) openScene(scenePath_);
  if (!options_.bundled.empty()) {
    std::string current = std::filesystem::path(settings_.scene).stem().string();
    ImGui::SetNextItemWidth(-1);
    if (ImGui::BeginCombo("##bundled", ("bundled: " + current).c_str())) {
      for (const std::string& b : options_.bundled) {
        std::string name = std::filesystem::path(b).stem().string();
        if (ImGui::Selectable(name.c_str(), b == settings_.scene)) openScene(b);
      }
      ImGui::EndCombo();
    }
  }
  ImGui::TextDisabled("(or drop a .gltf/.glb on the window)");

  sectionTitle("Virtual lights");
  ManyLightSettings& m = settings_.many;
  int lights = int(m.lights);
  if (ImGui::SliderInt("lights", &lights, 100, 1000000, "%d", ImGuiSliderFlags_Logarithmic)) {
    m.lights = uint32_t(std::clamp(lights, 1, 50000000));
    changed = true;
  }
  changed |= ImGui::Checkbox("global radius", &globalRadius_);
  if (globalRadius_) {
    changed |= ImGui::SliderFloat("radius", &m.globalRadius, 1e-4f, 0.5f, "%.4f x scene", ImGuiSliderFlags_Logarithmic);
  } else {
    changed |= ImGui::SliderFloat("radius scale", &m.radiusScale, 1e-3f, 100.0f, "%.3f", ImGuiSliderFlags_Logarithmic);
    changed |= ImGui::SliderInt("k (nearest)", &m.knn, 1, 64);
  }
  changed |= ImGui::Checkbox("auto VSL samples", &vslAuto_);
  if (!vslAuto_) changed |= ImGui::SliderInt("VSL samples", &m.vslSamples, 1, 128, "%d", ImGuiSliderFlags_Logarithmic);
  sectionTitle("VPL");
  changed |= ImGui::Checkbox("clamp off", &clampOff_);
  if (!clampOff_) {
    ImGui::SameLine();
    changed |= ImGui::Checkbox("auto bound", &clampAuto_);
    if (!clampAuto_)
      changed |= ImGui::SliderFloat("clamp", &clampValue_, 1e-3f, 1e4f, "%.3g", ImGuiSliderFlags_Logarithmic);
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "Bound on the luminance of f_x cos_x f_p cos_p / d^2 per virtual light.\nAuto: 1/(pi^2 (0.1 R)^2), R the "
        "scene's bounding radius.");
  changed |= ImGui::Checkbox("diffuse-only emission", &m.diffuseOnly);

  sectionTitle("Render");
  int seed = int(m.seed);
  if (ImGui::InputInt("seed", &seed)) {
    m.seed = uint64_t(std::max(seed, 0));
    changed = true;
  }
  int width = m.width > 0 ? m.width : 256;
  if (ImGui::SliderInt("width", &width, 32, 2048, "%d px", ImGuiSliderFlags_Logarithmic)) {
    m.width = width;
    m.height = 0;  // from the camera's aspect
    changed = true;
  }
  changed |= ImGui::SliderInt("batches", &m.batches, 1, 64);
  changed |=
      ImGui::SliderInt("reference spp", &settings_.maxReferenceSpp, 16, 65536, "%d", ImGuiSliderFlags_Logarithmic);
  if (changed) restart();
  if (ImGui::Button("Restart")) restart();

  sectionTitle("View");
  int mode = int(view_.mode);
  if (ImGui::Combo("layout", &mode, kModeNames, 4)) view_.mode = ViewMode(mode);
  int panels = view_.mode == ViewMode::Single ? 1 : view_.mode == ViewMode::SideBySide3 ? 3 : 2;
  for (int i = 0; i < panels; ++i) {
    int src = int(view_.panels[i]);
    std::string label = view_.mode == ViewMode::Wipe ? (i == 0 ? "left" : "right") : "panel " + std::to_string(i + 1);
    std::vector<const char*> names;
    for (int k = 0; k < int(Source::Count); ++k) names.push_back(sourceName(Source(k)));
    if (ImGui::Combo(label.c_str(), &src, names.data(), int(names.size()))) view_.panels[i] = Source(src);
  }
  if (view_.mode == ViewMode::Single && ImGui::Button("Toggle VPL / VSL  (T)"))
    view_.panels[0] = view_.panels[0] == Source::Vsl ? Source::Vpl : Source::Vsl;
  if (ImGui::IsKeyPressed('T') && !ImGui::GetIO().WantTextInput)
    view_.panels[0] = view_.panels[0] == Source::Vsl ? Source::Vpl : Source::Vsl;
  int comp = int(view_.component);
  if (ImGui::Combo("component", &comp, kComponentNames, 3)) view_.component = Component(comp);
  int disp = int(view_.display);
  const char* displays[] = {"image", "error map", "signed difference"};
  if (ImGui::Combo("display", &disp, displays, 3)) view_.display = Display(disp);
  if (view_.display == Display::Error) {
    int metric = int(view_.metric);
    if (ImGui::Combo("metric", &metric, kMetricNames, 4)) view_.metric = ErrorMetric(metric);
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "t = method, r = reference (same component), eps = %.2g.\nColours: black 0 -> blue -> magenta -> yellow -> "
          "white max.",
          kEps);
  }
  if (view_.display == Display::Image) {
    ImGui::SliderFloat("exposure", &view_.exposure, -10, 10, "%.1f stops");
  } else {
    ImGui::SliderFloat("map max", &view_.errorScale, 0, 10, view_.errorScale > 0 ? "%.4g" : "auto (99th pct)",
                       ImGuiSliderFlags_Logarithmic);
  }
  if (ImGui::Button("Fit")) view_.zoom = 1, view_.center = ImVec2(0.5f, 0.5f);
  ImGui::SameLine();
  ImGui::TextDisabled("zoom %.2fx (wheel), pan (drag)", view_.zoom);

  sectionTitle("Export");
  ImGui::SetNextItemWidth(-1);
  ImGui::InputText("##dir", &exportDir_);
  if (ImGui::Button("Save view (PNG)")) {
    std::error_code ec;
    std::filesystem::create_directories(exportDir_, ec);
    savePngPath_ = (std::filesystem::path(exportDir_) / "view.png").string();
    savePngPending_ = true;
  }
  ImGui::SameLine();
  if (ImGui::Button("Export EXR + JSON")) {
    std::string err;
    std::vector<std::string> written;
    if (exportAll(exportDir_, &err, &written))
      message_ = "wrote " + std::to_string(written.size()) + " files to " + exportDir_;
    else
      errorDialog_ = "Export failed; existing files are untouched.\n\n" + err;
  }
  if (!message_.empty()) ImGui::TextWrapped("%s", message_.c_str());
}

// ---- [4] Views -----------------------------------------------------------------------

void Studio::viewsPanel() {
  ImVec2 origin = ImGui::GetCursorScreenPos(), avail = ImGui::GetContentRegionAvail();
  viewMin_ = origin;
  viewMax_ = ImVec2(origin.x + avail.x, origin.y + avail.y);
  if (!snap_ || snap_->width == 0) {
    std::string stage = session_ ? session_->status().stage : "idle";
    ImGui::Text("Waiting for the first picture (%s)...", stage.c_str());
    return;
  }
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const bool maps = view_.display != Display::Image;
  if (maps) avail.y -= 28;  // room for the legend
  int n = view_.mode == ViewMode::SideBySide2 ? 2 : view_.mode == ViewMode::SideBySide3 ? 3 : 1;
  const float labelH = ImGui::GetTextLineHeightWithSpacing();
  const float aspect = float(snap_->width) / float(snap_->height);
  const float panelW = (avail.x - 8 * (n - 1)) / n, panelH = avail.y - labelH;
  // Fit the image into a panel, keeping its aspect.
  float w = panelW, h = panelW / aspect;
  if (h > panelH) h = panelH, w = panelH * aspect;
  // Zoom and pan: the visible UV window.
  float half = 0.5f / view_.zoom;
  view_.center.x = std::clamp(view_.center.x, half, 1 - half);
  view_.center.y = std::clamp(view_.center.y, half, 1 - half);
  ImVec2 uv0(view_.center.x - half, view_.center.y - half), uv1(view_.center.x + half, view_.center.y + half);

  // One colour scale for every map on screen, so panels compare fairly.
  auto isMethod = [](Source s) {
    return s != Source::Reference && s != Source::LostClamping && s != Source::LostDiffuse;
  };
  float sharedMax = 0;
  for (int i = 0; i < (view_.mode == ViewMode::Wipe ? 2 : n); ++i)
    if (isMethod(view_.panels[i])) sharedMax = std::max(sharedMax, autoScale_[int(view_.panels[i])]);
  const float mapMax = view_.errorScale > 0 ? view_.errorScale : std::max(sharedMax, 1e-12f);
  auto params = [&](Source s) {
    DisplayParams p;
    if (!maps || !isMethod(s)) {
      p.mode = DisplayMode::Tonemap;
      p.scale = std::exp2(view_.exposure);
    } else {
      float vmax = mapMax;
      p.mode = view_.display == Display::Error ? DisplayMode::FalseColour : DisplayMode::Signed;
      p.scale = 1.0f / std::max(vmax, 1e-12f);
    }
    return p;
  };
  for (int i = 0; i < n; ++i) {
    ImVec2 p0(origin.x + i * (panelW + 8) + (panelW - w) / 2, origin.y + labelH);
    ImVec2 p1(p0.x + w, p0.y + h);
    if (view_.mode == ViewMode::Wipe) {
      Source a = view_.panels[0], b = view_.panels[1];
      float sx = p0.x + view_.wipe * w, su = uv0.x + view_.wipe * (uv1.x - uv0.x);
      drawImage(dl, textures_[int(a)], p0, ImVec2(sx, p1.y), uv0, ImVec2(su, uv1.y), params(a));
      drawImage(dl, textures_[int(b)], ImVec2(sx, p0.y), p1, ImVec2(su, uv0.y), uv1, params(b));
      drawn_.push_back({p0, ImVec2(sx, p1.y), uv0, ImVec2(su, uv1.y), a});
      drawn_.push_back({ImVec2(sx, p0.y), p1, ImVec2(su, uv0.y), uv1, b});
      dl->AddLine(ImVec2(sx, p0.y), ImVec2(sx, p1.y), IM_COL32(255, 255, 255, 200), 1.5f);
      dl->AddText(ImVec2(p0.x, origin.y), IM_COL32_WHITE,
                  (std::string(sourceName(a)) + "  |  " + sourceName(b)).c_str());
    } else {
      Source s = view_.panels[i];
      drawImage(dl, textures_[int(s)], p0, p1, uv0, uv1, params(s));
      drawn_.push_back({p0, p1, uv0, uv1, s});
      dl->AddText(ImVec2(p0.x, origin.y), IM_COL32_WHITE, sourceName(s));
    }
  }
  // Interaction over the whole view area: wheel zooms, drag pans (in wipe
  // mode, dragging near the split line moves it).
  ImGui::SetCursorScreenPos(origin);
  ImGui::InvisibleButton("viewarea", ImVec2(std::max(avail.x, 1.0f), std::max(avail.y, 1.0f)));
  if (ImGui::IsItemHovered()) {
    float wheel = ImGui::GetIO().MouseWheel;
    if (wheel != 0) view_.zoom = std::clamp(view_.zoom * std::pow(1.15f, wheel), 1.0f, 64.0f);
  }
  if (ImGui::IsItemActive() && ImGui::IsMouseDragging(ImGuiMouseButton_Left)) {
    ImVec2 d = ImGui::GetIO().MouseDelta;
    float splitX = origin.x + (panelW - w) / 2 + view_.wipe * w;
    if (view_.mode == ViewMode::Wipe && std::abs(ImGui::GetIO().MouseClickedPos[0].x - splitX) < 40) {
      view_.wipe = std::clamp((ImGui::GetIO().MousePos.x - (origin.x + (panelW - w) / 2)) / w, 0.0f, 1.0f);
    } else {
      view_.center.x -= d.x / w / view_.zoom;
      view_.center.y -= d.y / h / view_.zoom;
    }
  }
  if (maps) {
    ImGui::SetCursorScreenPos(ImVec2(origin.x, origin.y + labelH + h + 6));
    legend(mapMax);
  }
}

void Studio::legend(float vmax) {
  ImDrawList* dl = ImGui::GetWindowDrawList();
  ImVec2 p = ImGui::GetCursorScreenPos();
  const float W = 240, H = 12;
  const int steps = 48;
  bool signedMap = view_.display == Display::Signed;
  for (int i = 0; i < steps; ++i) {
    float t = (i + 0.5f) / steps;
    Vec3 c;
    if (signedMap) {
      float v = 2 * t - 1;
      c = v < 0 ? lerp(-v, Vec3(1.0f), Vec3(0.15f, 0.35f, 1.0f)) : lerp(v, Vec3(1.0f), Vec3(1.0f, 0.2f, 0.1f));
    } else {
      c = falseColour(t);
    }
    dl->AddRectFilled(ImVec2(p.x + W * i / steps, p.y), ImVec2(p.x + W * (i + 1) / steps, p.y + H),
                      IM_COL32(int(c.x * 255), int(c.y * 255), int(c.z * 255), 255));
  }
  char buf[128];
  if (signedMap)
    std::snprintf(buf, sizeof buf, "%.3g   0   +%.3g   (method - reference)", -vmax, vmax);
  else
    std::snprintf(buf, sizeof buf, "0 ... %.3g   %s", vmax, kMetricNames[int(view_.metric)]);
  dl->AddText(ImVec2(p.x + W + 8, p.y - 2), IM_COL32_WHITE, buf);
  ImGui::Dummy(ImVec2(W, H));
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("eps = %.2g; the maximum is %s", kEps,
                      view_.errorScale > 0 ? "set by hand" : "the 99th percentile");
}

// ---- [5] Metrics and plot -------------------------------------------------------------

namespace {
constexpr Source kMetricSources[4] = {Source::Vsl, Source::Vpl, Source::VplUnclamped, Source::VplDiffuse};
}

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
}

void Studio::metricsPanel() {
  if (!snap_ || snap_->width == 0) {
    ImGui::TextUnformatted("No picture yet.");
    return;
  }
  const Snapshot& s = *snap_;
  updateMetrics();
  ImGui::BeginGroup();
  ImGui::Text("%s  |  %dx%d  |  %s component", std::filesystem::path(s.settings.scene).filename().c_str(), s.width,
              s.height, kComponentNames[int(view_.component)]);
  ImGui::Text("lights %zu / %zu  (batch %d/%d)   reference %d spp   %.1f s", s.lightsProcessed, s.lightsTotal,
              s.batchesDone, s.batchCount, s.ptSpp, s.seconds);
  ImGui::Text("gather %.2f M pairs/s   light tracing %.2f s   non-finite rejected %llu", s.pairsPerSecond * 1e-6,
              s.lightTracingSeconds, (unsigned long long)s.nonFinite);
  ImGui::Text("UI frame %.1f ms   change -> picture %.0f ms   launch -> picture %.0f ms", lastFrameMs_,
              restartToPictureMs_, launchToPictureMs_);
  if (ImGui::BeginTable("metrics", 4, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingFixedFit)) {
    ImGui::TableSetupColumn("method vs reference");
    ImGui::TableSetupColumn("mean");
    ImGui::TableSetupColumn("RMSE");
    ImGui::TableSetupColumn("relMSE");
    ImGui::TableHeadersRow();
    for (int i = 0; i < 4; ++i) {
      const CompareResult& c = metrics_[i];
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(sourceName(kMetricSources[i]));
      ImGui::TableNextColumn();
      ImGui::Text("%.5g", c.average.meanTest);
      ImGui::TableNextColumn();
      ImGui::Text("%.4g", c.average.rmse);
      ImGui::TableNextColumn();
      ImGui::Text("%.4g", c.average.relMse);
    }
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextUnformatted("Reference (PT)");
    ImGui::TableNextColumn();
    ImGui::Text("%.5g", referenceMean_);
    ImGui::TableNextColumn();
    ImGui::TextUnformatted("-");
    ImGui::TableNextColumn();
    ImGui::Text("~%.3g", s.history.empty() ? 0.0 : s.history.back().pt);
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("The reference's own expected relMSE (indirect), from its sample variance");
    ImGui::EndTable();
  }
  ImGui::EndGroup();
  ImGui::SameLine();
  plotErrors(
      ImVec2(std::max(ImGui::GetContentRegionAvail().x, 100.0f), std::max(ImGui::GetContentRegionAvail().y, 80.0f)));
}

void Studio::plotErrors(const ImVec2& size) {
  const auto& h = snap_->history;
  ImDrawList* dl = ImGui::GetWindowDrawList();
  ImVec2 p0 = ImGui::GetCursorScreenPos(), p1(p0.x + size.x, p0.y + size.y);
  dl->AddRect(p0, p1, IM_COL32(120, 120, 120, 255));
  ImGui::Dummy(size);
  if (h.empty()) return;
  // Log-log axes over every series' range.
  double tMin = 1e30, tMax = 1e-30, eMin = 1e30, eMax = 1e-30;
  for (const ErrorSample& e : h) {
    for (double t : {e.manySeconds, e.ptSeconds})
      if (t > 0) tMin = std::min(tMin, t), tMax = std::max(tMax, t);
    for (double v : {e.vsl, e.vpl, e.pt})
      if (v > 0) eMin = std::min(eMin, v), eMax = std::max(eMax, v);
  }
  if (!(tMax > tMin)) tMax = tMin * 10;
  if (!(eMax > eMin)) eMax = eMin * 10;
  const float padL = 50, padB = 16;
  ImVec2 a(p0.x + padL, p0.y + 4), b(p1.x - 4, p1.y - padB);
  auto X = [&](double t) {
    return a.x + float((std::log(t) - std::log(tMin)) / (std::log(tMax) - std::log(tMin))) * (b.x - a.x);
  };
  auto Y = [&](double e) {
    return b.y - float((std::log(e) - std::log(eMin)) / (std::log(eMax) - std::log(eMin))) * (b.y - a.y);
  };
  struct Series {
    const char* name;
    ImU32 colour;
    double (*t)(const ErrorSample&);
    double (*v)(const ErrorSample&);
  };
  const Series series[] = {
      {"VSL", IM_COL32(255, 120, 80, 255), [](const ErrorSample& e) { return e.manySeconds; },
       [](const ErrorSample& e) { return e.vsl; }},
      {"VPL", IM_COL32(90, 160, 255, 255), [](const ErrorSample& e) { return e.manySeconds; },
       [](const ErrorSample& e) { return e.vpl; }},
      {"PT", IM_COL32(120, 220, 120, 255), [](const ErrorSample& e) { return e.ptSeconds; },
       [](const ErrorSample& e) { return e.pt; }},
  };
  float ly = a.y;
  for (const Series& s : series) {
    std::vector<ImVec2> pts;
    for (const ErrorSample& e : h)
      if (s.t(e) > 0 && s.v(e) > 0) pts.push_back(ImVec2(X(s.t(e)), Y(s.v(e))));
    if (pts.size() >= 2) dl->AddPolyline(pts.data(), int(pts.size()), s.colour, 0, 2.0f);
    for (const ImVec2& q : pts) dl->AddCircleFilled(q, 2.5f, s.colour);
    dl->AddText(ImVec2(b.x - 40, ly + 16), s.colour, s.name);
    ly += 14;
  }
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.2g", eMax);
  dl->AddText(ImVec2(p0.x + 2, a.y), IM_COL32_WHITE, buf);
  std::snprintf(buf, sizeof buf, "%.2g", eMin);
  dl->AddText(ImVec2(p0.x + 2, b.y - 12), IM_COL32_WHITE, buf);
  std::snprintf(buf, sizeof buf, "%.2g s", tMin);
  dl->AddText(ImVec2(a.x, b.y + 1), IM_COL32_WHITE, buf);
  std::snprintf(buf, sizeof buf, "%.2g s", tMax);
  dl->AddText(ImVec2(b.x - ImGui::CalcTextSize(buf).x, b.y + 1), IM_COL32_WHITE, buf);
  dl->AddText(ImVec2(a.x + 60, a.y), IM_COL32(200, 200, 200, 255), "relMSE (indirect) vs compute time, log-log");
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
    ImGui::TextColored(col, "[%s] %s", log::levelName(entries[i].level), entries[i].message.c_str());
  }
  if (ImGui::GetScrollY() >= ImGui::GetScrollMaxY()) ImGui::SetScrollHereY(1.0f);
  ImGui::EndChild();
}

// ---- [7] Export ------------------------------------------------------------------------

void Studio::afterRender(int fbWidth, int fbHeight) {
  if (!savePngPending_) return;
  savePngPending_ = false;
  int x0 = std::max(0, int(viewMin_.x)), y0 = std::max(0, int(viewMin_.y));
  int x1 = std::min(fbWidth, int(viewMax_.x)), y1 = std::min(fbHeight, int(viewMax_.y));
  if (x1 <= x0 || y1 <= y0) return;
  std::vector<uint8_t> px = readFramebuffer(x0, y0, x1 - x0, y1 - y0, fbHeight);
  std::string err;
  if (writePngRgb8(savePngPath_, x1 - x0, y1 - y0, px, &err)) {
    message_ = "wrote " + savePngPath_;
    log::info(message_);
  } else {
    errorDialog_ = "Saving the view failed; existing files are untouched.\n\n" + err;
  }
}

bool Studio::exportAll(const std::string& dir, std::string* error, std::vector<std::string>* written) {
  if (!snap_ || snap_->width == 0) {
    if (error) *error = "nothing to export yet";
    return false;
  }
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    if (error) *error = dir + ": cannot create the directory (" + ec.message() + ")";
    return false;
  }
  const Snapshot& s = *snap_;
  std::string stem = std::filesystem::path(s.settings.scene).stem().string();
  std::filesystem::path base = std::filesystem::path(dir) / ("studio-" + stem);
  Image ptFull = add(s.ptDirect, s.ptIndirect), vslFull = add(s.many.direct, s.many.vsl),
        vplFull = add(s.many.direct, s.many.vpl);
  ErrorImages ev = errorImages(s.many.vsl, s.ptIndirect), ep = errorImages(s.many.vpl, s.ptIndirect);
  std::vector<Layer> layers = {{"", vslFull},
                               {"vsl-full", vslFull},
                               {"vsl-indirect", s.many.vsl},
                               {"vpl-full", vplFull},
                               {"vpl-indirect", s.many.vpl},
                               {"direct", s.many.direct},
                               {"pt-full", ptFull},
                               {"pt-direct", s.ptDirect},
                               {"pt-indirect", s.ptIndirect},
                               {"vpl-unclamped-indirect", s.many.vplUnclamped},
                               {"vpl-diffuse-indirect", s.many.vplDiffuse},
                               {"lost-to-clamping", s.many.lostToClamping},
                               {"lost-to-diffuse", s.many.lostToDiffuse},
                               {"error-vsl-signed", ev.signedDiff},
                               {"error-vsl-relsq", ev.relSquared},
                               {"error-vpl-signed", ep.signedDiff},
                               {"error-vpl-relsq", ep.relSquared}};
  std::string exr = base.string() + ".exr", js = base.string() + ".json", png = base.string() + ".png";
  std::string err;
  if (!writeExr(exr, layers, &err,
                {{"vsl.version", VSL_VERSION},
                 {"vsl.scene", s.settings.scene},
                 {"vsl.settings", s.settings.many.describe()}})) {
    if (error) *error = err;
    return false;
  }
  // PNG: the first panel's image as displayed (tone mapped at the current exposure).
  Image scratch;
  const Image* first = componentImage(view_.panels[0], view_.component, scratch);
  if (!writePng(png, *first, view_.exposure, &err)) {
    if (error) *error = err;
    return false;
  }
  nlohmann::json metrics;
  for (Source src : kMetricSources) {
    for (Component c : {Component::Full, Component::Indirect}) {
      Image sc, rs;
      const Image* img = componentImage(src, c, sc);
      const Image* ref = referenceImage(c, rs);
      CompareResult r = compareImages(*img, *ref);
      metrics[sourceName(src)][componentName(c)] = {
          {"mean", r.average.meanTest}, {"rmse", r.average.rmse}, {"relMSE", r.average.relMse}};
    }
  }
  nlohmann::json hist = nlohmann::json::array();
  for (const ErrorSample& e : s.history)
    hist.push_back(
        {{"manySeconds", e.manySeconds}, {"vsl", e.vsl}, {"vpl", e.vpl}, {"ptSeconds", e.ptSeconds}, {"pt", e.pt}});
  nlohmann::json j = {{"version", VSL_VERSION},
                      {"scene", s.settings.scene},
                      {"settings",
                       {{"describe", s.settings.many.describe()},
                        {"lights", s.settings.many.lights},
                        {"radiusScale", s.settings.many.radiusScale},
                        {"knn", s.settings.many.knn},
                        {"globalRadius", s.settings.many.globalRadius},
                        {"vslSamples", s.settings.many.vslSamples},
                        {"clamp", std::isinf(s.settings.many.clamp) ? -2.0 : double(s.settings.many.clamp)},
                        {"diffuseOnly", s.settings.many.diffuseOnly},
                        {"seed", s.settings.many.seed},
                        {"batches", s.settings.many.batches},
                        {"maxReferenceSpp", s.settings.maxReferenceSpp}}},
                      {"width", s.width},
                      {"height", s.height},
                      {"lightsProcessed", s.lightsProcessed},
                      {"lightsTotal", s.lightsTotal},
                      {"referenceSpp", s.ptSpp},
                      {"seconds", s.seconds},
                      {"lightTracingSeconds", s.lightTracingSeconds},
                      {"pairsPerSecond", s.pairsPerSecond},
                      {"nonFiniteRejected", s.nonFinite},
                      {"metricsAgainstReference", metrics},
                      {"relMseEpsilon", kEps},
                      {"errorHistory", hist}};
  if (!writeTextFile(js, j.dump(2) + "\n", &err)) {
    if (error) *error = err;
    return false;
  }
  if (written) *written = {exr, js, png};
  log::info("exported " + exr + ", " + js + ", " + png);
  return true;
}

}  // namespace vsl::ui
