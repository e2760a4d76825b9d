// FLIP and HDR-FLIP (see flip.h for the papers and parameters).
//
// Index:
//   [SECTION] Colour spaces: linear sRGB, XYZ, YCxCz, CIELAB, Hunt, HyAB
//   [SECTION] Filters: the contrast sensitivity functions and feature detectors
//   [SECTION] LDR-FLIP on linear RGB in [0,1]
//   [SECTION] HDR-FLIP: exposures, tone curve, maximum over exposures
//   [SECTION] Tone map and colour map
#include "core/flip.h"

#include "core/compare.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "core/parallel.h"

namespace vsl {

namespace {

constexpr double kPi = 3.14159265358979323846;
using Rgb = std::array<double, 3>;
using Plane = std::vector<double>;

// ---- [SECTION] Colour spaces ---------------------------------------------------------

// Linear sRGB (D65) to CIE XYZ, IEC 61966-2-1; the white point is the image of
// (1,1,1), so white maps to a* = b* = 0 exactly.
constexpr double kRgbToXyz[3][3] = {{0.4124, 0.3576, 0.1805}, {0.2126, 0.7152, 0.0722}, {0.0193, 0.1192, 0.9505}};

struct ColourSpace {
  double xyzToRgb[3][3];
  Rgb white;
  ColourSpace() {
    for (int r = 0; r < 3; ++r) white[r] = kRgbToXyz[r][0] + kRgbToXyz[r][1] + kRgbToXyz[r][2];
    // Inverse by cofactors.
    const auto& m = kRgbToXyz;
    double c[3][3];
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) {
        int r1 = (r + 1) % 3, r2 = (r + 2) % 3, k1 = (k + 1) % 3, k2 = (k + 2) % 3;
        c[k][r] = m[r1][k1] * m[r2][k2] - m[r1][k2] * m[r2][k1];  // transposed: the adjugate
      }
    double det = m[0][0] * c[0][0] + m[0][1] * c[1][0] + m[0][2] * c[2][0];
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) xyzToRgb[r][k] = c[r][k] / det;
  }
};
const ColourSpace& space() {
  static const ColourSpace s;
  return s;
}

Rgb mul(const double (&m)[3][3], const Rgb& v) {
  return {m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2], m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
          m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]};
}

// YCxCz: the linear opponent space of the CSF filtering (CIELAB without the
// cube root): Y* = 116 Y/Yw - 16, Cx = 500 (X/Xw - Y/Yw), Cz = 200 (Y/Yw - Z/Zw).
Rgb linearToYCxCz(const Rgb& rgb) {
  Rgb xyz = mul(kRgbToXyz, rgb);
  const Rgb& w = space().white;
  double x = xyz[0] / w[0], y = xyz[1] / w[1], z = xyz[2] / w[2];
  return {116 * y - 16, 500 * (x - y), 200 * (y - z)};
}

Rgb yCxCzToLinear(const Rgb& c) {
  const Rgb& w = space().white;
  double y = (c[0] + 16) / 116, x = y + c[1] / 500, z = y - c[2] / 200;
  return mul(space().xyzToRgb, Rgb{x * w[0], y * w[1], z * w[2]});
}

// CIELAB of a linear RGB colour, then Hunt's adjustment (chroma scaled by
// 0.01 L*: dark colours look less colourful).
Rgb huntLab(const Rgb& rgb) {
  Rgb xyz = mul(kRgbToXyz, rgb);
  const Rgb& w = space().white;
  constexpr double d = 6.0 / 29;
  auto f = [&](double t) { return t > d * d * d ? std::cbrt(t) : t / (3 * d * d) + 4.0 / 29; };
  double fx = f(xyz[0] / w[0]), fy = f(xyz[1] / w[1]), fz = f(xyz[2] / w[2]);
  double L = 116 * fy - 16;
  return {L, 0.01 * L * 500 * (fx - fy), 0.01 * L * 200 * (fy - fz)};
}

// HyAB: city-block in lightness, Euclidean in the chroma plane.
double hyab(const Rgb& p, const Rgb& q) { return std::abs(p[0] - q[0]) + std::hypot(p[1] - q[1], p[2] - q[2]); }

