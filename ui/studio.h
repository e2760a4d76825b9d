// The vsl-studio user interface: ImGui panels and GL image views over a
// background Session. frame() builds the UI for one frame and never waits for
// rendering: it pulls the newest snapshot (if any) and uploads only the
// textures that changed. Only the UI thread calls into this class.
#pragma once

#include <imgui.h>

#include <chrono>
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/compare.h"
#include "core/math.h"
#include "core/params.h"
#include "core/session.h"
#include "core/stopwatch.h"
#include "ui/gl_image.h"
#include "ui/param_widgets.h"

namespace vsl::ui {

// What a view panel shows.
// Pinned: a VSL picture kept from an earlier render of the same scene and
// size (Studio's "Compare presets"), measured against today's reference.
enum class Source : int { Vsl, Vpl, Reference, VplUnclamped, VplDiffuse, LostClamping, LostDiffuse, Pinned, Count };
// Flip: each method's LDR-FLIP map against the reference (core/flip.h) for
// the shown component and exposure, computed off the UI thread with the
// table's FLIP column, through magma on [0, map max] (auto: [0, 1]).
enum class Display : int { Image, Error, Signed, Flip };
enum class ErrorMetric : int { Absolute, RelativeAbsolute, Squared, RelativeSquared };
enum class ViewMode : int { Single, SideBySide2, SideBySide3, Wipe };
// How the images (not the maps) are shown, in the panels, Save view and the
// exported PNGs (gl_image.h DisplayMode, studio_internal.h toneMapPixel):
// linear * 2^exposure clamped and sRGB-encoded; a filmic curve; or log10
// luminance through the false-colour ramp (kFalseColourDecades).
enum class ToneMap : int { Linear, Filmic, FalseColour };
const char* toneMapName(ToneMap t);

const char* sourceName(Source s);
// "vsl", "vpl-clamped", "reference", ...: file names and JSON keys.
std::string sourceSlug(Source s);
// "VSL (indirect)": the source's name and the component it shows.
std::string panelTitle(Source s, Component c);

// A crop inset: a rectangle in image pixels (x, y its top-left corner, top
// row first) of an image imageW x imageH. imageW = 0: of whatever size the
// render has (the --crop option).
struct CropRect {
  int x = 0, y = 0, w = 0, h = 0;
  int imageW = 0, imageH = 0;
  bool empty() const { return w <= 0 || h <= 0; }
  bool operator==(const CropRect&) const = default;
  // The rectangle for an image of width x height: rescaled when it was made
  // on an image of another size, then clipped to the image (empty if it
  // lies outside).
  CropRect resolved(int width, int height) const;
};
// The pixels of img inside r (r must lie inside img).
Image cropImage(const Image& img, const CropRect& r);
// The integer factor crops are magnified by in exports (nearest neighbour):
// the longer side becomes about 256 pixels, between 1x and 32x.
int cropMagnification(const CropRect& r);

// The words for a time left predicted ageSeconds ago (a snapshot's, for work
// not done): "~T left", counted down by the age, so that it moves between
// snapshots (an MRCS light set publishes none while it runs, for up to
// minutes); "finishing" once a prediction has run out; "time left not known
// yet" where there is none (0, as the snapshot says it, or not a number).
std::string timeLeftText(double predictedSeconds, double ageSeconds);

struct StudioOptions {
  std::string scene;                 // initial scene
  std::vector<std::string> bundled;  // bundled scene paths for the picker
  std::string exportDir = "vsl-export";
  bool startSession = true;  // false: tests inject snapshots
  StudioSettings settings;   // initial render settings (scene is filled in)
  // What "Reset to defaults" applies (the scene stays); unset: `settings`.
  // Differs from `settings` when those came back from the last session.
  std::optional<StudioSettings> defaults;
};

struct ViewState {
  ViewMode mode = ViewMode::SideBySide3;
  Source panels[3] = {Source::Vsl, Source::Vpl, Source::Reference};
  Display display = Display::Image;
  ErrorMetric metric = ErrorMetric::RelativeAbsolute;
  Component component = Component::Indirect;
  float exposure = 0;  // stops
  ToneMap toneMap = ToneMap::Linear;
  float errorScale = 0;       // colour-map maximum; 0 = automatic (99th percentile)
  float wipe = 0.5f;          // split position in [0,1]
  float zoom = 1;             // 1 = fit
  ImVec2 center{0.5f, 0.5f};  // image point at the view centre (UV)
  CropRect crop;              // the crop inset (empty: none)
  bool cropTool = false;      // a plain drag makes a crop (Shift+drag always does)
};

// The last session (scene, render settings and view) is saved on quit and
// restored on a start without a scene argument. The file is
// $XDG_CONFIG_HOME/vsl-studio/last-session.json, or ~/.config/... when
// XDG_CONFIG_HOME is unset; "" when neither is known.
std::string lastSessionPath();
// Written atomically (writeTextFile); creates the folder. An error on failure.
Result<void> saveLastSession(const std::string& path, const StudioSettings& settings, const ViewState& view);
// Written as kLastSessionVersion. Version 2 (2026-12-03): the lobe floor's
// default became 1, so a version-1 file's lobe floor of 0 (the old default)
// is not restored.
constexpr int kLastSessionVersion = 2;
// Reads the file over *settings and *view (fields it lacks keep their
// values). False when there is nothing to restore: *warning is "" for a
// missing file, else the reason (unreadable, corrupt, invalid settings), and
// *settings and *view are unchanged.
bool loadLastSession(const std::string& path, StudioSettings* settings, ViewState* view, std::string* warning);

class Studio {
 public:
  explicit Studio(const StudioOptions& options);
  ~Studio();

