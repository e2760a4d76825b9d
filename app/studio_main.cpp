// vsl-studio: the interactive comparison studio (GLFW + Dear ImGui + OpenGL
// 3.3), or the same UI rendered off-screen through EGL with --headless.
// Without a display it says so and renders the default comparison
// headlessly, exporting files.
//
//   vsl-studio [SCENE] [--headless] [--frames N] [--screenshot PATH]
//              [--export DIR] [--after SECONDS] [--window WxH] [--lights N] [--width W]
//              [--crop X,Y,W,H] [--fresh] [--reference REF.exr] [--background-reference SPP]
//              [--light-sets N] [--estimator NAME] [--mrcs ROWS,CLUSTERS[,MIX]] [--mrcs-...]
//              [--progressive-radius ALPHA]
//
// Without a SCENE, the last session's scene, settings and view come back
// (ui::lastSessionPath(); --fresh ignores it); every run that did not fail
// saves them on quit.
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>
#include <cctype>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <thread>

#include "app/environment_options.h"
#include "app/estimator_options.h"
#include "app/finite_options.h"
#include "app/param_options.h"
#include "core/image_io.h"
#include "core/log.h"
#include "core/presets.h"
#include "core/stopwatch.h"
#include "core/verdict.h"
#include "ui/gl.h"
#include "ui/headless_gl.h"
#include "ui/studio.h"

using namespace vsl;
using Clock = std::chrono::steady_clock;

namespace {

// The studio's own defaults: fewer lights and more batches than `vsl
// render`, so that the first picture comes fast (docs/REFERENCE.md).
ManyLightSettings studioDefaults() {
  ManyLightSettings m;
  m.lights = 5000;
  m.batches = 16;
  m.directSamples = 64;
  return m;
}

struct Args {
  std::string scene;
  bool headless = false;
  int frames = 0;  // 0 = until closed (windowed); headless, until the export or the render is done
  std::string screenshot, exportDir;
  double after = -1;  // seconds; < 0 = when the many-light render is complete
  std::string window = "1280x800";
  bool windowGiven = false;  // --window on the command line: used as given, not fitted to the screen
  // A run that ends by itself (frames or an export): no waiting for input, and
  // its window keeps the size it is given.
  bool scripted() const { return frames > 0 || !exportDir.empty(); }
  // The methods' parameters (core/params.h) at the studio's defaults, and
  // the names of those given on the command line: they win over the last
  // session.
  ManyLightSettings many = studioDefaults();
  std::set<std::string> given;
  int width = 256;
  bool widthGiven = false;                     // on the command line: it wins over the last session
  bool fresh = false;                          // ignore the last session
  bool verbose = false;                        // echo the log's info lines to stderr
  std::string crop;                            // X,Y,W,H in image pixels
  std::string reference;                       // a converged reference EXR
  int referenceMethod = 0;                     // ReferenceMethod of the background reference
  int backgroundReference = 0;                 // spp of a reference rendered into the cache
  int lightSets = StudioSettings().lightSets;  // independent light sets
  bool lightSetsGiven = false;
  std::string preset;                 // --preset (empty: none given)
  bool comparePresets = false;        // --compare-presets: the render, then the other preset beside it
  EstimatorOptions estimatorOptions;  // --estimator, its parameters, --mrcs ROWS,CLUSTERS[,MIX]
  float progressive = 0;              // > 0: the progressive radius with this alpha
  EstimatorSettings estimator;        // resolved from estimatorOptions and progressive
  bool estimatorGiven = false;
  EnvironmentOptions envOptions;  // --env, --sky, --sun and their numbers
  EnvironmentSettings env;        // resolved from envOptions
};

// What the studio starts with: options and the initial view.
struct Launch {
  ui::StudioOptions options;
  ui::ViewState view;
};

std::vector<std::string> bundledScenes() {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(VSL_ASSETS_DIR, ec))
    if (e.path().extension() == ".gltf" || e.path().extension() == ".glb") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

// Drives the frame loop's scripted exits: export, screenshot, frame count.
struct Script {
  const Args& args;
  Stopwatch elapsed = {};
  bool exported = false, failed = false;
  bool compared = false;  // --compare-presets has pinned the first render
  std::string exportFolder = {};
  Stopwatch sinceProgress = {};

