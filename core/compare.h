// Image comparison metrics, per channel, over pixels that are finite in both.
//   bias   = mean(test - ref)
//   MAE    = mean(|test - ref|)
//   RMSE   = sqrt(mean((test - ref)^2))
//   relMSE = mean((test - ref)^2 / (ref^2 + eps)), eps = 1e-2 by default
#pragma once

#include "core/film.h"

namespace vsl {

constexpr double kRelMseEpsilon = 1e-2;

struct ChannelMetrics {
  double meanTest = 0, meanRef = 0, bias = 0, mae = 0, rmse = 0, relMse = 0;
};

struct CompareResult {
  ChannelMetrics channel[3];
  ChannelMetrics average;  // the three channels averaged
  size_t pixels = 0;       // pixels compared
  size_t nonFiniteTest = 0, nonFiniteRef = 0;
  double epsilon = kRelMseEpsilon;
};

// Images must have equal sizes (checked by the caller).
CompareResult compareImages(const Image& test, const Image& ref, double epsilon = kRelMseEpsilon);

// Per-pixel error images: signed difference, absolute, squared, relative squared.
struct ErrorImages {
  Image signedDiff, absolute, squared, relSquared;
};
ErrorImages errorImages(const Image& test, const Image& ref, double epsilon = kRelMseEpsilon);

// Share of the summed per-pixel relative squared error (channels averaged)
// held by the worst `fraction` of pixels: near `fraction` for evenly spread
// error, near 1 when a few outliers (speckles, blobs) hold it all. 0 for a
// perfect image.
double worstPixelShare(const Image& test, const Image& ref, double fraction = 0.01, double epsilon = kRelMseEpsilon);

// A false-colour map (black-blue-magenta-yellow-white) of v / vmax.
Vec3 falseColour(float t);

}  // namespace vsl