  // Builds the UI (between ImGui::NewFrame and ImGui::Render).
  void frame();
  // After the frame is rendered into the bound framebuffer: performs a
  // pending "save view as PNG" (reads back the view area).
  void afterRender(int framebufferWidth, int framebufferHeight);

  void openScene(const std::string& path);
  // Sets the environment light's map (an .exr, as a dropped file does); a
  // file that cannot be used is reported and the previous environment stays.
  void openEnvironment(const std::string& path);
  // Writes one new folder under dir, named <scene>-<UTC timestamp> (with a
  // counter if that exists: nothing is ever overwritten), holding the EXR
  // (every image and error map), a PNG of every image at the render's native
  // resolution (the shown component and exposure; error maps with a colour
  // bar) and a JSON with every resolved setting, the metrics, the machine,
  // the thread count and the timings. *folder receives its path.
  Result<void> exportAll(const std::string& dir, std::vector<std::string>* written = nullptr,
                         std::string* folder = nullptr);

  // True when the session changed since the last frame (a new snapshot, a
  // new stage, an error): the caller redraws. busy(): work is in progress
  // (the busy mark animates while the window has focus).
  bool wantsFrame() const;
  bool busy() const;
  // A settings change waits for the controls to rest before it restarts.
  bool restartPending() const;
  // Seconds until a pending restart is due (0 when due or none is pending;
  // 0.25 while text is being typed, which restarts when it is entered).
  double secondsToRestart() const;
  // Sends a pending restart whose controls have rested long enough; the
  // window loop calls it between frames, so that the restart does not wait
  // for a frame (50-70 ms under software GL). True if it sent one.
  bool restartIfDue();
  // A restart's first picture has not arrived yet (for up to 5 s: a session
  // with no scene never sends one): the caller polls often and draws it at
  // once, with no frame-rate cap.
  bool awaitingPicture() const { return restartGeneration_ != firstPictureGeneration_ && sinceChange_.seconds() < 5.0; }
  // Seconds since a control last changed the settings.
  double secondsSinceChange() const { return sinceChange_.seconds(); }
  // The session has a snapshot this studio has not pulled yet.
  bool pictureArrived() const;
  // Why the session cannot render ("" if it can): the first scene did not
  // load. The headless front end exits with it.
  std::string fatalError() const;
  // The first scene has loaded or failed to (fatalError() then says why).
  bool firstSceneSettled() const;
  // Why the reference file in the settings was refused ("" if it is in use,
  // or none was given): the file and the reason. The studio goes on against
  // the live path tracer; the headless front end exits with it.
  std::string referenceError() const;
  // The message next to a rejected control ("" if none).
  const std::string& settingsError() const { return settingsError_; }
  const std::string& errorDialog() const { return errorDialog_; }
  // The open scene's loader warnings (shown under the scene field, exported).
  const std::vector<std::string>& sceneWarnings() const { return sceneWarnings_; }
  bool shortcutsShown() const { return showShortcuts_; }
  // The methods' picture comes from under kRoughShare of the first light
  // set's lights: its panels carry a "ROUGH" badge.
  bool roughPicture() const;
  // The source shows completed light sets kept across a restart that changed
  // only the other method's parameters (never rough).
  bool keptSetsShown(Source s) const;
  static constexpr double kRoughShare = 0.05;
  // The scene field's text (a failed load leaves the typed path there).
  const std::string& sceneField() const { return scenePath_; }
  // The reference field's text: the settings' reference file (the
  // --reference option) until the user types another.
  const std::string& referenceField() const { return referencePathInput_; }
  // The pixel probe's tooltip: where it was last drawn and its size.
  ImVec2 probeMin() const { return probeMin_; }
  ImVec2 probeSize() const { return probeSize_; }
  // Panel i's image does not belong to the current settings.
  bool panelStale(int i) const;
  // False for a source the snapshot has no picture of in component c: under
  // MRCS the VPL variants other than clamped VPL and the lost-energy images
  // (never rendered), and clamped VPL while its columns are pending
  // (Snapshot::vplPending). Such a source is drawn as a labelled box and kept
  // out of colour scales and crops. missingPictureText says why.
  bool hasPicture(Source s, Component c) const;
  std::string missingPictureText(Source s) const;
  // A method row the metrics table shows (and ranks): kMetricSources[i] has
  // an indirect picture of its own (the direct image is every method's).
  bool metricShown(int i) const;
  // Applies settings as if set in the controls (tests and the command line).
  void applySettings(const StudioSettings& settings);
  // The settings the session renders now (the last accepted ones).
  const StudioSettings& acceptedSettings() const { return accepted_; }
  // "Compare with the other preset" (docs/REFERENCE.md, "Presets"): pins the
  // VSL picture shown as Source::Pinned, sets the other preset's method
  // parameters, shows VSL, the pinned VSL and the reference side by side and
  // restarts. False, changing nothing, without an up-to-date VSL picture.
  bool comparePresets();
  // The same with the other cone integral (quadrature or closed form,
  // ManyLightSettings::vslIntegral), from the same light sets.
  bool compareIntegrals();

