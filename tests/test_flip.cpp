// FLIP and HDR-FLIP (core/flip.h): exact zero for identical images, the
// closed form on uniform images, growth with noise, and HDR-FLIP's exposure
// range following the reference's luminance.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>

#include "core/flip.h"

using namespace vsl;

namespace {

Image uniform(int w, int h, Vec3 v) {
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.set(x, y, v);
  return img;
}

// A deterministic value in [-1, 1] per pixel and channel.
float hashNoise(int x, int y, int c) {
  uint32_t h = uint32_t(x) * 73856093u ^ uint32_t(y) * 19349663u ^ uint32_t(c + 1) * 83492791u;
  h ^= h >> 13;
  h *= 0x5bd1e995u;
  h ^= h >> 15;
  return float(h & 0xffffff) / float(0xffffff) * 2 - 1;
}

// sRGB image: base + amplitude x noise, clamped to [0,1].
Image noisy(int w, int h, float base, float amplitude) {
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        img.rgb[(size_t(y) * w + x) * 3 + c] = std::clamp(base + amplitude * hashNoise(x, y, c), 0.0f, 1.0f);
  return img;
}

// ---- The closed form on uniform images -------------------------------------------------
// The CSF filters sum to one, so a uniform image stays uniform; the edge and
// point detectors sum to zero, so the feature difference is 0 and FLIP is the
// colour error: remap(HyAB(Hunt(Lab(test)), Hunt(Lab(ref)))^0.7), remap taking
// [0, 0.4 cmax] linearly to [0, 0.95] and [0.4 cmax, cmax] to [0.95, 1], with
// cmax = HyAB(green, blue)^0.7. Written here from the definitions (sRGB
// matrix, D65 white), independently of core/flip.cpp.
std::array<double, 3> huntLab(double r, double g, double b) {
  const double X = 0.4124 * r + 0.3576 * g + 0.1805 * b, Y = 0.2126 * r + 0.7152 * g + 0.0722 * b,
               Z = 0.0193 * r + 0.1192 * g + 0.9505 * b;
  auto f = [](double t) {
    const double d = 6.0 / 29;
    return t > d * d * d ? std::cbrt(t) : t / (3 * d * d) + 4.0 / 29;
  };
  double fx = f(X / 0.95047), fy = f(Y / 1.0), fz = f(Z / 1.08883);
  double L = 116 * fy - 16;
  return {L, 0.01 * L * 500 * (fx - fy), 0.01 * L * 200 * (fy - fz)};
}

double hyab(const std::array<double, 3>& p, const std::array<double, 3>& q) {
  return std::abs(p[0] - q[0]) + std::hypot(p[1] - q[1], p[2] - q[2]);
}

double closedFormFlip(Vec3 testLinear, Vec3 refLinear) {
  const double cmax = std::pow(hyab(huntLab(0, 1, 0), huntLab(0, 0, 1)), 0.7);
  const double e = std::pow(
      hyab(huntLab(testLinear.x, testLinear.y, testLinear.z), huntLab(refLinear.x, refLinear.y, refLinear.z)), 0.7);
  const double pc = 0.4 * cmax;
  return e < pc ? 0.95 / pc * e : 0.95 + (e - pc) / (cmax - pc) * 0.05;
}

float toSrgb(float v) { return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1 / 2.4f) - 0.055f; }

}  // namespace

TEST(Flip, IdenticalImagesScoreExactlyZero) {
  Image a = noisy(40, 30, 0.5f, 0.4f);
  FlipResult r = flipLdr(a, a);
  EXPECT_EQ(r.mean, 0.0);
  for (float v : r.map.rgb) ASSERT_EQ(v, 0.0f);
  Image hdr = a;
  for (float& v : hdr.rgb) v *= 20;
  FlipResult h = flipHdr(hdr, hdr);
  EXPECT_EQ(h.mean, 0.0);
  EXPECT_GE(h.exposures, 2);
}

TEST(Flip, UniformImagesEqualTheRemappedColourDifference) {
  struct Case {
    Vec3 test, ref;  // linear
  } cases[] = {{{0, 0, 0}, {1, 1, 1}},
               {{1, 1, 1}, {0, 0, 0}},
               {{0.2f, 0.2f, 0.2f}, {0.25f, 0.25f, 0.25f}},
               {{0.8f, 0.1f, 0.1f}, {0.3f, 0.3f, 0.3f}},
               {{0.05f, 0.3f, 0.9f}, {0.6f, 0.5f, 0.1f}}};
  for (const Case& c : cases) {
    Vec3 ts(toSrgb(c.test.x), toSrgb(c.test.y), toSrgb(c.test.z)),
        rs(toSrgb(c.ref.x), toSrgb(c.ref.y), toSrgb(c.ref.z));
    FlipResult r = flipLdr(uniform(24, 20, ts), uniform(24, 20, rs));
    double expected = closedFormFlip(c.test, c.ref);
    EXPECT_NEAR(r.mean, expected, 1e-3) << "test " << c.test.x << " ref " << c.ref.x;
    // Uniform: every pixel (borders included) has the same value.
    for (float v : r.map.rgb) ASSERT_NEAR(v, r.mean, 1e-6);
  }
  // The number quoted for FLIP on black against white.
  EXPECT_NEAR(flipLdr(uniform(16, 16, Vec3(0.0f)), uniform(16, 16, Vec3(1.0f))).mean, 0.967, 0.001);
}