  // Returns true when the loop should end after this frame.
  bool afterFrame(ui::Studio& studio, int frame, int fbw, int fbh, bool headlessProgress) {
    double el = elapsed.seconds();
    auto snap = studio.snapshot();
    if (headlessProgress && sinceProgress.seconds() > 5 && snap) {
      sinceProgress.reset();
      char left[48] = "time left not known yet";  // nothing gathered is timed yet (an MRCS set's first picture)
      if (snap->manyLightDone || snap->manyRemainingSeconds > 0)
        std::snprintf(left, sizeof left, "~%.0f s left", snap->manyRemainingSeconds);
      std::fprintf(stderr, "rendering: %zu/%zu lights (%.0f%% of the time, %s), reference %d/%d spp, %.0f s\n",
                   snap->lightsProcessed, snap->lightsTotal, 100.0 * snap->manyFractionDone, left, snap->ptSpp,
                   snap->settings.maxReferenceSpp, el);
    }
    // --compare-presets: once the render is done, it is pinned and the other
    // preset renders beside it; the run goes on until that one is done.
    const bool current = snap && sameImageSettings(snap->settings, studio.acceptedSettings());
    if (args.comparePresets && !compared && current && snap->manyLightDone) {
      compared = studio.comparePresets();
      return false;
    }
    const bool waiting = args.comparePresets && !compared;
    // The render is done (or --after has passed): time for the export, or for
    // the end of a headless run without one.
    const bool ready = args.after >= 0
                           ? el >= args.after
                           : (!waiting && snap && (current || !args.comparePresets) && snap->manyLightDone) || el > 900;
    if (!args.exportDir.empty() && !exported) {
      if (ready) {
        std::string folder;
        std::vector<std::string> written;
        exported = true;
        Result<void> done = studio.exportAll(args.exportDir, &written, &folder);
        if (done) {
          for (const std::string& w : written) std::fprintf(stderr, "wrote %s\n", w.c_str());
          exportFolder = folder;
        } else {
          std::fprintf(
              stderr, "error: export failed: %s%s\n", done.error().c_str(),
              snap ? "" : " (no picture yet: give --after more seconds, or leave it out to wait for the render)");
          failed = true;
          return true;
        }
        if (!args.screenshot.empty() && !saveScreenshot(fbw, fbh)) return failed = true;
        if (args.frames == 0) return true;
      }
    }
    if (args.frames > 0 && frame + 1 >= args.frames) {
      if (!args.screenshot.empty() && !saveScreenshot(fbw, fbh)) failed = true;
      return true;
    }
    // Headless with neither an export nor a frame count: the run ends when the
    // many-light render is done (or at --after), with the screenshot if asked.
    if (headlessProgress && args.exportDir.empty() && args.frames == 0 && ready) {
      if (!args.screenshot.empty() && !saveScreenshot(fbw, fbh)) failed = true;
      return true;
    }
    return false;
  }

  bool saveScreenshot(int fbw, int fbh) {
    std::vector<uint8_t> px = ui::readFramebuffer(0, 0, fbw, fbh, fbh);
    Result<void> written = writePngRgb8(args.screenshot, fbw, fbh, px);
    if (written) {
      std::fprintf(stderr, "wrote %s\n", args.screenshot.c_str());
      return true;
    }
    std::fprintf(stderr, "error: %s\n", written.error().c_str());
    return false;
  }

