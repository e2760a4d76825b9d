// The studio's frames, rendered headlessly through EGL: the image texture
// appears where the view says it is, with the film's tone-mapped values, the
// wipe split is honoured, exposure is a uniform, and error maps use the
// stated colour map.
#include <gtest/gtest.h>

#include <imgui.h>
#include <imgui_impl_opengl3.h>
#include <stb_image.h>
#include <sys/wait.h>
#include <thread>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "core/compare.h"
#include "core/flip.h"
#include "core/image_io.h"
#include "core/params.h"
#include "core/params_json.h"
#include "core/presets.h"
#include "core/reference.h"
#include "support.h"
#include "ui/gl.h"
#include "ui/headless_gl.h"
#include "ui/studio.h"
#include "ui/studio_internal.h"

using namespace vsl;

namespace {

constexpr int kW = 1000, kH = 700;

class StudioFrame : public ::testing::Test {
 protected:
  ui::HeadlessGL gl;
  std::unique_ptr<ui::Studio> studio;

  void SetUp() override {
    Result<void> ready = gl.init(kW, kH);
    ASSERT_TRUE(ready) << ready.error();
    ImGui::CreateContext();
    ImGuiIO& io = ImGui::GetIO();
    io.IniFilename = nullptr;
    io.DisplaySize = ImVec2(kW, kH);
    ASSERT_TRUE(ImGui_ImplOpenGL3_Init("#version 330 core"));
    ui::StudioOptions o;
    o.scene = "synthetic.gltf";  // the snapshot's settings: its images are current
    o.startSession = false;
    studio = std::make_unique<ui::Studio>(o);
    studio->setSnapshotForTesting(makeSnapshot());
  }
  void TearDown() override {
    studio.reset();
    ui::shutdown();
    ImGui_ImplOpenGL3_Shutdown();
    ImGui::DestroyContext();
  }

  // VSL: a horizontal ramp in red, constant green, a vertical ramp in blue.
  // VPL: constant 0.2. Reference indirect: constant 0.25.
  static std::shared_ptr<Snapshot> makeSnapshot() {
    auto s = std::make_shared<Snapshot>();
    const int w = 64, h = 32;
    s->width = w;
    s->height = h;
    s->settings.scene = "synthetic.gltf";
    auto fill = [&](Image& img, auto f) {
      img = Image(w, h);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) img.set(x, y, f(x, y));
    };
    fill(s->many.vsl, [&](int x, int y) { return Vec3(0.9f * x / (w - 1), 0.3f, 0.6f * y / (h - 1)); });
    fill(s->many.vpl, [](int, int) { return Vec3(0.2f); });
    fill(s->ptIndirect, [](int, int) { return Vec3(0.25f); });
    for (Image* img : {&s->many.direct, &s->many.vplUnclamped, &s->many.vplDiffuse, &s->many.lostToClamping,
                       &s->many.lostToDiffuse, &s->ptDirect})
      fill(*img, [](int, int) { return Vec3(0.0f); });
    s->refIndirect = s->ptIndirect;  // the live path tracer is the reference
    s->refDirect = s->ptDirect;
    return s;
  }

  // Exports everything into a fresh folder under the build tree and returns
  // its metrics.json's "metricsAgainstReference".
  nlohmann::json exportedMetrics(const std::string& name) {
    const std::string dir = std::string(VSL_BINARY_DIR) + "/" + name;
    std::filesystem::remove_all(dir);
    std::string folder;
    std::vector<std::string> written;
    EXPECT_TRUE(studio->exportAll(dir, &written, &folder));
    return nlohmann::json::parse(std::ifstream(folder + "/metrics.json"))["metricsAgainstReference"];
  }

  std::vector<uint8_t> renderFrames(int frames = 3) {
    for (int i = 0; i < frames; ++i) {
      ImGui::GetIO().DeltaTime = 1.0f / 30;
      ImGui_ImplOpenGL3_NewFrame();
      ImGui::NewFrame();
      studio->frame();
      ImGui::Render();
      gl.bind();
      glClearColor(0, 0, 0, 1);
      glClear(GL_COLOR_BUFFER_BIT);
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    }
    return gl.readPixels();
  }

  static Vec3 pixel(const std::vector<uint8_t>& px, int x, int y) {
    const uint8_t* p = &px[(size_t(y) * kW + x) * 3];
    return Vec3(p[0], p[1], p[2]);
  }

  // Compares screen pixels at a grid of points inside a drawn image with the
  // expected colour of the texel under each point.
  template <typename Expected>
  int compareGrid(const std::vector<uint8_t>& px, const ui::Studio::DrawnImage& d, Expected expected, int tol) {
    int bad = 0, checked = 0;
    // Low-discrepancy points (golden-ratio sequence) inside the image, so no
    // grid step can alias with the texel size.
    for (int k = 0; k < 100; ++k) {
      float fx = 0.05f + 0.9f * float(std::fmod(0.5 + k * 0.6180339887, 1.0));
      float fy = 0.05f + 0.9f * float(std::fmod(0.3 + k * 0.7548776662, 1.0));
      int sx = int(d.p0.x + fx * (d.p1.x - d.p0.x)), sy = int(d.p0.y + fy * (d.p1.y - d.p0.y));
      // The texel under the pixel centre.
      float u = d.uv0.x + (sx + 0.5f - d.p0.x) / (d.p1.x - d.p0.x) * (d.uv1.x - d.uv0.x);
      float v = d.uv0.y + (sy + 0.5f - d.p0.y) / (d.p1.y - d.p0.y) * (d.uv1.y - d.uv0.y);
      int tx = std::min(int(u * 64), 63), ty = std::min(int(v * 32), 31);
      // Skip points within half a pixel of a texel edge (nearest filtering).
      float du = u * 64 - std::floor(u * 64), dv = v * 32 - std::floor(v * 32);
      if (du < 0.1f || du > 0.9f || dv < 0.1f || dv > 0.9f) continue;
      Vec3 want = expected(tx, ty), got = pixel(px, sx, sy);
      ++checked;
      for (int c = 0; c < 3; ++c)
        if (std::abs(got[c] - want[c]) > tol) {
          ++bad;
          ADD_FAILURE() << "screen (" << sx << "," << sy << ") texel (" << tx << "," << ty << ") channel " << c
                        << ": got " << got[c] << " want " << want[c];
          break;
        }
    }
    EXPECT_GT(checked, 40) << "image at (" << d.p0.x << "," << d.p0.y << ")-(" << d.p1.x << "," << d.p1.y << ") uv ("
                           << d.uv0.x << "," << d.uv0.y << ")-(" << d.uv1.x << "," << d.uv1.y << ")";
    return bad;
  }

  static Vec3 srgb8(const Vec3& v) { return Vec3(toSrgb8(v.x), toSrgb8(v.y), toSrgb8(v.z)); }
};

}  // namespace

TEST_F(StudioFrame, SingleViewShowsToneMappedFilmValues) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::Single;
  v.panels[0] = ui::Source::Vsl;
  v.component = Component::Indirect;
  v.exposure = 0;
  auto px = renderFrames();
  ASSERT_EQ(studio->drawnImages().size(), 1u);
  const auto& d = studio->drawnImages()[0];
  EXPECT_GT(d.p1.x - d.p0.x, 200);
  const Image& img = studio->snapshot()->many.vsl;
  EXPECT_EQ(compareGrid(
                px, d, [&](int x, int y) { return srgb8(img.at(x, y)); }, 2),
            0);

  // Exposure is a uniform: +1 stop doubles the linear values.
  v.exposure = 1;
  px = renderFrames(1);
  EXPECT_EQ(compareGrid(
                px, studio->drawnImages()[0], [&](int x, int y) { return srgb8(img.at(x, y) * 2.0f); }, 2),
            0);
}

// The table's FLIP column: computed off the UI thread, it equals LDR-FLIP of
// the tone-mapped method against the tone-mapped reference.
TEST_F(StudioFrame, FlipColumnMatchesFlipOfTheShownImages) {
  ui::ViewState& v = studio->view();
  v.component = Component::Indirect;
  v.exposure = 0;
  std::optional<std::vector<double>> f;
  for (int i = 0; i < 200 && !f; ++i) {  // bounded: the task takes milliseconds here
    renderFrames(1);
    f = studio->flipMeans();
    if (!f) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(f);
  const Snapshot& s = *studio->snapshot();
  EXPECT_DOUBLE_EQ((*f)[0], flipLdr(toSrgbImage(s.many.vsl), toSrgbImage(s.refIndirect)).mean);
  EXPECT_DOUBLE_EQ((*f)[1], flipLdr(toSrgbImage(s.many.vpl), toSrgbImage(s.refIndirect)).mean);
  EXPECT_GT((*f)[0], 0.0);
  // Another exposure is another tone map: the old numbers no longer apply.
  v.exposure = 2;
  std::optional<std::vector<double>> g;
  for (int i = 0; i < 200 && !g; ++i) {
    renderFrames(1);
    g = studio->flipMeans();
    if (!g) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(g);
  EXPECT_DOUBLE_EQ((*g)[0], flipLdr(toSrgbImage(s.many.vsl, 2), toSrgbImage(s.refIndirect, 2)).mean);
  EXPECT_NE((*g)[0], (*f)[0]);
}

// The FLIP display: the first frame shows no map (the UI never waits for
// FLIP); once the asynchronous task is done, the panel shows core/flip's
// LDR-FLIP map of the same tone-mapped images, through magma on [0, 1].
TEST_F(StudioFrame, FlipMapShowsCoreFlipsMap) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::Single;
  v.panels[0] = ui::Source::Vsl;
  v.component = Component::Indirect;
  v.display = ui::Display::Flip;
  v.exposure = 0;
  v.errorScale = 0;
  renderFrames(1);
  EXPECT_EQ(studio->flipMap(ui::Source::Vsl), nullptr) << "the first frame does not wait for FLIP";
  const Image* shown = nullptr;
  for (int i = 0; i < 200 && !shown; ++i) {  // bounded: the task takes milliseconds here
    renderFrames(1);
    shown = studio->flipMap(ui::Source::Vsl);
    if (!shown) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(shown);
  const Snapshot& s = *studio->snapshot();
  const FlipResult want = flipLdr(toSrgbImage(s.many.vsl), toSrgbImage(s.refIndirect));
  EXPECT_EQ(shown->rgb, want.map.rgb) << "the map is core/flip's, bit for bit";
  float lo = 1, hi = 0;
  for (float x : want.map.rgb) lo = std::min(lo, x), hi = std::max(hi, x);
  EXPECT_LT(lo + 0.1f, hi) << "a map with some contrast, so the colours below mean something";
  auto px = renderFrames();
  ASSERT_EQ(studio->drawnImages().size(), 1u);
  EXPECT_EQ(compareGrid(
                px, studio->drawnImages()[0],
                [&](int x, int y) {
                  Vec3 c = magma(want.map.at(x, y).x);
                  return Vec3(c.x * 255, c.y * 255, c.z * 255);
                },
                3),
            0);
}

TEST_F(StudioFrame, WipeSplitIsHonoured) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::Wipe;
  v.panels[0] = ui::Source::Vsl;
  v.panels[1] = ui::Source::Vpl;
  v.component = Component::Indirect;
  v.exposure = 0;
  v.wipe = 0.3f;
  auto px = renderFrames();
  ASSERT_EQ(studio->drawnImages().size(), 2u);
  const auto& left = studio->drawnImages()[0];
  const auto& right = studio->drawnImages()[1];
  // The split sits at 30% of the image width, in screen space and in UV.
  float width = right.p1.x - left.p0.x;
  EXPECT_NEAR((left.p1.x - left.p0.x) / width, 0.3f, 0.01f);
  EXPECT_NEAR(left.uv1.x, 0.3f, 1e-4f);
  EXPECT_NEAR(right.uv0.x, 0.3f, 1e-4f);
  const Image& vsl = studio->snapshot()->many.vsl;
  EXPECT_EQ(compareGrid(
                px, left, [&](int x, int y) { return srgb8(vsl.at(x, y)); }, 2),
            0);
  EXPECT_EQ(compareGrid(
                px, right, [&](int, int) { return srgb8(Vec3(0.2f)); }, 2),
            0);
  // Just left and right of the split line (which is drawn on top).
  int sy = int((left.p0.y + left.p1.y) / 2), sx = int(left.p1.x);
  Vec3 l = pixel(px, sx - 4, sy), r = pixel(px, sx + 4, sy);
  EXPECT_NEAR(r.x, toSrgb8(0.2f), 2);
  EXPECT_GT(std::abs(l.z - r.z), 10) << "the two sides differ in blue";
}

TEST_F(StudioFrame, ErrorMapUsesTheStatedColourMap) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::Single;
  v.panels[0] = ui::Source::Vpl;
  v.component = Component::Indirect;
  v.display = ui::Display::Error;
  v.metric = ui::ErrorMetric::Absolute;
  v.errorScale = 0.1f;  // |0.2 - 0.25| = 0.05 -> half of the map
  auto px = renderFrames();
  ASSERT_EQ(studio->drawnImages().size(), 1u);
  Vec3 c = falseColour(0.5f);
  Vec3 want(c.x * 255, c.y * 255, c.z * 255);
  EXPECT_EQ(compareGrid(
                px, studio->drawnImages()[0], [&](int, int) { return want; }, 3),
            0);
}