TEST(Flip, GrowsMonotonicallyWithNoiseAmplitude) {
  const Image ref = uniform(64, 48, Vec3(0.5f));
  double prev = 0;
  for (float amp : {0.01f, 0.03f, 0.1f, 0.2f, 0.4f}) {
    double m = flipLdr(noisy(64, 48, 0.5f, amp), ref).mean;
    EXPECT_GT(m, prev) << "amplitude " << amp;
    prev = m;
  }
  // HDR-FLIP too, on a linear reference around 3.
  Image refHdr = uniform(64, 48, Vec3(3.0f));
  prev = 0;
  for (float amp : {0.01f, 0.03f, 0.1f, 0.2f, 0.4f}) {
    Image t = noisy(64, 48, 0.5f, amp);
    for (float& v : t.rgb) v *= 6;  // 3 +- 6 amp
    double m = flipHdr(t, refHdr).mean;
    EXPECT_GT(m, prev) << "amplitude " << amp;
    prev = m;
  }
}

// The exposure range: start = log2(x / Y_max), stop = log2(x / Y_median), x
// where the ACES curve (input pre-exposed by 0.6) reaches 0.85; found here by
// bisection. Scaling both images by 4 shifts both exposures by -2 stops and
// leaves HDR-FLIP unchanged.
TEST(Flip, HdrExposureRangeFollowsTheReferenceLuminance) {
  auto aces = [](double x) {
    double u = 0.6 * x;
    return u * (2.51 * u + 0.03) / (u * (2.43 * u + 0.59) + 0.14);
  };
  double lo = 0, hi = 100;
  for (int i = 0; i < 200; ++i) (aces(0.5 * (lo + hi)) < 0.85 ? lo : hi) = 0.5 * (lo + hi);
  const double x = 0.5 * (lo + hi);

  // Grey pixels 0.1, 0.2, ..., 2.5 (25 pixels): median 1.3, maximum 2.5.
  Image ref(5, 5);
  for (int i = 0; i < 25; ++i) ref.set(i % 5, i / 5, Vec3(0.1f * float(i + 1)));
  FlipExposures e = flipExposureRange(ref);
  EXPECT_NEAR(e.start, std::log2(x / 2.5), 1e-5);
  EXPECT_NEAR(e.stop, std::log2(x / 1.3), 1e-5);
  EXPECT_EQ(e.count, std::max(2, int(std::ceil(e.stop - e.start))));

  Image test = noisy(48, 40, 0.4f, 0.3f), big = uniform(48, 40, Vec3(0.0f));
  for (int y = 0; y < 40; ++y)
    for (int x2 = 0; x2 < 48; ++x2) big.set(x2, y, Vec3(0.05f + 0.1f * float(x2 % 7) + 0.3f * float(y % 3)));
  FlipResult a = flipHdr(test, big);
  Image test4 = test, big4 = big;
  for (float& v : test4.rgb) v *= 4;
  for (float& v : big4.rgb) v *= 4;
  FlipResult b = flipHdr(test4, big4);
  EXPECT_NEAR(b.startExposure, a.startExposure - 2, 1e-6);
  EXPECT_NEAR(b.stopExposure, a.stopExposure - 2, 1e-6);
  EXPECT_EQ(a.exposures, b.exposures);
  EXPECT_GT(a.mean, 0.01);
  EXPECT_NEAR(b.mean, a.mean, 1e-6);
  // A black reference: no exposure range to speak of, and no crash.
  FlipExposures black = flipExposureRange(uniform(4, 4, Vec3(0.0f)));
  EXPECT_EQ(black.start, 0.0);
  EXPECT_EQ(black.stop, 0.0);
}

TEST(Flip, MagmaRunsFromDarkToLightMonotonically) {
  auto lum = [](Vec3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; };
  EXPECT_LT(lum(magma(0)), 0.01f);
  EXPECT_GT(lum(magma(1)), 0.9f);
  float prev = -1;
  for (int i = 0; i <= 100; ++i) {
    float l = lum(magma(i / 100.0f));
    EXPECT_GT(l, prev) << i;
    prev = l;
  }
}
