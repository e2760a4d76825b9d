// The studio under long random use (a "monkey" test): a driver feeds the
// studio random input through headless EGL frames for a set time: drags,
// clicks, wheel and keys, every registered parameter and both presets,
// scene loads of good and bad files, exports, view changes, window sizes and
// the preset comparison. It passes when
//   - nothing crashes and no sanitizer reports (the test runs under
//     ASan+UBSan in `scripts/test.sh --monkey`);
//   - resident memory at the end is within 10% of its level after the
//     warm-up (two minutes, or a fifth of a shorter run), each measured in
//     the same settled state (Monkey::settledMiB);
//   - every export is complete (its EXR opens, its JSON parses);
//   - once the input stops, the picture shown is of the last settings.
// VSL_MONKEY_SECONDS (default 60) and VSL_MONKEY_SEED (default 1) set the
// run; the seed and the figures are printed, so a finding can be replayed.
#include <gtest/gtest.h>
#include <imgui.h>
#include <imgui_impl_opengl3.h>
#include <imgui_internal.h>

#include <malloc.h>
#include <unistd.h>
#if defined(__SANITIZE_ADDRESS__)
// The sanitizer runtime's allocator statistics (its
// sanitizer/allocator_interface.h is not installed with GCC here).
extern "C" size_t __sanitizer_get_current_allocated_bytes();
extern "C" size_t __sanitizer_get_heap_size();
#endif
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "core/image_io.h"
#include "core/memory_budget.h"
#include "core/params.h"
#include "core/presets.h"
#include "core/session.h"
#include "core/stopwatch.h"
#include "ui/headless_gl.h"
#include "ui/studio.h"

using namespace vsl;

namespace {

constexpr int kW = 1280, kH = 800;

double envNumber(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::atof(v) : fallback;
}

// Resident memory in MiB (/proc/self/statm).
double residentMiB() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return double(resident) * double(sysconf(_SC_PAGESIZE)) / (1 << 20);
}

// Resident memory and the C heap's own figures (in use, and held by the
// allocator), to tell growth of live data from fragmentation.
void logMemory(double t, int actions, int imguiWindows) {
#if defined(__SANITIZE_ADDRESS__)
  // ASan's allocator: in use, and mapped (in use, free and its quarantine).
  const double inUse = double(__sanitizer_get_current_allocated_bytes()), held = double(__sanitizer_get_heap_size());
#else
  const struct mallinfo2 m = mallinfo2();
  const double inUse = double(m.uordblks + m.hblkhd), held = double(m.arena + m.hblkhd);
#endif
  std::printf(
      "monkey: %4.0f s, %6d actions: resident %.0f MiB, heap in use %.0f MiB, held %.0f MiB, %d ImGui windows\n", t,
      actions, residentMiB(), inUse / (1 << 20), held / (1 << 20), imguiWindows);
  std::fflush(stdout);
}

class Monkey {
 public:
  Monkey(uint64_t seed, const std::string& dir) : rng_(seed), dir_(dir) {
    for (const char* name : {"cornell-glossy", "furnace", "kitchen", "hall", "tableau"})
      good_.push_back(std::string(VSL_SOURCE_DIR) + "/assets/scenes/" + name + ".gltf");
    std::ofstream(dir + "/corrupt.gltf") << "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [";
    bad_ = {dir + "/corrupt.gltf", dir + "/missing.gltf", dir};
    ui::StudioOptions o;
    o.scene = o.settings.scene = good_[0];
    o.settings.many.lights = 300;
    o.settings.many.width = 32;
    o.settings.many.batches = 4;
    o.settings.many.directSamples = 4;
    o.settings.lightSets = 2;
    o.settings.maxReferenceSpp = 64;
    o.bundled = good_;
    first_ = o.settings;
    studio_ = std::make_unique<ui::Studio>(o);
  }

  ui::Studio& studio() { return *studio_; }

