// Internal to the studio's own files (studio.cpp, studio_export.cpp): the
// constants and image helpers both use. Not part of the ui interface.
#pragma once

#include <vector>

#include "core/compare.h"
#include "ui/studio.h"

namespace vsl::ui::studio_detail {

// The methods of the metrics table, the FLIP maps and the exported error maps.
// The pictures clamped VPL and its variants make.
inline bool vplSource(Source s) {
  return s == Source::Vpl || s == Source::VplUnclamped || s == Source::VplDiffuse || s == Source::LostClamping ||
         s == Source::LostDiffuse;
}
inline constexpr Source kMetricSources[4] = {Source::Vsl, Source::Vpl, Source::VplUnclamped, Source::VplDiffuse};
inline const char* const kMetricNames[] = {"absolute |t-r|", "relative absolute |t-r|/(r+eps)", "squared (t-r)^2",
                                           "relative squared (t-r)^2/(r^2+eps)"};
// Each metric's units: the images' radiance, or none for the relative ones.
inline const char* const kMetricUnits[] = {"radiance", "unitless", "radiance^2", "unitless"};
// "relative absolute error |t-r|/(r+eps), unitless": the colour bars' name.
inline std::string metricLabel(ErrorMetric m) {
  std::string name = kMetricNames[int(m)];
  return name.insert(name.find(' ') == std::string::npos ? name.size() : name.rfind(' '), " error") + ", " +
         kMetricUnits[int(m)];
}

// Whether snapshot s holds a picture of source src in component c (see
// Studio::hasPicture: under MRCS the VPL variants and the lost-energy images
// are never rendered, and clamped VPL waits for its columns while
// s.vplPending). Exports leave out what it does not hold.
bool snapshotHasPicture(const Snapshot& s, Source src, Component c);

// One pixel's error under a metric. eps follows the reference as relMSE's
// does (compare.h: 0.01 x the reference's mean luminance squared) for the
// squared metrics, and its square root for the absolute ones.
float metricError(float d, float r, ErrorMetric metric, float eps);
// The eps of the relative error maps for a reference image.
float mapEpsilon(const Image& ref);
// a + b per channel, over the shorter of the two.
Image add(const Image& a, const Image& b);
// The 99th percentile of |channel mean| over the finite pixels (at least
// 1e-12); 1 for an image without any.
float percentile99(const Image& img);
// Per-pixel error of test against ref under a metric, averaged over the
// channels (as the studio's maps show it), in every channel.
Image errorMap(const Image& test, const Image& ref, ErrorMetric metric);

// The false-colour tone map's range: log10 of the luminance (Rec. 709
// weights) times 2^exposure, from kFalseColourDecades[0] (black) to [1]
// (white), through falseColour() (core/compare.h).
inline constexpr float kFalseColourDecades[2] = {-3, 1};
// One pixel as the tone map shows it: display values in [0,1], sRGB-encoded
// (the linear and filmic curves) or false colour. Must match the display
// shader in gl_image.cpp.
Vec3 toneMapPixel(Vec3 linear, float exposure, ToneMap t);
// The ACES filmic curve fitted by Narkowicz 2015 ("ACES Filmic Tone Mapping
// Curve", knarkowicz.wordpress.com), with his 0.6 pre-scale, per channel,
// clamped to [0,1]; linear in, linear out.
float acesFilmic(float x);

// The reference's progress bar: its fraction (never over 1) and its text.
// Past its setting the live path tracer keeps refining (it takes turns with
// the methods): the bar stays full and says "refining past N spp".
struct ReferenceProgressText {
  float fraction = 0;
  std::string overlay;  // inside the bar
  std::string count;    // "S / N spp", or "refining past N spp (S spp)"
};
ReferenceProgressText referenceProgressText(int spp, int maxSpp);

// The on-screen scale of an image of imageW x imageH pixels in a panel of
// panelW x panelH screen pixels (issue 49, "Layout"): the largest whole
// number that fits, so that every pixel is a square of s x s screen pixels
// (tev zooms in such steps), or the fit scale (below 1) when not even 1x fits.
// 0 for an empty panel or image.
float imageScale(float panelW, float panelH, int imageW, int imageH);

// Statistics of an image's luminance (the Stats tab, as tev's histogram):
// over its finite pixels, the mean, min, max and percentiles, the count of
// non-finite ones, and a histogram of log10 luminance over the positive
// pixels in kStatsBins bins from the smallest to the largest.
struct ImageStats {
  static constexpr int kStatsBins = 64;
  size_t pixels = 0, nonFinite = 0, zeroOrNegative = 0;
  double mean = 0, min = 0, max = 0, p01 = 0, p50 = 0, p99 = 0;
  double logMin = 0, logMax = 0;  // the histogram's range, log10 luminance
  std::vector<float> histogram;   // kStatsBins counts (empty without a positive pixel)
};
ImageStats imageStats(const Image& img);

}  // namespace vsl::ui::studio_detail
