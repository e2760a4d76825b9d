#include "core/compare.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <functional>
#include <sstream>
#include <vector>

#include "core/check.h"

namespace vsl {

double RelMseEpsilon::resolve(const Image& ref) const {
  if (mode == Mode::Absolute) return value;
  double sum = 0;
  size_t n = 0;
  for (size_t i = 0; i + 2 < ref.rgb.size(); i += 3) {
    double y = 0.2126 * ref.rgb[i] + 0.7152 * ref.rgb[i + 1] + 0.0722 * ref.rgb[i + 2];
    if (std::isfinite(y)) {
      sum += y;
      ++n;
    }
  }
  double mean = n ? sum / double(n) : 0.0;
  return std::max(value * mean * mean, 1e-30);
}

std::string RelMseEpsilon::describe() const {
  std::ostringstream s;
  s << value;
  if (mode == Mode::Relative) s << " x mean luminance^2";
  return s.str();
}

CompareResult compareImages(const Image& test, const Image& ref, RelMseEpsilon spec) {
  VSL_CHECK_EQ(test.width, ref.width);
  VSL_CHECK_EQ(test.height, ref.height);
  CompareResult r;
  r.epsilonSpec = spec;
  const double epsilon = r.epsilon = spec.resolve(ref);
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

double worstPixelShare(const Image& test, const Image& ref, double fraction, RelMseEpsilon spec) {
  VSL_CHECK_EQ(test.width, ref.width);
  VSL_CHECK_EQ(test.height, ref.height);
  const double epsilon = spec.resolve(ref);
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

ErrorImages errorImages(const Image& test, const Image& ref, RelMseEpsilon spec) {
  VSL_CHECK_EQ(test.width, ref.width);
  VSL_CHECK_EQ(test.height, ref.height);
  const double epsilon = spec.resolve(ref);
  ErrorImages e{Image(test.width, test.height), Image(test.width, test.height), Image(test.width, test.height),
                Image(test.width, test.height)};
  // Values a float cannot hold (a tiny absolute eps over a black reference
  // pixel) are written as the largest float, 0 / 0 (eps 0 there) as 0;
  // channels whose test or reference value is not finite are left 0, as the
  // metrics skip them.
  const auto toFloat = [](double v) {
    return std::isnan(v) ? 0.0f : float(std::clamp(v, -double(FLT_MAX), double(FLT_MAX)));
  };
  for (size_t i = 0; i < test.rgb.size(); ++i) {
    if (!std::isfinite(test.rgb[i]) || !std::isfinite(ref.rgb[i])) continue;
    double d = double(test.rgb[i]) - ref.rgb[i];
    e.signedDiff.rgb[i] = toFloat(d);
    e.absolute.rgb[i] = toFloat(std::abs(d));
    e.squared.rgb[i] = toFloat(d * d);
    e.relSquared.rgb[i] = toFloat(d * d / (double(ref.rgb[i]) * ref.rgb[i] + epsilon));
  }
  return e;
}

BiasVarianceResult biasVariance(const std::vector<const Image*>& tests, const Image& ref, RelMseEpsilon spec) {
  for (const Image* test : tests) {
    VSL_CHECK_EQ(test->width, ref.width);
    VSL_CHECK_EQ(test->height, ref.height);
  }
  BiasVarianceResult r;
  const int K = int(tests.size());
  r.renders = K;
  r.epsilonSpec = spec;
  const double eps = r.epsilon = spec.resolve(ref);
  r.mean = r.bias = r.noise = Image(ref.width, ref.height);
  if (K < 2) return r;
  double s[3][5] = {};  // sum of test means, ref, w s^2, w ((m-ref)^2 - s^2/K), w (m-ref)^2
  const size_t n = size_t(ref.width) * ref.height;
  for (size_t i = 0; i < n; ++i) {
    bool finite = true;
    for (int c = 0; c < 3; ++c) {
      finite = finite && std::isfinite(ref.rgb[3 * i + c]);
      for (const Image* t : tests) finite = finite && std::isfinite(t->rgb[3 * i + c]);
    }
    if (!finite) continue;
    ++r.pixels;
    for (int c = 0; c < 3; ++c) {
      // Mean and unbiased sample variance over the renders.
      const size_t j = 3 * i + size_t(c);
      double m = 0, v = 0;
      for (const Image* t : tests) m += t->rgb[j];
      m /= K;
      for (const Image* t : tests) v += (t->rgb[j] - m) * (t->rgb[j] - m);
      v /= K - 1;
      const double f = ref.rgb[j], d = m - f, w = 1 / (f * f + eps);
      s[c][0] += m;
      s[c][1] += f;
      s[c][2] += w * v;
      s[c][3] += w * (d * d - v / K);
      s[c][4] += w * d * d;
      r.mean.rgb[j] = float(m);
      r.bias.rgb[j] = float(d);
      r.noise.rgb[j] = float(std::sqrt(v));
    }
  }
  const double inv = r.pixels ? 1.0 / double(r.pixels) : 0.0;
  for (int c = 0; c < 3; ++c) {
    BiasVarianceChannel& m = r.channel[c];
    m = {s[c][0] * inv, s[c][1] * inv, s[c][3] * inv, s[c][2] * inv, s[c][4] * inv};
    r.average.meanTest += m.meanTest / 3;
    r.average.meanRef += m.meanRef / 3;
    r.average.bias2 += m.bias2 / 3;
    r.average.variance += m.variance / 3;
    r.average.relMse += m.relMse / 3;
  }
  return r;
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

namespace {

// A 3x5 pixel font for the colour bar's numbers: each glyph is five rows of
// three bits (most significant on the left).
struct Glyph {
  char c;
  uint8_t row[5];
};
constexpr Glyph kGlyphs[] = {{'0', {7, 5, 5, 5, 7}}, {'1', {2, 6, 2, 2, 7}}, {'2', {7, 1, 7, 4, 7}},
                             {'3', {7, 1, 7, 1, 7}}, {'4', {5, 5, 7, 1, 1}}, {'5', {7, 4, 7, 1, 7}},
                             {'6', {7, 4, 7, 5, 7}}, {'7', {7, 1, 1, 1, 1}}, {'8', {7, 5, 7, 5, 7}},
                             {'9', {7, 5, 7, 1, 7}}, {'.', {0, 0, 0, 0, 2}}, {'-', {0, 0, 7, 0, 0}},
                             {'+', {0, 2, 7, 2, 0}}, {'e', {0, 7, 7, 4, 7}}};

// Width in pixels of text in that font (3 per glyph, 1 between).
int textWidth(const std::string& t) { return t.empty() ? 0 : int(t.size()) * 4 - 1; }

// Draws text with its top-left corner at (x, y), clipped to the image.
void drawText(std::vector<uint8_t>& px, int w, int h, int x, int y, const std::string& t) {
  for (char ch : t) {
    for (const Glyph& g : kGlyphs) {
      if (g.c != ch) continue;
      for (int r = 0; r < 5; ++r)
        for (int c = 0; c < 3; ++c)
          if ((g.row[r] >> (2 - c)) & 1) {
            const int X = x + c, Y = y + r;
            if (X < 0 || X >= w || Y < 0 || Y >= h) continue;
            uint8_t* q = &px[(size_t(Y) * w + X) * 3];
            q[0] = q[1] = q[2] = 230;
          }
    }
    x += 4;
  }
}

}  // namespace

std::vector<uint8_t> colourMapWithBar(const Image& map, Vec3 (*colour)(float), float vmax, int* rows) {
  const int w = map.width, h = map.height, bar = kColourBarRows;
  const float scale = 1.0f / std::max(vmax, 1e-12f);
  std::vector<uint8_t> px(size_t(w) * size_t(h + bar) * 3, 20);
  auto put = [&](int x, int y, const Vec3& c) {
    uint8_t* q = &px[(size_t(y) * w + x) * 3];
    q[0] = uint8_t(std::clamp(c.x, 0.0f, 1.0f) * 255 + 0.5f);
    q[1] = uint8_t(std::clamp(c.y, 0.0f, 1.0f) * 255 + 0.5f);
    q[2] = uint8_t(std::clamp(c.z, 0.0f, 1.0f) * 255 + 0.5f);
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) put(x, y, colour(map.at(x, y).x * scale));
  for (int y = h + 4; y < h + 16; ++y)
    for (int x = 0; x < w; ++x) put(x, y, colour((x + 0.5f) / float(w)));
  // The scale under the bar: 0 at the left, vmax at the right (if both fit).
  char label[32];
  std::snprintf(label, sizeof label, "%.3g", double(vmax));
  const std::string right = label;
  drawText(px, w, h + bar, 1, h + 18, "0");
  if (textWidth(right) + 6 <= w) drawText(px, w, h + bar, w - 1 - textWidth(right), h + 18, right);
  *rows = h + bar;
  return px;
}

}  // namespace vsl