namespace {
// One frame with this input (old ImGui 1.86 input API).
struct Input {
  ImVec2 mouse{-1, -1};
  bool down = false;
  float wheel = 0;
  int key = -1;
  bool shift = false;
};
}  // namespace

class StudioInput : public StudioFrame {
 protected:
  void frameWith(const Input& in) {
    ImGuiIO& io = ImGui::GetIO();
    io.MousePos = in.mouse;
    io.MouseDown[0] = in.down;
    io.MouseWheel = in.wheel;
    io.KeyShift = in.shift;
    if (in.key >= 0) io.KeysDown[in.key] = true;
    renderFrames(1);
    if (in.key >= 0) io.KeysDown[in.key] = false;
  }
};

// A panel whose image belongs to older settings is flagged and dimmed; the
// reference stays current when only many-light settings changed.
TEST_F(StudioFrame, StalePanelsAreDimmedAndBadged) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::SideBySide3;
  v.component = Component::Indirect;
  StudioSettings current = studio->snapshot()->settings;
  studio->applySettings(current);
  auto px = renderFrames();
  EXPECT_FALSE(studio->panelStale(0));
  const auto& d0 = studio->drawnImages()[0];
  Vec3 fresh = pixel(px, int(d0.p0.x + 0.75f * (d0.p1.x - d0.p0.x)), int(d0.p0.y + 0.75f * (d0.p1.y - d0.p0.y)));

  StudioSettings changed = current;
  changed.many.lights = current.many.lights + 1000;
  studio->applySettings(changed);
  px = renderFrames();
  EXPECT_TRUE(studio->panelStale(0)) << "VSL belongs to the old light count";
  EXPECT_TRUE(studio->panelStale(1));
  EXPECT_FALSE(studio->panelStale(2)) << "the reference depends only on scene and resolution";
  const auto& d = studio->drawnImages()[0];
  Vec3 dim = pixel(px, int(d.p0.x + 0.75f * (d.p1.x - d.p0.x)), int(d.p0.y + 0.75f * (d.p1.y - d.p0.y)));
  EXPECT_LT(dim.x + dim.y + dim.z, 0.7f * (fresh.x + fresh.y + fresh.z)) << "a stale image is dimmed";

  // The first picture of the new settings clears it.
  auto snap = std::make_shared<Snapshot>(*studio->snapshot());
  snap->settings = changed;
  studio->setSnapshotForTesting(snap);
  renderFrames(1);
  EXPECT_FALSE(studio->panelStale(0));
}

// While an MRCS light set's clamped-VPL columns are still rendering
// (Snapshot::vplPending) the VPL panel shows a waiting box, never its black
// layers as if they were the picture; VSL and the reference are drawn.
TEST_F(StudioFrame, PendingVplPanelWaitsInsteadOfShowingBlack) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::SideBySide3;
  v.component = Component::Indirect;
  v.panels[0] = ui::Source::Vsl;
  v.panels[1] = ui::Source::Vpl;
  v.panels[2] = ui::Source::Reference;
  auto centre = [&](const std::vector<uint8_t>& px, int i) {
    const auto& d = studio->drawnImages()[i];
    return pixel(px, int(d.p0.x + 0.6f * (d.p1.x - d.p0.x)), int(d.p0.y + 0.6f * (d.p1.y - d.p0.y)));
  };
  auto px = renderFrames();
  const Vec3 vplShown = centre(px, 1), grey = srgb8(Vec3(0.2f));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(vplShown[c], grey[c], 2) << "the VPL image when it is in";

  auto snap = std::make_shared<Snapshot>(*studio->snapshot());
  snap->vplPending = true;
  studio->setSnapshotForTesting(snap);
  px = renderFrames();
  const Vec3 waiting = centre(px, 1);
  EXPECT_LT(waiting.x + waiting.y + waiting.z, 60.0f) << "no image in the pending VPL panel";
  const Vec3 ref = centre(px, 2), greyRef = srgb8(Vec3(0.25f));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(ref[c], greyRef[c], 2) << "the reference is still drawn";
  const Vec3 vsl = centre(px, 0);
  EXPECT_GT(vsl.x + vsl.y + vsl.z, 200.0f) << "VSL is still drawn";
  EXPECT_FALSE(studio->hasPicture(ui::Source::Vpl, Component::Indirect));
  EXPECT_FALSE(studio->hasPicture(ui::Source::Vpl, Component::Full));
  EXPECT_TRUE(studio->hasPicture(ui::Source::Vpl, Component::Direct)) << "the direct image is in for both";

  // The direct component: the VPL panel shows the (shared) direct image.
  v.component = Component::Direct;
  snap = std::make_shared<Snapshot>(*studio->snapshot());
  snap->many.direct = snap->many.vpl;  // 0.2 grey
  snap->refDirect = snap->many.vpl;
  studio->setSnapshotForTesting(snap);
  px = renderFrames();
  const Vec3 direct = centre(px, 1);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(direct[c], grey[c], 2) << "the direct image is drawn while VPL is pending";

  // Under MRCS, the VPL variants MRCS never renders are boxes, not black
  // pictures, and stay out of the crops.
  v.component = Component::Indirect;
  snap = std::make_shared<Snapshot>(*studio->snapshot());
  snap->vplPending = false;
  snap->settings.estimator.name = "mrcs";
  snap->many.vplUnclamped = snap->many.vpl;  // 0.2 grey: would show if drawn
  studio->setSnapshotForTesting(snap);
  studio->applySettings(snap->settings);
  v.panels[1] = ui::Source::VplUnclamped;
  px = renderFrames();
  const Vec3 unclamped = centre(px, 1);
  EXPECT_LT(unclamped.x + unclamped.y + unclamped.z, 60.0f) << "no picture for a layer MRCS does not render";
  EXPECT_TRUE(studio->hasPicture(ui::Source::Vpl, Component::Indirect));
  const auto crops = studio->buildCrops(ui::CropRect{10, 4, 16, 8}, Component::Indirect, nullptr);
  EXPECT_EQ(crops.size(), 5u) << "the reference, then VSL and clamped VPL with their error maps";
  for (const auto& item : crops)
    EXPECT_TRUE(item.source == ui::Source::Reference || item.source == ui::Source::Vsl ||
                item.source == ui::Source::Vpl)
        << "crop of a source MRCS does not render: " << int(item.source);
}

// T swaps the two methods in a 2-up view (never the same one twice) and
// toggles VSL and VPL in a single view; number keys pick panel 1's image.
TEST_F(StudioInput, KeysNeverShowOneMethodTwice) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::SideBySide2;
  v.panels[0] = ui::Source::Vsl;
  v.panels[1] = ui::Source::Vpl;
  renderFrames(2);
  Input t;
  t.key = 'T';
  frameWith(t);
  EXPECT_EQ(v.panels[0], ui::Source::Vpl);
  EXPECT_EQ(v.panels[1], ui::Source::Vsl);
  frameWith(Input());
  frameWith(t);
  EXPECT_EQ(v.panels[0], ui::Source::Vsl);
  EXPECT_EQ(v.panels[1], ui::Source::Vpl);
  Input two;
  two.key = '2';  // VPL (clamped), shown in panel 2: the panels swap
  frameWith(Input());
  frameWith(two);
  EXPECT_EQ(v.panels[0], ui::Source::Vpl);
  EXPECT_EQ(v.panels[1], ui::Source::Vsl);
  v.mode = ui::ViewMode::Single;
  frameWith(Input());
  frameWith(t);
  EXPECT_EQ(v.panels[0], ui::Source::Vsl);
}

// The wheel zooms about the cursor: the image point under it stays put.
TEST_F(StudioInput, ZoomKeepsThePointUnderTheCursor) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::Single;
  renderFrames(2);
  auto uvAt = [&](ImVec2 m) {
    const auto& d = studio->drawnImages()[0];
    return ImVec2(d.uv0.x + (m.x - d.p0.x) / (d.p1.x - d.p0.x) * (d.uv1.x - d.uv0.x),
                  d.uv0.y + (m.y - d.p0.y) / (d.p1.y - d.p0.y) * (d.uv1.y - d.uv0.y));
  };
  const auto& d = studio->drawnImages()[0];
  ImVec2 m(d.p0.x + 0.2f * (d.p1.x - d.p0.x), d.p0.y + 0.7f * (d.p1.y - d.p0.y));
  ImVec2 before = uvAt(m);
  Input in;
  in.mouse = m;
  in.wheel = 3;
  frameWith(in);
  in.wheel = 0;
  frameWith(in);
  EXPECT_GT(v.zoom, 1.4f);
  ImVec2 after = uvAt(m);
  EXPECT_NEAR(after.x, before.x, 2e-3f);
  EXPECT_NEAR(after.y, before.y, 2e-3f);
}

// A drag that starts on the wipe's split line moves the line all the way
// with the cursor (it never turns into a pan).
TEST_F(StudioInput, WipeDragFollowsTheCursor) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::Wipe;
  v.wipe = 0.5f;
  renderFrames(2);
  const auto left = studio->drawnImages()[0];
  const auto right = studio->drawnImages()[1];
  const float x0 = left.p0.x, w = right.p1.x - left.p0.x, y = (left.p0.y + left.p1.y) / 2;
  Input in;
  in.mouse = ImVec2(x0 + 0.5f * w, y);
  frameWith(in);
  in.down = true;
  frameWith(in);
  for (int k = 10; k >= 2; --k) {  // 0.5 down to 0.1 of the width
    in.mouse = ImVec2(x0 + 0.05f * float(k) * w, y);
    frameWith(in);
  }
  EXPECT_NEAR(v.wipe, 0.1f, 0.02f);
  EXPECT_NEAR(v.center.x, 0.5f, 1e-6f) << "no pan";
  in.down = false;
  frameWith(in);
}

// Each export is a new folder; PNGs are at the render's resolution; the JSON
// holds the resolved clamp and the machine.
TEST_F(StudioFrame, ExportsNeverOverwriteAndKeepNativeResolution) {
  renderFrames(1);
  std::string dir = std::string(VSL_BINARY_DIR) + "/studio-export-test";
  std::filesystem::remove_all(dir);
  std::string f1, f2;
  std::vector<std::string> w1, w2;
  Result<void> e1 = studio->exportAll(dir, &w1, &f1);
  ASSERT_TRUE(e1) << e1.error();
  Result<void> e2 = studio->exportAll(dir, &w2, &f2);
  ASSERT_TRUE(e2) << e2.error();
  EXPECT_NE(f1, f2);
  EXPECT_TRUE(std::filesystem::exists(f1 + "/metrics.json"));
  EXPECT_TRUE(std::filesystem::exists(f2 + "/metrics.json"));
  int pngs = 0;
  for (const std::string& f : w1) {
    if (f.size() < 4 || f.substr(f.size() - 4) != ".png") continue;
    if (f.find("/figure-") != std::string::npos) continue;  // magnified (FigureLaysOutReferenceMethodsAndErrorMaps)
    ++pngs;
    int w = 0, h = 0, n = 0;
    ASSERT_TRUE(stbi_info(f.c_str(), &w, &h, &n)) << f;
    EXPECT_EQ(w, 64) << f;
    const bool map = f.find("/error-") != std::string::npos || f.find("/flip-") != std::string::npos;
    if (map)
      EXPECT_GE(h, 32 + 4 + 12 + 2 * 26) << f << ": maps have a colour bar, its scale and its name below them";
    else
      EXPECT_EQ(h, 32) << f;
  }
  EXPECT_GE(pngs, 11);
  // The maps' bars are labelled in the studio's 13-px font drawn 2x (issue
  // 49, item 6: "about 5 px tall"): under the bar, text at least 16 rows
  // tall (the digits; '|' more), naming the metric and its units.
  EXPECT_EQ(ui::studio_detail::metricLabel(ui::ErrorMetric::RelativeAbsolute),
            "relative absolute error |t-r|/(r+eps), unitless");
  int mw = 0, mh = 0, mn = 0;
  unsigned char* map = stbi_load((f1 + "/error-vsl-relabs-indirect.png").c_str(), &mw, &mh, &mn, 3);
  ASSERT_NE(map, nullptr);
  int run = 0, tallest = 0;
  for (int y = 32 + 16; y < mh; ++y) {
    bool text = false;
    for (int x = 0; x < mw; ++x) text |= map[(size_t(y) * mw + x) * 3] > 150 && map[(size_t(y) * mw + x) * 3 + 2] > 150;
    run = text ? run + 1 : 0;
    tallest = std::max(tallest, run);
  }
  stbi_image_free(map);
  EXPECT_GE(tallest, 16) << "the labels' tallest glyphs";
  std::ifstream js(f1 + "/metrics.json");
  nlohmann::json j = nlohmann::json::parse(js);
  EXPECT_EQ(j["settings"]["clamp"], "auto");
  EXPECT_TRUE(j["settings"]["resolved"]["clampBound"].is_number()) << "the automatic bound as resolved";
  EXPECT_TRUE(j["machine"].contains("renderThreads"));
  EXPECT_TRUE(j["settings"]["resolved"]["vslSamplesPerPair"].is_number());
  EXPECT_EQ(j["settings"]["vslSamples"], "auto");
  EXPECT_EQ(j["settings"]["vslCount"], "lobe") << "which automatic count the export used";
}