constexpr double kQc = 0.7, kQf = 0.5, kPc = 0.4, kPt = 0.95;

// The largest colour difference: green against blue, raised to q_c.
double cmax() {
  static const double c = std::pow(hyab(huntLab({0, 1, 0}), huntLab({0, 0, 1})), kQc);
  return c;
}

// Compresses large differences into [p_t, 1]: errors up to p_c cmax take the
// range [0, p_t].
double remapColourError(double e) {
  const double cm = cmax(), pccmax = kPc * cm;
  return e < pccmax ? kPt / pccmax * e : kPt + (e - pccmax) / (cm - pccmax) * (1 - kPt);
}

// ---- [SECTION] Filters -----------------------------------------------------------------

// Correlates a w x h plane with kx along x, then ky along y (odd lengths,
// centred), replicating the border. Rows are padded once so the inner loops
// run without bounds checks; the vertical pass adds whole rows (contiguous).
Plane separable(const Plane& in, int w, int h, const std::vector<double>& kx, const std::vector<double>& ky) {
  Plane tmp(in.size()), out(in.size());
  const int rx = int(kx.size() / 2), ry = int(ky.size() / 2);
  parallelFor(size_t(h), [&](size_t y) {
    std::vector<double> row(size_t(w + 2 * rx));
    for (int x = -rx; x < w + rx; ++x) row[size_t(x + rx)] = in[y * w + size_t(std::clamp(x, 0, w - 1))];
    double* t = &tmp[y * w];
    for (int x = 0; x < w; ++x) {
      double acc = 0;
      const double* r = &row[size_t(x)];
      for (size_t i = 0; i < kx.size(); ++i) acc += kx[i] * r[i];
      t[x] = acc;
    }
  });
  parallelFor(size_t(h), [&](size_t y) {
    double* o = &out[y * w];
    for (int i = -ry; i <= ry; ++i) {
      const double k = ky[size_t(i + ry)];
      const double* t = &tmp[size_t(std::clamp(int(y) + i, 0, h - 1)) * w];
      for (int x = 0; x < w; ++x) o[x] += k * t[x];
    }
  });
  return out;
}

// A contrast sensitivity function as a sum of Gaussians in visual angle,
// sum_i a_i sqrt(pi / b_i) exp(-pi^2 r^2 / b_i) (the FLIP paper, after
// Johnson and Fairchild), normalised to sum 1 over its 2D support. Each term
// is separable: term i is weight_i (kernel_i x kernel_i), kernel_i summing to 1.
struct Csf {
  struct Term {
    double weight;
    std::vector<double> kernel;
  };
  std::vector<Term> terms;
};

Csf makeCsf(double a1, double b1, double a2, double b2, double ppd) {
  // One radius for all channels, from the widest Gaussian (b = 0.04).
  const int r = int(std::ceil(3 * std::sqrt(0.04 / (2 * kPi * kPi)) * ppd));
  Csf csf;
  double total = 0;
  for (auto [a, b] : {std::pair{a1, b1}, std::pair{a2, b2}}) {
    if (a == 0) continue;
    Csf::Term t{a * std::sqrt(kPi / b), std::vector<double>(size_t(2 * r + 1))};
    double s = 0;
    for (int i = -r; i <= r; ++i) s += t.kernel[size_t(i + r)] = std::exp(-kPi * kPi * (i / ppd) * (i / ppd) / b);
    for (double& k : t.kernel) k /= s;
    t.weight *= s * s;  // the 2D sum of the unnormalised term
    total += t.weight;
    csf.terms.push_back(std::move(t));
  }
  for (Csf::Term& t : csf.terms) t.weight /= total;
  return csf;
}

Plane applyCsf(const Plane& in, int w, int h, const Csf& csf) {
  Plane out(in.size(), 0.0);
  for (const Csf::Term& t : csf.terms) {
    Plane p = separable(in, w, h, t.kernel, t.kernel);
    for (size_t i = 0; i < out.size(); ++i) out[i] += t.weight * p[i];
  }
  return out;
}