  // The same state at the warm-up and at the end, so that resident memory is
  // compared like for like (which scene is loaded and how far its render
  // has come move it by a hundred MiB): the first scene at the first
  // settings, rendered to the end, the heap's free pages handed back.
  // Returns resident memory then.
  double settledMiB() {
    ImGui::GetIO().DisplaySize = ImVec2(kW, kH);
    studio_->openScene(good_[0]);
    studio_->applySettings(first_);
    Stopwatch clock;
    auto done = [&] {
      auto s = studio_->snapshot();
      return s && s->manyLightDone && s->settings.scene == good_[0] && sameImageSettings(s->settings, first_);
    };
    while (!done() && clock.seconds() < 120) {
      frame();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_TRUE(done()) << "the first settings' render did not finish in 2 minutes";
    for (int i = 0; i < 10; ++i) frame();  // the views catch up
    returnFreeMemory();
    return residentMiB();
  }
  int exports = 0, actions = 0;

  // One random action, then a frame.
  void step() {
    ++actions;
    const int what = pick(100);
    if (what < 40)
      input();
    else if (what < 60)
      parameter();
    else if (what < 68)
      view();
    else if (what < 74)
      scene();
    else if (what < 78)
      exportAll();
    else if (what < 81)
      studio_->comparePresets();
    else if (what < 86)
      ImGui::GetIO().DisplaySize = ImVec2(float(640 + pick(kW - 640)), float(480 + pick(kH - 480)));
    frame();
  }

  void frame() {
    ImGui::GetIO().DeltaTime = 1.0f / 30;
    ImGui_ImplOpenGL3_NewFrame();
    ImGui::NewFrame();
    studio_->frame();
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  }

 private:
  int pick(int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng_); }
  double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng_); }

  // The mouse somewhere, maybe pressed, a wheel turn or a key.
  void input() {
    ImGuiIO& io = ImGui::GetIO();
    io.MousePos = ImVec2(float(pick(int(io.DisplaySize.x))), float(pick(int(io.DisplaySize.y))));
    io.MouseDown[0] = pick(3) == 0;
    io.MouseWheel = pick(4) == 0 ? float(pick(7) - 3) : 0.0f;
    io.KeyShift = pick(4) == 0;
    for (bool& k : io.KeysDown) k = false;
    const int keys[] = {'T', '1', '2', '3', '4', '5', '6', '7', '8', 'E', 'R', 'F'};
    if (pick(3) == 0) io.KeysDown[keys[pick(int(std::size(keys)))]] = true;
  }

  // A registered parameter at a random value in its studio range (or one of
  // its words), kept small enough to render quickly; or a preset.
  void parameter() {
    StudioSettings s = studio_->acceptedSettings();
    if (pick(8) == 0) {
      applyPreset(pick(2) ? Preset::Paper : Preset::Default, s.many);
    } else {
      const auto& all = manyLightParams().all();
      const Param<ManyLightSettings>& p = all[size_t(pick(int(all.size())))];
      double v = 0;
      if (!p.spec.words.empty() && pick(3) == 0) {
        v = p.spec.words[size_t(pick(int(p.spec.words.size())))].value;
      } else if (p.spec.kind == ParamKind::Flag) {
        v = pick(2);
      } else {
        const double lo = p.spec.uiMin != 0 || p.spec.uiMax != 0 ? p.spec.uiMin : p.spec.min;
        double hi = p.spec.uiMin != 0 || p.spec.uiMax != 0 ? p.spec.uiMax : p.spec.max;
        if (std::string_view(p.spec.unit) == "lights") hi = std::min(hi, 3000.0);
        v = uniform(lo, hi);
        if (p.spec.kind == ParamKind::Int) v = std::floor(v);
      }
      p.set(s.many, v);
    }
    if (pick(10) == 0) s.many.width = 16 + pick(48);
    if (pick(10) == 0) s.lightSets = 1 + pick(3);
    studio_->applySettings(s);
  }

  void view() {
    ui::ViewState& v = studio_->view();
    v.mode = ui::ViewMode(pick(4));
    for (ui::Source& p : v.panels) p = ui::Source(pick(int(ui::Source::Count)));
    v.component = Component(pick(3));
    v.display = ui::Display(pick(4));
    v.metric = ui::ErrorMetric(pick(4));
    v.exposure = float(uniform(-3, 3));
    if (pick(4) == 0) v.crop = {pick(16), pick(16), 1 + pick(16), 1 + pick(16)};
  }

  void scene() {
    if (pick(3) == 0)
      studio_->openScene(bad_[size_t(pick(int(bad_.size())))]);
    else
      studio_->openScene(good_[size_t(pick(int(good_.size())))]);
  }

  // An export, checked: every EXR opens and metrics.json parses.
  void exportAll() {
    std::string folder;
    std::vector<std::string> written;
    if (!studio_->exportAll(dir_ + "/exports", &written, &folder)) return;  // nothing to export yet
    ++exports;
    for (const std::string& f : written) {
      if (f.size() > 4 && f.substr(f.size() - 4) == ".exr") {
        Result<std::vector<Layer>> layers = readExr(f);
        EXPECT_TRUE(layers) << f << ": " << (layers ? "" : layers.error());
      }
    }
    std::ifstream js(folder + "/metrics.json");
    EXPECT_FALSE(nlohmann::json::parse(js, nullptr, false).is_discarded()) << folder << "/metrics.json";
    std::filesystem::remove_all(folder);  // the run writes hundreds
  }

  std::mt19937_64 rng_;
  std::string dir_;
  std::vector<std::string> good_, bad_;
  StudioSettings first_;
  std::unique_ptr<ui::Studio> studio_;
};

}  // namespace

