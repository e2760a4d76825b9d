// A reusable chi-square goodness-of-fit harness for sampling routines, after
// Mitsuba 3's chi2.py (ChiSquareTest with its line, planar and spherical
// domains). Sections:
//   [1] the chi-square distribution's tail and the Sidak correction
//   [2] domains: a 2D parameter rectangle mapped onto the sampled space
//   [3] chi2Test: histogram, pdf integration, pooling, p-value, dump
//   [4] chi2Discrete: frequencies of a discrete distribution against its pmf
//
// The test: draw many samples and histogram them on a grid over the domain's
// parameter rectangle; integrate the claimed pdf over each cell (midpoint
// rule, with the parameterisation's Jacobian); pool cells whose expected
// count is small (Mitsuba's rule: cells sorted by expected count, consecutive
// small cells pooled until the pool reaches minExpected); and compute the
// p-value of Pearson's statistic. It fails outright (message set) when a
// sample lands outside the domain, when samples land in an interior cell
// whose expected count is zero (a cell of the pdf's zero region none of whose
// neighbours has any expected count; a zero cell next to the support may
// straddle its edge between integration points and is pooled instead), or
// when the pdf integrates to more than 1.02. On failure the observed and
// expected histograms are written to DUMPNAME.chi2.txt.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include "core/math.h"
#include "core/rng.h"

namespace vsl::test {

// ---- [1] The chi-square tail --------------------------------------------------------

// Regularised upper incomplete gamma Q(a, x), for the chi-square tail.
inline double gammaQ(double a, double x) {
  if (x <= 0) return 1.0;
  double lg = std::lgamma(a);
  if (x < a + 1) {  // series for P
    double sum = 1.0 / a, term = sum;
    for (int n = 1; n < 100000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-15) break;
    }
    return 1.0 - sum * std::exp(-x + a * std::log(x) - lg);
  }
  // Continued fraction for Q (modified Lentz).
  double b = x + 1 - a, c = 1e300, d = 1 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::abs(c) < 1e-300) c = 1e-300;
    d = 1 / d;
    double del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-15) break;
  }
  return std::exp(-x + a * std::log(x) - lg) * h;
}

inline double chi2Survival(double statistic, int dof) { return gammaQ(0.5 * dof, 0.5 * statistic); }

// Per-test significance level so that `tests` tests together have level alpha.
inline double sidak(double alpha, int tests) { return 1.0 - std::pow(1.0 - alpha, 1.0 / tests); }

// ---- [2] Domains ----------------------------------------------------------------------

// A sampled space with a parameterisation over the rectangle [x0,x1] x [y0,y1],
// cut into resX x resY cells. Histograms are taken and the pdf integrated in
// parameter space. Points of the sampled space are Vec3s (a line uses x, a
// plane x and y, the sphere unit vectors).
struct Domain {
  std::string name;
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  int resX = 1, resY = 1;
  bool wrapX = false;  // x is periodic (an azimuth): the first and last columns are neighbours
  // Parameter -> point.
  std::function<Vec3(double x, double y)> forward;
  // The measure of the pdf per unit parameter area at (x, y) (the Jacobian).
  std::function<double(double x, double y)> jacobian = [](double, double) { return 1.0; };
  // Point -> parameter, unclamped (the harness checks the rectangle).
  std::function<std::array<double, 2>(const Vec3&)> backward;
};

// The interval [a, b] (points (x, 0, 0)); the pdf is per unit length.
inline Domain lineDomain(double a, double b, int bins) {
  Domain d;
  d.name = "line";
  d.x0 = a;
  d.x1 = b;
  d.resX = bins;
  d.y0 = -0.5;
  d.y1 = 0.5;
  d.resY = 1;
  d.forward = [](double x, double) { return Vec3(float(x), 0, 0); };
  d.backward = [](const Vec3& p) { return std::array<double, 2>{p.x, 0.0}; };
  return d;
}

// The rectangle lo..hi of the plane (points (x, y, 0)); the pdf is per unit area.
inline Domain planeDomain(Vec2 lo, Vec2 hi, int resX, int resY) {
  Domain d;
  d.name = "plane";
  d.x0 = lo.x;
  d.x1 = hi.x;
  d.y0 = lo.y;
  d.y1 = hi.y;
  d.resX = resX, d.resY = resY;
  d.forward = [](double x, double y) { return Vec3(float(x), float(y), 0); };
  d.backward = [](const Vec3& p) { return std::array<double, 2>{p.x, p.y}; };
  return d;
}