// The export records the light sets and each method's bias and noise where
// measured (null where not).
TEST_F(StudioFrame, ExportRecordsLightSetsAndBiasNoise) {
  auto snap = std::make_shared<Snapshot>(*studio->snapshot());
  snap->settings.lightSets = snap->lightSets = 3;
  snap->lightSetsDone = 3;
  snap->referenceNoise = 0.001;
  snap->biasNoise[int(BiasNoiseRow::Vpl)] = {3, 0.25, 0.5, 0.4};
  studio->setSnapshotForTesting(snap);
  renderFrames(1);
  std::string dir = std::string(VSL_BINARY_DIR) + "/studio-export-bias-test";
  std::filesystem::remove_all(dir);
  std::string folder;
  Result<void> e = studio->exportAll(dir, nullptr, &folder);
  ASSERT_TRUE(e) << e.error();
  std::ifstream js(folder + "/metrics.json");
  nlohmann::json j = nlohmann::json::parse(js);
  EXPECT_EQ(j["settings"]["lightSets"], 3);
  EXPECT_EQ(j["samples"]["lightSetsDone"], 3);
  const nlohmann::json& vpl = j["biasNoiseIndirect"]["methods"]["VPL (clamped)"];
  EXPECT_EQ(vpl["renders"], 3);
  EXPECT_DOUBLE_EQ(vpl["bias2"].get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(vpl["variance"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(vpl["relMSE"].get<double>(), 0.4);
  EXPECT_DOUBLE_EQ(vpl["bias2MinusReferenceNoise"].get<double>(), 0.249);
  EXPECT_TRUE(j["biasNoiseIndirect"]["methods"]["VSL"].is_null());
  // FLIP is in every export, computed there if the asynchronous task has not
  // caught up with the picture.
  EXPECT_DOUBLE_EQ(j["flip"]["mean"]["VSL"].get<double>(),
                   flipLdr(toSrgbImage(snap->many.vsl), toSrgbImage(snap->refIndirect)).mean);
  EXPECT_TRUE(std::filesystem::exists(folder + "/flip-vsl-indirect.png"));
}

// An export holds only what was rendered: under MRCS no PNG, error or FLIP
// map, EXR layer, metric or bias row of the VPL variants and lost-energy
// images (black, and scored against the reference they looked like a method),
// and while clamped VPL's columns are pending, none of clamped VPL either;
// metrics.json says why in notRendered.
TEST_F(StudioFrame, ExportLeavesOutWhatWasNotRendered) {
  auto exportOf = [&](const std::shared_ptr<Snapshot>& snap, const std::string& name, std::vector<std::string>& files,
                      nlohmann::json& j, std::vector<std::string>& layers) {
    studio->setSnapshotForTesting(snap);
    studio->applySettings(snap->settings);
    renderFrames(1);
    const std::string dir = std::string(VSL_BINARY_DIR) + "/" + name;
    std::filesystem::remove_all(dir);
    std::string folder;
    Result<void> e = studio->exportAll(dir, &files, &folder);
    ASSERT_TRUE(e) << e.error();
    j = nlohmann::json::parse(std::ifstream(folder + "/metrics.json"));
    Result<std::vector<Layer>> exr = readExr(folder + "/images.exr");
    ASSERT_TRUE(exr) << exr.error();
    layers.clear();
    for (const Layer& l : *exr) layers.push_back(l.name);
  };
  auto anyFile = [](const std::vector<std::string>& files, const std::string& part) {
    return std::any_of(files.begin(), files.end(), [&](const std::string& f) {
      return std::filesystem::path(f).filename().string().find(part) != std::string::npos;
    });
  };
  auto hasLayer = [](const std::vector<std::string>& layers, const std::string& name) {
    return std::find(layers.begin(), layers.end(), name) != layers.end();
  };
  studio->view().component = Component::Indirect;
  std::vector<std::string> files, layers;
  nlohmann::json j;

  // Brute force: everything.
  auto snap = std::make_shared<Snapshot>(*studio->snapshot());
  snap->biasNoise[int(BiasNoiseRow::VplUnclamped)] = {3, 0.25, 0.5, 0.4};
  exportOf(snap, "studio-export-all", files, j, layers);
  for (const char* part : {"vpl-clamped-", "vpl-unclamped-", "vpl-diffuse-", "lost-to-clamping-", "error-vpl-unclamped",
                           "flip-vpl-diffuse"})
    EXPECT_TRUE(anyFile(files, part)) << part;
  for (const char* name : {"vpl-indirect", "vpl-unclamped-indirect", "lost-to-diffuse", "error-vpl-relsq"})
    EXPECT_TRUE(hasLayer(layers, name)) << name;
  EXPECT_TRUE(j["metricsAgainstReference"]["VPL unclamped"].is_object());
  EXPECT_TRUE(j["notRendered"].empty());
  EXPECT_EQ(j["biasNoiseIndirect"]["methods"]["VPL unclamped"]["renders"], 3);

  // MRCS: VSL and clamped VPL only.
  snap = std::make_shared<Snapshot>(*snap);
  snap->settings.estimator.name = "mrcs";
  exportOf(snap, "studio-export-mrcs", files, j, layers);
  for (const char* part : {"vpl-unclamped", "vpl-diffuse", "lost-to-"})
    EXPECT_FALSE(anyFile(files, part)) << part << " exported under MRCS";
  EXPECT_TRUE(anyFile(files, "error-vpl-clamped"));
  EXPECT_TRUE(anyFile(files, "flip-vsl"));
  for (const char* name : {"vpl-unclamped-indirect", "vpl-diffuse-indirect", "lost-to-clamping", "lost-to-diffuse"})
    EXPECT_FALSE(hasLayer(layers, name)) << name;
  EXPECT_TRUE(hasLayer(layers, "vpl-indirect"));
  EXPECT_TRUE(j["metricsAgainstReference"]["VPL unclamped"].is_null());
  EXPECT_TRUE(j["metricsAgainstReference"]["VPL diffuse-only"].is_null());
  EXPECT_TRUE(j["metricsAgainstReference"]["VPL (clamped)"].is_object());
  EXPECT_EQ(j["notRendered"].size(), 2u) << j["notRendered"].dump();
  EXPECT_TRUE(j["notRendered"].contains("VPL unclamped"));
  EXPECT_TRUE(j["biasNoiseIndirect"]["methods"]["VPL unclamped"].is_null());
  EXPECT_FALSE(j["flip"]["mean"].contains("VPL unclamped"));
  // The direct component is every method's, but the lost-energy images have
  // none: under MRCS they are still not rendered.
  studio->view().component = Component::Direct;
  exportOf(snap, "studio-export-mrcs-direct", files, j, layers);
  EXPECT_FALSE(anyFile(files, "lost-to-")) << "a black lost-energy PNG under MRCS";
  EXPECT_TRUE(anyFile(files, "vpl-unclamped-direct")) << "the direct image is every method's";
  studio->view().component = Component::Indirect;

  // MRCS with clamped VPL's columns pending: VSL alone.
  snap = std::make_shared<Snapshot>(*snap);
  snap->vplPending = true;
  exportOf(snap, "studio-export-pending", files, j, layers);
  EXPECT_FALSE(anyFile(files, "vpl-clamped"));
  EXPECT_FALSE(hasLayer(layers, "vpl-indirect"));
  EXPECT_FALSE(hasLayer(layers, "error-vpl-signed"));
  EXPECT_TRUE(hasLayer(layers, "vsl-indirect"));
  EXPECT_TRUE(j["metricsAgainstReference"]["VPL (clamped)"].is_null());
  EXPECT_EQ(j["notRendered"].size(), 3u) << j["notRendered"].dump();
  EXPECT_TRUE(j["metricsAgainstReference"]["VSL"].is_object());
}

namespace {
// The crop of img at (x0, y0), w x h, cut here independently of the studio.
Image cutOut(const Image& img, int x0, int y0, int w, int h) {
  Image out(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) out.set(x, y, img.at(x0 + x, y0 + y));
  return out;
}
}  // namespace

// A crop inset in the export: a PNG of every image and error map at native
// pixels magnified by an integer factor, the crop figure, and per-crop
// metrics equal to compareImages on the crops cut out directly.
TEST_F(StudioFrame, CropInsetsAreExportedWithTheirMetrics) {
  renderFrames(1);
  ui::ViewState& v = studio->view();
  v.component = Component::Indirect;
  v.crop = ui::CropRect{10, 4, 16, 8};
  std::string dir = std::string(VSL_BINARY_DIR) + "/studio-crop-test";
  std::filesystem::remove_all(dir);
  std::string folder;
  std::vector<std::string> written;
  Result<void> exported = studio->exportAll(dir, &written, &folder);
  ASSERT_TRUE(exported) << exported.error();
  const int f = ui::cropMagnification(v.crop);
  EXPECT_EQ(f, 16);  // 256 / 16
  int crops = 0;
  for (const std::string& file : written) {
    const std::string name = std::filesystem::path(file).filename().string();
    if (name.rfind("crop-", 0) != 0 || name.rfind("crop-figure", 0) == 0) continue;
    ++crops;
    int w = 0, h = 0, n = 0;
    ASSERT_TRUE(stbi_info(file.c_str(), &w, &h, &n)) << file;
    EXPECT_EQ(w, 16 * f) << file;
    EXPECT_EQ(h, 8 * f) << file;
  }
  EXPECT_EQ(crops, 9) << "the reference, four methods and their four error maps";
  // The figure: a band of titles (the font's 13 px line drawn 2x, 2 px, 4
  // px), the 64x32 image magnified 8x (512 / 32 = 16, at most 8), then five
  // columns of crops magnified (256 - 32) / (2 x 8) = 14x, 8 px apart, the
  // error maps' row under a band of 32 naming them.
  int w = 0, h = 0, n = 0;
  ASSERT_TRUE(stbi_info((folder + "/crop-figure-indirect.png").c_str(), &w, &h, &n));
  EXPECT_EQ(w, 8 * 64 + 8 + 5 * (16 * 14 + 8));
  EXPECT_EQ(h, 32 + 8 * 32);
  {
    unsigned char* figure = stbi_load((folder + "/crop-figure-indirect.png").c_str(), &w, &h, &n, 3);
    ASSERT_NE(figure, nullptr);
    // Light text in the title band over the reference and over each column,
    // and in the band between the rows.
    auto textIn = [&](int x0, int x1, int y0, int y1) {
      int light = 0;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x)
          light += figure[(size_t(y) * w + x) * 3] > 150 && figure[(size_t(y) * w + x) * 3 + 2] > 150;
      return light;
    };
    EXPECT_GT(textIn(0, 8 * 64, 0, 32), 20) << "the reference's title";
    for (int col = 0; col < 5; ++col)
      EXPECT_GT(textIn(520 + col * 232, 520 + col * 232 + 224, 0, 32), 10) << "column " << col << "'s title";
    EXPECT_GT(textIn(520, w, 32 + 8 * 14, 32 + 8 * 14 + 32), 40) << "the error maps' title";
    stbi_image_free(figure);
  }
  // A crop of the magnified VSL file is the VSL crop, pixel for pixel (nearest neighbour).
  int cw = 0, chh = 0;
  unsigned char* png = stbi_load((folder + "/crop-vsl-indirect.png").c_str(), &cw, &chh, &n, 3);
  ASSERT_NE(png, nullptr);
  const Image& vsl = studio->snapshot()->many.vsl;
  for (int y : {0, 3, 7})
    for (int x : {0, 5, 15}) {
      Vec3 want = srgb8(vsl.at(10 + x, 4 + y));
      const unsigned char* p = &png[(size_t(y * f + f / 2) * cw + x * f + f / 2) * 3];
      EXPECT_NEAR(p[0], want.x, 1);
      EXPECT_NEAR(p[2], want.z, 1);
    }
  stbi_image_free(png);

  std::ifstream js(folder + "/metrics.json");
  nlohmann::json j = nlohmann::json::parse(js);
  const nlohmann::json& c = j["crop"];
  EXPECT_EQ(c["x"], 10);
  EXPECT_EQ(c["y"], 4);
  EXPECT_EQ(c["width"], 16);
  EXPECT_EQ(c["height"], 8);
  EXPECT_EQ(c["magnification"], f);
  const Snapshot& s = *studio->snapshot();
  CompareResult direct = compareImages(cutOut(s.many.vsl, 10, 4, 16, 8), cutOut(s.ptIndirect, 10, 4, 16, 8));
  EXPECT_DOUBLE_EQ(c["metricsAgainstReferenceCrop"]["VSL"]["indirect"]["relMSE"].get<double>(), direct.average.relMse);
  EXPECT_GT(direct.average.relMse, 0);
  // VPL is 0.2 against 0.25 everywhere: relMSE = 0.05^2 / (0.25^2 + eps), the
  // eps relative to the reference crop: 0.01 x its mean luminance (0.25)^2.
  EXPECT_NEAR(c["metricsAgainstReferenceCrop"]["VPL (clamped)"]["indirect"]["relMSE"].get<double>(),
              0.0025 / (0.0625 + 0.01 * 0.0625), 1e-6);
  // The crop differs from the whole image's metric (the VSL ramp varies across it).
  EXPECT_NE(c["metricsAgainstReferenceCrop"]["VSL"]["indirect"]["relMSE"].get<double>(),
            j["metricsAgainstReference"]["VSL"]["indirect"]["relMSE"].get<double>());

  // A crop outside the image fails the export with the reason, after the
  // images were written; the failed export's folder goes with them.
  auto entries = [&] {
    return std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator());
  };
  const auto before = entries();
  v.crop = ui::CropRect{100, 50, 8, 8};
  exported = studio->exportAll(dir, &written, &folder);
  EXPECT_FALSE(exported);
  EXPECT_NE(exported.error().find("lies outside"), std::string::npos) << exported.error();
  EXPECT_NE(exported.error().find("nothing was exported"), std::string::npos) << exported.error();
  EXPECT_EQ(entries(), before) << "a failed export leaves no folder";
}

// The figure export (issue 49, item 6): reference, methods and error maps in
// one labelled PNG, each tile the same pixels as its own file, magnified.
TEST_F(StudioFrame, FigureLaysOutReferenceMethodsAndErrorMaps) {
  renderFrames(1);
  studio->view().component = Component::Indirect;
  const std::string dir = std::string(VSL_BINARY_DIR) + "/studio-figure-test";
  std::filesystem::remove_all(dir);
  std::string folder;
  std::vector<std::string> written;
  Result<void> exported = studio->exportAll(dir, &written, &folder);
  ASSERT_TRUE(exported) << exported.error();
  std::ifstream js(folder + "/metrics.json");
  const nlohmann::json j = nlohmann::json::parse(js);
  ASSERT_TRUE(j["figure"].is_object()) << j.dump();
  EXPECT_EQ(j["figure"]["file"], "figure-indirect.png");
  // 64x32 pixels: magnified min(ceil(256 / 32), 4) = 4 times; five columns
  // (the reference and four methods) 8 px apart; two title lines (the
  // font's 13 px drawn 2x, plus 2, each) and 4 px over the top row.
  const int f = 4, tw = 64 * f, th = 32 * f, band = 2 * 28 + 4;
  EXPECT_EQ(j["figure"]["magnification"], f);
  int w = 0, h = 0, n = 0;
  unsigned char* fig = stbi_load((folder + "/figure-indirect.png").c_str(), &w, &h, &n, 3);
  ASSERT_NE(fig, nullptr);
  EXPECT_EQ(w, 5 * tw + 4 * 8);
  EXPECT_GT(h, band + 2 * th + 8) << "the rows, then the colour bar";
  // Each tile's centre pixels are its own file's pixels.
  auto samePixels = [&](const std::string& file, int x0, int y0) {
    int pw = 0, ph = 0, pn = 0;
    unsigned char* png = stbi_load((folder + "/" + file).c_str(), &pw, &ph, &pn, 3);
    if (!png) return ::testing::AssertionFailure() << file << " is missing";
    ::testing::AssertionResult r = ::testing::AssertionSuccess();
    for (int y : {1, 15, 30})
      for (int x : {2, 33, 60})
        for (int k = 0; k < 3; ++k) {
          const int a = fig[(size_t(y0 + y * f + f / 2) * w + x0 + x * f + f / 2) * 3 + k],
                    b = png[(size_t(y) * pw + x) * 3 + k];
          if (a != b)
            r = ::testing::AssertionFailure() << file << " pixel " << x << "," << y << ": " << a << " vs " << b;
        }
    stbi_image_free(png);
    return r;
  };
  EXPECT_TRUE(samePixels("reference-indirect.png", 0, band));
  EXPECT_TRUE(samePixels("vsl-indirect.png", tw + 8, band));
  EXPECT_TRUE(samePixels("vpl-clamped-indirect.png", 2 * (tw + 8), band));
  EXPECT_TRUE(samePixels("error-vsl-relabs-indirect.png", tw + 8, band + th + 8));
  // Light text in the title band of every column and in the cell under the reference.
  auto textIn = [&](int x0, int x1, int y0, int y1) {
    int light = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x)
        light += fig[(size_t(y) * w + x) * 3] > 150 && fig[(size_t(y) * w + x) * 3 + 2] > 150;
    return light;
  };
  for (int col = 0; col < 5; ++col)
    EXPECT_GT(textIn(col * (tw + 8), col * (tw + 8) + tw, 0, band), 40) << "column " << col << "'s two title lines";
  EXPECT_GT(textIn(0, tw, band + th + 8, band + 2 * th + 8), 40) << "the error maps' metric";
  EXPECT_GT(textIn(0, w, band + 2 * th + 8, h), 40) << "the colour bar's labels";
  stbi_image_free(fig);
}

