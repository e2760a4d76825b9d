// `vsl compare TEST.exr REFERENCE.exr`: per-channel error metrics (mean,
// bias, MAE, RMSE, relMSE with the stated eps) and LDR-/HDR-FLIP of one test
// image, as a table or JSON, with optional error images; with several test
// images (independent renders of one method), their error split into bias2
// and variance (core/compare.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "app/cli.h"
#include "core/compare.h"
#include "core/flip.h"
#include "core/image_io.h"

namespace vsl {

namespace {

using json = nlohmann::json;

struct CompareArgs {
  std::vector<std::string> images;  // TEST [TEST2 ...] REFERENCE
  std::string layer, refLayer, out, png, flipExr, flipPng;
  bool json = false, noFlip = false;
  double epsilon = kRelMseEpsilon;
  std::string epsilonMode = "relative";
  float exposure = 0;  // of the tone map before LDR-FLIP
};

// ---- FLIP and JSON pieces --------------------------------------------------------

json metricsJson(const ChannelMetrics& m) {
  return {{"mean", m.meanTest}, {"meanReference", m.meanRef}, {"bias", m.bias}, {"mae", m.mae},
          {"rmse", m.rmse},     {"relMSE", m.relMse}};
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
// bar, LDR to PATH and HDR to PATH's stem + "-hdr.png". Returns 0, or the
// exit code after reporting.
int writeFlipMaps(const CompareArgs& a, const CompareFlip& f) {
  if (!a.flipExr.empty()) {
    if (Result<void> w = writeExr(a.flipExr, {{"", f.ldr.map}, {"ldr", f.ldr.map}, {"hdr", f.hdr.map}}); !w)
      return fail(kExitBadInput, w.error());
    std::fprintf(stderr, "wrote %s (FLIP maps, layers: default=ldr, ldr, hdr)\n", a.flipExr.c_str());
  }
  if (!a.flipPng.empty()) {
    for (auto [path, map] : {std::pair{a.flipPng, &f.ldr.map}, std::pair{flipHdrPngPath(a.flipPng), &f.hdr.map}}) {
      int rows = 0;
      std::vector<uint8_t> px = magmaWithBar(*map, &rows);
      if (Result<void> w = writePngRgb8(path, map->width, rows, px); !w) return fail(kExitBadInput, w.error());
      std::fprintf(stderr, "wrote %s (FLIP, magma: black 0 ... light yellow 1, colour bar below)\n", path.c_str());
    }
  }
  return 0;
}

// ---- Inputs ------------------------------------------------------------------------

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
    if (!read) return fail(kExitBadInput, read.error());
    in.testLayers[k] = std::move(read).value();
  }
  Result<std::vector<Layer>> refRead = readExr(refPath);
  if (!refRead) return fail(kExitBadInput, refRead.error());
  in.refLayers = std::move(refRead).value();
  const std::string& refName = refLayerGiven ? a.refLayer : a.layer;
  const Image* r = in.ref = findLayer(in.refLayers, refName, refLayerGiven || layerGiven);
  if (!r) return failf(kExitBadInput, "%s: no layer '%s'", refPath.c_str(), refName.c_str());
  for (size_t k = 0; k < K; ++k) {
    const Image* t = findLayer(in.testLayers[k], a.layer, layerGiven);
    if (!t) return failf(kExitBadInput, "%s: no layer '%s'", a.images[k].c_str(), a.layer.c_str());
    if (t->width != r->width || t->height != r->height)
      return failf(kExitBadInput, "sizes differ: %s is %dx%d, %s is %dx%d", a.images[k].c_str(), t->width, t->height,
                   refPath.c_str(), r->width, r->height);
    in.tests.push_back(t);
  }
  return 0;
}

// ---- One test image ------------------------------------------------------------------

// The metrics as JSON on stdout, or as a table.
void printCompare(const CompareArgs& a, const CompareResult& c, const RelMseEpsilon& eps, const CompareFlip& flip) {
  const std::string& testPath = a.images[0];
  const std::string& refPath = a.images.back();
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
    return;
  }
  std::printf("comparing %s against %s (layer '%s', %zu pixels)\n", testPath.c_str(), refPath.c_str(), a.layer.c_str(),
              c.pixels);
  std::printf("relMSE = mean((t-r)^2 / (r^2 + eps)), eps = %s = %g (%s); non-finite pixels: test %zu, reference %zu\n",
              eps.describe().c_str(), c.epsilon, eps.modeName(), c.nonFiniteTest, c.nonFiniteRef);
  std::printf("%-8s %12s %12s %12s %12s %12s %12s\n", "channel", "mean", "mean(ref)", "bias", "MAE", "RMSE", "relMSE");
  const char* names[4] = {"R", "G", "B", "average"};
  for (int i = 0; i < 4; ++i) {
    const ChannelMetrics& m = i < 3 ? c.channel[i] : c.average;
    std::printf("%-8s %12.6g %12.6g %12.6g %12.6g %12.6g %12.6g\n", names[i], m.meanTest, m.meanRef, m.bias, m.mae,
                m.rmse, m.relMse);
  }
  if (!a.noFlip) printFlip(flip, a.exposure);
}

