// Sampling triplets: round trips, pdfs that integrate to one, and
// distributions whose frequencies match their pmfs.
#include <gtest/gtest.h>

#include "chi2.h"
#include "core/rng.h"
#include "core/sampling.h"

using namespace vsl;

TEST(Sampling, ConcentricDiskRoundTrip) {
  Rng rng(3, 4);
  for (int i = 0; i < 100000; ++i) {
    Vec2 u{rng.uniform(), rng.uniform()};
    Vec2 p = sampleUniformDiskConcentric(u);
    ASSERT_LE(p.x * p.x + p.y * p.y, 1.0f + 1e-5f);
    Vec2 back = invertUniformDiskConcentric(p);
    ASSERT_NEAR(back.x, u.x, 2e-4f) << "u = (" << u.x << ", " << u.y << ")";
    ASSERT_NEAR(back.y, u.y, 2e-4f) << "u = (" << u.x << ", " << u.y << ")";
  }
}

TEST(Sampling, CosineHemisphereRoundTripAndPdf) {
  Rng rng(5, 6);
  for (int i = 0; i < 50000; ++i) {
    Vec2 u{rng.uniform(), rng.uniform()};
    Vec3 w = sampleCosineHemisphere(u);
    ASSERT_NEAR(length(w), 1.0f, 1e-5f);
    ASSERT_GE(w.z, 0.0f);
    Vec2 back = invertCosineHemisphere(w);
    ASSERT_NEAR(back.x, u.x, 2e-4f);
    ASSERT_NEAR(back.y, u.y, 2e-4f);
  }
  test::Chi2Config cfg;
  cfg.samples = 400000;
  auto r = test::chi2Directions(
      [](Rng& g) {
        return std::optional<Vec3>(sampleCosineHemisphere({g.uniform(), g.uniform()}));
      },
      [](const Vec3& w) { return double(cosineHemispherePdf(w.z)); }, cfg, "cosine");
  EXPECT_TRUE(r.message.empty()) << r.message;
  EXPECT_GT(r.pValue, 1e-3) << "chi2 " << r.statistic << " dof " << r.dof;
}

// A uniform cone sample has (1 - cos theta) / (1 - cosMax) and phi / 2pi both
// uniform on [0,1) and independent; chi-square on a 2D grid of the two.
TEST(Sampling, UniformConeIsUniformInSolidAngle) {
  for (float cosMax : {0.99999f, 0.999f, 0.9f, 0.0f, -0.5f}) {
    Rng rng(12, 1);
    const int bins = 20, n = 400000;
    std::vector<int> h(bins * bins, 0);
    for (int i = 0; i < n; ++i) {
      Vec3 w = sampleUniformCone({rng.uniform(), rng.uniform()}, cosMax);
      ASSERT_NEAR(length(w), 1.0f, 1e-5f);
      ASSERT_GE(w.z, cosMax - 1e-5f);
      // 1 - cos from the sine, which stays accurate for tiny cones.
      double s2 = double(w.x) * w.x + double(w.y) * w.y;
      double oneMinusCos = w.z > 0 ? s2 / (1.0 + w.z) : 1.0 - w.z;
      double t = oneMinusCos / (1.0 - double(cosMax));
      double phi = std::atan2(double(w.y), double(w.x));
      if (phi < 0) phi += 2 * M_PI;
      int a = std::min(std::max(int(t * bins), 0), bins - 1), b = std::min(int(phi / (2 * M_PI) * bins), bins - 1);
      h[a * bins + b]++;
    }
    double e = double(n) / (bins * bins), chi2 = 0;
    for (int c : h) chi2 += (c - e) * (c - e) / e;
    EXPECT_GT(test::chi2Survival(chi2, bins * bins - 1), 1e-3) << "cosMax " << cosMax << " chi2 " << chi2;
    EXPECT_FLOAT_EQ(uniformConePdf(cosMax), float(1.0 / (2 * M_PI * (1.0 - cosMax))));
  }
}