// Shift+drag on an image draws the crop rectangle over the pixels it
// touches; the Crops tab shows it; Shift+click clears it.
TEST_F(StudioInput, ShiftDragMakesACrop) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::Single;
  renderFrames(2);
  const auto d = studio->drawnImages()[0];
  auto at = [&](float fx, float fy) {
    return ImVec2(d.p0.x + fx * (d.p1.x - d.p0.x), d.p0.y + fy * (d.p1.y - d.p0.y));
  };
  Input in;
  in.shift = true;
  in.mouse = at(0.26f, 0.26f);
  frameWith(in);
  in.down = true;
  frameWith(in);
  for (float t = 0.3f; t <= 0.76f; t += 0.1f) {
    in.mouse = at(0.26f + 0.25f * (t - 0.26f) / 0.5f, t);
    frameWith(in);
  }
  in.mouse = at(0.51f, 0.76f);
  frameWith(in);
  in.down = false;
  frameWith(in);
  // 0.26..0.51 of 64 columns = 16.6..32.6 -> x 16, w 17; 0.26..0.76 of 32 rows = 8.3..24.3 -> y 8, h 17.
  EXPECT_EQ(v.crop.x, 16);
  EXPECT_EQ(v.crop.w, 17);
  EXPECT_EQ(v.crop.y, 8);
  EXPECT_EQ(v.crop.h, 17);
  EXPECT_NEAR(v.center.x, 0.5f, 1e-6f) << "no pan";
  // The Crops tab comes up with the crops (rendered without failing).
  in.shift = false;
  frameWith(in);
  frameWith(in);
  auto crops = studio->buildCrops(v.crop, Component::Indirect, nullptr);
  ASSERT_EQ(crops.size(), 9u);
  EXPECT_EQ(crops[1].image.width, 17);
  // Shift+click clears it.
  in.shift = true;
  in.mouse = at(0.5f, 0.5f);
  frameWith(in);
  in.down = true;
  frameWith(in);
  in.down = false;
  frameWith(in);
  EXPECT_TRUE(v.crop.empty());
}

// The last session: saved and read back field for field; a corrupt file,
// a wrong type or an invalid value is a warning and changes nothing.
namespace {
struct StudioRun {
  int code = -1;
  std::string out;  // stdout and stderr
};
// Runs build/bin/vsl-studio ARGS (as the shell reads them) with a last
// session of its own under configDir, never the user's. Hack: tests/run_vsl.h
// runs only `vsl`, so this is its twin for the studio.
// An empty folder NAME in the build tree for one test's files.
std::string freshDir(const std::string& name) {
  const std::string dir = std::string(VSL_BINARY_DIR) + "/" + name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

StudioRun runStudio(const std::string& configDir, const std::string& args) {
  std::string cmd =
      "XDG_CONFIG_HOME='" + configDir + "' " + std::string(VSL_BINARY_DIR) + "/bin/vsl-studio " + args + " 2>&1";
  StudioRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) r.out.append(buf, n);
  int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}
}  // namespace

// A headless run given a reference it cannot use ends at once with exit
// status 1, naming the file and the reason (another size, no indirect
// layer, another scene), and exports nothing; a reference file that does not exist is a bad
// argument (exit status 2).
TEST(StudioCli, HeadlessRunWithARefusedReferenceFails) {
  const std::string dir = freshDir("studio-reference-cli");
  const std::string wrongSize = dir + "/wrong-size.exr", noIndirect = dir + "/no-indirect.exr";
  ASSERT_TRUE(writeExr(wrongSize, {{"indirect", Image(20, 16)}}));
  ASSERT_TRUE(writeExr(noIndirect, {{"direct", Image(16, 16)}}));
  // The default scene (cornell-glossy, square) at 16x16.
  const std::string common =
      "--headless --fresh --window 320x240 --lights 50 --width 16 --light-sets 1 --export " + dir + "/out";
  StudioRun r = runStudio(dir + "/config", common + " --reference " + wrongSize);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("error: reference not used: " + wrongSize + ": 20x16, but the render is 16x16"),
            std::string::npos)
      << r.out;
  r = runStudio(dir + "/config", common + " --reference " + noIndirect);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find(noIndirect + ": no 'indirect' layer"), std::string::npos) << r.out;
  // A reference `vsl reference` made of another scene (its key's scene hash
  // is not this scene's).
  Reference other;
  other.width = other.height = 16;
  other.full = other.direct = other.indirect = Image(16, 16);
  other.key = "furnace-0123456789abcdef-16x16-d64";
  const std::string otherScene = dir + "/other-scene.exr";
  ASSERT_TRUE(writeReference(otherScene, other, "furnace.gltf"));
  r = runStudio(dir + "/config", common + " --reference " + otherScene);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find(otherScene + ": rendered from another scene or camera"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir + "/out")) << "nothing is exported";
  r = runStudio(dir + "/config", common + " --reference " + dir + "/missing.exr");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("missing.exr"), std::string::npos) << r.out;
}

namespace {
// The metrics.json of every export folder in outDir (a failed read is a test
// failure and gives no entry).
std::vector<nlohmann::json> exportedMetrics(const std::string& outDir) {
  std::vector<nlohmann::json> all;
  for (const auto& e : std::filesystem::directory_iterator(outDir)) {
    std::ifstream js(e.path() / "metrics.json");
    EXPECT_TRUE(js) << e.path();
    if (js) all.push_back(nlohmann::json::parse(js));
  }
  return all;
}
}  // namespace

// Another renderer's reference holds a full image only: the studio compares
// the full component against it, says so in metrics.json, and measures the
// path tracer's full image too (docs/REFERENCE.md, "References").
TEST(StudioCli, HeadlessRunComparesTheFullImageOfAFullOnlyReference) {
  const std::string dir = freshDir("studio-full-reference");
  Image full(16, 16);
  for (float& v : full.rgb) v = 0.5f;
  const std::string fullOnly = dir + "/full-only.exr";
  ASSERT_TRUE(writeExr(fullOnly, {{"", full}}));
  const std::string common =
      "--headless --fresh --window 320x240 --lights 50 --width 16 --light-sets 2 --export " + dir + "/out";
  StudioRun r = runStudio(dir + "/config", common + " --reference " + fullOnly);
  ASSERT_EQ(r.code, 0) << r.out;
  std::vector<nlohmann::json> all = exportedMetrics(dir + "/out");
  ASSERT_EQ(all.size(), 1u);
  const nlohmann::json& j = all[0];
  EXPECT_EQ(j["comparedComponent"], "full");
  EXPECT_EQ(j["reference"]["component"], "full");
  EXPECT_EQ(j["reference"]["source"], fullOnly);
  EXPECT_TRUE(j["reference"]["fullNoiseRelMSE"].is_null()) << "no halves: its noise is unknown";
  EXPECT_EQ(j["view"]["component"], "full") << "the view shows the component measured";
  EXPECT_TRUE(j.contains("equalTimeFull") && !j.contains("equalTimeIndirect")) << j.dump(1);
  EXPECT_TRUE(j.contains("biasNoiseFull") && !j.contains("biasNoiseIndirect")) << j.dump(1);
  // Only the full component is measured: there is no indirect image to
  // measure against.
  const nlohmann::json& vsl = j["metricsAgainstReference"]["VSL"];
  EXPECT_TRUE(vsl.contains("full") && !vsl.contains("indirect")) << vsl.dump();
  // The history holds the full images' errors: the methods' and the path
  // tracer's (a constant 0.5 is no render of the scene, so every error is
  // well above zero), and the last point is the export's VSL relMSE.
  const nlohmann::json& h = j["errorHistory"];
  ASSERT_FALSE(h.empty());
  for (const char* m : {"vsl", "vpl", "pt"}) EXPECT_GT(h.back()[m].get<double>(), 0.01) << m;
  EXPECT_NEAR(h.back()["vsl"].get<double>(), vsl["full"]["relMSE"].get<double>(),
              1e-3 * vsl["full"]["relMSE"].get<double>());
}