// Unit vectors about +z with polar angle theta in [0, thetaMax] (the whole
// sphere by default, a cone otherwise); the pdf is per steradian. Cells are
// uniform in (phi, theta): x = phi in [0, 2 pi), y = theta, Jacobian sin(theta).
// Theta-uniform rows resolve lobes peaked near the pole; with an even number
// of rows over the sphere the equator is a cell boundary, so a hemisphere's
// zero half has expected count exactly zero.
inline Domain sphereDomain(int thetaBins = 32, int phiBins = 64, double thetaMax = M_PI) {
  Domain d;
  d.name = "sphere";
  d.x0 = 0, d.x1 = 2 * M_PI, d.resX = phiBins, d.wrapX = true;
  d.y0 = 0, d.y1 = thetaMax, d.resY = thetaBins;
  d.forward = [](double phi, double theta) {
    double r = std::sin(theta);
    return Vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(std::cos(theta)));
  };
  d.jacobian = [](double, double theta) { return std::sin(theta); };
  d.backward = [](const Vec3& w) {
    // theta from atan2 keeps its precision near the pole (tiny cones).
    double theta = std::atan2(std::hypot(double(w.x), double(w.y)), double(w.z));
    double phi = std::atan2(double(w.y), double(w.x));
    if (phi < 0) phi += 2 * M_PI;
    return std::array<double, 2>{std::min(phi, 2 * M_PI), theta};
  };
  return d;
}

// The unit disk in polar cells (x = r, y = phi; Jacobian r); points (x, y, 0),
// pdf per unit area.
inline Domain diskDomain(int rBins = 32, int phiBins = 64) {
  Domain d;
  d.name = "disk";
  d.x0 = 0, d.x1 = 1, d.resX = rBins;
  d.y0 = 0, d.y1 = 2 * M_PI, d.resY = phiBins;
  d.forward = [](double r, double phi) { return Vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), 0); };
  d.jacobian = [](double r, double) { return r; };
  d.backward = [](const Vec3& p) {
    double phi = std::atan2(double(p.y), double(p.x));
    if (phi < 0) phi += 2 * M_PI;
    return std::array<double, 2>{std::hypot(double(p.x), double(p.y)), phi};
  };
  return d;
}

// The barycentric triangle b0, b1 >= 0, b0 + b1 <= 1 (points (b0, b1, 0); pdf
// per unit b0-b1 area, so a uniform density is 2). Its cells are those of
// (x, y) = (b0, b1 / (1 - b0)) on the unit square, Jacobian 1 - b0: the
// triangle's edges are cell edges and the midpoint rule integrates a constant
// exactly (on a grid over (b0, b1) the diagonal would cut cells).
inline Domain triangleDomain(int bins = 32) {
  Domain d;
  d.name = "triangle";
  d.resX = d.resY = bins;
  d.forward = [](double x, double y) { return Vec3(float(x), float(y * (1 - x)), 0); };
  d.jacobian = [](double x, double) { return 1 - x; };
  d.backward = [](const Vec3& b) {
    double b0 = b.x, b1 = b.y;
    return std::array<double, 2>{b0, b0 < 1 ? b1 / (1 - b0) : 0.0};
  };
  return d;
}

// ---- [3] chi2Test ---------------------------------------------------------------------

struct Chi2Result {
  double pValue = 0;
  double statistic = 0;
  int dof = 0;
  int pooledIn = 0, pooledOut = 0;  // small cells pooled, and the pools they made
  std::string message;              // why it failed outright, if it did
};

struct Chi2Config {
  int thetaBins = 32, phiBins = 64;  // chi2Directions' sphere grid
  int subdiv = 12;                   // pdf integration points per cell and axis
  size_t samples = 1000000;
  double minExpected = 5;  // cells below this are pooled
  uint64_t seed = 1, stream = 17;
};