TEST(Sampling, TriangleIsUniform) {
  // Mean barycentrics of a uniform triangle sample are (1/3, 1/3, 1/3), and
  // the fraction in the sub-triangle b0 > 1/2 is 1/4.
  Rng rng(9, 9);
  const int n = 400000;
  double m0 = 0, m1 = 0, corner = 0;
  for (int i = 0; i < n; ++i) {
    Vec2 b = sampleUniformTriangle({rng.uniform(), rng.uniform()});
    ASSERT_GE(b.x, 0.0f);
    ASSERT_GE(b.y, 0.0f);
    ASSERT_LE(b.x + b.y, 1.0f + 1e-6f);
    m0 += b.x;
    m1 += b.y;
    corner += b.x > 0.5f;
  }
  // Standard errors: sqrt(1/18 / n) ~ 3.7e-4 for means, sqrt(3/16 / n) ~ 6.8e-4.
  EXPECT_NEAR(m0 / n, 1.0 / 3, 5 * 3.7e-4);
  EXPECT_NEAR(m1 / n, 1.0 / 3, 5 * 3.7e-4);
  EXPECT_NEAR(corner / n, 0.25, 5 * 6.8e-4);
}

TEST(Sampling, DiscreteDistributionFrequenciesMatchPmf) {
  std::vector<double> w = {0, 1, 2, 0, 3, 0.5, 0};
  DiscreteDistribution d(w);
  double total = 6.5;
  for (size_t i = 0; i < w.size(); ++i) EXPECT_FLOAT_EQ(d.pmf(i), float(w[i] / total));
  Rng rng(1, 2);
  const int n = 650000;
  std::vector<int> counts(w.size(), 0);
  for (int i = 0; i < n; ++i) {
    float pmf, ur;
    size_t k = d.sample(rng.uniform(), &pmf, &ur);
    ASSERT_GT(pmf, 0.0f) << "sampled zero-weight item " << k;
    ASSERT_FLOAT_EQ(pmf, d.pmf(k));
    ASSERT_GE(ur, 0.0f);
    ASSERT_LT(ur, 1.0f);
    counts[k]++;
  }
  double chi2 = 0;
  int dof = -1;
  for (size_t i = 0; i < w.size(); ++i) {
    if (w[i] == 0) {
      EXPECT_EQ(counts[i], 0);
      continue;
    }
    double e = n * w[i] / total;
    chi2 += (counts[i] - e) * (counts[i] - e) / e;
    ++dof;
  }
  EXPECT_GT(test::chi2Survival(chi2, dof), 1e-3) << "chi2 " << chi2;
}

TEST(Sampling, EmptyDistributionIsSafe) {
  std::vector<double> w = {0, 0};
  DiscreteDistribution d(w);
  float pmf = 1;
  d.sample(0.5f, &pmf);
  EXPECT_EQ(pmf, 0.0f);
  std::vector<double> bad = {std::nan(""), -1, INFINITY};
  DiscreteDistribution e(bad);
  EXPECT_EQ(e.total(), 0.0);
}

TEST(Rng, ForItemIsReproducibleAndDistinct) {
  Rng a = Rng::forItem(10, 2, 0, 7), b = Rng::forItem(10, 2, 0, 7), c = Rng::forItem(11, 2, 0, 7);
  for (int i = 0; i < 100; ++i) {
    uint32_t x = a.next();
    EXPECT_EQ(x, b.next());
    (void)c;
  }
  Rng d = Rng::forItem(10, 2, 0, 7), e = Rng::forItem(11, 2, 0, 7);
  int same = 0;
  for (int i = 0; i < 100; ++i) same += d.next() == e.next();
  EXPECT_LT(same, 3);
  Rng u(1, 1);
  for (int i = 0; i < 100000; ++i) {
    float f = u.uniform();
    ASSERT_GE(f, 0.0f);
    ASSERT_LT(f, 1.0f);
  }
}