// --preset paper reaches the studio's render: metrics.json names the preset,
// and its replay command carries the paper's settings; an option given with
// it overrides it.
TEST(StudioCli, PresetReachesTheRender) {
  const std::string dir = freshDir("studio-preset-cli");
  const std::string common =
      "--headless --fresh --window 320x240 --lights 50 --width 16 --light-sets 1 --export " + dir + "/out";
  StudioRun r = runStudio(dir + "/config", common + " --preset paper");
  ASSERT_EQ(r.code, 0) << r.out;
  r = runStudio(dir + "/config", common + " --preset paper --lobe-floor 0.5");
  ASSERT_EQ(r.code, 0) << r.out;
  std::vector<std::string> presets, replays;
  for (const nlohmann::json& j : exportedMetrics(dir + "/out")) {
    presets.push_back(j["settings"]["preset"]);
    replays.push_back(j["replay"]);
  }
  std::sort(presets.begin(), presets.end());
  EXPECT_EQ(presets, (std::vector<std::string>{"custom", "paper"}));
  for (const std::string& replay : replays) EXPECT_NE(replay.find("--vsl-count authors"), std::string::npos) << replay;
  r = runStudio(dir + "/config", common + " --preset nonsense");
  EXPECT_EQ(r.code, 2) << r.out;
}

// --split-alpha reaches the render (the export's replay command carries it) and
// a value outside [0,1] is a bad argument.
TEST(StudioCli, SplitAlphaReachesTheRender) {
  const std::string dir = freshDir("studio-split-cli");
  const std::string common = "--headless --fresh --window 320x240 --lights 50 --width 16 --light-sets 1 --export " +
                             dir + "/out --split-alpha ";
  StudioRun r = runStudio(dir + "/config", common + "0.05 --lobe-floor 0.5");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::vector<nlohmann::json> exports = exportedMetrics(dir + "/out");
  EXPECT_EQ(exports.size(), 1u);
  for (const nlohmann::json& metrics : exports) {
    const std::string replay = metrics["replay"].get<std::string>();
    EXPECT_NE(replay.find("--split-alpha 0.05"), std::string::npos) << replay;
    EXPECT_NE(replay.find("--lobe-floor 0.5"), std::string::npos) << replay;
    // The replay command runs as written (it had no output file and was
    // refused) and renders the first light set.
    ASSERT_EQ(replay.rfind("vsl render ", 0), 0u) << replay;
    const std::string cmd =
        "cd '" + dir + "' && " + std::string(VSL_BINARY_DIR) + "/bin/" + replay + " > /dev/null 2>&1";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    EXPECT_TRUE(std::filesystem::exists(dir + "/first-light-set.exr")) << replay;
    EXPECT_NE(metrics["replayRenders"].get<std::string>().find("the first of the 1 light sets"), std::string::npos)
        << metrics["replayRenders"];
    // The export's settings name them too.
    EXPECT_FLOAT_EQ(metrics["settings"]["splitAlpha"].get<float>(), 0.05f);
    EXPECT_FLOAT_EQ(metrics["settings"]["lobeFloor"].get<float>(), 0.5f);
    EXPECT_FLOAT_EQ(metrics["settings"]["lobeRadius"].get<float>(), 0.0f);
    EXPECT_EQ(metrics["settings"]["clippedDisk"], false);
    EXPECT_FLOAT_EQ(metrics["settings"]["continueAlpha"].get<float>(), ManyLightSettings::kDefaultContinueAlpha);
  }
  for (const char* bad : {"2", "-0.1", "nan"}) {
    r = runStudio(dir + "/config", common + bad);
    EXPECT_EQ(r.code, 2) << bad << ": " << r.out;
    EXPECT_NE(r.out.find("--split-alpha"), std::string::npos) << r.out;
  }
  // NaN passes CLI11's range checks; the studio refuses it itself.
  r = runStudio(dir + "/config", common + "0 --after nan");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--after"), std::string::npos) << r.out;
}

// --pair-roulette reaches the render: the export's replay command and
// settings carry it, with the pairs it dropped (the studio gathers both
// methods, so it plays on the pairs' larger estimate); a negative or
// non-finite K is a bad argument.
TEST(StudioCli, PairRouletteReachesTheRender) {
  const std::string dir = freshDir("studio-roulette-cli");
  const std::string common = "--headless --fresh --window 320x240 --lights 400 --width 24 --light-sets 1 --export " +
                             dir + "/out --pair-roulette ";
  StudioRun r = runStudio(dir + "/config", common + "2");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::vector<nlohmann::json> exports = exportedMetrics(dir + "/out");
  EXPECT_EQ(exports.size(), 1u);
  for (const nlohmann::json& metrics : exports) {
    const std::string replay = metrics["replay"].get<std::string>();
    EXPECT_NE(replay.find("--pair-roulette 2"), std::string::npos) << replay;
    EXPECT_FLOAT_EQ(metrics["settings"]["pairRoulette"].get<float>(), 2.0f);
    EXPECT_GT(metrics["settings"]["resolved"]["pairsDropped"].get<uint64_t>(), 0u);
  }
  for (const char* bad : {"-1", "nan", "200", "1 --mrcs 10,20"}) {
    r = runStudio(dir + "/config", common + bad);
    EXPECT_EQ(r.code, 2) << bad << ": " << r.out;
    EXPECT_NE(r.out.find("--pair-roulette"), std::string::npos) << r.out;
  }
}

// --lobe-gather and --lobe-gather-rays reach the render (the export's replay
// command and settings carry them, with MRCS too); a count below the k
// nearest or directions out of [1, 1024] are bad arguments.
TEST(StudioCli, LobeGatherReachesTheRender) {
  const std::string dir = freshDir("studio-lobe-cli");
  const std::string common = "--headless --fresh --window 320x240 --lights 50 --width 16 --light-sets 1 --export " +
                             dir + "/out --lobe-gather ";
  StudioRun r = runStudio(dir + "/config", common + "1000");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::vector<nlohmann::json> exports = exportedMetrics(dir + "/out");
  EXPECT_EQ(exports.size(), 1u);
  for (const nlohmann::json& metrics : exports) {
    const std::string replay = metrics["replay"].get<std::string>();
    EXPECT_NE(replay.find("--lobe-gather 1000 --lobe-gather-rays " +
                          std::to_string(ManyLightSettings::kDefaultLobeGatherRays)),
              std::string::npos)
        << replay;
    EXPECT_EQ(metrics["settings"]["lobeGather"].get<int>(), 1000);
    EXPECT_EQ(metrics["settings"]["lobeGatherRays"].get<int>(), ManyLightSettings::kDefaultLobeGatherRays);
  }
  r = runStudio(dir + "/config", common + std::to_string(ManyLightSettings::kLobeGatherK - 1));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(
      r.out.find("--lobe-gather: must be in [" + std::to_string(ManyLightSettings::kLobeGatherK) + ",50000000] or off"),
      std::string::npos)
      << r.out;
  std::filesystem::remove_all(dir + "/out");
  r = runStudio(dir + "/config", common + "1000 --mrcs 10,20");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::vector<nlohmann::json> withMrcs = exportedMetrics(dir + "/out");
  EXPECT_EQ(withMrcs.size(), 1u);
  for (const nlohmann::json& metrics : withMrcs) {
    const std::string replay = metrics["replay"].get<std::string>();
    EXPECT_NE(replay.find("--lobe-gather 1000"), std::string::npos) << replay;
    EXPECT_NE(replay.find("--mrcs 10,20"), std::string::npos) << replay;
  }
  // The exported EXR names the estimator beside the settings.
  for (const auto& e : std::filesystem::directory_iterator(dir + "/out")) {
    std::map<std::string, std::string> attrs;
    ASSERT_TRUE(readExr((e.path() / "images.exr").string(), &attrs));
    EXPECT_EQ(attrs["vsl.estimator"].rfind("mrcs --mrcs 10,20,", 0), 0u) << attrs["vsl.estimator"];
    EXPECT_NE(attrs["vsl.settings"].find("--lobe-gather 1000"), std::string::npos) << attrs["vsl.settings"];
  }
  std::filesystem::remove_all(dir + "/out");
  r = runStudio(dir + "/config", common + "1000 --lobe-gather-rays 3 --lobe-gather-alpha 0.15");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::vector<nlohmann::json> threeRays = exportedMetrics(dir + "/out");
  EXPECT_EQ(threeRays.size(), 1u);
  for (const nlohmann::json& metrics : threeRays) {
    EXPECT_NE(metrics["replay"].get<std::string>().find("--lobe-gather 1000 --lobe-gather-rays 3 --lobe-gather-alpha "
                                                        "0.15"),
              std::string::npos)
        << metrics["replay"];
    EXPECT_EQ(metrics["settings"]["lobeGatherRays"].get<int>(), 3);
    EXPECT_FLOAT_EQ(metrics["settings"]["lobeGatherAlpha"].get<float>(), 0.15f);
  }
  r = runStudio(dir + "/config", common + "1000 --lobe-gather-rays 0");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--lobe-gather-rays"), std::string::npos) << r.out;
  r = runStudio(dir + "/config", common + "1000 --lobe-gather-alpha 0");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--lobe-gather-alpha"), std::string::npos) << r.out;
}

// Headless without --export or --frames ends when the render is done (it
// used to run until killed), taking the screenshot if asked; empty paths are
// bad arguments.
TEST(StudioCli, HeadlessRunsWithoutAnExportEnd) {
  const std::string dir = freshDir("studio-headless-end");
  const std::string common = "--headless --fresh --window 320x240 --lights 20 --width 8 --light-sets 1";
  StudioRun r = runStudio(dir + "/config", common + " --screenshot " + dir + "/shot.png");
  EXPECT_EQ(r.code, 0) << r.out;
  int w = 0, h = 0, n = 0;
  EXPECT_TRUE(stbi_info((dir + "/shot.png").c_str(), &w, &h, &n)) << r.out;
  EXPECT_EQ(w, 320);
  r = runStudio(dir + "/config", common);
  EXPECT_EQ(r.code, 0) << r.out;
  for (const char* empty : {"--export ''", "--screenshot ''"}) {
    r = runStudio(dir + "/config", common + " " + empty);
    EXPECT_EQ(r.code, 2) << empty << ": " << r.out;
    EXPECT_NE(r.out.find("the path is empty"), std::string::npos) << r.out;
  }
}

// A headless run whose frame count ends before its scene has loaded still
// ends with exit status 1 if the scene cannot load (it ended with 0, and a
// screenshot of "loading ...", before the load had failed).
TEST(StudioCli, HeadlessRunWithFewFramesReportsASceneThatCannotLoad) {
  const std::string dir = freshDir("studio-frames-bad-scene");
  const std::string dark = dir + "/dark.gltf";
  test::writeNoEmitterTriangle(dark);
  const std::string common = "--headless --fresh --window 320x240 --lights 20 --width 8 --light-sets 1 ";
  StudioRun r = runStudio(dir + "/config", common + "--frames 1 " + dark);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("error: " + dark), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("no emitters"), std::string::npos) << r.out;
  r = runStudio(dir + "/config", common + "--frames 1 " + dir + "/missing.gltf");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("missing.gltf"), std::string::npos) << r.out;
}

// The time left counts down between snapshots (an MRCS light set publishes
// none while it runs) and says "finishing" once it has run out.
TEST(StudioText, TimeLeftCountsDownBetweenSnapshots) {
  EXPECT_EQ(ui::timeLeftText(90.0, 0.0), "~1 min 30 s left");
  EXPECT_EQ(ui::timeLeftText(90.0, 30.0), "~1 min 00 s left");
  EXPECT_EQ(ui::timeLeftText(12.0, 2.5), "~10 s left");
  EXPECT_EQ(ui::timeLeftText(5.0, 5.5), "~0 s left");  // within a second of the prediction
  EXPECT_EQ(ui::timeLeftText(5.0, 7.0), "finishing");
  EXPECT_EQ(ui::timeLeftText(5.0, -3.0), "~5 s left");               // no age: the prediction as made
  EXPECT_EQ(ui::timeLeftText(0.0, 0.0), "time left not known yet");  // the snapshot has none yet
  EXPECT_EQ(ui::timeLeftText(0.0, 10.0), "time left not known yet");
  EXPECT_EQ(ui::timeLeftText(std::nan(""), 0.0), "time left not known yet");
}

