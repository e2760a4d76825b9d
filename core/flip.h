// FLIP: a perceptual difference evaluator for alternating images.
//   LDR-FLIP: Andersson, Nilsson, Akenine-Möller, Oskarsson, Åström and
//   Fairchild, "FLIP: A Difference Evaluator for Alternating Images", HPG 2020.
//   HDR-FLIP: Andersson, Nilsson, Shirley and Akenine-Möller, "Visualizing
//   Errors in Rendered High Dynamic Range Images", Eurographics 2021 (short).
// Our own implementation from the papers, with the published corrections: the
// feature pipeline works on the achromatic channel normalised by 116
// ((Y* + 16) / 116, i.e. Y / Y_white), and images are pooled by the mean.
//
// Parameters (the papers' defaults): pixels per degree 67 (a 0.7 m wide 3840
// pixel monitor seen from 0.7 m); colour exponent q_c = 0.7, feature exponent
// q_f = 0.5, remapping p_c = 0.4, p_t = 0.95; feature width 0.082 degrees.
// HDR-FLIP tone maps with ACES (Narkowicz's fit, pre-exposed by 0.6) over
// exposures from log2(x/Y_max) to log2(x/Y_median) of the reference's
// luminance, x the input where the tone curve reaches 0.85, and keeps each
// pixel's maximum error.
//
// Values are in [0,1]; identical inputs give exactly 0. Thread-safe (uses
// parallelFor internally); inputs must have equal sizes (checked by callers).
#pragma once

#include <cstdint>
#include <vector>

#include "core/film.h"

namespace vsl {

// Pixels per degree of a 0.7 m wide, 3840 pixel monitor seen from 0.7 m.
constexpr double kFlipPixelsPerDegree = 0.7 * 3840 / 0.7 * 3.14159265358979323846 / 180;

struct FlipResult {
  Image map;        // per-pixel FLIP in [0,1], the same value in R, G and B
  double mean = 0;  // mean over the pixels (the published pooling)
  // HDR-FLIP only: the exposures (stops) the error was taken over.
  double startExposure = 0, stopExposure = 0;
  int exposures = 0;
};

// LDR-FLIP of sRGB-encoded images with values in [0,1] (clamped).
FlipResult flipLdr(const Image& testSrgb, const Image& refSrgb, double pixelsPerDegree = kFlipPixelsPerDegree);

// HDR-FLIP of linear, non-negative images (negative and non-finite values
// count as 0). The exposure range comes from the reference only.
FlipResult flipHdr(const Image& test, const Image& ref, double pixelsPerDegree = kFlipPixelsPerDegree);

// HDR-FLIP's exposure range for a reference: start = log2(x / Y_max), stop =
// log2(x / Y_median), x the ACES input that maps to 0.85, count = max(2,
// ceil(stop - start)). A median of 0 uses the smallest positive luminance
// instead; an all-black reference gives start = stop = 0.
struct FlipExposures {
  double start = 0, stop = 0;
  int count = 2;
};
FlipExposures flipExposureRange(const Image& ref);

// The PNG tone map as floats: linear * 2^exposure, clamped to [0,1],
// sRGB-encoded (the input LDR-FLIP expects for a rendered image).
Image toSrgbImage(const Image& linear, float exposure = 0);

// The magma colour map (matplotlib's published values), sRGB-encoded, t in [0,1].
Vec3 magma(float t);

// A FLIP map (values in [0,1], R channel) as 8-bit sRGB pixels through magma,
// with a colour bar from 0 (left) to 1 (right) in 16 rows below it (4 of them
// a dark gap), as the studio's error maps; *rows = height + 16.
std::vector<uint8_t> magmaWithBar(const Image& map, int* rows);

}  // namespace vsl
