// Error metrics (core/compare.h): relMSE's eps relative to the reference, and
// bias against noise over independent renders.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cfloat>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/compare.h"
#include "core/image_io.h"
#include "core/many_light.h"
#include "support.h"
#include "tests/run_vsl.h"

using namespace vsl;
using namespace vsl::test;

// The relative eps is 0.01 x (mean luminance)^2 of the reference; a bare
// number stays an absolute eps.
TEST(Compare, RelativeEpsilonScalesWithTheReference) {
  Image ref(4, 4), test(4, 4);
  for (int i = 0; i < 16; ++i) {
    ref.set(i % 4, i / 4, Vec3(0.5f, 1.0f, 2.0f));
    test.set(i % 4, i / 4, Vec3(1.0f));
  }
  const double lum = 0.2126 * 0.5 + 0.7152 * 1.0 + 0.0722 * 2.0;
  CompareResult r = compareImages(test, ref);
  EXPECT_EQ(r.epsilonSpec.mode, RelMseEpsilon::Mode::Relative);
  EXPECT_NEAR(r.epsilon, 0.01 * lum * lum, 1e-9);
  EXPECT_NEAR(r.channel[0].relMse, 0.25 / (0.25 + r.epsilon), 1e-9);
  CompareResult a = compareImages(test, ref, 0.01);
  EXPECT_EQ(a.epsilonSpec.mode, RelMseEpsilon::Mode::Absolute);
  EXPECT_EQ(a.epsilon, 0.01);
  // Scaling both images leaves the relative relMSE unchanged.
  for (float& v : ref.rgb) v *= 1e-3f;
  for (float& v : test.rgb) v *= 1e-3f;
  EXPECT_NEAR(compareImages(test, ref).average.relMse, r.average.relMse, 1e-6);
}

// An all-black image must not rank above a noisy image with the right mean.
// Dim reference (mean luminance 1e-3): half its pixels 1.8e-3, half 0.2e-3.
// The noisy image is right on average in every pixel pair: in the bright
// pixels it is 0 (60%) or 2.5 x the reference (40%), relative variance 1.5,
// like fireflies; in the dim pixels it is 0.8 or 1.2 x the reference.
// With an absolute eps = 0.01 every pixel's weight is ~1/eps, relMSE is the
// MSE / eps, and the bright pixels' noise (1.5 x 3.2e-6) outweighs black's
// error (mean of ref^2 = 1.6e-6): black ranks first. With the relative eps
// (1e-8 here) black scores ~0.9 (about 1 in every pixel) and the noisy image
// ~0.76.
TEST(Compare, AllBlackNeverRanksAboveTheRightMeanOnADimReference) {
  const int W = 40, H = 20;
  Image ref(W, H), noisy(W, H), black(W, H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const bool bright = x < W / 2;
      const float r = bright ? 1.8e-3f : 0.2e-3f;
      ref.set(x, y, Vec3(r));
      const int k = (x * 7 + y * 3) % 10;  // 0..9, evenly over each half
      float v = bright ? (k < 6 ? 0.0f : 2.5f * r) : (k < 5 ? 0.8f * r : 1.2f * r);
      noisy.set(x, y, Vec3(v));
    }
  CompareResult n = compareImages(noisy, ref), b = compareImages(black, ref);
  EXPECT_NEAR(n.average.meanTest, n.average.meanRef, 0.05 * n.average.meanRef);  // the right mean
  EXPECT_NEAR(n.epsilon, 1e-8, 1e-10);
  EXPECT_NEAR(b.average.relMse, 0.9, 0.01);
  EXPECT_LT(n.average.relMse, b.average.relMse);
  // The absolute eps gets this wrong, which is why it is no longer the default.
  EXPECT_GT(compareImages(noisy, ref, 0.01).average.relMse, compareImages(black, ref, 0.01).average.relMse);
}