// The environment light comes back as it was saved; a file written before
// it was saved has none.
TEST(LastSession, KeepsTheEnvironment) {
  const std::string dir = std::string(VSL_BINARY_DIR) + "/last-session-environment-test";
  std::filesystem::remove_all(dir);
  const std::string path = dir + "/last-session.json";
  StudioSettings s;
  s.scene = "/some/scene.gltf";
  s.env.map = "/some/sky.exr";
  s.env.scale = 2.5f;
  s.env.sky = Vec3(0.1f, 0.2f, 0.3f);
  s.env.sunDirection = Vec3(1, 2, 3);
  s.env.sunDiameterDeg = 4;
  s.env.sunIrradiance = 7;
  ui::ViewState v;
  ASSERT_TRUE(ui::saveLastSession(path, s, v));
  StudioSettings r;
  ui::ViewState rv;
  std::string warning;
  ASSERT_TRUE(ui::loadLastSession(path, &r, &rv, &warning)) << warning;
  EXPECT_TRUE(r.env == s.env) << r.env.describe();
  nlohmann::json j = nlohmann::json::parse(std::ifstream(path));
  j["settings"].erase("environment");
  std::ofstream(path) << j.dump();
  StudioSettings old;
  ASSERT_TRUE(ui::loadLastSession(path, &old, &rv, &warning)) << warning;
  EXPECT_FALSE(old.env.any());
}

// The estimator comes back by name with its parameters under their keys
// (the registry's, estimator_registry.h), and a file written before the
// registry (version 2: "estimator", "mrcsRows", "mrcsClusters") still loads.
TEST(LastSession, KeepsTheEstimatorAndItsParameters) {
  const std::string dir = std::string(VSL_BINARY_DIR) + "/last-session-estimator-test";
  std::filesystem::remove_all(dir);
  const std::string path = dir + "/last-session.json";
  StudioSettings s;
  s.scene = "/some/scene.gltf";
  s.estimator.name = "mrcs";
  s.estimator.values = {{"mrcs-rows", 123}, {"mrcs-clusters", 456}, {"mrcs-mix", 0.25}, {"mrcs-spread", 1}};
  s.estimator.progressiveRadius = true;
  s.estimator.alpha = 0.5f;
  ui::ViewState v;
  ASSERT_TRUE(ui::saveLastSession(path, s, v));
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(path));
  EXPECT_EQ(j["settings"]["estimator"], "mrcs");
  EXPECT_EQ(j["settings"]["mrcsRows"], 123);
  EXPECT_EQ(j["settings"]["mrcsSpread"], true);
  StudioSettings r;
  ui::ViewState rv;
  std::string warning;
  ASSERT_TRUE(ui::loadLastSession(path, &r, &rv, &warning)) << warning;
  EXPECT_EQ(r.estimator.name, "mrcs");
  for (const char* p : {"mrcs-rows", "mrcs-clusters", "mrcs-mix", "mrcs-spread"})
    EXPECT_EQ(r.estimator.value(p), s.estimator.value(p)) << p;
  EXPECT_TRUE(r.estimator.sameEstimate(s.estimator));
  EXPECT_EQ(r.estimator.describe(), s.estimator.describe());
  // Brute force chosen: MRCS's values are kept for when it is chosen again.
  s.estimator.name = "brute-force";
  ASSERT_TRUE(ui::saveLastSession(path, s, v));
  ASSERT_TRUE(ui::loadLastSession(path, &r, &rv, &warning)) << warning;
  EXPECT_EQ(r.estimator.name, "brute-force");
  EXPECT_EQ(r.estimator.value("mrcs-rows"), 123);
  // The keys of a version-2 file.
  std::ofstream(path, std::ios::trunc)
      << R"({"version": 2, "scene": "x.gltf", "settings": {"estimator": "mrcs", "mrcsRows": 77, "mrcsClusters": 88}})";
  StudioSettings old;
  ASSERT_TRUE(ui::loadLastSession(path, &old, &rv, &warning)) << warning;
  EXPECT_EQ(old.estimator.name, "mrcs");
  EXPECT_EQ(old.estimator.value("mrcs-rows"), 77);
  EXPECT_EQ(old.estimator.value("mrcs-clusters"), 88);
  EXPECT_EQ(old.estimator.value("mrcs-mix"), 0) << "absent: the default";
  EXPECT_EQ(old.estimator.describe(), "mrcs --mrcs 77,88,0");
  // An estimator this version does not have: the default.
  std::ofstream(path, std::ios::trunc)
      << R"({"version": 2, "scene": "x.gltf", "settings": {"estimator": "lightslice"}})";
  StudioSettings unknown;
  ASSERT_TRUE(ui::loadLastSession(path, &unknown, &rv, &warning)) << warning;
  EXPECT_EQ(unknown.estimator.name, "brute-force");
}

TEST(LastSession, RoundTripAndCorruptFiles) {
  const std::string dir = std::string(VSL_BINARY_DIR) + "/last-session-test";
  std::filesystem::remove_all(dir);
  const std::string path = dir + "/sub/last-session.json";
  StudioSettings s;
  s.scene = "/some/scene.gltf";
  s.many.lights = 1234;
  s.many.width = 77;
  s.many.radiusScale = 0.5f;
  s.many.clamp = INFINITY;
  s.many.lobeGather = 4321;
  s.many.lobeGatherRays = 256;
  s.many.lobeGatherAlpha = 0.15f;
  s.maxReferenceSpp = 99;
  ui::ViewState v;
  v.mode = ui::ViewMode::Wipe;
  v.panels[0] = ui::Source::VplDiffuse;
  v.exposure = 1.5f;
  Result<void> saved = ui::saveLastSession(path, s, v);
  ASSERT_TRUE(saved) << saved.error();
  StudioSettings r;
  ui::ViewState rv;
  std::string warning;
  ASSERT_TRUE(ui::loadLastSession(path, &r, &rv, &warning)) << warning;
  EXPECT_EQ(r.scene, s.scene);
  EXPECT_EQ(r.many.lights, 1234u);
  EXPECT_EQ(r.many.width, 77);
  EXPECT_EQ(r.many.radiusScale, 0.5f);
  EXPECT_TRUE(std::isinf(r.many.clamp));
  EXPECT_EQ(r.many.lobeGather, 4321u);
  EXPECT_EQ(r.many.lobeGatherRays, 256);
  EXPECT_EQ(r.many.lobeGatherAlpha, 0.15f);
  EXPECT_EQ(r.maxReferenceSpp, 99);
  EXPECT_EQ(rv.mode, ui::ViewMode::Wipe);
  EXPECT_EQ(rv.panels[0], ui::Source::VplDiffuse);
  EXPECT_EQ(rv.exposure, 1.5f);
  EXPECT_EQ(r.many.lobeFloor, s.many.lobeFloor);

  // The lobe floor: an explicit 0 is kept; a version-1 file's 0 (the default
  // when it was written) gives way to today's default; its other values stay.
  s.many.lobeFloor = 0;
  ASSERT_TRUE(ui::saveLastSession(path, s, v));
  ASSERT_TRUE(ui::loadLastSession(path, &r, &rv, &warning)) << warning;
  EXPECT_EQ(r.many.lobeFloor, 0.0f);
  for (float old : {0.0f, 0.5f}) {
    std::ofstream(path, std::ios::trunc) << "{\"version\": 1, \"scene\": \"x.gltf\", \"settings\": {\"lobeFloor\": "
                                         << old << "}}";
    StudioSettings fresh;
    ASSERT_TRUE(ui::loadLastSession(path, &fresh, &rv, &warning)) << warning;
    EXPECT_EQ(fresh.many.lobeFloor, old == 0 ? ManyLightSettings::kDefaultLobeFloor : old);
  }

  // Nothing saved: false without a warning.
  StudioSettings d;
  ui::ViewState dv;
  EXPECT_FALSE(ui::loadLastSession(dir + "/none.json", &d, &dv, &warning));
  EXPECT_TRUE(warning.empty());
  for (const char* bad :
       {"{\"scene\": \"x.gltf\", \"settings\": {\"lights\": ", "[1, 2]", "", "{\"scene\": 3}",
        "{\"settings\": {\"lights\": \"many\"}}", "{\"scene\": \"x.gltf\", \"settings\": {\"lights\": 0}}",
        "{\"scene\": \"x.gltf\", \"view\": {\"mode\": 9}}"}) {
    std::ofstream(path, std::ios::trunc) << bad;
    StudioSettings before;
    before.scene = "kept.gltf";
    StudioSettings got = before;
    ui::ViewState gv;
    EXPECT_FALSE(ui::loadLastSession(path, &got, &gv, &warning)) << bad;
    EXPECT_NE(warning.find("starting with the defaults"), std::string::npos) << bad << ": " << warning;
    EXPECT_EQ(got.scene, "kept.gltf");
    EXPECT_EQ(got.many.lights, before.many.lights);
    EXPECT_EQ(gv.mode, ui::ViewState().mode);
  }
}

// Every registered parameter (core/params.h) makes the whole trip: given on
// the studio's command line, it reaches the render's settings, the last
// session's file, and, in a second run that restores that session with no
// option given, metrics.json and the replay command; the replay renders a
// file byte-identical to `vsl render` given the same parameters as text.
// A parameter added to the registry without a value here fails the test.
TEST(StudioCli, EveryParameterRoundTrips) {
  const std::map<std::string, std::string> values = {{"lights", "60"},
                                                     {"batches", "3"},
                                                     {"direct-samples", "5"},
                                                     {"light-max-depth", "7"},
                                                     {"radius", "0.05"},
                                                     {"radius-scale", "1.5"},
                                                     {"knn", "6"},
                                                     {"vsl-samples", "3"},
                                                     {"clipped-disk", ""},
                                                     {"clamp", "0.5"},
                                                     {"diffuse-vpl", ""},
                                                     {"vsl-count", "shares"},
                                                     {"vsl-integral", "sg"},
                                                     {"vsl-sg-max-angle", "10"},
                                                     {"lobe-radius", "0.25"},
                                                     {"lobe-floor", "0.75"},
                                                     {"continue-alpha", "0.03"},
                                                     {"split-alpha", "0.04"},
                                                     {"lobe-gather", "40"},
                                                     {"lobe-gather-rays", "2"},
                                                     {"lobe-gather-alpha", "0.2"},
                                                     {"pair-roulette", "0.5"}};
  std::string text;  // the parameters as command-line text
  for (const Param<ManyLightSettings>& p : manyLightParams().all()) {
    ASSERT_TRUE(values.count(p.spec.name)) << "no test value for the parameter " << p.spec.name;
    text += std::string(" --") + p.spec.name + (p.spec.kind == ParamKind::Flag ? "" : " " + values.at(p.spec.name));
  }
  ManyLightSettings given;  // what the text means
  for (const Param<ManyLightSettings>& p : manyLightParams().all())
    ASSERT_TRUE(manyLightParams().setText(given, p.spec.name,
                                          p.spec.kind == ParamKind::Flag ? "true" : values.at(p.spec.name)));
  const nlohmann::json expected = paramsToJson(manyLightParams(), given);
  const std::string dir = freshDir("studio-params-round-trip");
  const std::string common = "--headless --window 320x240 --width 16 --light-sets 1 --export " + dir + "/out";
  StudioRun r = runStudio(dir + "/config", common + " --fresh" + text);
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json session =
      nlohmann::json::parse(std::ifstream(dir + "/config/vsl-studio/last-session.json"))["settings"];
  std::filesystem::remove_all(dir + "/out");
  r = runStudio(dir + "/config", common);  // the last session, nothing given
  ASSERT_EQ(r.code, 0) << r.out;
  const std::vector<nlohmann::json> exports = exportedMetrics(dir + "/out");
  ASSERT_EQ(exports.size(), 1u);
  const nlohmann::json& metrics = exports[0];
  for (const Param<ManyLightSettings>& p : manyLightParams().all()) {
    EXPECT_EQ(session[p.spec.key], expected[p.spec.key]) << p.spec.name << " in the last session";
    EXPECT_EQ(metrics["settings"][p.spec.key], expected[p.spec.key]) << p.spec.name << " in metrics.json";
  }
  const std::string replay = metrics["replay"];
  ASSERT_EQ(replay.rfind("vsl render ", 0), 0u) << replay;
  const std::string bin = std::string(VSL_BINARY_DIR) + "/bin/";
  ASSERT_EQ(std::system(("cd '" + dir + "' && " + bin + replay + " > /dev/null 2>&1").c_str()), 0) << replay;
  const std::string direct = bin + "vsl render " + metrics["scene"].get<std::string>() +
                             " --method all --seed 0 --width 16" + text + " -o " + dir + "/given.exr > /dev/null 2>&1";
  ASSERT_EQ(std::system(direct.c_str()), 0) << direct;
  std::ifstream a(dir + "/first-light-set.exr", std::ios::binary), b(dir + "/given.exr", std::ios::binary);
  const std::string bytesA((std::istreambuf_iterator<char>(a)), {}), bytesB((std::istreambuf_iterator<char>(b)), {});
  ASSERT_FALSE(bytesA.empty());
  EXPECT_TRUE(bytesA == bytesB) << "the replay and the parameters given as text render different files:\n"
                                << replay << "\n"
                                << direct;
}

