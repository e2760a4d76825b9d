// The glTF metallic-roughness BRDF: sampling against pdf (chi-square), energy
// (white furnace: albedo <= 1), reciprocity, consistency of the triplet, and
// finiteness at the extremes.
#include <gtest/gtest.h>

#include "chi2.h"
#include "core/material.h"
#include "core/sampling.h"
#include "support.h"

using namespace vsl;

namespace {

Vec3 dirFromAngles(float thetaDeg, float phiDeg) {
  float t = thetaDeg * kPi / 180, p = phiDeg * kPi / 180;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

// Directional albedo E[f cos / pdf] with its standard error.
std::pair<double, double> albedo(const Brdf& b, const Vec3& wo, int n, uint64_t seed) {
  Rng rng(seed, 3);
  test::MeanAccumulator acc;
  for (int i = 0; i < n; ++i) {
    auto bs = b.sample(wo, rng.uniform(), {rng.uniform(), rng.uniform()});
    acc.add(bs ? double(luminance(bs->f)) * bs->wi.z / bs->pdf : 0.0);
  }
  return {acc.mean(), acc.standardError()};
}

struct Case {
  float roughness, anisotropy, metallic, thetaDeg;
};

std::vector<Case> chi2Cases() {
  std::vector<Case> cases;
  for (float r : {0.3f, 0.6f, 1.0f})
    for (float a : {0.0f, 0.8f})
      for (float m : {0.0f, 1.0f})
        for (float th : {20.0f, 75.0f}) cases.push_back({r, a, m, th});
  return cases;
}

}  // namespace

TEST(BrdfStats, SamplingMatchesPdfChiSquare) {
  const auto cases = chi2Cases();
  const double level = test::sidak(0.01, int(cases.size()));
  for (const Case& c : cases) {
    Brdf b = Brdf::fromGltf(Vec3(0.7f, 0.5f, 0.3f), c.metallic, c.roughness, c.anisotropy);
    Vec3 wo = dirFromAngles(c.thetaDeg, 30);
    test::Chi2Config cfg;
    cfg.samples = 1000000;
    cfg.subdiv = 10;
    char name[128];
    std::snprintf(name, sizeof name, "brdf_r%.2f_a%.2f_m%.0f_t%.0f", c.roughness, c.anisotropy, c.metallic, c.thetaDeg);
    auto r = test::chi2Directions(
        [&](Rng& g) -> std::optional<Vec3> {
          auto s = b.sample(wo, g.uniform(), {g.uniform(), g.uniform()});
          if (!s) return std::nullopt;
          return s->wi;
        },
        [&](const Vec3& wi) { return double(b.pdf(wo, wi)); }, cfg, name);
    EXPECT_TRUE(r.message.empty()) << name << ": " << r.message;
    EXPECT_GT(r.pValue, level) << name << ": chi2 " << r.statistic << " dof " << r.dof;
    std::printf("%-32s chi2 %9.1f dof %4d p %.4f\n", name, r.statistic, r.dof, r.pValue);
  }
}

TEST(Brdf, SampleIsConsistentWithEvalAndPdf) {
  Rng rng(4, 4);
  for (float r : {0.05f, 0.3f, 1.0f})
    for (float m : {0.0f, 0.5f, 1.0f})
      for (float a : {0.0f, 0.9f}) {
        Brdf b = Brdf::fromGltf(Vec3(0.8f, 0.6f, 0.4f), m, r, a);
        for (int i = 0; i < 2000; ++i) {
          Vec3 wo = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
          if (wo.z < 1e-3f) continue;
          auto s = b.sample(wo, rng.uniform(), {rng.uniform(), rng.uniform()});
          if (!s) continue;
          Vec3 f = b.eval(wo, s->wi);
          float p = b.pdf(wo, s->wi);
          ASSERT_NEAR(s->pdf, p, 1e-4f * std::max(1.0f, p));
          ASSERT_NEAR(s->f.x, f.x, 1e-4f * std::max(1.0f, f.x));
          ASSERT_GT(s->wi.z, 0.0f);
        }
      }
}

TEST(Brdf, Reciprocity) {
  Rng rng(8, 1);
  for (float r : {0.1f, 0.4f, 1.0f})
    for (float m : {0.0f, 0.3f, 1.0f})
      for (float a : {0.0f, 0.7f}) {
        Brdf b = Brdf::fromGltf(Vec3(0.9f, 0.5f, 0.2f), m, r, a);
        for (int i = 0; i < 2000; ++i) {
          Vec3 wo = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
          Vec3 wi = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
          Vec3 f1 = b.eval(wo, wi), f2 = b.eval(wi, wo);
          for (int c = 0; c < 3; ++c) ASSERT_NEAR(f1[c], f2[c], 2e-5f * std::max(1.0f, std::abs(f1[c])));
        }
      }
}

// White furnace: a white BRDF (base colour 1) reflects at most what it
// receives, from every direction. The estimator's standard error sets the
// tolerance: albedo - 1 must stay below 4 standard errors.
TEST(BrdfStats, WhiteFurnaceAlbedoAtMostOne) {
  for (float m : {0.0f, 1.0f, 0.5f})
    for (float r : {0.02f, 0.2f, 0.5f, 1.0f})
      for (float a : {0.0f, 0.9f})
        for (float th : {0.0f, 45.0f, 80.0f, 89.0f}) {
          Brdf b = Brdf::fromGltf(Vec3(1.0f), m, r, a);
          auto [mean, se] = albedo(b, dirFromAngles(th, 17), 200000, 5);
          EXPECT_LE(mean, 1.0 + 4 * se + 1e-6) << "metallic " << m << " roughness " << r << " anisotropy " << a
                                               << " theta " << th << ": albedo " << mean << " +- " << se;
          EXPECT_GT(mean, 0.3) << "suspiciously dark: metallic " << m << " roughness " << r << " theta " << th;
        }
}

// A white Lambertian dielectric (specularFactor 0) has albedo exactly 1, and
// a white dielectric with its specular lobe stays close to 1 (albedo scaling).
TEST(BrdfStats, AlbedoScalingConservesEnergy) {
  Brdf lambert = Brdf::fromGltf(Vec3(1.0f), 0, 1, 0, 0.0f);
  auto [m0, se0] = albedo(lambert, dirFromAngles(60, 0), 100000, 2);
  EXPECT_NEAR(m0, 1.0, 1e-5);  // cosine sampling of a Lambertian: zero variance
  for (float r : {0.1f, 0.5f, 1.0f})
    for (float th : {0.0f, 60.0f, 85.0f}) {
      Brdf b = Brdf::fromGltf(Vec3(1.0f), 0, r, 0);
      auto [m, se] = albedo(b, dirFromAngles(th, 0), 200000, 3);
      // Tolerance: 4 standard errors plus the albedo table's interpolation error.
      EXPECT_NEAR(m, 1.0, 4 * se + 0.01) << "roughness " << r << " theta " << th;
    }
}

TEST(Brdf, ExtremesStayFinite) {
  Rng rng(2, 2);
  for (float r : {0.0f, 1e-4f, 1e-2f, 1.0f})
    for (float a : {0.0f, 1.0f})
      for (float m : {0.0f, 1.0f}) {
        Brdf b = Brdf::fromGltf(Vec3(1.0f), m, r, a);
        for (float th : {0.0f, 89.9f, 89.999f}) {
          Vec3 wo = dirFromAngles(th, 33);
          // Exactly the mirror direction, and random directions.
          Vec3 mirror(-wo.x, -wo.y, wo.z);
          for (const Vec3& wi : {mirror, wo, Vec3(0, 0, 1), dirFromAngles(89.99f, 200)}) {
            Vec3 f = b.eval(wo, wi);
            float p = b.pdf(wo, wi);
            ASSERT_TRUE(isFinite(f)) << "r " << r << " th " << th;
            ASSERT_TRUE(std::isfinite(p)) << "r " << r << " th " << th;
          }
          for (int i = 0; i < 1000; ++i) {
            auto s = b.sample(wo, rng.uniform(), {rng.uniform(), rng.uniform()});
            if (!s) continue;
            ASSERT_TRUE(isFinite(s->f));
            ASSERT_TRUE(std::isfinite(s->pdf) && s->pdf > 0);
            Vec3 w = s->f * (s->wi.z / s->pdf);
            ASSERT_TRUE(isFinite(w)) << "r " << r << " th " << th;
          }
        }
      }
}

TEST(Brdf, BelowSurfaceIsZero) {
  Brdf b = Brdf::fromGltf(Vec3(0.5f), 0.5f, 0.5f, 0);
  EXPECT_TRUE(isBlack(b.eval(Vec3(0, 0, 1), Vec3(0, 0, -1))));
  EXPECT_EQ(b.pdf(Vec3(0, 0, -1), Vec3(0, 0, 1)), 0.0f);
  EXPECT_FALSE(b.sample(Vec3(0, 0, -1), 0.5f, {0.5f, 0.5f}).has_value());
}

TEST(Ggx, VisibleNormalPdfIntegratesToOne) {
  // integral of D_wo(h) over the hemisphere of h is 1 (Heitz 2018).
  for (float ax : {0.1f, 0.5f})
    for (float ay : {0.1f, 0.9f})
      for (float th : {10.0f, 70.0f}) {
        GGX g{ax, ay};
        Vec3 wo = dirFromAngles(th, 40);
        test::Chi2Config cfg;
        cfg.samples = 300000;
        cfg.subdiv = 16;
        auto r = test::chi2Directions(
            [&](Rng& r2) {
              return std::optional<Vec3>(g.sampleVisibleNormal(wo, {r2.uniform(), r2.uniform()}));
            },
            [&](const Vec3& h) { return double(g.visibleNormalPdf(wo, h)); }, cfg);
        EXPECT_TRUE(r.message.empty()) << r.message;
        EXPECT_GT(r.pValue, 1e-3) << "ax " << ax << " ay " << ay << " th " << th;
      }
}