// Error images hold only finite values: a non-finite test or reference
// channel gives 0 (the metrics skip it), and a relative squared error beyond
// a float (a tiny absolute eps over a black reference) gives the largest float.
TEST(Compare, ErrorImagesAreFinite) {
  Image test(3, 1), ref(3, 1);
  test.set(0, 0, Vec3(1.0f));
  test.set(1, 0, Vec3(std::numeric_limits<float>::quiet_NaN()));
  test.set(2, 0, Vec3(2.0f));
  ref.set(2, 0, Vec3(std::numeric_limits<float>::infinity()));
  ErrorImages e = errorImages(test, ref, 1e-300);
  for (const Image* im : {&e.signedDiff, &e.absolute, &e.squared, &e.relSquared})
    for (float v : im->rgb) EXPECT_TRUE(std::isfinite(v)) << v;
  EXPECT_EQ(e.relSquared.at(0, 0).x, FLT_MAX);  // 1 / 1e-300
  EXPECT_EQ(e.squared.at(0, 0).x, 1.0f);
  EXPECT_EQ(e.absolute.at(1, 0).x, 0.0f);
  EXPECT_EQ(e.signedDiff.at(2, 0).x, 0.0f);
  // An absolute eps of 0 over a pixel black in both: 0 / 0 gives 0.
  ErrorImages z = errorImages(Image(1, 1), Image(1, 1), 0.0);
  EXPECT_EQ(z.relSquared.at(0, 0).x, 0.0f);
}

// The colour bar's scale is printed under it: "0" at the left, vmax at the
// right, in the 3x5 font (read back here glyph by glyph), and only where it
// fits.
TEST(Compare, ColourBarPrintsItsScale) {
  const int w = 64, h = 8;
  Image map(w, h);
  int rows = 0;
  std::vector<uint8_t> px = colourMapWithBar(map, falseColour, 0.25f, &rows);
  ASSERT_EQ(rows, h + kColourBarRows);
  ASSERT_EQ(px.size(), size_t(w) * rows * 3);
  // Glyph k of a text whose top-left corner is (x0, y0), as five rows of
  // three bits (the font's own form).
  auto glyphAt = [&](int x0, int y0) {
    std::array<int, 5> g{};
    for (int r = 0; r < 5; ++r)
      for (int c = 0; c < 3; ++c)
        if (px[(size_t(y0 + r) * w + size_t(x0 + c)) * 3] > 200) g[size_t(r)] |= 1 << (2 - c);
    return g;
  };
  const std::array<int, 5> zero{7, 5, 5, 5, 7}, dot{0, 0, 0, 0, 2}, two{7, 1, 7, 4, 7}, five{7, 4, 7, 1, 7};
  const int y0 = h + 18;
  EXPECT_EQ(glyphAt(1, y0), zero);
  // "0.25": four glyphs, 15 pixels, ending one pixel from the right edge.
  const int x0 = w - 1 - 15;
  EXPECT_EQ(glyphAt(x0, y0), zero);
  EXPECT_EQ(glyphAt(x0 + 4, y0), dot);
  EXPECT_EQ(glyphAt(x0 + 8, y0), two);
  EXPECT_EQ(glyphAt(x0 + 12, y0), five);
  // Too narrow for the right label: only "0" is printed.
  Image narrow(12, h);
  px = colourMapWithBar(narrow, falseColour, 0.25f, &rows);
  int lit = 0;
  for (int y = h + 16; y < rows; ++y)
    for (int x = 4; x < 12; ++x) lit += px[(size_t(y) * 12 + size_t(x)) * 3] > 200;
  EXPECT_EQ(lit, 0);
}

