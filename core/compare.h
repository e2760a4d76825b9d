// Image comparison metrics, per channel, over pixels that are finite in both.
//   bias   = mean(test - ref)
//   MAE    = mean(|test - ref|)
//   RMSE   = sqrt(mean((test - ref)^2))
//   relMSE = mean((test - ref)^2 / (ref^2 + eps))
// eps is relative by default: 0.01 x (the reference's mean luminance)^2, so
// relMSE does not depend on the image's overall scale and an all-black image
// scores about 1 (docs/METRICS.md). An absolute eps (the old default, 0.01)
// is still available: a bare number passed as the eps means that.
// Thread-safe; images must have equal sizes (VSL_CHECK: a bug otherwise).
#pragma once

#include <string>
#include <vector>

#include "core/film.h"

namespace vsl {

// The factor (relative mode) or value (absolute mode) of relMSE's eps.
constexpr double kRelMseEpsilon = 1e-2;

// How relMSE's eps is chosen for a reference image.
struct RelMseEpsilon {
  enum class Mode { Relative, Absolute };
  Mode mode = Mode::Relative;  // eps = value x (mean luminance of the reference)^2
  double value = kRelMseEpsilon;
  RelMseEpsilon() = default;
  // A bare number is an absolute eps, as before the relative mode existed.
  RelMseEpsilon(double absolute) : mode(Mode::Absolute), value(absolute) {}  // NOLINT(implicit)
  static RelMseEpsilon relative(double factor = kRelMseEpsilon) {
    RelMseEpsilon e;
    e.value = factor;
    return e;
  }
  // The eps used against ref: relative mode takes the Rec. 709 luminance
  // averaged over ref's finite pixels, and never returns less than 1e-30
  // (a black reference would divide 0 by 0).
  double resolve(const Image& ref) const;
  const char* modeName() const { return mode == Mode::Relative ? "relative" : "absolute"; }
  // "0.01 x mean luminance^2" or "0.01" (for printing next to the resolved value).
  std::string describe() const;
};

struct ChannelMetrics {
  double meanTest = 0, meanRef = 0, bias = 0, mae = 0, rmse = 0, relMse = 0;
};

struct CompareResult {
  ChannelMetrics channel[3];
  ChannelMetrics average;  // the three channels averaged
  size_t pixels = 0;       // pixels compared
  size_t nonFiniteTest = 0, nonFiniteRef = 0;
  double epsilon = kRelMseEpsilon;  // the eps used (resolved against ref)
  RelMseEpsilon epsilonSpec;        // how it was chosen
};

CompareResult compareImages(const Image& test, const Image& ref, RelMseEpsilon epsilon = {});

// Per-pixel error images: signed difference, absolute, squared, relative squared.
// Every value is finite: 0 where the test or the reference is not, at most
// the largest float elsewhere.
struct ErrorImages {
  Image signedDiff, absolute, squared, relSquared;
};
ErrorImages errorImages(const Image& test, const Image& ref, RelMseEpsilon epsilon = {});

// Share of the summed per-pixel relative squared error (channels averaged)
// held by the worst `fraction` of pixels: near `fraction` for evenly spread
// error, near 1 when a few outliers (speckles, blobs) hold it all. 0 for a
// perfect image.
double worstPixelShare(const Image& test, const Image& ref, double fraction = 0.01, RelMseEpsilon epsilon = {});

// Bias against noise, from K >= 2 independent renders x_1..x_K of one method,
// per pixel and channel weighted like relMSE (w = 1 / (ref^2 + eps)), over
// pixels finite in every image:
//   variance = mean(w s^2), s^2 the unbiased sample variance of the K renders
//              (the noise of one render)
//   bias2    = mean(w ((m - ref)^2 - s^2 / K)), m their mean: the squared
//              bias with the variance share of (m - ref)^2 removed (unbiased,
//              so it can come out slightly negative for an unbiased method)
//   relMse   = mean(w (m - ref)^2) = bias2 + variance / K, of the mean image
// One render's expected relMSE is bias2 + variance.
struct BiasVarianceChannel {
  double meanTest = 0, meanRef = 0, bias2 = 0, variance = 0, relMse = 0;
};
struct BiasVarianceResult {
  BiasVarianceChannel channel[3], average;  // average: the three channels averaged
  int renders = 0;
  size_t pixels = 0;
  double epsilon = kRelMseEpsilon;
  RelMseEpsilon epsilonSpec;
  Image mean;   // the renders' mean
  Image bias;   // per pixel: mean - ref (signed)
  Image noise;  // per pixel: the sample standard deviation of one render
};
BiasVarianceResult biasVariance(const std::vector<const Image*>& tests, const Image& ref, RelMseEpsilon epsilon = {});

// A false-colour map (black-blue-magenta-yellow-white) of v / vmax.
Vec3 falseColour(float t);

// A map (values in the R channel) as 8-bit sRGB pixels through a colour map
// of value / vmax, with a colour bar from 0 (left) to vmax (right) in the
// kColourBarRows rows below it: a dark gap of 4, the bar's 12, then its scale
// ("0" at the left, vmax as %.3g at the right where it fits) in a 3x5 pixel
// font; *rows = height + kColourBarRows.
constexpr int kColourBarRows = 25;
std::vector<uint8_t> colourMapWithBar(const Image& map, Vec3 (*colour)(float), float vmax, int* rows);

}  // namespace vsl