// -o: the error images as EXR layers.
int writeErrorExr(const std::string& path, const ErrorImages& e) {
  if (Result<void> written = writeExr(path, {{"", e.absolute},
                                             {"signed", e.signedDiff},
                                             {"absolute", e.absolute},
                                             {"squared", e.squared},
                                             {"relSquared", e.relSquared}});
      !written)
    return fail(kExitBadInput, written.error());
  std::fprintf(stderr, "wrote %s (layers: default=absolute, signed, absolute, squared, relSquared)\n", path.c_str());
  return 0;
}

// --png: false colour of the per-pixel relative squared error (channel mean),
// scaled so that the 99th percentile maps to white.
int writeErrorPng(const std::string& path, const Image& relSquared) {
  size_t n = size_t(relSquared.width) * relSquared.height;
  std::vector<float> v(n), finite;
  for (size_t i = 0; i < n; ++i)
    v[i] = (relSquared.rgb[3 * i] + relSquared.rgb[3 * i + 1] + relSquared.rgb[3 * i + 2]) / 3;
  for (float x : v)
    if (std::isfinite(x)) finite.push_back(x);
  float vmax = finite.empty() ? 1.0f : std::max(percentile(finite, 0.99), 1e-12f);
  std::vector<uint8_t> px(n * 3);
  for (size_t i = 0; i < n; ++i) {
    Vec3 col = falseColour(v[i] / vmax);
    px[3 * i] = uint8_t(col.x * 255);
    px[3 * i + 1] = uint8_t(col.y * 255);
    px[3 * i + 2] = uint8_t(col.z * 255);
  }
  if (Result<void> written = writePngRgb8(path, relSquared.width, relSquared.height, px); !written)
    return fail(kExitBadInput, written.error());
  std::fprintf(stderr, "wrote %s (relative squared error, white = %.3g)\n", path.c_str(), vmax);
  return 0;
}

int compareOne(const CompareArgs& a, const Image& t, const Image& r, const RelMseEpsilon& eps) {
  CompareResult c = compareImages(t, r, eps);
  if (c.pixels == 0)  // nothing to measure: never report a perfect score
    return failf(kExitBadInput, "no pixel is finite in both images (non-finite pixels: test %zu, reference %zu)",
                 c.nonFiniteTest, c.nonFiniteRef);
  CompareFlip flip;
  if (!a.noFlip) flip = compareFlip(t, r, a.exposure);
  printCompare(a, c, eps, flip);
  if (!a.noFlip)
    if (int rc = writeFlipMaps(a, flip); rc != 0) return rc;
  if (a.out.empty() && a.png.empty()) return 0;
  ErrorImages e = errorImages(t, r, eps);
  if (!a.out.empty())
    if (int rc = writeErrorExr(a.out, e); rc != 0) return rc;
  if (!a.png.empty()) return writeErrorPng(a.png, e.relSquared);
  return 0;
}

// ---- Several test images ---------------------------------------------------------------

// K >= 2 independent renders of one method against the reference: bias2,
// variance and the relMSE of their mean (core/compare.h), FLIP of the mean.
int compareMany(const CompareArgs& a, const std::vector<const Image*>& tests, const Image& r,
                const RelMseEpsilon& eps) {
  BiasVarianceResult bv = biasVariance(tests, r, eps);
  if (bv.pixels == 0) return fail(kExitBadInput, "no pixel is finite in every image");
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
  if (!a.noFlip)
    if (int rc = writeFlipMaps(a, flip); rc != 0) return rc;
  if (!a.out.empty()) {
    if (Result<void> written =
            writeExr(a.out, {{"", bv.bias}, {"bias", bv.bias}, {"noise", bv.noise}, {"mean", bv.mean}});
        !written)
      return fail(kExitBadInput, written.error());
    std::fprintf(stderr,
                 "wrote %s (layers: default=bias, bias (mean - reference), noise (one render's standard "
                 "deviation), mean)\n",
                 a.out.c_str());
  }
  if (!a.png.empty()) std::fprintf(stderr, "warning: --png is for a single test image; not written\n");
  return 0;
}

int cmdCompare(const CompareArgs& a, bool layerGiven, bool refLayerGiven) {
  CompareInputs in;
  if (int rc = loadCompareInputs(a, layerGiven, refLayerGiven, in); rc != 0) return rc;
  const RelMseEpsilon eps = a.epsilonMode == "absolute" ? RelMseEpsilon(a.epsilon) : RelMseEpsilon::relative(a.epsilon);
  if (in.tests.size() > 1) return compareMany(a, in.tests, *in.ref, eps);
  return compareOne(a, *in.tests[0], *in.ref, eps);
}

}  // namespace

Subcommand addCompareCommand(CLI::App& app) {
  auto args = std::make_shared<CompareArgs>();
  CompareArgs& ca = *args;
  CLI::App* compare = app.add_subcommand(
      "compare",
      "Compare an EXR against a reference EXR; with several test EXRs (independent renders of one method), "
      "split their error into bias and noise");
  compare
      ->add_option("images", ca.images,
                   "TEST.exr REFERENCE.exr, or TEST1.exr TEST2.exr ... REFERENCE.exr (the reference comes last)")
      ->required()
      ->expected(2, CLI::detail::expected_max_vector_size);
  CLI::Option* layer = compare->add_option("--layer", ca.layer, "Layer name (default: the default layer, else 'full')");
  CLI::Option* refLayer =
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
  return {compare, [args, layer, refLayer] { return cmdCompare(*args, layer->count() > 0, refLayer->count() > 0); }};
}

}  // namespace vsl