// "Compare with the paper preset": the VSL picture is pinned and shown
// beside the new one and the reference, the paper preset is set, and the
// table and metrics.json measure the pinned picture against the reference
// the new one is measured against.
TEST_F(StudioFrame, ComparePresetsPinsTheVslPictureBesideTheOtherPreset) {
  auto first = makeSnapshot();
  first->settings = studio->acceptedSettings();
  studio->setSnapshotForTesting(first);
  renderFrames(1);
  ASSERT_EQ(matchingPreset(studio->acceptedSettings().many), "default");
  ASSERT_TRUE(studio->comparePresets());
  EXPECT_EQ(matchingPreset(studio->acceptedSettings().many), "paper");
  const ui::ViewState& v = studio->view();
  EXPECT_EQ(v.mode, ui::ViewMode::SideBySide3);
  EXPECT_EQ(v.panels[1], ui::Source::Pinned);
  // The paper preset's picture: VSL equal to the reference.
  auto second = makeSnapshot();
  second->settings = studio->acceptedSettings();
  second->many.vsl = second->refIndirect;
  studio->setSnapshotForTesting(second);
  studio->view().component = Component::Indirect;
  studio->view().exposure = 0;
  auto px = renderFrames();
  ASSERT_EQ(studio->drawnImages().size(), 3u);
  const Image& pinned = first->many.vsl;
  EXPECT_EQ(compareGrid(
                px, studio->drawnImages()[1], [&](int x, int y) { return srgb8(pinned.at(x, y)); }, 2),
            0)
      << "the pinned panel shows the first picture";
  const nlohmann::json m = exportedMetrics("studio-compare-presets");
  EXPECT_EQ(m["Pinned VSL"]["name"], "VSL [closed form]") << "the default preset's VSL";
  EXPECT_EQ(m["Pinned VSL"]["preset"], "default");
  const double want = compareImages(pinned, second->refIndirect).average.relMse;
  EXPECT_NEAR(m["Pinned VSL"]["indirect"]["relMSE"].get<double>(), want, 1e-9 * want);
  EXPECT_GT(want, 0.01);
  EXPECT_EQ(m["VSL"]["indirect"]["relMSE"].get<double>(), 0.0);
  // The same scene and size only: another scene's picture is not shown.
  auto other = makeSnapshot();
  other->settings = studio->acceptedSettings();
  other->settings.scene = "another.gltf";
  studio->setSnapshotForTesting(other);
  EXPECT_FALSE(studio->hasPicture(ui::Source::Pinned, Component::Indirect));
}

// "Compare with the quadrature": the default view's VSL (the closed form)
// is pinned beside VSL by the quadrature (the same light sets), and back
// again ("Compare with the closed form").
TEST_F(StudioFrame, CompareIntegralsPinsTheClosedFormBesideTheQuadrature) {
  auto first = makeSnapshot();
  first->settings = studio->acceptedSettings();
  studio->setSnapshotForTesting(first);
  renderFrames(1);
  ASSERT_EQ(studio->acceptedSettings().many.vslIntegral, VslIntegral::Sg) << "the default view shows the closed form";
  const ManyLightSettings before = studio->acceptedSettings().many;
  ASSERT_TRUE(studio->compareIntegrals());
  const ManyLightSettings after = studio->acceptedSettings().many;
  EXPECT_EQ(after.vslIntegral, VslIntegral::Quadrature);
  EXPECT_EQ(after.lights, before.lights);
  ManyLightSettings afterSg = after;
  afterSg.vslIntegral = VslIntegral::Sg;
  EXPECT_EQ(matchingPreset(afterSg), matchingPreset(before)) << "the other parameters stay as they were";
  EXPECT_EQ(studio->view().panels[1], ui::Source::Pinned);
  auto second = makeSnapshot();
  second->settings = studio->acceptedSettings();
  studio->setSnapshotForTesting(second);
  renderFrames(1);
  EXPECT_EQ(exportedMetrics("studio-compare-integrals")["Pinned VSL"]["name"], "VSL [closed form]");
  // And back: the quadrature's picture is pinned under its own name.
  ASSERT_TRUE(studio->compareIntegrals());
  EXPECT_EQ(studio->acceptedSettings().many.vslIntegral, VslIntegral::Sg);
  EXPECT_EQ(exportedMetrics("studio-compare-integrals")["Pinned VSL"]["name"], "VSL");
}

// The pixel probe stays inside the window, even over the right edge of the
// right-most image.
TEST_F(StudioInput, ProbeStaysInsideTheWindow) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::SideBySide3;
  renderFrames(2);
  const auto& d = studio->drawnImages().back();
  Input in;
  for (ImVec2 m : {ImVec2(d.p1.x - 2, d.p0.y + 2), ImVec2(d.p1.x - 2, d.p1.y - 2), ImVec2(d.p0.x + 2, d.p0.y + 2)}) {
    in.mouse = m;
    for (int i = 0; i < 3; ++i) frameWith(in);  // the first frame measures the probe, the next place it
    ASSERT_GT(studio->probeSize().x, 100) << "the probe is shown";
    EXPECT_GE(studio->probeMin().x, 0);
    EXPECT_LE(studio->probeMin().x + studio->probeSize().x, float(kW) + 0.5f) << "at " << m.x << "," << m.y;
    EXPECT_LE(studio->probeMin().y + studio->probeSize().y, float(kH) + 0.5f) << "at " << m.x << "," << m.y;
  }
}

// A picture of another scene starts clean: no crop, no old export message.
TEST_F(StudioFrame, NewSceneClearsTheCropAndTheExportMessage) {
  studio->view().crop = ui::CropRect{4, 4, 8, 8};
  renderFrames(1);
  auto same = makeSnapshot();
  studio->setSnapshotForTesting(same);
  EXPECT_FALSE(studio->view().crop.empty()) << "the same scene keeps its crop";
  auto other = makeSnapshot();
  other->settings.scene = "another.gltf";
  studio->setSnapshotForTesting(other);
  EXPECT_TRUE(studio->view().crop.empty());
}