// Edge (first derivative of a Gaussian) and point (second derivative)
// detectors of standard deviation 0.5 x 0.082 degrees. In 2D the detector is
// h(x) g(y) with its positive and negative weights normalised to +1 and -1;
// that is the 1D h normalised per sign, times g normalised to 1.
struct FeatureKernels {
  std::vector<double> gauss, edge, point;
};

FeatureKernels makeFeatureKernels(double ppd) {
  const double sd = 0.5 * 0.082 * ppd;
  const int r = int(std::ceil(3 * sd));
  FeatureKernels k;
  for (int i = -r; i <= r; ++i) {
    double g = std::exp(-double(i * i) / (2 * sd * sd));
    k.gauss.push_back(g);
    k.edge.push_back(-i * g);
    k.point.push_back((i * i / (sd * sd) - 1) * g);
  }
  auto normalisePerSign = [](std::vector<double>& v) {
    double pos = 0, neg = 0;
    for (double x : v) (x > 0 ? pos : neg) += std::abs(x);
    for (double& x : v) x /= x > 0 ? pos : neg;
  };
  double s = 0;
  for (double g : k.gauss) s += g;
  for (double& g : k.gauss) g /= s;
  normalisePerSign(k.edge);
  normalisePerSign(k.point);
  return k;
}

// Magnitudes of the edge and point responses of an achromatic plane.
void features(const Plane& y, int w, int h, const FeatureKernels& k, Plane& edges, Plane& points) {
  Plane ex = separable(y, w, h, k.edge, k.gauss), ey = separable(y, w, h, k.gauss, k.edge);
  Plane px = separable(y, w, h, k.point, k.gauss), py = separable(y, w, h, k.gauss, k.point);
  edges.resize(y.size());
  points.resize(y.size());
  for (size_t i = 0; i < y.size(); ++i) {
    edges[i] = std::hypot(ex[i], ey[i]);
    points[i] = std::hypot(px[i], py[i]);
  }
}

// ---- [SECTION] LDR-FLIP on linear RGB in [0,1] ----------------------------------------

// The three YCxCz planes of an image (values clamped to [0,1]; non-finite as 0).
std::array<Plane, 3> toYCxCzPlanes(const Image& img) {
  const size_t n = size_t(img.width) * img.height;
  std::array<Plane, 3> p;
  for (Plane& c : p) c.resize(n);
  const size_t w = size_t(img.width);
  parallelFor(size_t(img.height), [&](size_t y) {
    for (size_t i = y * w; i < (y + 1) * w; ++i) {
      Rgb rgb;
      for (int c = 0; c < 3; ++c) {
        float v = img.rgb[3 * i + c];
        rgb[size_t(c)] = std::isfinite(v) ? std::clamp(double(v), 0.0, 1.0) : 0.0;
      }
      Rgb o = linearToYCxCz(rgb);
      for (int c = 0; c < 3; ++c) p[size_t(c)][i] = o[size_t(c)];
    }
  });
  return p;
}