  // One crop inset of one image, as shown in the Crops tab and exported:
  // the image itself, or (error) the per-pixel error map of the method
  // against the reference under the view's metric. metrics: the crop of the
  // method against the crop of the reference (methods only).
  struct CropItem {
    Source source;
    bool error = false;
    Image image;
    bool hasMetrics = false;
    CompareResult metrics;
  };
  // Crops of the reference, each method and each method's error map, in the
  // given component, for r resolved against the snapshot. *errorMax: the
  // error maps' colour-map maximum (the view's, or the largest 99th
  // percentile of the full maps, as in the exported maps). Empty without a
  // snapshot or for an empty rectangle.
  std::vector<CropItem> buildCrops(const CropRect& r, Component c, float* errorMax) const;

  std::shared_ptr<const Snapshot> snapshot() const { return snap_; }
  Session* session() { return session_.get(); }
  ViewState& view() { return view_; }
  const ViewState& view() const { return view_; }
  void setSnapshotForTesting(std::shared_ptr<const Snapshot> s);
  // The newest LDR-FLIP means (kMetricSources order, then the live path
  // tracer) for the shown component and exposure, if one has been computed
  // for the current snapshot.
  std::optional<std::vector<double>> flipMeans() const;
  // The LDR-FLIP map the view shows for a method (VSL, the VPL variants) in
  // the FLIP display: the newest computed for the shown component and
  // exposure (possibly of an earlier snapshot while a new one is computed);
  // null if none yet. *fresh: it belongs to the current snapshot.
  const Image* flipMap(Source s, bool* fresh = nullptr) const;

