#include "core/compare.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

namespace vsl {

CompareResult compareImages(const Image& test, const Image& ref, double epsilon) {
  CompareResult r;
  r.epsilon = epsilon;
  double s[3][6] = {};
  size_t n = size_t(test.width) * test.height;
  for (size_t i = 0; i < n; ++i) {
    bool ft = true, fr = true;
    for (int c = 0; c < 3; ++c) {
      ft = ft && std::isfinite(test.rgb[3 * i + c]);
      fr = fr && std::isfinite(ref.rgb[3 * i + c]);
    }
    if (!ft) ++r.nonFiniteTest;
    if (!fr) ++r.nonFiniteRef;
    if (!ft || !fr) continue;
    ++r.pixels;
    for (int c = 0; c < 3; ++c) {
      double t = test.rgb[3 * i + c], f = ref.rgb[3 * i + c], d = t - f;
      s[c][0] += t;
      s[c][1] += f;
      s[c][2] += d;
      s[c][3] += std::abs(d);
      s[c][4] += d * d;
      s[c][5] += d * d / (f * f + epsilon);
    }
  }
  double inv = r.pixels ? 1.0 / double(r.pixels) : 0.0;
  for (int c = 0; c < 3; ++c) {
    ChannelMetrics& m = r.channel[c];
    m.meanTest = s[c][0] * inv;
    m.meanRef = s[c][1] * inv;
    m.bias = s[c][2] * inv;
    m.mae = s[c][3] * inv;
    m.rmse = std::sqrt(s[c][4] * inv);
    m.relMse = s[c][5] * inv;
    r.average.meanTest += m.meanTest / 3;
    r.average.meanRef += m.meanRef / 3;
    r.average.bias += m.bias / 3;
    r.average.mae += m.mae / 3;
    r.average.relMse += m.relMse / 3;
    r.average.rmse += s[c][4] * inv / 3;  // mean of MSEs, square-rooted below
  }
  r.average.rmse = std::sqrt(r.average.rmse);
  return r;
}

double worstPixelShare(const Image& test, const Image& ref, double fraction, double epsilon) {
  const size_t n = size_t(test.width) * test.height;
  std::vector<double> e(n, 0.0);
  double total = 0;
  for (size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) {
      double t = test.rgb[3 * i + c], f = ref.rgb[3 * i + c];
      if (std::isfinite(t) && std::isfinite(f)) e[i] += (t - f) * (t - f) / (f * f + epsilon) / 3;
    }
    total += e[i];
  }
  if (!(total > 0) || n == 0) return 0;
  size_t k = std::max<size_t>(1, size_t(std::ceil(fraction * double(n))));
  k = std::min(k, n);
  std::nth_element(e.begin(), e.begin() + std::ptrdiff_t(k - 1), e.end(), std::greater<double>());
  double worst = 0;
  for (size_t i = 0; i < k; ++i) worst += e[i];
  return worst / total;
}

ErrorImages errorImages(const Image& test, const Image& ref, double epsilon) {
  ErrorImages e{Image(test.width, test.height), Image(test.width, test.height), Image(test.width, test.height),
                Image(test.width, test.height)};
  for (size_t i = 0; i < test.rgb.size(); ++i) {
    double d = double(test.rgb[i]) - ref.rgb[i];
    e.signedDiff.rgb[i] = float(d);
    e.absolute.rgb[i] = float(std::abs(d));
    e.squared.rgb[i] = float(d * d);
    e.relSquared.rgb[i] = float(d * d / (double(ref.rgb[i]) * ref.rgb[i] + epsilon));
  }
  return e;
}

Vec3 falseColour(float t) {
  if (!std::isfinite(t)) return Vec3(1, 0, 1);
  t = clamp(t, 0.0f, 1.0f);
  // Piecewise-linear through black, blue, magenta, yellow, white.
  const Vec3 stops[5] = {{0, 0, 0}, {0.1f, 0.1f, 0.8f}, {0.85f, 0.1f, 0.6f}, {1, 0.85f, 0.1f}, {1, 1, 1}};
  float x = t * 4;
  int i = std::min(int(x), 3);
  return lerp(x - i, stops[i], stops[i + 1]);
}

}  // namespace vsl