// Per-pixel FLIP of two linear-RGB images in [0,1].
std::vector<double> flipLinear(const Image& test, const Image& ref, double ppd) {
  const int w = ref.width, h = ref.height;
  const size_t n = size_t(w) * h;
  const std::array<Plane, 3> rp = toYCxCzPlanes(ref), tp = toYCxCzPlanes(test);

  // Colour: filter each opponent channel by its CSF, back to linear RGB
  // clamped to the unit cube, Hunt-adjusted CIELAB, HyAB, then remap.
  const Csf csf[3] = {makeCsf(1, 0.0047, 0, 1e-5, ppd), makeCsf(1, 0.0053, 0, 1e-5, ppd),
                      makeCsf(34.1, 0.04, 13.5, 0.025, ppd)};
  std::array<Plane, 3> rf, tf;
  for (int c = 0; c < 3; ++c) {
    rf[size_t(c)] = applyCsf(rp[size_t(c)], w, h, csf[c]);
    tf[size_t(c)] = applyCsf(tp[size_t(c)], w, h, csf[c]);
  }
  std::vector<double> colour(n);
  parallelFor(size_t(h), [&](size_t y) {
    for (size_t i = y * w; i < (y + 1) * w; ++i) {
      auto lab = [&](const std::array<Plane, 3>& f) {
        Rgb rgb = yCxCzToLinear({f[0][i], f[1][i], f[2][i]});
        for (double& v : rgb) v = std::clamp(v, 0.0, 1.0);
        return huntLab(rgb);
      };
      colour[i] = remapColourError(std::pow(hyab(lab(rf), lab(tf)), kQc));
    }
  });

  // Features on the achromatic channel, normalised by 116: (Y* + 16) / 116 = Y / Yw.
  const FeatureKernels fk = makeFeatureKernels(ppd);
  Plane ry(n), ty(n), re, rpnt, te, tpnt;
  for (size_t i = 0; i < n; ++i) {
    ry[i] = (rp[0][i] + 16) / 116;
    ty[i] = (tp[0][i] + 16) / 116;
  }
  features(ry, w, h, fk, re, rpnt);
  features(ty, w, h, fk, te, tpnt);

  // Combine: features raise the colour error towards 1.
  std::vector<double> out(n);
  parallelFor(size_t(h), [&](size_t y) {
    for (size_t i = y * w; i < (y + 1) * w; ++i) {
      double df = std::max(std::abs(re[i] - te[i]), std::abs(rpnt[i] - tpnt[i]));
      double ef = std::pow(df / std::sqrt(2.0), kQf);
      out[i] = std::pow(colour[i], 1 - ef);
    }
  });
  return out;
}

FlipResult toResult(const std::vector<double>& e, int w, int h) {
  FlipResult r;
  r.map = Image(w, h);
  double s = 0;
  for (size_t i = 0; i < e.size(); ++i) {
    s += e[i];
    for (int c = 0; c < 3; ++c) r.map.rgb[3 * i + c] = float(e[i]);
  }
  r.mean = e.empty() ? 0 : s / double(e.size());
  return r;
}

float srgbToLinear(float s) {
  s = std::isfinite(s) ? std::clamp(s, 0.0f, 1.0f) : 0.0f;
  return s <= 0.04045f ? s / 12.92f : std::pow((s + 0.055f) / 1.055f, 2.4f);
}

// ---- [SECTION] HDR-FLIP ----------------------------------------------------------------

// Narkowicz's fit to the ACES filmic curve, on an input pre-exposed by 0.6
// (as HDR-FLIP assumes): y = u (2.51 u + 0.03) / (u (2.43 u + 0.59) + 0.14), u = 0.6 x.
double aces(double x) {
  double u = 0.6 * x;
  return std::clamp(u * (2.51 * u + 0.03) / (u * (2.43 * u + 0.59) + 0.14), 0.0, 1.0);
}

// The input x at which the tone curve reaches t (the larger root of the
// quadratic (2.51 - 2.43 t) u^2 + (0.03 - 0.59 t) u - 0.14 t = 0, x = u / 0.6).
double acesInverse(double t) {
  double a = 2.51 - 2.43 * t, b = 0.03 - 0.59 * t, c = -0.14 * t;
  return (-b + std::sqrt(b * b - 4 * a * c)) / (2 * a) / 0.6;
}

double luminanceOf(const Image& img, size_t i) {
  double y = 0.2126 * img.rgb[3 * i] + 0.7152 * img.rgb[3 * i + 1] + 0.0722 * img.rgb[3 * i + 2];
  return std::isfinite(y) && y > 0 ? y : 0.0;
}

}  // namespace

FlipResult flipLdr(const Image& testSrgb, const Image& refSrgb, double ppd) {
  Image t(testSrgb.width, testSrgb.height), r(refSrgb.width, refSrgb.height);
  for (size_t i = 0; i < t.rgb.size(); ++i) t.rgb[i] = srgbToLinear(testSrgb.rgb[i]);
  for (size_t i = 0; i < r.rgb.size(); ++i) r.rgb[i] = srgbToLinear(refSrgb.rgb[i]);
  return toResult(flipLinear(t, r, ppd), r.width, r.height);
}