  // Screen rectangles of the images drawn in the last frame (for tests and
  // for saving the view).
  struct DrawnImage {
    ImVec2 p0, p1;    // screen rectangle
    ImVec2 uv0, uv1;  // texture coordinates at p0 and p1
    Source source;
  };
  const std::vector<DrawnImage>& drawnImages() const { return drawn_; }
  ImVec2 viewAreaMin() const { return viewMin_; }
  ImVec2 viewAreaMax() const { return viewMax_; }
  // What "Save view" writes: the panels' titles, images and legend as drawn
  // in the last frame (the whole view area before there is a picture).
  ImVec2 panelsMin() const { return panelsMin_; }
  ImVec2 panelsMax() const { return panelsMax_; }
  // "Save view (PNG)": a new PNG in the export folder, written by the next
  // afterRender.
  void saveView();
  // "Export images": exportAll into the export folder; the message names the
  // folder's absolute path, which copyMessagePath() puts on the clipboard.
  void exportFromControls();
  const std::string& message() const { return message_; }
  const std::string& messagePath() const { return messagePath_; }
  void copyMessagePath() const;

 private:
  void controlsPanel();
  // controlsPanel's sections, top to bottom; those returning bool return
  // whether a setting changed (a restart follows once the controls rest).
  void sceneControls();
  bool presetControl();
  bool paramControls(ParamTier tier);
  int heuristicsOn() const;
  void methodNotes() const;
  bool methodControls();
  bool estimatorControls();
  bool renderControls();
  bool referenceControls();
  void viewControls();
  void exportControls();
  void viewToolbar();  // above the images: layout, component, display, Save view, Export
  bool track(const char* key, bool c);
  void viewsPanel();
  float mapScale(int n) const;  // the maps' colour scale for n panels
  int panelCount() const;
  bool legendShown() const;
  ImVec2 panelImageSize(ImVec2 avail, float* panelW) const;
  float viewsHeight(float width, float maxH) const;
  void drawPanels(ImDrawList* dl, ImVec2 origin, float panelW, ImVec2 size, float mapMax);
  static constexpr float kLegendH = 28;  // the colour bar's room under the images
  float chromeH_ = 80;                   // the views' toolbar and status lines, as last drawn
  ImVec2 panelsMin_, panelsMax_;
  DisplayParams displayParams(Source s, float mapMax) const;
  void metricsPanel();
  // metricsPanel's parts, top to bottom.
  void metricsSummary(const Snapshot& s, bool stale);
  void metricsTable(const Snapshot& s);
  // metricsTable's parts: what every row compares against, then its rows.
  struct TableState;
  TableState metricsTableState(const Snapshot& s) const;
  void methodRow(const Snapshot& s, const TableState& t, int i);
  void livePtRow(const Snapshot& s, const TableState& t);
  void biasCells(const Snapshot& s, const TableState& t, BiasNoiseRow row);
  void flipCell(const Snapshot& s, const TableState& t, int i);
  void metricsReferenceNotes(const Snapshot& s);
  void logPanel();
  void cropsPanel();
  void updateCrops();
  void drawCropOutline(ImDrawList* dl);
  Result<void> exportCrops(const std::string& folder, const Image& full, nlohmann::json* out,
                           std::vector<std::string>* files) const;
  Result<void> exportFigure(const std::string& folder, nlohmann::json* out, std::vector<std::string>* files) const;
  // exportAll's parts (studio_export.cpp): the PNGs and error maps (returns
  // the error maps' scale), the FLIP maps (returns their JSON), metrics.json.
  Result<float> exportPictures(const std::string& folder, std::vector<std::string>* files) const;
  Result<nlohmann::json> exportFlipMaps(const std::string& folder, std::vector<std::string>* files) const;
  nlohmann::json exportMetricsJson(float errorMapMax, const nlohmann::json& flipJson,
                                   const nlohmann::json& cropJson) const;
  void plotErrors(const ImVec2& size);
  void restart(bool fromScratch = false);
  void pullSnapshot();
  bool sourceStale(Source s) const;
  void statusBar();
  void referenceProgress(const Snapshot& s, double age);  // statusBar's reference half
  void probe(const ImVec2& mouse);
  void handleViewInput(const ImVec2& origin, const ImVec2& avail, float panelW, float w, float h, int n);
  void handleViewKeys();
  void errorField(const char* key);
  bool pixelValue(Source s, Component c, int x, int y, Vec3* out) const;
  std::string exportStem() const;  // <scene>-<UTC timestamp>
  static std::string uniquePath(const std::string& dir, const std::string& stem, const std::string& ext);
  void updateTextures();
  // The images a source is made of: `whole` for one without components (the
  // missing-energy images), else its direct and indirect parts; all null for
  // Source::Count.
  struct SourceParts {
    const Image *whole = nullptr, *direct = nullptr, *indirect = nullptr;
  };
  SourceParts sourceParts(Source s) const;
  const Image* componentImage(Source s, Component c, Image& scratch) const;
  const Image* referenceImage(Component c, Image& scratch) const;
  void legend(float vmax);
  void updateMetrics();

