// A reusable chi-square goodness-of-fit harness for direction samplers, after
// Mitsuba's chi2.py: histogram sampled directions on a (theta, phi) grid
// over the whole sphere, integrate the claimed pdf over each cell numerically,
// pool cells with small expected counts, and compute a p-value. On failure the
// observed and expected histograms are dumped as PGM-like text for inspection.
#pragma once

#include <cmath>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/math.h"
#include "core/rng.h"

namespace vsl::test {

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

struct Chi2Result {
  double pValue = 0;
  double statistic = 0;
  int dof = 0;
  std::string message;  // why it failed, if it did
};

struct Chi2Config {
  int thetaBins = 32, phiBins = 64;  // theta-uniform cells resolve peaked lobes near the pole
  int subdiv = 12;                   // pdf integration points per cell and axis
  size_t samples = 1000000;
  double minExpected = 5;  // cells below this are pooled
  uint64_t seed = 1;
};

// sample(rng) returns a unit direction or nothing (a failed sample still
// counts toward the total); pdf(w) is the claimed density (solid angle).
inline Chi2Result chi2Directions(const std::function<std::optional<Vec3>(Rng&)>& sample,
                                 const std::function<double(const Vec3&)>& pdf, const Chi2Config& cfg,
                                 const std::string& dumpName = "") {
  const int nc = cfg.thetaBins, np = cfg.phiBins;
  std::vector<double> observed(size_t(nc) * np, 0.0), expected(size_t(nc) * np, 0.0);
  Rng rng(cfg.seed, 17);
  for (size_t i = 0; i < cfg.samples; ++i) {
    std::optional<Vec3> w = sample(rng);
    if (!w) continue;
    double z = std::min(std::max(double(w->z), -1.0), 1.0);
    double theta = std::acos(z);
    double phi = std::atan2(double(w->y), double(w->x));
    if (phi < 0) phi += 2 * M_PI;
    int ic = std::min(int(theta / M_PI * nc), nc - 1);
    int ip = std::min(int(phi / (2 * M_PI) * np), np - 1);
    observed[size_t(ic) * np + ip] += 1;
  }
  // Integrate the pdf over each cell: midpoint rule in (theta, phi) with the
  // solid-angle element sin(theta) dtheta dphi.
  const double dtheta = M_PI / nc, dphi = 2 * M_PI / np;
  double total = 0;
  for (int ic = 0; ic < nc; ++ic)
    for (int ip = 0; ip < np; ++ip) {
      double sum = 0;
      for (int a = 0; a < cfg.subdiv; ++a)
        for (int b = 0; b < cfg.subdiv; ++b) {
          double theta = (ic + (a + 0.5) / cfg.subdiv) * dtheta;
          double phi = (ip + (b + 0.5) / cfg.subdiv) * dphi;
          double r = std::sin(theta), z = std::cos(theta);
          sum += r * pdf(Vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)));
        }
      double integral = sum * dtheta * dphi / (cfg.subdiv * cfg.subdiv);
      expected[size_t(ic) * np + ip] = integral * cfg.samples;
      total += integral;
    }
  Chi2Result res;
  // Pool small cells. Cells whose integrated pdf is zero but that received
  // samples are pooled too (a cell can straddle the edge of the pdf's
  // support); a real mismatch shows up in the pooled term.
  double pooledObs = 0, pooledExp = 0, stat = 0;
  int cells = 0;
  for (size_t i = 0; i < observed.size(); ++i) {
    if (expected[i] < cfg.minExpected) {
      pooledObs += observed[i];
      pooledExp += expected[i];
    } else {
      stat += (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
      ++cells;
    }
  }
  if (pooledExp >= cfg.minExpected) {
    stat += (pooledObs - pooledExp) * (pooledObs - pooledExp) / pooledExp;
    ++cells;
  } else if (pooledObs > 4 * cfg.minExpected) {
    res.message = "pooled low-pdf cells received " + std::to_string(pooledObs) + " samples, expected " +
                  std::to_string(pooledExp);
    return res;
  }
  res.statistic = stat;
  res.dof = std::max(cells - 1, 1);
  res.pValue = chi2Survival(stat, res.dof);
  if (std::abs(total - 1) > 0.02 && total > 1) res.message = "pdf integrates to " + std::to_string(total) + " (> 1)";
  if (!dumpName.empty() && (res.pValue < 1e-3 || !res.message.empty())) {
    std::string path = dumpName + ".chi2.txt";
    if (FILE* f = std::fopen(path.c_str(), "w")) {
      std::fprintf(f, "# rows: theta bins from 0 to pi; columns: phi bins. observed then expected\n");
      for (const auto* h : {&observed, &expected}) {
        for (int ic = 0; ic < nc; ++ic) {
          for (int ip = 0; ip < np; ++ip) std::fprintf(f, "%.1f ", (*h)[size_t(ic) * np + ip]);
          std::fprintf(f, "\n");
        }
        std::fprintf(f, "\n");
      }
      std::fclose(f);
      std::fprintf(stderr, "chi2 histograms written to %s\n", path.c_str());
    }
  }
  return res;
}

}  // namespace vsl::test