FlipExposures flipExposureRange(const Image& ref) {
  const size_t n = size_t(ref.width) * ref.height;
  std::vector<double> y(n);
  double ymax = 0, ymin = INFINITY;
  for (size_t i = 0; i < n; ++i) {
    y[i] = luminanceOf(ref, i);
    ymax = std::max(ymax, y[i]);
    if (y[i] > 0) ymin = std::min(ymin, y[i]);
  }
  FlipExposures e;
  if (!(ymax > 0)) return e;  // black: one exposure is as good as any
  std::nth_element(y.begin(), y.begin() + std::ptrdiff_t(n / 2), y.end());
  double ymedian = y[n / 2] > 0 ? y[n / 2] : ymin;
  const double x = acesInverse(0.85);
  e.start = std::log2(x / ymax);
  e.stop = std::log2(x / ymedian);
  e.count = std::max(2, int(std::ceil(e.stop - e.start)));
  return e;
}

FlipResult flipHdr(const Image& test, const Image& ref, double ppd) {
  const FlipExposures ex = flipExposureRange(ref);
  const double step = (ex.stop - ex.start) / std::max(ex.count - 1, 1);
  std::vector<double> worst(size_t(ref.width) * ref.height, 0.0);
  Image t(test.width, test.height), r(ref.width, ref.height);
  for (int k = 0; k < ex.count; ++k) {
    const double scale = std::exp2(ex.start + k * step);
    auto toneMap = [&](const Image& in, Image& out) {
      for (size_t i = 0; i < in.rgb.size(); ++i) {
        float v = in.rgb[i];
        out.rgb[i] = float(aces(std::isfinite(v) && v > 0 ? scale * v : 0.0));
      }
    };
    toneMap(test, t);
    toneMap(ref, r);
    std::vector<double> e = flipLinear(t, r, ppd);
    for (size_t i = 0; i < e.size(); ++i) worst[i] = std::max(worst[i], e[i]);
  }
  FlipResult res = toResult(worst, ref.width, ref.height);
  res.startExposure = ex.start;
  res.stopExposure = ex.stop;
  res.exposures = ex.count;
  return res;
}

// ---- [SECTION] Tone map and colour map ------------------------------------------------

Image toSrgbImage(const Image& linear, float exposure) {
  Image out(linear.width, linear.height);
  const float scale = std::exp2(exposure);
  for (size_t i = 0; i < linear.rgb.size(); ++i) {
    float v = linear.rgb[i] * scale;
    v = std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f;
    out.rgb[i] = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1 / 2.4f) - 0.055f;
  }
  return out;
}

Vec3 magma(float t) {
  // Every 16th entry (and the last) of matplotlib's 256-entry magma table
  // (van der Walt and Smith, 2015), sRGB; linear in between.
  static const Vec3 kStops[17] = {
      {0.001462f, 0.000466f, 0.013866f}, {0.039608f, 0.031090f, 0.133515f}, {0.113094f, 0.065492f, 0.276784f},
      {0.211718f, 0.061992f, 0.418647f}, {0.316654f, 0.071690f, 0.485380f}, {0.414709f, 0.110431f, 0.504662f},
      {0.512831f, 0.148179f, 0.507648f}, {0.613617f, 0.181811f, 0.498536f}, {0.716387f, 0.214982f, 0.475290f},
      {0.816914f, 0.255895f, 0.436461f}, {0.904281f, 0.319610f, 0.388137f}, {0.960949f, 0.418323f, 0.359630f},
      {0.986700f, 0.535582f, 0.382210f}, {0.996096f, 0.653659f, 0.446213f}, {0.996898f, 0.769591f, 0.534892f},
      {0.992440f, 0.884330f, 0.640099f}, {0.987053f, 0.991438f, 0.749504f}};
  if (!std::isfinite(t)) t = 1;
  float x = std::clamp(t, 0.0f, 1.0f) * 255;  // index into the 256-entry table
  int i = std::min(int(x / 16), 15);
  float x0 = 16.0f * i, x1 = i == 15 ? 255.0f : 16.0f * (i + 1);
  return lerp((x - x0) / (x1 - x0), kStops[i], kStops[i + 1]);
}

std::vector<uint8_t> magmaWithBar(const Image& map, int* rows) { return colourMapWithBar(map, magma, 1.0f, rows); }

}  // namespace vsl