TEST(Monkey, RandomUseLeavesTheStudioSound) {
  const double seconds = envNumber("VSL_MONKEY_SECONDS", 60);
  const uint64_t seed = uint64_t(envNumber("VSL_MONKEY_SEED", 1));
  const std::string dir = std::string(VSL_BINARY_DIR) + "/monkey";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  ui::HeadlessGL gl;
  Result<void> ready = gl.init(kW, kH);
  ASSERT_TRUE(ready) << ready.error();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui::GetIO().DisplaySize = ImVec2(kW, kH);
  ASSERT_TRUE(ImGui_ImplOpenGL3_Init("#version 330 core"));
  {
    Monkey monkey(seed, dir);
    const double warmUp = std::min(120.0, seconds / 5);
    double warmMiB = 0;
    Stopwatch clock;
    double nextLog = 0;
    while (clock.seconds() < seconds) {
      monkey.step();
      if (warmMiB == 0 && clock.seconds() >= warmUp) {
        warmMiB = monkey.settledMiB();
        std::printf("monkey: settled after the warm-up: resident %.0f MiB\n", warmMiB);
      }
      if (clock.seconds() >= nextLog) {
        logMemory(clock.seconds(), monkey.actions, ImGui::GetCurrentContext()->Windows.Size);
        nextLog += 30;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    // Input stops: the picture must come to show the last settings.
    Stopwatch settle;
    auto current = [&] {
      auto s = monkey.studio().snapshot();
      return s && sameImageSettings(s->settings, monkey.studio().acceptedSettings()) &&
             s->settings.scene == monkey.studio().acceptedSettings().scene;
    };
    while (!current() && settle.seconds() < 300) {
      monkey.frame();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_TRUE(current()) << "the picture shown is not of the last settings";
    const double settleSeconds = settle.seconds();
    const double endMiB = monkey.settledMiB();
    std::printf(
        "monkey: seed %llu, %.0f s, %d actions, %d exports; the last settings' picture after %.1f s; resident "
        "memory in the settled state %.0f MiB after the warm-up (%.0f s), %.0f MiB at the end (%+.1f%%)\n",
        (unsigned long long)seed, clock.seconds(), monkey.actions, monkey.exports, settleSeconds, warmMiB, warmUp,
        endMiB, 100 * (endMiB / warmMiB - 1));
    EXPECT_GT(monkey.exports, 0);
    // The settled state is the same at both ends, so the bound holds for any
    // length of run.
    EXPECT_LE(endMiB, 1.10 * warmMiB) << "resident memory grew past the warm-up's by more than 10%";
  }
  ui::shutdown();
  ImGui_ImplOpenGL3_Shutdown();
  ImGui::DestroyContext();
}