// A scene that fails to load leaves the open one rendering and the typed
// path in the field, to be corrected in place.
TEST_F(StudioFrame, FailedLoadKeepsTheTypedPath) {
  ui::StudioOptions o;
  o.scene = std::string(VSL_SOURCE_DIR) + "/assets/scenes/furnace.gltf";
  o.settings.scene = o.scene;
  o.settings.many.lights = 20;
  o.settings.many.width = 8;
  o.settings.lightSets = 1;
  studio = std::make_unique<ui::Studio>(o);
  const std::string typo = std::string(VSL_BINARY_DIR) + "/no-such-dir/furnce.gltf";
  for (int i = 0; i < 600 && !studio->snapshot(); ++i) {
    renderFrames(1);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(studio->snapshot());
  studio->openScene(typo);
  for (int i = 0; i < 600 && studio->errorDialog().empty(); ++i) {
    renderFrames(1);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_NE(studio->errorDialog().find("furnce.gltf"), std::string::npos) << studio->errorDialog();
  EXPECT_EQ(studio->sceneField(), typo) << "the typed path stays for correction";
  EXPECT_EQ(studio->acceptedSettings().scene, o.scene) << "the open scene goes on";
}

// A dropped .exr that cannot be used (Studio::openEnvironment, as the
// window's drop callback calls it) is shown in the error dialog, naming the
// file; the previous environment (a sky here) stays in use.
TEST_F(StudioFrame, BadEnvironmentMapKeepsThePreviousEnvironment) {
  ui::StudioOptions o;
  o.scene = std::string(VSL_SOURCE_DIR) + "/assets/scenes/furnace.gltf";
  o.settings.scene = o.scene;
  o.settings.many.lights = 20;
  o.settings.many.width = 8;
  o.settings.lightSets = 1;
  o.settings.env.sky = Vec3(0.25f);
  studio = std::make_unique<ui::Studio>(o);
  for (int i = 0; i < 600 && !studio->snapshot(); ++i) {
    renderFrames(1);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(studio->snapshot());
  const std::string bad = std::string(VSL_BINARY_DIR) + "/no-such-dir/sky.exr";
  studio->openEnvironment(bad);
  for (int i = 0; i < 600 && studio->errorDialog().empty(); ++i) {
    renderFrames(1);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_NE(studio->errorDialog().find("sky.exr"), std::string::npos) << studio->errorDialog();
  EXPECT_NE(studio->errorDialog().find("environment"), std::string::npos) << studio->errorDialog();
  EXPECT_TRUE(studio->acceptedSettings().env == o.settings.env) << studio->acceptedSettings().env.describe();
}

// A scene loaded with warnings says so under the scene field (the count and
// the first) and its export carries them.
TEST_F(StudioFrame, SceneWarningsAreShownAndExported) {
  nlohmann::json doc =
      nlohmann::json::parse(std::ifstream(std::string(VSL_SOURCE_DIR) + "/assets/scenes/furnace.gltf"));
  doc["extensionsUsed"] = {"EXT_made_up"};
  const std::string dir = std::string(VSL_BINARY_DIR) + "/studio-scene-warnings";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/warned.gltf";
  std::ofstream(path) << doc.dump();
  ui::StudioOptions o;
  o.scene = o.settings.scene = path;
  o.settings.many.lights = 20;
  o.settings.many.width = 8;
  o.settings.lightSets = 1;
  studio = std::make_unique<ui::Studio>(o);
  for (int i = 0; i < 600 && !(studio->snapshot() && studio->snapshot()->manyLightDone); ++i) {
    renderFrames(1);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(studio->snapshot());
  ASSERT_EQ(studio->sceneWarnings().size(), 1u);
  EXPECT_NE(studio->sceneWarnings()[0].find("EXT_made_up"), std::string::npos) << studio->sceneWarnings()[0];
  std::string folder;
  std::vector<std::string> written;
  ASSERT_TRUE(studio->exportAll(dir + "/out", &written, &folder));
  const nlohmann::json m = nlohmann::json::parse(std::ifstream(folder + "/metrics.json"));
  ASSERT_EQ(m["sceneWarnings"].size(), 1u);
  EXPECT_NE(m["sceneWarnings"][0].get<std::string>().find("EXT_made_up"), std::string::npos);
}

// tev's viewing keys: E and Shift+E step the exposure by half a stop, R
// resets the view, F1 shows and hides the list of keys.
TEST_F(StudioInput, ExposureResetAndShortcutKeys) {
  ui::ViewState& v = studio->view();
  v.exposure = 0;
  v.zoom = 3;
  v.center = ImVec2(0.3f, 0.6f);
  renderFrames(2);
  Input e;
  e.key = 'E';
  frameWith(e);
  EXPECT_FLOAT_EQ(v.exposure, 0.5f);
  frameWith(Input());
  e.shift = true;
  frameWith(e);
  frameWith(Input());
  frameWith(e);
  EXPECT_FLOAT_EQ(v.exposure, -0.5f);
  Input r;
  r.key = 'R';
  frameWith(r);
  EXPECT_EQ(v.zoom, 1.0f);
  EXPECT_EQ(v.center.x, 0.5f);
  EXPECT_EQ(v.center.y, 0.5f);
  EXPECT_FALSE(studio->shortcutsShown());
  Input f1;
  f1.key = 290;  // GLFW_KEY_F1
  frameWith(f1);
  EXPECT_TRUE(studio->shortcutsShown());
  frameWith(Input());
  frameWith(f1);
  EXPECT_FALSE(studio->shortcutsShown());
}

// A picture from under 5% of the first light set's lights carries a ROUGH
// badge on the methods' panels, not on the reference's; it goes once the
// set has more.
TEST_F(StudioFrame, EarlyPicturesAreMarkedRough) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::SideBySide3;
  v.panels[0] = ui::Source::Vsl;
  v.panels[1] = ui::Source::Vpl;
  v.panels[2] = ui::Source::Reference;
  auto snap = std::make_shared<Snapshot>(*studio->snapshot());
  snap->lightSets = 2;
  snap->lightsTotal = 20000;
  snap->lightsProcessed = 30;
  snap->lightSetsDone = 0;
  snap->manyLightDone = false;
  studio->setSnapshotForTesting(snap);
  auto px = renderFrames();
  EXPECT_TRUE(studio->roughPicture());
  // The badge's blue box at each method panel's top-left corner, none on the reference.
  auto badge = [&](int i) {
    const auto& d = studio->drawnImages()[size_t(i)];
    const Vec3 c = pixel(px, int(d.p0.x + 6), int(d.p0.y + 6));
    return c.z > c.x + 40;
  };
  EXPECT_TRUE(badge(0));
  EXPECT_TRUE(badge(1));
  EXPECT_FALSE(badge(2)) << "the reference is not the methods' picture";
  snap = std::make_shared<Snapshot>(*snap);
  snap->lightsProcessed = 600;  // 6% of the first set's 10,000
  studio->setSnapshotForTesting(snap);
  px = renderFrames();
  EXPECT_FALSE(studio->roughPicture());
  EXPECT_FALSE(badge(0));
}

// The Stats tab's numbers: luminance mean, extremes, percentiles and a
// histogram of log10 luminance, non-finite pixels counted apart.
TEST(StudioStats, ImageStatsOfAKnownImage) {
  Image img(10, 10);
  for (int i = 0; i < 100; ++i) img.set(i % 10, i / 10, Vec3(float(i + 1)));  // luminance 1..100
  img.set(0, 0, Vec3(NAN));
  const ui::studio_detail::ImageStats st = ui::studio_detail::imageStats(img);
  EXPECT_EQ(st.pixels, 99u);
  EXPECT_EQ(st.nonFinite, 1u);
  EXPECT_NEAR(st.mean, (5050.0 - 1) / 99, 1e-3);
  EXPECT_NEAR(st.min, 2, 1e-4);
  EXPECT_NEAR(st.max, 100, 1e-3);
  EXPECT_NEAR(st.p50, 51, 1e-3);
  EXPECT_NEAR(st.logMin, std::log10(2.0), 1e-5);
  EXPECT_NEAR(st.logMax, 2.0, 1e-5);
  float total = 0;
  for (float c : st.histogram) total += c;
  EXPECT_EQ(total, 99.0f);
  EXPECT_EQ(st.histogram.front(), 1.0f) << "2 alone in the first bin (3 is a tenth of the log range further)";
  EXPECT_GE(st.histogram.back(), 1.0f) << "100 in the last bin";
}

// Layout (issue 49, item 4): the largest whole scale that fits, or the fit
// scale when not even 1x fits.
TEST(StudioLayout, ImageScaleIsTheLargestWholeNumberThatFits) {
  using ui::studio_detail::imageScale;
  EXPECT_EQ(imageScale(305, 480, 256, 256), 1.0f) << "1.19x fits: 1x, pixel for pixel";
  EXPECT_EQ(imageScale(914, 520, 256, 256), 2.0f);
  EXPECT_EQ(imageScale(914, 520, 128, 64), 7.0f) << "the width decides";
  EXPECT_FLOAT_EQ(imageScale(200, 300, 256, 256), 200.0f / 256) << "too large for 1x: fit";
  EXPECT_EQ(imageScale(0, 300, 256, 256), 0.0f);
}

// The panels' images are drawn at a whole scale that fills their room: the
// next scale would not fit, and the view area ends under the images (the
// metrics get the rest).
TEST_F(StudioFrame, ImagesFillTheViewAreaAtAWholeScale) {
  for (ui::ViewMode mode : {ui::ViewMode::Single, ui::ViewMode::SideBySide3}) {
    studio->view().mode = mode;
    renderFrames();
    const auto& d = studio->drawnImages().front();
    const float w = d.p1.x - d.p0.x, h = d.p1.y - d.p0.y, scale = w / 64;
    EXPECT_EQ(scale, std::round(scale)) << "a whole scale, not " << scale;
    EXPECT_EQ(h, scale * 32);
    const int n = mode == ui::ViewMode::Single ? 1 : 3;
    const float areaW = studio->viewAreaMax().x - studio->viewAreaMin().x;
    const float panelW = (areaW - 8 * (n - 1)) / n;
    // The views end at most 260 px (the metrics' least) above the window's
    // content bottom, less their padding.
    const float roomH = (kH - 8 - 260 - 8 - 2) - d.p0.y;
    EXPECT_TRUE((scale + 1) * 64 > panelW || (scale + 1) * 32 > roomH) << "scale " << scale << " could be larger";
    EXPECT_LT(studio->viewAreaMax().y - d.p1.y, 8) << "the area ends under the images";
  }
}

// "Save view" writes the panels as drawn (titles, images), not the empty
// room beside them.
TEST_F(StudioFrame, SaveViewWritesOnlyThePanels) {
  studio->view().mode = ui::ViewMode::Single;
  renderFrames();
  studio->saveView();
  renderFrames(1);
  studio->afterRender(kW, kH);
  const std::string path = studio->messagePath();
  ASSERT_FALSE(path.empty()) << studio->message();
  EXPECT_TRUE(std::filesystem::path(path).is_absolute()) << path;
  int w = 0, h = 0, n = 0;
  ASSERT_TRUE(stbi_info(path.c_str(), &w, &h, &n)) << path;
  const auto& d = studio->drawnImages().front();
  EXPECT_NEAR(w, d.p1.x - d.p0.x, 1) << "the image's width, not the view area's "
                                     << studio->viewAreaMax().x - studio->viewAreaMin().x;
  EXPECT_NEAR(h, d.p1.y - studio->panelsMin().y, 1) << "the title and the image";
  std::filesystem::remove(path);
}

// The export's message names the folder's absolute path, and its button
// copies it.
TEST_F(StudioFrame, ExportMessageGivesTheAbsolutePathToCopy) {
  renderFrames(1);
  studio->exportFromControls();
  const std::string folder = studio->messagePath();
  ASSERT_FALSE(folder.empty()) << studio->errorDialog();
  EXPECT_TRUE(std::filesystem::path(folder).is_absolute()) << folder;
  EXPECT_TRUE(std::filesystem::exists(folder + "/metrics.json"));
  EXPECT_NE(studio->message().find(folder), std::string::npos) << studio->message();
  studio->copyMessagePath();
  EXPECT_EQ(std::string(ImGui::GetClipboardText()), folder);
  std::filesystem::remove_all(folder);
}

// Tone maps (issue 49, item 7): the filmic curve compresses highlights
// without clipping, and false colour maps log10 luminance over its decades.
TEST(StudioToneMap, CurvesAsStated) {
  using ui::studio_detail::acesFilmic;
  using ui::studio_detail::toneMapPixel;
  EXPECT_EQ(acesFilmic(0), 0.0f);
  EXPECT_LT(acesFilmic(4), 1.0f) << "not clipped where linear is";
  EXPECT_LT(acesFilmic(1), acesFilmic(4));
  EXPECT_LT(acesFilmic(0.9f), 0.9f) << "highlights compressed";
  EXPECT_NEAR(toneMapPixel(Vec3(4.0f), 0, ui::ToneMap::Linear).x, 1.0f, 1e-6f);
  const Vec3 fc = toneMapPixel(Vec3(0.01f), 1, ui::ToneMap::FalseColour);  // luminance 0.02: t = (log10 0.02 + 3) / 4
  const Vec3 want = falseColour((std::log10(0.02f) + 3) / 4);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(fc[c], want[c], 1e-5f);
}

// The tone-map choice reaches the panels and the exported PNGs: filmic
// darkens VSL's bright red ramp, false colour shows VPL's constant 0.2 as
// the ramp's colour for log10 0.2, with its bar under the images. It is kept
// in the last session.
TEST_F(StudioFrame, ToneMapChangesThePanelsAndTheExports) {
  ui::ViewState& v = studio->view();
  v.mode = ui::ViewMode::SideBySide2;
  v.panels[0] = ui::Source::Vsl;
  v.panels[1] = ui::Source::Vpl;
  const std::string dir = std::string(VSL_BINARY_DIR) + "/studio-tonemap-test";
  std::filesystem::remove_all(dir);
  auto exported = [&](const char* file) {
    std::string folder;
    EXPECT_TRUE(studio->exportAll(dir, nullptr, &folder));
    int w = 0, h = 0, n = 0;
    uint8_t* data = stbi_load((folder + "/" + file).c_str(), &w, &h, &n, 3);
    EXPECT_TRUE(data) << folder << "/" << file;
    std::vector<uint8_t> px(data, data + (data ? w * h * 3 : 0));
    stbi_image_free(data);
    return px;
  };
  v.toneMap = ui::ToneMap::Filmic;
  const std::vector<uint8_t> filmic = exported("vsl-indirect.png");
  ASSERT_EQ(filmic.size(), 64u * 32 * 3);
  const size_t brightRed = (size_t(16) * 64 + 63) * 3;  // x = 63: red 0.9
  EXPECT_LT(filmic[brightRed], toSrgb8(0.9f) - 20) << "filmic compresses the highlight that linear shows at 0.9";
  EXPECT_NEAR(filmic[brightRed], 255 * ui::studio_detail::toneMapPixel(Vec3(0.9f, 0.3f, 0.3f), 0, v.toneMap).x, 1);

  v.toneMap = ui::ToneMap::FalseColour;
  const Vec3 want = falseColour((std::log10(0.2f) + 3) / 4) * 255.0f;
  const std::vector<uint8_t> fc = exported("vpl-clamped-indirect.png");
  ASSERT_GE(fc.size(), 3u);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(fc[size_t(c)], want[c], 1);
  auto px = renderFrames();
  const auto& d = studio->drawnImages()[1];
  const Vec3 shown = pixel(px, int((d.p0.x + d.p1.x) / 2), int((d.p0.y + d.p1.y) / 2));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(shown[c], want[c], 2) << "the panel as exported";
  EXPECT_GT(studio->panelsMax().y, d.p1.y + 12) << "the bar under the images";
  std::filesystem::remove_all(dir);

  const std::string session = dir + "-session.json";
  ASSERT_TRUE(ui::saveLastSession(session, studio->acceptedSettings(), v));
  StudioSettings s;
  ui::ViewState back;
  std::string warning;
  ASSERT_TRUE(ui::loadLastSession(session, &s, &back, &warning)) << warning;
  EXPECT_EQ(back.toneMap, ui::ToneMap::FalseColour);
  std::filesystem::remove(session);
}

// A heuristic's tooltip: the one-line help, then where to read more (issue
// 49, item 2), and short.
TEST(StudioTooltips, HeuristicsHaveAMoreLine) {
  int heuristics = 0;
  for (const Param<ManyLightSettings>& p : manyLightParams().all()) {
    const std::string t = ui::paramTooltip(p.spec, p.get(ManyLightSettings{}));
    std::vector<std::string> lines;
    for (size_t a = 0, b; a <= t.size(); a = b + 1) {
      b = t.find('\n', a);
      if (b == std::string::npos) b = t.size();
      lines.push_back(t.substr(a, b - a));
    }
    EXPECT_EQ(lines[0], std::string(p.spec.help) + ".") << p.spec.name;
    EXPECT_LE(lines.size(), 4u) << t;
    if (p.spec.tier != ParamTier::Experimental) continue;
    ++heuristics;
    ASSERT_GE(lines.size(), 2u) << t;
    EXPECT_EQ(lines[1].rfind("More: ", 0), 0u) << t;
    EXPECT_NE(lines[1].find("docs/"), std::string::npos) << "names a document: " << t;
    EXPECT_EQ(t.find("Why: "), std::string::npos) << "the more line replaces the why line: " << t;
  }
  EXPECT_GT(heuristics, 3);
}

// The reference's bar never reads over 100%: past its setting the live path
// tracer is "refining past N spp".
TEST(StudioText, ReferenceProgressNeverExceedsAHundredPercent) {
  for (int spp : {0, 1, 511, 1023, 1024, 1025, 1044, 5000}) {
    const ui::studio_detail::ReferenceProgressText r = ui::studio_detail::referenceProgressText(spp, 1024);
    EXPECT_LE(r.fraction, 1.0f) << spp;
    const int percent = std::atoi(r.overlay.c_str() + r.overlay.find_first_of("0123456789"));
    EXPECT_LE(percent, 100) << r.overlay;
    EXPECT_EQ(r.count.find("refining past 1024 spp") != std::string::npos, spp > 1024) << r.count;
  }
  EXPECT_EQ(ui::studio_detail::referenceProgressText(1023, 1024).overlay, "reference 99%") << "not rounded up to done";
}

// A reference given on the command line (--reference FILE, through the
// studio's starting settings) shows in the Reference field.
TEST_F(StudioFrame, ReferenceFieldHoldsTheGivenReference) {
  ui::StudioOptions o;
  o.scene = "synthetic.gltf";
  o.startSession = false;
  o.settings.referencePath = "/data/kitchen-reference.exr";
  ui::Studio s(o);
  EXPECT_EQ(s.referenceField(), "/data/kitchen-reference.exr");
  StudioSettings other = o.settings;
  other.referencePath.clear();
  s.applySettings(other);
  EXPECT_EQ(s.referenceField(), "") << "the field follows the settings applied";
}
