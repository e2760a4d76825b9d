// Internal to the studio's own files (studio.cpp, studio_export.cpp): the
// constants and image helpers both use. Not part of the ui interface.
#pragma once

#include <vector>

#include "core/compare.h"
#include "ui/studio.h"

namespace vsl::ui::studio_detail {

// The methods of the metrics table, the FLIP maps and the exported error maps.
inline constexpr Source kMetricSources[4] = {Source::Vsl, Source::Vpl, Source::VplUnclamped, Source::VplDiffuse};
inline const char* const kMetricNames[] = {"absolute |t-r|", "relative absolute |t-r|/(r+eps)", "squared (t-r)^2",
                                           "relative squared (t-r)^2/(r^2+eps)"};

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