  StudioOptions options_;
  StudioSettings settings_;
  StudioSettings accepted_;  // what the session renders now
  uint64_t drawnVersion_ = 0;
  std::string settingsError_, settingsErrorKey_;  // the rejected value's reason, and its control
  uint64_t seenRunErrors_ = 0;
  std::string lastControl_ = "width";                  // the control changed last (where a memory refusal is shown)
  bool wipeGrabbed_ = false;                           // the current drag moves the wipe's split line
  bool cropDragging_ = false;                          // the current drag draws a crop rectangle
  bool cropMade_ = false;                              // a crop was just made: show the Crops tab
  CropRect shownCrop_;                                 // the crop the Crops tab was last brought up for
  std::chrono::steady_clock::time_point restartAt_{};  // when a pending settings change restarts
  std::unique_ptr<Session> session_;
  std::shared_ptr<const Snapshot> snap_;
  uint64_t serial_ = 0;
  ViewState view_;
  ViewState uploaded_;  // the view state the textures were built for
  bool texturesDirty_ = true;
  FloatTexture textures_[int(Source::Count)];
  float autoScale_[int(Source::Count)] = {};
  std::vector<DrawnImage> drawn_;
  ImVec2 viewMin_, viewMax_;
  // Controls that are not settings values.
  std::string scenePath_, exportDir_;
  float mapEps_ = 1e-2f;            // the error maps' eps, from the reference (metricError)
  std::string referencePathInput_;  // the reference control's text
  std::string envPathInput_;        // the environment map control's text
  bool environmentControls();       // ui/studio_environment.cpp
  int backgroundSpp_ = 4096;        // samples for "render reference in background"
  void takeSnapshot(std::shared_ptr<const Snapshot> s);
  void noteSceneWarnings(const std::string& scene, const std::vector<std::string>& warnings);
  std::string warningsScene_;               // the scene sceneWarnings_ belong to
  std::vector<std::string> sceneWarnings_;  // the loader's warnings for the open scene
  bool showLog_ = false;                    // bring up the Log tab in the next frame
  bool showShortcuts_ = false;              // the keys' overlay (F1 or ?)
  void shortcutsOverlay();
  void statsPanel();
  ImVec2 probeMin_ = {}, probeSize_ = {};  // the pixel probe's last place and size (kept inside the window)
  ParamMemory paramMemory_;                // the numbers parameters return to from "auto" or "off" (param_widgets.h)
  std::string message_, errorDialog_;
  std::string messagePath_;  // the absolute path message_ names (copied by its button)
  uint64_t seenLoadErrors_ = 0;
  bool savePngPending_ = false;
  std::string savePngPath_;
  double lastFrameMs_ = 0;
  // Metrics of the shown snapshot and component, computed once per change
  // (not every frame).
  const Snapshot* metricsFor_ = nullptr;
  Component metricsComponent_ = Component::Full;
  CompareResult metrics_[4];
  CompareResult livePtMetrics_;  // the live path tracer against a converged reference
  // A VSL picture kept for comparison (Source::Pinned): what it was called
  // ("VSL [default]"), its layers, and the settings that made it.
  struct PinnedVsl {
    std::string name;
    Image direct, indirect;
    StudioSettings settings;
  };
  std::optional<PinnedVsl> pinned_;
  CompareResult pinnedMetrics_;  // against the reference the other rows use
  bool pinnedFits() const;       // of the scene and size shown
  nlohmann::json sourceMetricsJson(Source src) const;
  bool compareButton();  // comparePresets() and compareIntegrals() as buttons
  // Pins the VSL picture shown, applies change to the method parameters,
  // shows VSL, the pinned VSL and the reference side by side and restarts
  // (control names the change for the log). False without a current VSL
  // picture.
  bool pinVslAndRestart(const char* control, const std::function<void(ManyLightSettings&)>& change);
  void pinnedRow(const TableState& t);
  void headerRow(const TableState& t) const;
  std::string roughText() const;
  double lightsPerSet() const;     // of the snapshot shown
  bool vslPictureCurrent() const;  // an up-to-date VSL picture, which the presets comparison pins
  // LDR-FLIP of each method (and the live path tracer) against the reference
  // for the shown component and exposure, computed off the UI thread.
  struct FlipNumbers {
    uint64_t serial = 0;  // of the snapshot it was computed from
    Component component = Component::Indirect;
    float exposure = 0;
    double mean[5] = {};  // kMetricSources, then the live path tracer
    Image map[5];         // the per-pixel maps, in the same order
  };
  std::future<FlipNumbers> flipTask_;
  std::optional<FlipNumbers> flip_;
  uint64_t flipVersion_ = 0, flipUploaded_ = 0;  // results received, and the one in the textures
  void updateFlip();
  bool flipMatchesView() const;
  static FlipNumbers computeFlip(const Snapshot& s, Component c, float exposure);
  double referenceMean_ = 0;
  // Crop insets of the shown snapshot, rebuilt when it, the component, the
  // metric or the rectangle change.
  std::vector<CropItem> crops_;
  float cropErrorMax_ = 1;
  FloatTexture cropTextures_[9];
  const Snapshot* cropsFor_ = nullptr;
  ViewState cropsView_;
  // Responsiveness, measured on the UI thread: change -> picture runs from a
  // control's last change (the settle delay included) or from a restart
  // without one (Restart, a new scene) to the first snapshot of its
  // generation.
  static constexpr int kSettleMs = 50;  // a drag rests this long before a restart
  Stopwatch sinceLaunch_, sinceChange_ = sinceLaunch_;
  bool statusTwoLines_ = false;  // the status line's reference half on a line of its own
  bool changeTimed_ = false;     // sinceChange_ already runs from a control's change
  uint64_t restartGeneration_ = 0, firstPictureGeneration_ = 0;
  double launchToPictureMs_ = -1, restartToPictureMs_ = -1;
};

}  // namespace vsl::ui