TEST(Compare, BiasVarianceOfKnownImages) {
  // Renders ref + 0.1 and ref + 0.3 (alternating sign is not needed): mean
  // ref + 0.2, sample variance 0.02; ref = 1 everywhere, eps absolute 0 -> 1e-30.
  Image ref(3, 2), a(3, 2), b(3, 2);
  for (float& v : ref.rgb) v = 1;
  for (float& v : a.rgb) v = 1.1f;
  for (float& v : b.rgb) v = 1.3f;
  BiasVarianceResult r = biasVariance({&a, &b}, ref, 1e-30);
  EXPECT_EQ(r.renders, 2);
  EXPECT_EQ(r.pixels, 6u);
  EXPECT_NEAR(r.average.variance, 0.02, 1e-6);
  EXPECT_NEAR(r.average.bias2, 0.04 - 0.01, 1e-6);
  EXPECT_NEAR(r.average.relMse, 0.04, 1e-6);
  EXPECT_NEAR(r.average.relMse, r.average.bias2 + r.average.variance / 2, 1e-9);
  EXPECT_NEAR(r.bias.rgb[0], 0.2f, 1e-6f);
  EXPECT_NEAR(r.noise.rgb[0], std::sqrt(0.02f), 1e-6f);
}

// Four clamped-VPL renders (independent light sets) of the glossy Cornell box
// are smooth but darker than the path-traced reference: bias dominates. Four
// 4-spp path-traced renders are unbiased and noisy: variance dominates.
// Measured at 24 pixels wide, where one eye ray per pixel makes edge pixels
// noisy (anti-aliasing noise that more lights do not remove), so each VPL
// render averages 4 light sets of 2,000 lights (as the sweep's pass-based
// methods do; 4 eye rays per pixel), and the clamp is 0.01 x the auto bound
// (the auto bound loses almost nothing here: bias2 0.03 against variance 0.37
// with one set); this clamp loses about 30% of the indirect light, like the
// X
// (relative eps). The 1024-spp reference's own noise, relMSE(B, A)/2 = 0.02
// here, counts as bias2: it is small against both margins.
TEST(Compare, ClampedVplIsBiasedAndFewSamplePathTracingIsNoisy) {
  Loaded l = loadAsset("cornell-glossy", 24);
  const int W = l.width, H = l.height, K = 4, setsPerRender = 4;
  Reference ref = ptIndirect(l, W, H, 1024, 77);
  std::vector<Image> vpl, pt;
  for (int k = 0; k < K; ++k) {
    Image sum(W, H);
    for (int j = 0; j < setsPerRender; ++j) {
      ManyLightSettings s;
      s.lights = 2000;
      s.width = W;
      s.height = H;
      s.batches = 1;
      s.directSamples = 1;
      s.seed = 500 + 10 * k + j;
      s.computeVsl = false;
      ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
      s.clamp = 0.01f * ManyLightRenderer(*l.scene, *l.accel, *l.lights, run.set, run.radii, s).clampBound();
      ManyLightRenderer r(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
      ASSERT_TRUE(r.renderBatch(0));
      const Image& v = r.images().vpl;
      for (size_t i = 0; i < sum.rgb.size(); ++i) sum.rgb[i] += v.rgb[i] / setsPerRender;
    }
    vpl.push_back(sum);
    pt.push_back(ptIndirect(l, W, H, 4, 900 + k).indirect);
  }
  std::vector<const Image*> pv, pp;
  for (int k = 0; k < K; ++k) {
    pv.push_back(&vpl[size_t(k)]);
    pp.push_back(&pt[size_t(k)]);
  }
  BiasVarianceResult v = biasVariance(pv, ref.indirect), p = biasVariance(pp, ref.indirect);
  std::printf("clamped VPL: bias2 %.4g variance %.4g relMSE(mean) %.4g, mean %.4g (reference %.4g)\n", v.average.bias2,
              v.average.variance, v.average.relMse, v.average.meanTest, v.average.meanRef);
  std::printf("PT 4 spp:    bias2 %.4g variance %.4g relMSE(mean) %.4g\n", p.average.bias2, p.average.variance,
              p.average.relMse);
  EXPECT_LT(v.average.meanTest, 0.85 * v.average.meanRef);  // clamping darkens
  EXPECT_GT(v.average.bias2, v.average.variance);
  EXPECT_GT(p.average.variance, p.average.bias2);
  EXPECT_NEAR(p.average.relMse, p.average.bias2 + p.average.variance / K, 1e-9 * p.average.relMse);
}

// ---- `vsl compare` and `vsl sweep` from the command line ---------------------------

namespace {

namespace fs = std::filesystem;

using vsl::test::Proc;

// Runs `vsl ARGS`; stderr is dropped unless asked for (stdout is the JSON).
Proc vslOut(const std::string& args, bool withStderr = false) { return vsl::test::runVsl(args, withStderr); }

fs::path scratch(const std::string& name) { return vsl::test::scratchDir("vsl_compare_" + name); }

using vsl::test::slurp;

// A CSV without the given columns (timing differs between runs).
std::string withoutColumns(const std::string& csv, std::vector<size_t> drop) {
  std::istringstream in(csv);
  std::ostringstream out;
  for (std::string line; std::getline(in, line);) {
    std::istringstream ls(line);
    size_t i = 0;
    for (std::string f; std::getline(ls, f, ','); ++i)
      if (std::find(drop.begin(), drop.end(), i) == drop.end()) out << f << ",";
    out << "\n";
  }
  return out.str();
}

}  // namespace

// The number quoted for FLIP: black against white is about 0.967. FLIP is one
// value per RGB image ("flip" and "average"), next to the eps relMSE used.
TEST(CompareCli, BlackAgainstWhiteFlipAndEpsilonInTheJson) {
  fs::path d = scratch("flip");
  Image black(32, 24), white(32, 24);
  for (float& v : white.rgb) v = 1;
  Result<void> w = writeExr((d / "black.exr").string(), {{"", black}});
  ASSERT_TRUE(w) << w.error();
  w = writeExr((d / "white.exr").string(), {{"", white}});
  ASSERT_TRUE(w) << w.error();
  Proc p = vslOut("compare " + (d / "black.exr").string() + " " + (d / "white.exr").string() + " --json --flip-exr " +
                  (d / "flip.exr").string() + " --flip-png " + (d / "flip.png").string());
  ASSERT_EQ(p.code, 0) << p.out;
  auto j = nlohmann::json::parse(p.out);
  EXPECT_NEAR(double(j["average"]["flip"]["ldr"]), 0.967, 0.001);
  EXPECT_NEAR(double(j["flip"]["ldr"]), 0.967, 0.001);
  EXPECT_GT(double(j["flip"]["hdr"]), 0.9);
  EXPECT_EQ(j["epsilon_mode"], "relative");
  EXPECT_NEAR(double(j["epsilon"]), 0.01, 1e-6);  // 0.01 x (mean luminance 1)^2
  EXPECT_FALSE(j["R"].contains("flip"));
  Result<std::vector<Layer>> layers = readExr((d / "flip.exr").string());
  ASSERT_TRUE(layers) << layers.error();
  EXPECT_EQ(layers->size(), 3u);
  EXPECT_TRUE(fs::exists(d / "flip.png"));
  EXPECT_TRUE(fs::exists(d / "flip-hdr.png"));
  // The absolute eps on request.
  auto a = nlohmann::json::parse(vslOut("compare " + (d / "black.exr").string() + " " + (d / "white.exr").string() +
                                        " --json --no-flip --epsilon-mode absolute --epsilon 0.5")
                                     .out);
  EXPECT_EQ(a["epsilon_mode"], "absolute");
  EXPECT_EQ(double(a["epsilon"]), 0.5);
  EXPECT_NEAR(double(a["average"]["relMSE"]), 1 / 1.5, 1e-6);
  fs::remove_all(d);
}

// Several test images: bias2, variance and the relMSE of their mean, with maps.
// Two images without a finite pixel in common are refused (exit 1), never
// scored as a perfect match (they were: "0 pixels", relMSE 0).
TEST(CompareCli, NoFinitePixelIsNotAPerfectScore) {
  fs::path d = scratch("nan");
  Image nan(8, 8), ok(8, 8);
  for (float& v : nan.rgb) v = std::nanf("");
  ASSERT_TRUE(writeExr((d / "nan.exr").string(), {{"", nan}}));
  ASSERT_TRUE(writeExr((d / "ok.exr").string(), {{"", ok}}));
  Proc p = vslOut("compare " + (d / "nan.exr").string() + " " + (d / "ok.exr").string(), true);
  EXPECT_EQ(p.code, 1) << p.out;
  EXPECT_NE(p.out.find("no pixel is finite in both images (non-finite pixels: test 64, reference 0)"),
            std::string::npos)
      << p.out;
  p = vslOut("compare " + (d / "ok.exr").string() + " " + (d / "ok.exr").string() + " " + (d / "nan.exr").string(),
             true);
  EXPECT_EQ(p.code, 1) << p.out;
  EXPECT_NE(p.out.find("no pixel is finite in every image"), std::string::npos) << p.out;
  fs::remove_all(d);
}

// A sweep's reference must hold light: a black or negative indirect layer is
// refused (exit 1, before any run), where it scored relMSE 3e27 or 1 for
// every method; a few negative values are kept with a warning.
TEST(CompareCli, SweepRefusesABlackReference) {
  fs::path d = scratch("black");
  const std::string sceneFile = std::string(VSL_SOURCE_DIR) + "/assets/scenes/cornell-glossy.gltf";
  Image zero(8, 8), negative(8, 8), mostlyLight(8, 8);
  for (float& v : negative.rgb) v = -1;
  for (float& v : mostlyLight.rgb) v = 0.5f;
  mostlyLight.rgb[5] = -0.01f;
  for (auto [name, img] : {std::pair<std::string, Image*>{"zero", &zero}, {"negative", &negative}}) {
    ASSERT_TRUE(writeExr((d / (name + ".exr")).string(), {{"indirect", *img}}));
    Proc p = vslOut("sweep " + sceneFile + " --methods vpl --lights 20 --time 0.05 --sets 1 --reference " +
                        (d / (name + ".exr")).string() + " -o " + (d / name).string(),
                    true);
    EXPECT_EQ(p.code, 1) << name << ": " << p.out;
    EXPECT_NE(p.out.find("the indirect layer's mean is " + std::string(name == "zero" ? "0" : "-1")), std::string::npos)
        << p.out;
    EXPECT_FALSE(fs::exists(d / name / "sweep.csv")) << name;
  }
  ASSERT_TRUE(writeExr((d / "light.exr").string(), {{"indirect", mostlyLight}}));
  Proc p = vslOut("sweep " + sceneFile + " --methods vpl --lights 20 --time 0.05 --sets 1 --reference " +
                      (d / "light.exr").string() + " -o " + (d / "light").string(),
                  true);
  EXPECT_EQ(p.code, 0) << p.out;
  EXPECT_NE(p.out.find("1 of 192 values of the indirect layer are negative (kept)"), std::string::npos) << p.out;
  // Another renderer's full image alone serves the studio, not the sweep,
  // which ranks indirect light: exit 1, naming the file and the remedy.
  ASSERT_TRUE(writeExr((d / "full-only.exr").string(), {{"", mostlyLight}}));
  p = vslOut("sweep " + sceneFile + " --methods vpl --lights 20 --time 0.05 --sets 1 --reference " +
                 (d / "full-only.exr").string() + " -o " + (d / "full").string(),
             true);
  EXPECT_EQ(p.code, 1) << p.out;
  EXPECT_NE(p.out.find("full-only.exr: has a full image but no 'indirect' layer"), std::string::npos) << p.out;
  EXPECT_FALSE(fs::exists(d / "full" / "sweep.csv"));
  fs::remove_all(d);
}

TEST(CompareCli, SeveralRendersSplitBiasAndNoise) {
  fs::path d = scratch("bv");
  Image ref(8, 8), a(8, 8), b(8, 8), c(8, 8);
  for (size_t i = 0; i < ref.rgb.size(); ++i) {
    ref.rgb[i] = 1;
    a.rgb[i] = 1.1f;
    b.rgb[i] = 1.2f;
    c.rgb[i] = 1.3f;
  }
  for (auto [name, img] : {std::pair{"ref", &ref}, {"a", &a}, {"b", &b}, {"c", &c}}) {
    Result<void> w = writeExr((d / (std::string(name) + ".exr")).string(), {{"", *img}});
    ASSERT_TRUE(w) << w.error();
  }
  auto f = [&](const char* n) { return (d / (std::string(n) + ".exr")).string() + " "; };
  Proc p = vslOut("compare " + f("a") + f("b") + f("c") + f("ref") + "--json -o " + (d / "bv.exr").string());
  ASSERT_EQ(p.code, 0) << p.out;
  auto j = nlohmann::json::parse(p.out);
  EXPECT_EQ(j["renders"], 3);
  const double eps = 0.01;  // relative: 0.01 x 1^2
  // mean 1.2, sample variance 0.01; bias2 = 0.04 - 0.01/3.
  EXPECT_NEAR(double(j["average"]["variance"]), 0.01 / (1 + eps), 1e-5);
  EXPECT_NEAR(double(j["average"]["bias2"]), (0.04 - 0.01 / 3) / (1 + eps), 1e-5);
  EXPECT_NEAR(double(j["average"]["relMSE"]), 0.04 / (1 + eps), 1e-5);
  EXPECT_TRUE(j["average"].contains("flip"));
  Result<std::vector<Layer>> layers = readExr((d / "bv.exr").string());
  ASSERT_TRUE(layers) << layers.error();
  ASSERT_EQ(layers->size(), 4u);  // default (bias), bias, noise, mean
  std::map<std::string, const Image*> byName;
  for (const Layer& l : *layers) byName[l.name] = &l.image;
  ASSERT_TRUE(byName.count("bias") && byName.count("noise") && byName.count("mean"));
  EXPECT_NEAR(byName["bias"]->rgb[0], 0.2f, 1e-5f);
  EXPECT_NEAR(byName["noise"]->rgb[0], 0.1f, 1e-5f);
  EXPECT_NEAR(byName["mean"]->rgb[0], 1.2f, 1e-5f);
  fs::remove_all(d);
}

// Shards 0/2 and 1/2 merged give the unsharded sweep's CSVs (timing columns
// aside) and the same JSON summary. The many-light runs are not time-limited
// here, so their results do not depend on the clock.
TEST(CompareCli, ShardedSweepMergesToTheUnshardedOne) {
  fs::path d = scratch("shard");
  std::string sceneFile = std::string(VSL_SOURCE_DIR) + "/assets/scenes/cornell-glossy.gltf";
  ASSERT_EQ(vslOut("render " + sceneFile + " --spp 8 --width 16 --height 16 -o " + (d / "ref.exr").string()).code, 0);
  const std::string grid = "sweep " + sceneFile + " --methods vpl,vsl --lights 40,80 --radius-scale 0.5,1 " +
                           "--batches 2 --sets 2 --time 1000 --reference " + (d / "ref.exr").string() + " -o ";
  Proc all = vslOut(grid + (d / "all").string(), true);
  ASSERT_EQ(all.code, 0) << all.out;
  ASSERT_EQ(vslOut(grid + (d / "s0").string() + " --shard 0/2").code, 0);
  ASSERT_EQ(vslOut(grid + (d / "s1").string() + " --shard 1/2").code, 0);
  Proc m = vslOut("sweep --merge " + (d / "s1").string() + " " + (d / "s0").string() + " -o " + (d / "merged").string(),
                  true);
  ASSERT_EQ(m.code, 0) << m.out;
  // The shards split the six configurations.
  std::string s0 = slurp(d / "s0/sweep.csv"), s1 = slurp(d / "s1/sweep.csv");
  EXPECT_GT(std::count(s0.begin(), s0.end(), '\n'), 1);
  EXPECT_GT(std::count(s1.begin(), s1.end(), '\n'), 1);
  EXPECT_EQ(withoutColumns(slurp(d / "merged/sweep.csv"), {5}), withoutColumns(slurp(d / "all/sweep.csv"), {5}));
  EXPECT_EQ(withoutColumns(slurp(d / "merged/summary.csv"), {4}), withoutColumns(slurp(d / "all/summary.csv"), {4}));
  auto ja = nlohmann::json::parse(slurp(d / "all/sweep.json")),
       jm = nlohmann::json::parse(slurp(d / "merged/sweep.json"));
  EXPECT_EQ(ja["summary"].size(), 6u);
  EXPECT_EQ(jm["summary"].size(), 6u);
  EXPECT_FALSE(jm.contains("shard"));
  EXPECT_EQ(jm["relMseEpsilon"], ja["relMseEpsilon"]);
  // bias2 and variance over the two sets, and FLIP, on every configuration.
  for (const auto& row : ja["summary"]) {
    EXPECT_TRUE(row["bias2"].is_number()) << row;
    EXPECT_GT(double(row["variance"]), 0) << row;
    EXPECT_GT(double(row["flipLdrMedian"]), 0) << row;
  }
  for (const char* png : {"merged/pareto.png", "merged/flip_vs_time.png"}) EXPECT_TRUE(fs::exists(d / png)) << png;
  // Every configuration's final image, as the unsharded run wrote it.
  int images = 0;
  for (const fs::directory_entry& e : fs::directory_iterator(d / "all/finals")) {
    const fs::path merged = d / "merged/finals" / e.path().filename();
    ASSERT_TRUE(fs::exists(merged)) << merged;
    EXPECT_EQ(slurp(merged), slurp(e.path())) << merged;
    ++images;
  }
  EXPECT_EQ(images, 2 * 6 + 1);  // EXR and PNG of six configurations, the reference's PNG
  // A shard given twice, or one missing, is refused; so is a malformed --shard.
  EXPECT_EQ(
      vslOut("sweep --merge " + (d / "s0").string() + " " + (d / "s0").string() + " -o " + (d / "x").string()).code, 1);
  EXPECT_EQ(vslOut("sweep --merge " + (d / "s0").string() + " -o " + (d / "x").string()).code, 1);
  EXPECT_EQ(vslOut(grid + (d / "x").string() + " --shard 2/2").code, 2);
  // The finals keep the time budget, so shards run with another are refused.
  EXPECT_EQ(double(jm["time"]), 1000.0);
  std::string grid999 = grid;
  grid999.replace(grid999.find("--time 1000"), 11, "--time 999");
  ASSERT_EQ(vslOut(grid999 + (d / "t1").string() + " --shard 1/2").code, 0);
  Proc t =
      vslOut("sweep --merge " + (d / "s0").string() + " " + (d / "t1").string() + " -o " + (d / "x").string(), true);
  EXPECT_EQ(t.code, 1) << t.out;
  EXPECT_NE(t.out.find("time budget"), std::string::npos) << t.out;
  // So are shards run with other settings the runs share: the seed, the
  // brute-force batches, --alpha and the -mrcs methods' settings, which
  // sweep.json records as the runs used them (one direct sample, no light
  // count: the grid's).
  const std::string settings = ja["settings"];
  for (const char* want : {"--seed 1 ", "--batches 2 ", "--direct-samples 1 ", "--alpha 0.7", "--mrcs 300,900,0"})
    EXPECT_NE(settings.find(want), std::string::npos) << want << " in " << settings;
  EXPECT_EQ(settings.find("--lights"), std::string::npos) << settings;
  EXPECT_EQ(settings.find("--radius-scale"), std::string::npos) << settings;
  for (const char* other : {"--seed 5", "--batches 3", "--alpha 0.5", "--mrcs 20,40", "--mrcs-spread"}) {
    std::string g = grid;
    if (std::string(other) == "--batches 3")
      g.replace(g.find("--batches 2"), 11, other);
    else
      g.replace(g.find("--time"), 0, std::string(other) + " ");
    ASSERT_EQ(vslOut(g + (d / "o1").string() + " --shard 1/2").code, 0) << other;
    Proc o =
        vslOut("sweep --merge " + (d / "s0").string() + " " + (d / "o1").string() + " -o " + (d / "x").string(), true);
    EXPECT_EQ(o.code, 1) << other << ": " << o.out;
    EXPECT_NE(o.out.find("another sweep"), std::string::npos) << o.out;
    fs::remove_all(d / "o1");
  }
  fs::remove_all(d);
}
