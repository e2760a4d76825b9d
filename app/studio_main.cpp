// vsl-studio: the interactive comparison studio (GLFW + Dear ImGui + OpenGL
// 3.3), or the same UI rendered off-screen through EGL with --headless.
// Without a display it says so and renders the default comparison
// headlessly, exporting files.
//
//   vsl-studio [SCENE] [--headless] [--frames N] [--screenshot PATH]
//              [--export DIR] [--after SECONDS] [--window WxH] [--lights N] [--width W]
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <thread>

#include "core/image_io.h"
#include "core/log.h"
#include "ui/gl.h"
#include "ui/headless_gl.h"
#include "ui/studio.h"

using namespace vsl;
using Clock = std::chrono::steady_clock;

namespace {

struct Args {
  std::string scene;
  bool headless = false;
  int frames = 0;  // 0 = until closed (windowed) or until the export (headless)
  std::string screenshot, exportDir;
  double after = -1;  // seconds; < 0 = when the many-light render is complete
  std::string window = "1280x800";
  uint32_t lights = 5000;
  int width = 256;
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
  Clock::time_point start = Clock::now();
  bool exported = false;
  Clock::time_point lastProgress = Clock::now();

  // Returns true when the loop should end after this frame.
  bool afterFrame(ui::Studio& studio, int frame, int fbw, int fbh, bool headlessProgress) {
    double el = std::chrono::duration<double>(Clock::now() - start).count();
    auto snap = studio.snapshot();
    if (headlessProgress && std::chrono::duration<double>(Clock::now() - lastProgress).count() > 5 && snap) {
      lastProgress = Clock::now();
      std::fprintf(stderr, "rendering: batch %d/%d, %zu/%zu lights, reference %d spp, %.0f s\n", snap->batchesDone,
                   snap->batchCount, snap->lightsProcessed, snap->lightsTotal, snap->ptSpp, el);
    }
    if (!args.exportDir.empty() && !exported) {
      bool ready = args.after >= 0 ? el >= args.after : (snap && snap->manyLightDone) || el > 900;
      if (ready) {
        std::string err;
        std::vector<std::string> written;
        if (studio.exportAll(args.exportDir, &err, &written)) {
          for (const std::string& w : written) std::fprintf(stderr, "wrote %s\n", w.c_str());
        } else {
          std::fprintf(stderr, "error: export failed: %s\n", err.c_str());
        }
        exported = true;
        if (!args.screenshot.empty()) saveScreenshot(fbw, fbh);
        if (args.frames == 0) return true;
      }
    }
    if (args.frames > 0 && frame + 1 >= args.frames) {
      if (!args.screenshot.empty()) saveScreenshot(fbw, fbh);
      return true;
    }
    return false;
  }

  void saveScreenshot(int fbw, int fbh) {
    std::vector<uint8_t> px = ui::readFramebuffer(0, 0, fbw, fbh, fbh);
    std::string err;
    if (writePngRgb8(args.screenshot, fbw, fbh, px, &err))
      std::fprintf(stderr, "wrote %s\n", args.screenshot.c_str());
    else
      std::fprintf(stderr, "error: %s\n", err.c_str());
  }
};

ui::StudioOptions studioOptions(const Args& a) {
  ui::StudioOptions o;
  o.scene = a.scene;
  o.bundled = bundledScenes();
  if (!a.exportDir.empty()) o.exportDir = a.exportDir;
  o.settings.many.lights = a.lights;
  o.settings.many.width = a.width;
  o.settings.many.batches = 16;
  o.settings.many.directSamples = 64;
  o.settings.maxReferenceSpp = 1024;
  return o;
}

int runHeadless(const Args& a, int w, int h) {
  ui::HeadlessGL gl;
  std::string err;
  if (!gl.init(w, h, &err)) {
    std::fprintf(stderr, "error: headless OpenGL: %s\n", err.c_str());
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
    ui::Studio studio(studioOptions(a));
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
      if (script.afterFrame(studio, frame, w, h, true)) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(33));  // the renderer gets the cores
    }
  }
  ui::shutdown();
  ImGui_ImplOpenGL3_Shutdown();
  ImGui::DestroyContext();
  return result;
}