namespace detail {

// Pearson's statistic over (observed, expected) cells with Mitsuba's pooling.
inline void pooledStatistic(const std::vector<double>& observed, const std::vector<double>& expected,
                            double minExpected, Chi2Result& res) {
  std::vector<size_t> order(expected.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return expected[a] < expected[b]; });
  std::vector<std::pair<double, double>> terms;  // (observed, expected)
  double poolObs = 0, poolExp = 0;
  bool poolOpen = false;
  for (size_t i : order) {
    double o = observed[i], e = expected[i];
    if (o == 0 && e == 0) continue;
    if (e < minExpected) {
      poolObs += o, poolExp += e, poolOpen = true;
      ++res.pooledIn;
      if (poolExp >= minExpected) {
        terms.push_back({poolObs, poolExp});
        ++res.pooledOut;
        poolObs = poolExp = 0, poolOpen = false;
      }
      continue;
    }
    if (poolOpen) {  // the rest of the pool joins the smallest large cell
      o += poolObs, e += poolExp;
      poolObs = poolExp = 0, poolOpen = false;
    }
    terms.push_back({o, e});
  }
  if (poolOpen) {
    if (!terms.empty()) {
      terms.back().first += poolObs, terms.back().second += poolExp;
    } else if (poolObs > 4 * minExpected) {
      res.message = "all cells pooled: " + std::to_string(poolObs) + " samples, expected " + std::to_string(poolExp);
      return;
    }
  }
  double stat = 0;
  for (auto [o, e] : terms) stat += (o - e) * (o - e) / e;
  res.statistic = stat;
  res.dof = std::max(int(terms.size()) - 1, 1);
  res.pValue = chi2Survival(stat, res.dof);
}

inline void dump(const std::string& dumpName, const Domain& d, const std::vector<double>& observed,
                 const std::vector<double>& expected) {
  std::string path = dumpName + ".chi2.txt";
  FILE* f = std::fopen(path.c_str(), "w");
  if (!f) return;
  std::fprintf(f, "# %s domain: rows y from %g to %g, columns x from %g to %g; observed, then expected\n",
               d.name.c_str(), d.y0, d.y1, d.x0, d.x1);
  for (const auto* h : {&observed, &expected}) {
    for (int iy = 0; iy < d.resY; ++iy) {
      for (int ix = 0; ix < d.resX; ++ix) std::fprintf(f, "%.1f ", (*h)[size_t(iy) * d.resX + ix]);
      std::fprintf(f, "\n");
    }
    std::fprintf(f, "\n");
  }
  std::fclose(f);
  std::fprintf(stderr, "chi2 histograms written to %s\n", path.c_str());
}

// Whether a cell with zero expected count lies inside the pdf's zero region
// (no neighbour, diagonals included, has any expected count).
inline bool interiorZeroCell(const Domain& d, const std::vector<double>& expected, int ix, int iy) {
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      int x = ix + dx, y = iy + dy;
      if (d.wrapX) x = (x + d.resX) % d.resX;
      if (x < 0 || x >= d.resX || y < 0 || y >= d.resY) continue;
      if (expected[size_t(y) * d.resX + x] > 0) return false;
    }
  return true;
}

}  // namespace detail