  // Headless runs end at once, with exit status 1, when they cannot succeed:
  // the first scene did not load (missing, unreadable, no emitters), the
  // reference file was refused, the settings were refused, or the render
  // failed.
  bool fatal(const ui::Studio& studio) {
    std::string why = studio.fatalError();
    // A reference given on the command line that cannot be used (another
    // size, no indirect layer): the numbers asked for cannot be made.
    if (why.empty() && !args.reference.empty()) why = studio.referenceError();
    if (why.empty() && !studio.settingsError().empty() && !studio.snapshot()) why = studio.settingsError();
    if (why.empty() && !studio.errorDialog().empty() && !studio.busy() && !studio.snapshot())
      why = studio.errorDialog();
    if (why.empty()) return false;
    std::fprintf(stderr, "error: %s\n", why.c_str());
    failed = true;
    return true;
  }
};

// The preset given (--preset), then the methods' options given one by one,
// which override it (docs/REFERENCE.md, "Presets").
void applyGiven(const Args& a, ManyLightSettings& m) {
  if (std::optional<Preset> p = parsePreset(a.preset)) applyPreset(*p, m);
  for (const std::string& name : a.given)
    if (const Param<ManyLightSettings>* p = manyLightParams().find(name)) p->set(m, p->get(a.many));
}

ui::StudioOptions studioOptions(const Args& a) {
  ui::StudioOptions o;
  o.scene = a.scene;
  o.settings.scene = a.scene;
  o.bundled = bundledScenes();
  if (!a.exportDir.empty()) o.exportDir = a.exportDir;
  o.settings.many = a.many;  // the preset and the parameters given are in it
  o.settings.many.width = a.width;
  o.settings.maxReferenceSpp = 1024;
  o.settings.referencePath = a.reference;
  o.settings.backgroundReferenceSpp = a.backgroundReference;
  o.settings.referenceMethod = a.referenceMethod;
  o.settings.lightSets = a.lightSets;
  o.settings.estimator = a.estimator;
  o.settings.env = a.env;
  return o;
}

// Saves the scene, settings and view for the next start without a scene
// argument. Not after a run that failed (its scene may not even load).
void rememberSession(const ui::Studio& studio) {
  if (!studio.fatalError().empty()) return;
  const std::string path = ui::lastSessionPath();
  if (path.empty()) {
    log::warning("the last session is not saved: neither XDG_CONFIG_HOME nor HOME is set");
    return;
  }
  if (Result<void> saved = ui::saveLastSession(path, studio.acceptedSettings(), studio.view()); !saved)
    log::warning("the last session is not saved: " + saved.error());
}

// Without a scene argument: the last session's scene, settings and view
// (lights and width given on the command line win). A scene that no longer
// exists gives the default scene; a corrupt file gives a warning and the
// defaults.
void restoreLastSession(const Args& a, Launch* launch) {
  const std::string path = ui::lastSessionPath();
  StudioSettings s = launch->options.settings;
  ui::ViewState v = launch->view;
  std::string warning;
  if (!ui::loadLastSession(path, &s, &v, &warning)) {
    if (!warning.empty()) log::warning(warning);
    return;
  }
  std::error_code ec;
  if (!std::filesystem::is_regular_file(s.scene, ec)) {
    log::warning("the last session's scene " + s.scene + " no longer exists; opening the default scene " + a.scene);
    s.scene = a.scene;
  }
  if (a.widthGiven) {
    s.many.width = a.width;
    s.many.height = 0;
  }
  if (a.lightSetsGiven) s.lightSets = a.lightSets;
  applyGiven(a, s.many);
  if (a.estimatorGiven) s.estimator = a.estimator;
  if (!(a.env == EnvironmentSettings())) s.env = a.env;  // environment options given win
  s.referencePath = a.reference;                         // the reference is this run's, never the last session's
  s.backgroundReferenceSpp = a.backgroundReference;
  s.referenceMethod = a.referenceMethod;
  v.crop = launch->view.crop;  // --crop applies to this run only
  launch->options.settings = s;
  launch->options.scene = s.scene;
  launch->view = v;
  std::fprintf(stderr, "vsl-studio: restored the last session (%s, %u lights, width %d) from %s; --fresh ignores it\n",
               std::filesystem::path(s.scene).filename().c_str(), s.many.lights, s.many.width, path.c_str());
}

int runHeadless(const Args& a, const Launch& launch, int w, int h) {
  ui::HeadlessGL gl;
  if (Result<void> ready = gl.init(w, h); !ready) {
    std::fprintf(stderr, "error: headless OpenGL: %s\n", ready.error().c_str());
    return 1;
  }
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGuiIO& io = ImGui::GetIO();
  io.IniFilename = nullptr;
  io.DisplaySize = ImVec2(float(w), float(h));
  ImGui::StyleColorsDark();
  ImGui_ImplOpenGL3_Init("#version 330 core");
  int result = 0;
  {
    ui::Studio studio(launch.options);
    studio.view() = launch.view;
    Script script{a};
    for (int frame = 0;; ++frame) {
      io.DeltaTime = 1.0f / 30;
      ImGui_ImplOpenGL3_NewFrame();
      ImGui::NewFrame();
      studio.frame();
      ImGui::Render();
      gl.bind();
      glClearColor(0.08f, 0.08f, 0.09f, 1);
      glClear(GL_COLOR_BUFFER_BIT);
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
      studio.afterRender(w, h);
      if (script.fatal(studio) || script.afterFrame(studio, frame, w, h, true)) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(33));  // the renderer gets the cores
    }
    // A run that ended (--frames) while its first scene was still loading
    // waits for the load, so that a scene that cannot load ends it with exit
    // status 1, as it would have a longer run.
    if (!script.failed) {
      for (int i = 0; i < 6000 && !studio.firstSceneSettled(); ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      if (!studio.firstSceneSettled()) {
        std::fprintf(stderr, "error: %s: still loading after the run's frames and 60 s more\n", a.scene.c_str());
        script.failed = true;
      } else {
        script.fatal(studio);
      }
    }
    result = script.failed ? 1 : 0;
    if (!script.failed) rememberSession(studio);
    // The comparison's verdict (core/verdict.h) closes a headless run.
    if (auto snap = studio.snapshot(); !script.failed && snap && snap->width > 0) {
      std::fprintf(stderr, "verdict (%s, against %s):\n", snap->settings.scene.c_str(), snap->referenceSource.c_str());
      for (const std::string& line : verdictReport(*snap)) std::fprintf(stderr, "  %s\n", line.c_str());
    }
    if (!script.exportFolder.empty())
      std::fprintf(stderr, "vsl-studio: exported to %s/\n", script.exportFolder.c_str());
  }
  ui::shutdown();
  ImGui_ImplOpenGL3_Shutdown();
  ImGui::DestroyContext();
  return result;
}

ui::Studio* gStudio = nullptr;
// Set by every input callback: the loop draws a few frames after any input,
// so that a press and its release (a short click) both reach ImGui.
bool gInput = false;
// Dear ImGui 1.86 reads key state once per frame, so a key pressed and
// released between two frames (a quick tap, or xdotool) would never be
// seen. Keys pressed since the last frame are held down for one frame.
std::vector<int> gPressed, gReleaseNext;
void holdShortKeyPresses() {
  ImGuiIO& io = ImGui::GetIO();
  for (int k : gReleaseNext)
    if (std::find(gPressed.begin(), gPressed.end(), k) == gPressed.end()) io.KeysDown[k] = false;
  gReleaseNext.clear();
  // Modifiers are not held: text typed right after them would read as shortcuts.
  for (int k : gPressed)
    if (!io.KeysDown[k] && (k < GLFW_KEY_LEFT_SHIFT || k > GLFW_KEY_RIGHT_SUPER)) {
      io.KeysDown[k] = true;
      gReleaseNext.push_back(k);
    }
  gPressed.clear();
}
void onDrop(GLFWwindow*, int count, const char** paths) {
  gInput = true;
  // An .exr sets the environment light; anything else opens as a scene.
  if (gStudio && count > 0) {
    std::string ext = std::filesystem::path(paths[0]).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (ext == ".exr")
      gStudio->openEnvironment(paths[0]);
    else
      gStudio->openScene(paths[0]);
  }
}
// Installed before the ImGui backend, which chains to them. Ctrl+Q quits.
void onKey(GLFWwindow* win, int key, int, int action, int mods) {
  gInput = true;
  if (action == GLFW_PRESS && key >= 0 && key < int(IM_ARRAYSIZE(ImGuiIO::KeysDown))) gPressed.push_back(key);
  if (key == GLFW_KEY_Q && action == GLFW_PRESS && (mods & GLFW_MOD_CONTROL)) glfwSetWindowShouldClose(win, 1);
}
void onMouseButton(GLFWwindow*, int, int, int) { gInput = true; }
void onCursor(GLFWwindow*, double, double) { gInput = true; }
void onScroll(GLFWwindow*, double, double) { gInput = true; }
void onChar(GLFWwindow*, unsigned) { gInput = true; }
void onWindowEvent(GLFWwindow*, int) { gInput = true; }
void onRefresh(GLFWwindow*) { gInput = true; }

// Quit within a second whatever the worker is doing (docs/USAGE.md): it is
// asked to stop and given kQuitWaitSeconds. A stage that cannot be
// interrupted (parsing a huge scene file, building a k-d tree over millions
// of lights) would hold the join for longer, so then the process exits
// without waiting; the session was saved before, so nothing is lost.
constexpr double kQuitWaitSeconds = 0.75;
void quitPromptly(GLFWwindow* win, ui::Studio& studio) {
  glfwHideWindow(win);
  Stopwatch sinceQuit;
  if (studio.session() && studio.session()->shutdown(kQuitWaitSeconds)) {
    std::fprintf(stderr, "vsl-studio: the renderer stopped %.0f ms after quit\n", 1000 * sinceQuit.seconds());
  } else if (studio.session()) {
    std::fprintf(stderr, "vsl-studio: the renderer did not stop within %.2f s (%s); exiting without waiting\n",
                 kQuitWaitSeconds, studio.session()->status().stage.c_str());
    std::fflush(stderr);
    std::_Exit(0);
  }
}
void onGlfwError(int code, const char* msg) { log::warning("GLFW error " + std::to_string(code) + ": " + msg); }

// A GL 3.3 window with ImGui on it and our input callbacks; null (GLFW
// terminated) if there is no window system or it refuses. fitScreen: the
// size is a default, made to fit the primary monitor's work area (less a
// margin for the window's frame), so that a 1280x800 window does not run off
// a smaller screen with the reference panel and the status line cut off.
GLFWwindow* openWindow(int w, int h, bool fitScreen) {
  glfwSetErrorCallback(onGlfwError);
  if (!glfwInit()) return nullptr;
  if (fitScreen)
    if (GLFWmonitor* monitor = glfwGetPrimaryMonitor()) {
      int x = 0, y = 0, aw = 0, ah = 0;
      glfwGetMonitorWorkarea(monitor, &x, &y, &aw, &ah);
      if (aw > 0 && ah > 0) {
        w = std::clamp(aw - 16, 640, w);
        h = std::clamp(ah - 48, 480, h);
      }
    }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  GLFWwindow* win = glfwCreateWindow(w, h, "vsl-studio", nullptr, nullptr);
  if (!win) {
    glfwTerminate();
    return nullptr;
  }
  glfwMakeContextCurrent(win);
  glfwSwapInterval(1);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui::StyleColorsDark();
  glfwSetKeyCallback(win, onKey);
  glfwSetMouseButtonCallback(win, onMouseButton);
  glfwSetCursorPosCallback(win, onCursor);
  glfwSetScrollCallback(win, onScroll);
  glfwSetCharCallback(win, onChar);
  glfwSetWindowFocusCallback(win, onWindowEvent);
  glfwSetCursorEnterCallback(win, onWindowEvent);
  glfwSetWindowRefreshCallback(win, onRefresh);
  ImGui_ImplGlfw_InitForOpenGL(win, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");
  return win;
}

// One frame of the studio's UI rendered into the window's back buffer (not
// yet swapped); the framebuffer's size in *fbw and *fbh.
void renderFrame(GLFWwindow* win, ui::Studio& studio, int* fbw, int* fbh) {
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  studio.frame();
  ImGui::Render();
  glfwGetFramebufferSize(win, fbw, fbh);
  glViewport(0, 0, *fbw, *fbh);
  glClearColor(0.08f, 0.08f, 0.09f, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  studio.afterRender(*fbw, *fbh);
}

// The studio's frame loop until the window closes or the script ends it.
// Returns the exit code.
int windowedLoop(GLFWwindow* win, const Args& a, const Launch& launch) {
  ui::Studio studio(launch.options);
  studio.view() = launch.view;
  gStudio = &studio;
  glfwSetDropCallback(win, onDrop);
  Script script{a};
  double busyMs = 0;
  int frames = 0, settle = 3;  // frames still owed after input
  const bool scripted = a.scripted();
  Stopwatch sinceDraw;
  for (int frame = 0; !glfwWindowShouldClose(win);) {
    // Idle when idle: sleep in the event queue; draw after input (a few
    // frames, so a click's press and release both land), for news from the
    // renderer (at most 4 per second focused, 1 unfocused; a restart's first
    // picture at once), and once a second while busy and focused for the
    // busy mark. Minimised: never.
    // A frame costs ~50-60 ms of a core under software GL: while a restart's
    // first picture is awaited, the session's other news (its stages) waits
    // for the usual rate, so that the first batch has the cores.
    const bool iconified = glfwGetWindowAttrib(win, GLFW_ICONIFIED) != 0;
    const bool focused = glfwGetWindowAttrib(win, GLFW_FOCUSED) != 0;
    // For the first 250 ms of a restart's wait for its first picture, the
    // frames owed after input wait too (the picture, or the 4-per-second
    // rate, still draws one): the frames that follow a slider's drag would
    // otherwise take a core from the first batch.
    // A drag's restart, once the pointer rests, is sent between frames when
    // it falls due (waiting for it instead of drawing the frames owed), not
    // at the end of the next 50-70 ms frame.
    const bool holding = !scripted && ((!studio.restartPending() && studio.awaitingPicture() &&
                                        studio.secondsSinceChange() < 0.25 && !studio.pictureArrived()) ||
                                       (studio.restartPending() && !gInput));
    if (scripted || (settle > 0 && !holding))
      glfwPollEvents();
    else
      glfwWaitEventsTimeout(studio.awaitingPicture()  ? 0.005
                            : studio.restartPending() ? std::max(0.001, studio.secondsToRestart())
                            : focused                 ? 0.25
                                                      : 1.0);
    holdShortKeyPresses();
    const bool input = gInput;
    if (gInput) {
      gInput = false;
      settle = 3;
    }
    if (!scripted && !input && studio.restartIfDue()) continue;
    const double since = sinceDraw.seconds();
    const bool news =
        studio.wantsFrame() && (studio.restartPending() || (studio.awaitingPicture() && studio.pictureArrived()) ||
                                since >= (focused ? 0.25 : 1.0));
    const bool tick = focused && studio.busy() && since >= 1.0;
    if (!scripted && (settle == 0 || holding) && (iconified || (!news && !tick))) continue;
    if (settle > 0) --settle;
    if (!studio.errorDialog().empty()) settle = std::max(settle, 1);  // a dialog needs a frame to size itself
    sinceDraw.reset();
    const Clock::time_point frameEnd = Clock::now() + std::chrono::milliseconds(16);
    int fbw, fbh;
    renderFrame(win, studio, &fbw, &fbh);
    if (script.afterFrame(studio, frame, fbw, fbh, false)) break;
    glfwSwapBuffers(win);
    busyMs += 1000 * sinceDraw.seconds();
    ++frames;
    ++frame;
    // Cap the UI at ~60 frames per second so the renderer keeps the cores.
    std::this_thread::sleep_until(frameEnd);
  }
  if (!script.failed) rememberSession(studio);
  quitPromptly(win, studio);
  gStudio = nullptr;
  if (frames > 0)
    std::fprintf(stderr, "vsl-studio: %d frames, mean UI frame time %.1f ms (events, UI, GL render, swap)\n", frames,
                 busyMs / frames);
  return script.failed ? 1 : 0;
}

void closeWindow(GLFWwindow* win) {
  ui::shutdown();
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(win);
  glfwTerminate();
}

int runWindowed(const Args& a, const Launch& launch, int w, int h, bool* fellBack) {
  // A scripted run keeps the size it is given, so that its screenshots do not
  // depend on the screen.
  GLFWwindow* win = openWindow(w, h, !a.windowGiven && !a.scripted());
  if (!win) {
    *fellBack = true;
    return 0;
  }
  const int rc = windowedLoop(win, a, launch);
  closeWindow(win);
  return rc;
}

// The command line, into a.
void addOptions(CLI::App& app, Args& a) {
  app.add_option("scene", a.scene, "Scene to open (default: the bundled cornell-glossy)");
  // Before the parameters: CLI11 runs options in the order they are
  // defined, so those given one by one override the preset.
  app.add_option_function<std::string>(
         "--preset",
         [&a](const std::string& v) {
           a.preset = v;
           if (std::optional<Preset> p = parsePreset(v)) applyPreset(*p, a.many);
         },
         "The methods' parameters: paper (VSL and clamped VPL as Hasan et al. 2009 published them) or default "
         "(the measured best); parameters given one by one override it")
      ->check(CLI::IsMember(presetNames()))
      ->default_str("default");
  addParamOptions(&app, manyLightParams(), a.many, &a.given);
  app.add_flag("--headless", a.headless, "Render the UI off-screen through EGL (no window)");
  addEnvironmentOptions(&app, a.envOptions);
  app.add_option("--frames", a.frames, "Exit after this many frames")->check(CLI::Range(1, 10000000));
  app.add_option("--screenshot", a.screenshot, "Save the last frame as PNG");
  app.add_option("--export", a.exportDir, "Export EXR, JSON and PNG to this directory, then exit");
  app.add_option("--after", a.after, "Export after this many seconds (default: when the many-light render is done)")
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--window", a.window, "Window or off-screen size, WxH")->default_str("1280x800");
  app.add_option("--width", a.width, "Initial render width")->default_str("256")->check(CLI::Range(8, 16384));
  app.add_option("--crop", a.crop,
                 "Crop inset X,Y,W,H in image pixels: exports include magnified crops of every image, their "
                 "metrics and a crop figure");
  app.add_option("--reference", a.reference,
                 "A converged reference EXR of the render's size: with an 'indirect' layer (vsl reference writes one) "
                 "the indirect component is compared, with only a full image (another renderer's) the full one; "
                 "default: a matching cached reference, else the live path tracer. Headless, a file that cannot be "
                 "used (another size or scene, no image layer) ends the run with exit status 1")
      ->check(CLI::ExistingFile);
  addParamOption(&app, runParam("light-sets"), a.lightSets);
  addParamOption(&app, runParam("background-reference"), a.backgroundReference);
  addParamOption(&app, runParam("reference-method"), a.referenceMethod);
  // Start with this estimator (default: brute-force batches); with MRCS,
  // each light set is one MRCS render and the sets are averaged.
  addEstimatorOptions(&app, a.estimatorOptions);
  addParamOption(&app, runParam("progressive-radius"), a.progressive);
  app.add_flag("--compare-presets", a.comparePresets,
               "Once the render is done, pin its VSL picture and render VSL with the other preset beside it (the "
               "\"Compare with the ... preset\" button); an export or screenshot waits for the second render");
  app.add_flag("--fresh", a.fresh, "Start with the defaults, not the last session's scene and settings");
  app.add_flag("--verbose", a.verbose,
               "Echo the log's info lines to stderr (stages, each restart's change -> picture time)");
}

// The estimator options and --progressive-radius into a.estimator. Returns
// 0, or 2 after saying what is wrong.
int resolveEstimator(Args& a, bool progressiveGiven) {
  const EstimatorOptions& o = a.estimatorOptions;
  Result<EstimatorSettings> chosen = resolveEstimatorOptions(o);
  if (!chosen) {
    std::fprintf(stderr, "error: %s\n", chosen.error().c_str());
    return 2;
  }
  EstimatorSettings& e = a.estimator;
  e = *chosen;
  if (progressiveGiven) {
    e.progressiveRadius = true;
    e.alpha = a.progressive;
  }
  if (Result<void> v = e.validate(); !v) {
    std::fprintf(stderr, "error: %s\n", v.error().c_str());  // names the setting and its range
    return 2;
  }
  a.estimatorGiven = !o.name.empty() || !o.given.empty() || !o.texts.empty() || progressiveGiven;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vsl-studio: VSL, clamped VPL and a path-traced reference, side by side"};
  Args a;
  addOptions(app, a);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "error: %s%s\n\n%s", e.what(), nearestOptionHint(app, e.what()).c_str(), app.help().c_str());
    return 2;
  }
  if (Result<EnvironmentSettings> env = resolveEnvironmentOptions(a.envOptions); env)
    a.env = *env;
  else {
    std::fprintf(stderr, "error: %s\n", env.error().c_str());
    return 2;
  }
  int w = 1280, h = 800;
  char extra = 0;  // digits only, at most five each: no trailing text, no wrap-around
  if (a.window.size() > 11 || a.window.find_first_not_of("0123456789x") != std::string::npos ||
      std::sscanf(a.window.c_str(), "%dx%d%c", &w, &h, &extra) != 2 || w < 320 || h < 240 || w > 8192 || h > 8192) {
    std::fprintf(stderr, "error: --window must be WxH between 320x240 and 8192x8192 (got '%s')\n", a.window.c_str());
    return 2;
  }
  a.windowGiven = app.count("--window") > 0;
  a.widthGiven = app.count("--width") > 0;
  a.lightSetsGiven = app.count("--light-sets") > 0;
  if (std::string bad = nonFiniteOption(app); !bad.empty()) {
    std::fprintf(stderr, "error: %s\n", bad.c_str());
    return 2;
  }
  for (const char* name : {"--export", "--screenshot", "--reference"}) {
    if (app.count(name) > 0 && app[name]->as<std::string>().empty()) {
      std::fprintf(stderr, "error: %s: the path is empty\n", name);
      return 2;
    }
  }
  if (int rc = resolveEstimator(a, a.progressive > 0); rc != 0) return rc;
  if (Result<void> e = a.estimator.validateWith(a.many); !e) {
    std::fprintf(stderr, "error: --%s\n", e.error().c_str());
    return 2;
  }
  Launch launch;
  if (!a.crop.empty()) {
    ui::CropRect& c = launch.view.crop;
    char end = 0;
    if (std::sscanf(a.crop.c_str(), "%d,%d,%d,%d%c", &c.x, &c.y, &c.w, &c.h, &end) != 4 || c.x < 0 || c.y < 0 ||
        c.w < 1 || c.h < 1 || c.x > 16384 || c.y > 16384 || c.w > 16384 || c.h > 16384) {
      std::fprintf(stderr, "error: --crop must be X,Y,W,H in image pixels, W and H at least 1 (got '%s')\n",
                   a.crop.c_str());
      return 2;
    }
  }
  log::setEchoLevel(a.verbose ? LogLevel::Info : LogLevel::Warning);
  const bool sceneGiven = !a.scene.empty();
  if (!sceneGiven) a.scene = std::string(VSL_ASSETS_DIR) + "/cornell-glossy.gltf";
  launch.options = studioOptions(a);
  launch.options.defaults = launch.options.settings;
  if (!sceneGiven && !a.fresh) restoreLastSession(a, &launch);

  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  bool noDisplay = (!display || !*display) && (!wayland || !*wayland);
  bool fallback = false;
  if (!a.headless && !noDisplay) {
    if (app.count("--after") && a.exportDir.empty())
      std::fprintf(stderr,
                   "warning: --after times an export (--export) or the end of a headless run (--headless); with a "
                   "window and no export it does nothing\n");
    int rc = runWindowed(a, launch, w, h, &fallback);
    if (!fallback) return rc;
  }
  if (!a.headless) {
    // No display (or the window system refused): say so, then do the
    // headless job: render the default comparison and export it.
    std::fprintf(stderr, "vsl-studio: no display available (%s); rendering the comparison headlessly instead.\n",
                 noDisplay ? "DISPLAY is not set" : "the window could not be created");
    if (a.exportDir.empty()) a.exportDir = "out/studio";
    if (a.screenshot.empty()) a.screenshot = a.exportDir + "/studio-ui.png";
    std::error_code ec;
    std::filesystem::create_directories(a.exportDir, ec);
  }
  return runHeadless(a, launch, w, h);
}