ui::Studio* gStudio = nullptr;
void onDrop(GLFWwindow*, int count, const char** paths) {
  if (gStudio && count > 0) gStudio->openScene(paths[0]);
}
// Ctrl+Q quits. Installed before the ImGui backend, which chains to it.
void onKey(GLFWwindow* win, int key, int, int action, int mods) {
  if (key == GLFW_KEY_Q && action == GLFW_PRESS && (mods & GLFW_MOD_CONTROL)) glfwSetWindowShouldClose(win, 1);
}
void onGlfwError(int code, const char* msg) { log::warning("GLFW error " + std::to_string(code) + ": " + msg); }

int runWindowed(const Args& a, int w, int h, bool* fellBack) {
  glfwSetErrorCallback(onGlfwError);
  if (!glfwInit()) {
    *fellBack = true;
    return 0;
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  GLFWwindow* win = glfwCreateWindow(w, h, "vsl-studio", nullptr, nullptr);
  if (!win) {
    glfwTerminate();
    *fellBack = true;
    return 0;
  }
  glfwMakeContextCurrent(win);
  glfwSwapInterval(1);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui::StyleColorsDark();
  glfwSetKeyCallback(win, onKey);
  ImGui_ImplGlfw_InitForOpenGL(win, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");
  {
    ui::Studio studio(studioOptions(a));
    gStudio = &studio;
    glfwSetDropCallback(win, onDrop);
    Script script{a};
    double busyMs = 0;
    int frames = 0;
    for (int frame = 0; !glfwWindowShouldClose(win); ++frame) {
      auto t0 = Clock::now();
      glfwPollEvents();
      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      studio.frame();
      ImGui::Render();
      int fbw, fbh;
      glfwGetFramebufferSize(win, &fbw, &fbh);
      glViewport(0, 0, fbw, fbh);
      glClearColor(0.08f, 0.08f, 0.09f, 1);
      glClear(GL_COLOR_BUFFER_BIT);
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
      studio.afterRender(fbw, fbh);
      if (script.afterFrame(studio, frame, fbw, fbh, false)) break;
      glfwSwapBuffers(win);
      busyMs += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      ++frames;
      // Cap the UI at ~60 frames per second so the renderer keeps the cores.
      std::this_thread::sleep_until(t0 + std::chrono::milliseconds(16));
    }
    gStudio = nullptr;
    if (frames > 0)
      std::fprintf(stderr, "vsl-studio: %d frames, mean UI frame time %.1f ms (events, UI, GL render, swap)\n", frames,
                   busyMs / frames);
  }
  ui::shutdown();
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(win);
  glfwTerminate();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vsl-studio: VSL, clamped VPL and a path-traced reference, side by side"};
  Args a;
  app.add_option("scene", a.scene, "Scene to open (default: the bundled cornell-glossy)");
  app.add_flag("--headless", a.headless, "Render the UI off-screen through EGL (no window)");
  app.add_option("--frames", a.frames, "Exit after this many frames")->check(CLI::Range(1, 10000000));
  app.add_option("--screenshot", a.screenshot, "Save the last frame as PNG");
  app.add_option("--export", a.exportDir, "Export EXR, JSON and PNG to this directory, then exit");
  app.add_option("--after", a.after, "Export after this many seconds (default: when the many-light render is done)")
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--window", a.window, "Window or off-screen size, WxH")->default_str("1280x800");
  app.add_option("--lights", a.lights, "Initial light count")->default_str("5000")->check(CLI::Range(1, 50000000));
  app.add_option("--width", a.width, "Initial render width")->default_str("256")->check(CLI::Range(8, 16384));
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "error: %s\n\n%s", e.what(), app.help().c_str());
    return 2;
  }
  int w = 1280, h = 800;
  if (std::sscanf(a.window.c_str(), "%dx%d", &w, &h) != 2 || w < 320 || h < 240 || w > 8192 || h > 8192) {
    std::fprintf(stderr, "error: --window must be WxH between 320x240 and 8192x8192 (got '%s')\n", a.window.c_str());
    return 2;
  }
  if (a.scene.empty()) a.scene = std::string(VSL_ASSETS_DIR) + "/cornell-glossy.gltf";
  log::setEchoLevel(LogLevel::Warning);

  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  bool noDisplay = (!display || !*display) && (!wayland || !*wayland);
  bool fallback = false;
  if (!a.headless && !noDisplay) {
    int rc = runWindowed(a, w, h, &fallback);
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
  int rc = runHeadless(a, w, h);
  if (rc == 0 && !a.exportDir.empty())
    std::fprintf(stderr, "vsl-studio: the comparison (EXR with every layer, JSON metrics, PNGs) is in %s/\n",
                 a.exportDir.c_str());
  return rc;
}