// sample(rng) returns a point or nothing (a failed sample still counts toward
// the total, so the pdf may integrate to less than one); pdf(p) is the
// claimed density in the domain's measure.
inline Chi2Result chi2Test(const Domain& d, const std::function<std::optional<Vec3>(Rng&)>& sample,
                           const std::function<double(const Vec3&)>& pdf, const Chi2Config& cfg,
                           const std::string& dumpName = "") {
  const size_t cells = size_t(d.resX) * d.resY;
  std::vector<double> observed(cells, 0.0), expected(cells, 0.0);
  Chi2Result res;

  // Histogram the samples in parameter space.
  const double sx = d.resX / (d.x1 - d.x0), sy = d.resY / (d.y1 - d.y0);
  const double epsX = (d.x1 - d.x0) * 1e-4, epsY = (d.y1 - d.y0) * 1e-4;
  size_t outside = 0;
  Rng rng(cfg.seed, cfg.stream);
  for (size_t i = 0; i < cfg.samples; ++i) {
    std::optional<Vec3> p = sample(rng);
    if (!p) continue;
    auto [x, y] = d.backward(*p);
    if (!(x >= d.x0 - epsX && x <= d.x1 + epsX && y >= d.y0 - epsY && y <= d.y1 + epsY)) {
      ++outside;
      continue;
    }
    int ix = std::clamp(int((x - d.x0) * sx), 0, d.resX - 1), iy = std::clamp(int((y - d.y0) * sy), 0, d.resY - 1);
    observed[size_t(iy) * d.resX + ix] += 1;
  }
  if (outside > 0) res.message = std::to_string(outside) + " samples fell outside the " + d.name + " domain";

  // Integrate the pdf over each cell (midpoint rule in parameter space).
  const double cw = (d.x1 - d.x0) / d.resX, ch = (d.y1 - d.y0) / d.resY;
  const int s = cfg.subdiv;
  double total = 0;
  for (int iy = 0; iy < d.resY; ++iy)
    for (int ix = 0; ix < d.resX; ++ix) {
      double sum = 0;
      for (int a = 0; a < s; ++a)
        for (int b = 0; b < s; ++b) {
          double x = d.x0 + (ix + (b + 0.5) / s) * cw, y = d.y0 + (iy + (a + 0.5) / s) * ch;
          sum += d.jacobian(x, y) * pdf(d.forward(x, y));
        }
      double integral = sum * cw * ch / (s * s);
      expected[size_t(iy) * d.resX + ix] = integral * double(cfg.samples);
      total += integral;
    }
  if (total > 1.02) res.message = "pdf integrates to " + std::to_string(total) + " (> 1)";

  // Samples where the pdf is zero reject the hypothesis outright.
  for (int iy = 0; iy < d.resY && res.message.empty(); ++iy)
    for (int ix = 0; ix < d.resX; ++ix) {
      size_t i = size_t(iy) * d.resX + ix;
      if (expected[i] == 0 && observed[i] > 0 && detail::interiorZeroCell(d, expected, ix, iy)) {
        char m[256];
        std::snprintf(m, sizeof m, "%.0f samples in cell x [%g, %g] y [%g, %g], where the pdf is zero", observed[i],
                      d.x0 + ix * cw, d.x0 + (ix + 1) * cw, d.y0 + iy * ch, d.y0 + (iy + 1) * ch);
        res.message = m;
        break;
      }
    }

  if (res.message.empty()) detail::pooledStatistic(observed, expected, cfg.minExpected, res);
  if (!dumpName.empty() && (res.pValue < 1e-3 || !res.message.empty())) detail::dump(dumpName, d, observed, expected);
  return res;
}

// Directions over the whole sphere (cfg.thetaBins x cfg.phiBins cells).
inline Chi2Result chi2Directions(const std::function<std::optional<Vec3>(Rng&)>& sample,
                                 const std::function<double(const Vec3&)>& pdf, const Chi2Config& cfg,
                                 const std::string& dumpName = "") {
  return chi2Test(sphereDomain(cfg.thetaBins, cfg.phiBins), sample, pdf, cfg, dumpName);
}

// ---- [4] chi2Discrete -------------------------------------------------------------------

// sample(rng) returns an index in [0, n) or nothing; pmf(i) is its claimed
// probability. Every item is interior: a sample of a zero-pmf item fails.
inline Chi2Result chi2Discrete(const std::function<std::optional<size_t>(Rng&)>& sample,
                               const std::function<double(size_t)>& pmf, size_t n, const Chi2Config& cfg,
                               const std::string& dumpName = "") {
  std::vector<double> observed(n, 0.0), expected(n, 0.0);
  Chi2Result res;
  Rng rng(cfg.seed, cfg.stream);
  size_t outside = 0;
  for (size_t i = 0; i < cfg.samples; ++i) {
    std::optional<size_t> k = sample(rng);
    if (!k) continue;
    if (*k >= n) {
      ++outside;
      continue;
    }
    observed[*k] += 1;
  }
  double total = 0;
  for (size_t i = 0; i < n; ++i) total += pmf(i), expected[i] = pmf(i) * double(cfg.samples);
  if (outside > 0) res.message = std::to_string(outside) + " samples outside [0, " + std::to_string(n) + ")";
  if (total > 1.0 + 1e-5) res.message = "pmf sums to " + std::to_string(total) + " (> 1)";
  for (size_t i = 0; i < n && res.message.empty(); ++i)
    if (expected[i] == 0 && observed[i] > 0)
      res.message = std::to_string(size_t(observed[i])) + " samples of item " + std::to_string(i) + ", whose pmf is 0";
  if (res.message.empty()) detail::pooledStatistic(observed, expected, cfg.minExpected, res);
  if (!dumpName.empty() && (res.pValue < 1e-3 || !res.message.empty())) {
    Domain d = lineDomain(0, double(n), int(n));
    d.name = "discrete";
    detail::dump(dumpName, d, observed, expected);
  }
  return res;
}

}  // namespace vsl::test
