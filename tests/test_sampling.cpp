// Sampling triplets: round trips, pdfs that integrate to one, and
// distributions whose frequencies match their pmfs (tests/chi2.h); the light
// sampler's pmf and sampleLi's pdf, after pbrt-v4's lightsamplers_test.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "chi2.h"
#include "core/lights.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/simd.h"
#include "support.h"

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
    bool bad = false;
    test::Chi2Config cfg;
    cfg.samples = 400000;
    cfg.seed = 12, cfg.stream = 1;
    cfg.subdiv = 2;
    auto r = test::chi2Test(
        test::planeDomain({0, 0}, {1, 1}, 20, 20),
        [&](Rng& rng) -> std::optional<Vec3> {
          Vec3 w = sampleUniformCone({rng.uniform(), rng.uniform()}, cosMax);
          if (!(std::abs(length(w) - 1.0f) <= 1e-5f) || !(w.z >= cosMax - 1e-5f)) bad = true;
          // 1 - cos from the sine, which stays accurate for tiny cones.
          double s2 = double(w.x) * w.x + double(w.y) * w.y;
          double oneMinusCos = w.z > 0 ? s2 / (1.0 + w.z) : 1.0 - w.z;
          double phi = std::atan2(double(w.y), double(w.x));
          if (phi < 0) phi += 2 * M_PI;
          return Vec3(float(oneMinusCos / (1.0 - double(cosMax))), float(phi / (2 * M_PI)), 0);
        },
        [](const Vec3&) { return 1.0; }, cfg, "cone_uniform");
    EXPECT_FALSE(bad) << "cosMax " << cosMax << ": a sample is not unit length or lies outside the cone";
    EXPECT_TRUE(r.message.empty()) << "cosMax " << cosMax << ": " << r.message;
    EXPECT_GT(r.pValue, 1e-3) << "cosMax " << cosMax << " chi2 " << r.statistic << " dof " << r.dof;
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
  test::Chi2Config cfg;
  cfg.samples = 650000;
  cfg.seed = 1, cfg.stream = 2;
  std::string bad;
  std::vector<float> remapped;  // u rescaled within the chosen bucket
  remapped.reserve(cfg.samples);
  auto r = test::chi2Discrete(
      [&](Rng& rng) -> std::optional<size_t> {
        float pmf, ur;
        size_t k = d.sample(rng.uniform(), &pmf, &ur);
        if (bad.empty() && !(pmf > 0 && pmf == d.pmf(k) && ur >= 0 && ur < 1))
          bad = "item " + std::to_string(k) + ": pmf " + std::to_string(pmf) + ", remapped u " + std::to_string(ur);
        remapped.push_back(ur);
        return k;
      },
      [&](size_t i) { return w[i] / total; }, w.size(), cfg, "discrete");
  EXPECT_TRUE(bad.empty()) << bad;
  EXPECT_TRUE(r.message.empty()) << r.message;  // includes: no zero-weight item is ever sampled
  EXPECT_GT(r.pValue, 1e-3) << "chi2 " << r.statistic << " dof " << r.dof;
  // The remapped u is uniform on [0,1) again, for reuse (line domain).
  size_t next = 0;
  cfg.samples = remapped.size();
  auto ru = test::chi2Test(
      test::lineDomain(0, 1, 50), [&](Rng&) { return std::optional<Vec3>(Vec3(remapped[next++], 0, 0)); },
      [](const Vec3&) { return 1.0; }, cfg, "discrete_remapped");
  EXPECT_TRUE(ru.message.empty()) << ru.message;
  EXPECT_GT(ru.pValue, 1e-3) << "remapped u: chi2 " << ru.statistic << " dof " << ru.dof;
}

// ---- The triplets: sample(inverse(x)) == x, and chi-square of sample against pdf ----

// Round trips in the sampled space, where they are well conditioned
// everywhere (u-space round trips lose phi at the poles).
TEST(Sampling, UniformSphereTriplet) {
  Rng rng(21, 1);
  for (int i = 0; i < 100000; ++i) {
    Vec2 u{rng.uniform(), rng.uniform()};
    Vec3 w = sampleUniformSphere(u);
    ASSERT_NEAR(length(w), 1.0f, 1e-5f);
    Vec2 back = invertUniformSphere(w);
    ASSERT_GE(back.x, 0.0f);
    ASSERT_LT(back.y, 1.0f);
    ASSERT_NEAR(back.x, u.x, 2e-6f);
    Vec3 again = sampleUniformSphere(back);
    ASSERT_LT(length(again - w), 2e-5f) << "u = (" << u.x << ", " << u.y << ")";
  }
  test::Chi2Config cfg;
  cfg.samples = 400000;
  auto r = test::chi2Directions(
      [](Rng& g) {
        return std::optional<Vec3>(sampleUniformSphere({g.uniform(), g.uniform()}));
      },
      [](const Vec3&) { return double(uniformSpherePdf()); }, cfg, "sphere");
  EXPECT_TRUE(r.message.empty()) << r.message;
  EXPECT_GT(r.pValue, 1e-3) << "chi2 " << r.statistic << " dof " << r.dof;
}

// The cone's pdf against a histogram over the cone itself (theta in
// [0, thetaMax]), so that tiny cones get as many cells as wide ones; both
// parameterisations (cosMax and 1 - cosMax) invert.
TEST(Sampling, UniformConeTriplet) {
  const std::vector<float> cosMaxes = {0.99999f, 0.999f, 0.9f, 0.0f, -0.5f};
  const double level = test::sidak(1e-3, int(cosMaxes.size()));
  for (size_t k = 0; k < cosMaxes.size(); ++k) {
    const float cosMax = cosMaxes[k], omc = 1 - cosMax;
    Rng rng(22, 1);
    for (int i = 0; i < 50000; ++i) {
      Vec2 u{rng.uniform(), rng.uniform()};
      Vec3 w = sampleUniformCone(u, cosMax);
      Vec2 back = invertUniformCone(w, cosMax), backOmc = invertUniformConeOmc(w, omc);
      ASSERT_NEAR(back.x, u.x, 1e-4f) << "cosMax " << cosMax;
      ASSERT_EQ(back.x, backOmc.x);
      ASSERT_EQ(back.y, backOmc.y);
      Vec3 again = sampleUniformConeOmc(back, omc);
      // Relative to the cone's size: tiny cones hold tiny differences.
      ASSERT_LT(length(again - w), 2e-5f * std::max(std::sqrt(omc), 1e-2f) + 1e-7f)
          << "cosMax " << cosMax << " u = (" << u.x << ", " << u.y << ")";
    }
    EXPECT_EQ(uniformConeOmcPdf(omc), uniformConePdf(cosMax));
    test::Chi2Config cfg;
    cfg.samples = 400000;
    cfg.seed = 23 + k;  // independent tests, for the Sidak correction
    const double thetaMax = std::acos(double(cosMax));
    auto r = test::chi2Test(
        test::sphereDomain(24, 48, thetaMax),
        [&](Rng& g) {
          return std::optional<Vec3>(sampleUniformCone({g.uniform(), g.uniform()}, cosMax));
        },
        [&](const Vec3&) { return double(uniformConeOmcPdf(omc)); }, cfg, "cone");
    EXPECT_TRUE(r.message.empty()) << "cosMax " << cosMax << ": " << r.message;
    EXPECT_GT(r.pValue, level) << "cosMax " << cosMax << " chi2 " << r.statistic << " dof " << r.dof;
    std::printf("cone cosMax %-8g chi2 %8.1f dof %4d p %.4f\n", cosMax, r.statistic, r.dof, r.pValue);
  }
}

TEST(Sampling, UniformTriangleTriplet) {
  Rng rng(24, 1);
  for (int i = 0; i < 100000; ++i) {
    Vec2 u{rng.uniform(), rng.uniform()};
    Vec2 b = sampleUniformTriangle(u);
    Vec2 back = invertUniformTriangle(b);
    ASSERT_NEAR(back.x, u.x, 2e-7f) << "u = (" << u.x << ", " << u.y << ")";
    ASSERT_NEAR(back.y, u.y, 2e-7f) << "u = (" << u.x << ", " << u.y << ")";
    Vec2 again = sampleUniformTriangle(back);
    ASSERT_NEAR(again.x, b.x, 2e-7f);
    ASSERT_NEAR(again.y, b.y, 2e-7f);
  }
  EXPECT_FLOAT_EQ(uniformTrianglePdf(0.25f), 4.0f);
  // Barycentric (b0, b1) space: the reference triangle has area 1/2, so the
  // density there is uniformTrianglePdf(1/2) = 2.
  test::Chi2Config cfg;
  cfg.samples = 400000;
  cfg.seed = 25;
  auto r = test::chi2Test(
      test::triangleDomain(32),
      [](Rng& g) {
        Vec2 b = sampleUniformTriangle({g.uniform(), g.uniform()});
        return std::optional<Vec3>(Vec3(b.x, b.y, 0));
      },
      [](const Vec3& b) {
        return b.x >= 0 && b.y >= 0 && b.x + b.y <= 1 + 1e-6f ? double(uniformTrianglePdf(0.5f)) : 0.0;
      },
      cfg, "triangle");
  EXPECT_TRUE(r.message.empty()) << r.message;
  EXPECT_GT(r.pValue, 1e-3) << "chi2 " << r.statistic << " dof " << r.dof;
}

TEST(Sampling, ConcentricDiskMatchesPdf) {
  test::Chi2Config cfg;
  cfg.samples = 400000;
  cfg.seed = 26;
  auto r = test::chi2Test(
      test::diskDomain(),
      [](Rng& g) {
        Vec2 p = sampleUniformDiskConcentric({g.uniform(), g.uniform()});
        return std::optional<Vec3>(Vec3(p.x, p.y, 0));
      },
      [](const Vec3&) { return double(uniformDiskPdf()); }, cfg, "disk");
  EXPECT_TRUE(r.message.empty()) << r.message;
  EXPECT_GT(r.pValue, 1e-3) << "chi2 " << r.statistic << " dof " << r.dof;
}

// The harness itself: it must reject a wrong pdf, samples where the pdf is
// zero, and samples outside the domain.
TEST(Sampling, Chi2HarnessRejectsWrongSamplers) {
  test::Chi2Config cfg;
  cfg.samples = 200000;
  auto uniformSphere = [](Rng& g) { return std::optional<Vec3>(sampleUniformSphere({g.uniform(), g.uniform()})); };
  // Cosine samples against the uniform hemisphere's pdf: a wrong shape.
  auto shape = test::chi2Directions(
      [](Rng& g) {
        return std::optional<Vec3>(sampleCosineHemisphere({g.uniform(), g.uniform()}));
      },
      [](const Vec3& w) { return w.z > 0 ? 1 / (2 * M_PI) : 0.0; }, cfg);
  EXPECT_LT(shape.pValue, 1e-6);
  // Sphere samples against a hemisphere's pdf: half land where it is zero.
  auto zero = test::chi2Directions(
      uniformSphere, [](const Vec3& w) { return w.z > 0 ? 1 / (2 * M_PI) : 0.0; }, cfg);
  EXPECT_NE(zero.message.find("where the pdf is zero"), std::string::npos) << zero.message;
  // Samples outside a cone domain.
  auto outside = test::chi2Test(
      test::sphereDomain(8, 16, 0.5), uniformSphere, [](const Vec3&) { return 0.1; }, cfg);
  EXPECT_NE(outside.message.find("outside"), std::string::npos) << outside.message;
  // A discrete sampler that picks a zero-pmf item.
  auto item = test::chi2Discrete([](Rng& g) { return std::optional<size_t>(g.uniform() < 0.5f ? 0 : 1); },
                                 [](size_t i) { return i == 0 ? 1.0 : 0.0; }, 2, cfg);
  EXPECT_NE(item.message.find("pmf is 0"), std::string::npos) << item.message;
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

// ---- The light sampler ------------------------------------------------------------------

namespace {

// A quad of the plane z = height spanning [x0,x1] x [y0,y1], facing -z (down,
// toward the origin) or +z.
void addQuadAt(Scene& s, float height, float x0, float x1, float y0, float y1, bool facesDown, uint32_t material) {
  if (facesDown)
    test::addQuad(s, Vec3(x0, y0, height), Vec3(0, y1 - y0, 0), Vec3(x1 - x0, 0, 0), material);
  else
    test::addQuad(s, Vec3(x0, y0, height), Vec3(x1 - x0, 0, 0), Vec3(0, y1 - y0, 0), material);
}

Material emitter(Vec3 Le, bool doubleSided) {
  Material m;
  m.emission = Le;
  m.doubleSided = doubleSided;
  return m;
}

// Emitters seen from the origin, none behind another. On the plane z = 1
// (each listed with its extent there; the quad at z = 2 projects onto it):
//   0: [-1.5,-0.5] x [-1.0, 0.5], z = 1, faces the origin, Le 1
//   1: [ 0.2, 1.2] x [ 0.3, 1.1], z = 1, faces the origin, Le (3, 1, 0.5)
//   2: [-1.0, 0.0] x [ 0.6, 1.5], z = 2, faces away but is double-sided, Le 0.7
//   3: [ 0.5, 1.5] x [-1.5,-0.5], z = 1, faces away (one-sided: dark from the origin)
// plus a point light and a spot light. Every edge lies on a multiple of 0.1 on
// the plane z = 1, the cell size of the histogram below.
std::unique_ptr<Scene> lightScene() {
  auto s = std::make_unique<Scene>();
  s->materials = {emitter(Vec3(1.0f), false), emitter(Vec3(3.0f, 1.0f, 0.5f), false), emitter(Vec3(0.7f), true),
                  emitter(Vec3(2.0f), false)};
  addQuadAt(*s, 1, -1.5f, -0.5f, -1.0f, 0.5f, true, 0);
  addQuadAt(*s, 1, 0.2f, 1.2f, 0.3f, 1.1f, true, 1);
  addQuadAt(*s, 2, -2.0f, 0.0f, 1.2f, 3.0f, false, 2);
  addQuadAt(*s, 1, 0.5f, 1.5f, -1.5f, -0.5f, false, 3);
  PunctualLight point;
  point.position = Vec3(0, 0, 3);
  point.intensity = Vec3(2.0f);
  PunctualLight spot;
  spot.type = PunctualLight::Type::Spot;
  spot.position = Vec3(1, 1, 1);
  spot.direction = Vec3(0, 0, -1);
  spot.intensity = Vec3(5.0f);
  spot.cosInner = 0.95f;
  spot.cosOuter = 0.8f;
  s->punctualLights = {point, spot};
  return s;
}

// The nearest triangle of s that the ray from o along w hits, with the
// distance (Moller-Trumbore in double).
std::optional<std::pair<uint32_t, double>> firstHit(const Scene& s, const Vec3& o, const Vec3& w) {
  std::optional<std::pair<uint32_t, double>> best;
  for (uint32_t t = 0; t < s.triangleCount(); ++t) {
    const Vec3 &p0 = s.positions[s.indices[3 * t]], &p1 = s.positions[s.indices[3 * t + 1]],
               &p2 = s.positions[s.indices[3 * t + 2]];
    double e1[3] = {p1.x - p0.x, p1.y - p0.y, p1.z - p0.z}, e2[3] = {p2.x - p0.x, p2.y - p0.y, p2.z - p0.z};
    double d[3] = {w.x, w.y, w.z}, q[3] = {o.x - p0.x, o.y - p0.y, o.z - p0.z};
    auto cross3 = [](const double* a, const double* b, double* c) {
      c[0] = a[1] * b[2] - a[2] * b[1], c[1] = a[2] * b[0] - a[0] * b[2], c[2] = a[0] * b[1] - a[1] * b[0];
    };
    auto dot3 = [](const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
    double pv[3], qv[3];
    cross3(d, e2, pv);
    double det = dot3(e1, pv);
    if (std::abs(det) < 1e-12) continue;
    double u = dot3(q, pv) / det;
    cross3(q, e1, qv);
    double v = dot3(d, qv) / det, dist = dot3(e2, qv) / det;
    if (u < 0 || v < 0 || u + v > 1 || dist <= 0) continue;
    if (!best || dist < best->second) best = {{t, dist}};
  }
  return best;
}

}  // namespace

// The sampler picks each light with the probability pmf() reports, and that
// probability is the light's share of the total power (pbrt-v4's
// PowerLightSampler tests). Chi-square of the picked indices against pmf().
TEST(LightSampler, PickFrequenciesMatchPmfAndPower) {
  std::unique_ptr<Scene> scene = lightScene();
  LightSampler lights(*scene);
  ASSERT_EQ(lights.lightCount(), 10u);  // 8 emissive triangles, 2 punctual lights
  // Power by hand: pi Le area per emitting side; punctual lights' own power().
  std::vector<double> power;
  for (uint32_t t = 0; t < scene->triangleCount(); ++t) {
    const Material& m = scene->materials[scene->triMaterial[t]];
    power.push_back(double(luminance(m.emission)) * scene->triangleArea(t) * M_PI * (m.doubleSided ? 2 : 1));
  }
  for (const PunctualLight& L : scene->punctualLights) power.push_back(L.power(scene->boundingRadius()));
  double total = 0, pmfSum = 0;
  for (double p : power) total += p;
  for (size_t i = 0; i < power.size(); ++i) {
    EXPECT_NEAR(lights.pmf(i), power[i] / total, 1e-6) << "light " << i;
    pmfSum += lights.pmf(i);
  }
  EXPECT_NEAR(pmfSum, 1.0, 1e-6);
  EXPECT_EQ(lights.pmf(lights.lightCount()), 0.0f);

  std::string bad;
  test::Chi2Config cfg;
  cfg.samples = 1000000;
  cfg.seed = 31;
  auto r = test::chi2Discrete(
      [&](Rng& g) -> std::optional<size_t> {
        std::optional<SampledLight> l = lights.sample(g.uniform());
        if (!l) {
          if (bad.empty()) bad = "sample() returned nothing";
          return std::nullopt;
        }
        if (bad.empty() && l->pmf != lights.pmf(l->light))
          bad = "light " + std::to_string(l->light) + ": sample() says pmf " + std::to_string(l->pmf) +
                ", pmf() says " + std::to_string(lights.pmf(l->light));
        return l->light;
      },
      [&](size_t i) { return double(lights.pmf(i)); }, lights.lightCount(), cfg, "light_pmf");
  EXPECT_TRUE(bad.empty()) << bad;
  EXPECT_TRUE(r.message.empty()) << r.message;
  EXPECT_GT(r.pValue, 1e-3) << "chi2 " << r.statistic << " dof " << r.dof;
  std::printf("light pick frequencies: chi2 %.1f dof %d p %.4f\n", r.statistic, r.dof, r.pValue);

  Scene empty;
  EXPECT_FALSE(LightSampler(empty).sample(0.5f).has_value());
}

// sampleLi's directions from a point follow the solid-angle density its pdf
// (and pdfLi) claims: chi-square on a histogram over the plane z = 1, whose
// cells the emitters' edges follow (the Jacobian from that plane to solid
// angle is cos / d^2 = 1 / d^3). Punctual lights (delta) and the quad that
// faces away give no direction; they count toward the total, so the expected
// counts sum to less than the sample count. Each sample's pdf must equal
// pdfLi for the point it chose (relative 1e-4).
TEST(LightSampler, SampleLiMatchesItsPdf) {
  std::unique_ptr<Scene> scene = lightScene();
  LightSampler lights(*scene);
  const Vec3 p(0.0f);

  test::Domain plane = test::planeDomain({-2, -2}, {2, 2}, 40, 40);
  plane.name = "plane z = 1";
  plane.forward = [](double x, double y) { return normalize(Vec3(float(x), float(y), 1)); };
  plane.jacobian = [](double x, double y) {
    double d2 = x * x + y * y + 1;
    return 1 / (d2 * std::sqrt(d2));
  };
  plane.backward = [](const Vec3& w) {
    if (!(w.z > 0)) return std::array<double, 2>{1e30, 1e30};
    return std::array<double, 2>{double(w.x) / w.z, double(w.y) / w.z};
  };
  // The density toward w: pdfLi of the emitter the ray meets, if it emits
  // toward p (the emitters do not overlap as seen from p).
  auto density = [&](const Vec3& w) {
    auto hit = firstHit(*scene, p, w);
    if (!hit) return 0.0;
    uint32_t tri = hit->first;
    const Material& m = scene->materials[scene->triMaterial[tri]];
    if (dot(scene->triangleNormal(tri), w) >= 0 && !m.doubleSided) return 0.0;
    return double(lights.pdfLi(p, tri, p + w * float(hit->second)));
  };

  std::string bad;
  size_t checked = 0;
  test::Chi2Config cfg;
  cfg.samples = 1000000;
  cfg.seed = 32;
  cfg.subdiv = 4;
  auto r = test::chi2Test(
      plane,
      [&](Rng& g) -> std::optional<Vec3> {
        float uLight = g.uniform();
        Vec2 u{g.uniform(), g.uniform()};
        std::optional<LightSample> s = lights.sampleLi(p, uLight, u);
        if (!s || s->delta) return std::nullopt;
        if (checked < 20000 && bad.empty()) {  // the sample's own pdf against pdfLi
          ++checked;
          auto hit = firstHit(*scene, p, s->wi);
          float expect = hit ? lights.pdfLi(p, hit->first, s->pLight) : 0.0f;
          if (!hit || std::abs(s->pdf - expect) > 1e-4f * expect)
            bad = "sample toward (" + std::to_string(s->wi.x) + ", " + std::to_string(s->wi.y) + ", " +
                  std::to_string(s->wi.z) + "): pdf " + std::to_string(s->pdf) + ", pdfLi " + std::to_string(expect);
        }
        return s->wi;
      },
      density, cfg, "sample_li");
  EXPECT_TRUE(bad.empty()) << bad;
  EXPECT_TRUE(r.message.empty()) << r.message;
  EXPECT_GT(r.pValue, 1e-3) << "chi2 " << r.statistic << " dof " << r.dof;
  std::printf("sampleLi directions: chi2 %.1f dof %d p %.4f (pooled %d cells into %d)\n", r.statistic, r.dof, r.pValue,
              r.pooledIn, r.pooledOut);
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

// Multi-jittered points (the lobe gather's first directions): one per cell of
// the m x n grid and one per 1/count stratum of x and of y, each point uniform
// in its cell (chi-square), and a mean over them of a smooth function with far
// less variance than over independent points.
TEST(Sampling, MultiJitteredIsStratifiedAndEachPointUniform) {
  std::vector<Vec2> p(200);
  for (int count = 1; count <= 200; ++count) {
    int m = 1;
    for (int d = 1; d * d <= count; ++d)
      if (count % d == 0) m = d;
    const int n = count / m;
    for (uint64_t seed = 0; seed < 3; ++seed) {
      Rng rng(seed, uint64_t(count));
      multiJittered(count, rng, p.data());
      std::vector<int> cell(size_t(count), 0), sx(size_t(count), 0), sy(size_t(count), 0);
      for (int k = 0; k < count; ++k) {
        ASSERT_TRUE(p[k].x >= 0 && p[k].x < 1 && p[k].y >= 0 && p[k].y < 1) << count << " " << k;
        ++cell[size_t(int(double(p[k].y) * n) * m + int(double(p[k].x) * m))];
        ++sx[size_t(double(p[k].x) * count)];
        ++sy[size_t(double(p[k].y) * count)];
      }
      for (int c = 0; c < count; ++c) {
        ASSERT_EQ(cell[size_t(c)], 1) << "count " << count << " cell " << c;
        ASSERT_EQ(sx[size_t(c)], 1) << "count " << count << " x stratum " << c;
        ASSERT_EQ(sy[size_t(c)], 1) << "count " << count << " y stratum " << c;
      }
    }
  }

  // Point 5 of 16 (cell (1, 1) of 4 x 4) and point 3 of 7 (cell (0, 3) of
  // 1 x 7), over 64,000 seeds: uniform in its cell, on an 8 x 8 histogram
  // (chi-square, 63 dof, Sidak-corrected 1e-3 over the two).
  struct Case {
    int count, k, m, n;
  };
  for (Case c : {Case{16, 5, 4, 4}, Case{7, 3, 1, 7}}) {
    const int i = c.k % c.m, j = c.k / c.m;
    std::vector<double> hist(64, 0.0);
    const int draws = 64000;
    for (int s = 0; s < draws; ++s) {
      Rng rng(uint64_t(s), 77);
      multiJittered(c.count, rng, p.data());
      const double u = double(p[c.k].x) * c.m - i, v = double(p[c.k].y) * c.n - j;
      ASSERT_TRUE(u >= 0 && u < 1 && v >= 0 && v < 1) << c.count << " " << u << " " << v;
      ++hist[size_t(int(v * 8) * 8 + int(u * 8))];
    }
    double chi2 = 0;
    for (double h : hist) chi2 += (h - draws / 64.0) * (h - draws / 64.0) / (draws / 64.0);
    EXPECT_GT(test::chi2Survival(chi2, 63), test::sidak(1e-3, 2)) << "count " << c.count << " point " << c.k;
  }

  // The mean of f(x, y) = x y + sin(3 x) over 16 points: variance over 4,000
  // seeds at most a quarter of the independent points' (it is about 1/40).
  auto f = [](Vec2 q) { return double(q.x) * q.y + std::sin(3.0 * q.x); };
  double s1 = 0, s2 = 0, i1 = 0, i2 = 0;
  const int seeds = 4000;
  for (int s = 0; s < seeds; ++s) {
    Rng rng(uint64_t(s), 5);
    multiJittered(16, rng, p.data());
    double mj = 0, ind = 0;
    for (int k = 0; k < 16; ++k) {
      mj += f(p[k]) / 16;
      ind += f({rng.uniform(), rng.uniform()}) / 16;
    }
    s1 += mj;
    s2 += mj * mj;
    i1 += ind;
    i2 += ind * ind;
  }
  const double varMj = s2 / seeds - (s1 / seeds) * (s1 / seeds), varInd = i2 / seeds - (i1 / seeds) * (i1 / seeds);
  // Both means near the integral, 1/4 + (1 - cos 3) / 3.
  const double exact = 0.25 + (1 - std::cos(3.0)) / 3;
  EXPECT_NEAR(s1 / seeds, exact, 5 * std::sqrt(varMj / seeds) + 1e-6);
  EXPECT_NEAR(i1 / seeds, exact, 5 * std::sqrt(varInd / seeds));
  EXPECT_LT(varMj, 0.25 * varInd);
  RecordProperty("varianceRatio", std::to_string(varMj / varInd));
}

// Rng::uniforms gives the numbers uniform() would, one call after the other,
// and leaves the generator where they would: both forms (four scalar chains,
// eight AVX2 lanes), every length to 200 (the chains' tails included), many
// seeds and streams; nothing is written past n.
TEST(Rng, UniformsEqualOneByOne) {
  constexpr int kMax = 200;
  for (int form = 0; form < 2; ++form) {
    if (form == 1 && !simdAvailable()) continue;
    for (int n = 0; n <= kMax; ++n)
      for (uint64_t seed = 0; seed < 6; ++seed) {
        Rng a(uint64_t(n) * 977 + seed * 31337 + 5, uint64_t(n) * 31 + seed + 1), b = a;
        float block[kMax + 1];
        block[n] = -1.0f;
        if (form == 0)
          a.uniformsScalar(block, n);
        else
          a.uniformsAvx2(block, n);
        for (int i = 0; i < n; ++i) ASSERT_EQ(block[i], b.uniform()) << "form " << form << " n " << n << " i " << i;
        ASSERT_EQ(block[n], -1.0f) << "form " << form << " n " << n;
        ASSERT_EQ(a.next(), b.next()) << "form " << form << " n " << n;
      }
  }
}

// sinCosTwoPi and sinCosQuarterPi against libm's double sin and cos: within
// float rounding over the whole turn (every quadrant and its edges).
TEST(Sampling, SinCosWithinFloatRounding) {
  double worst = 0;
  for (int i = 0; i <= 1 << 20; ++i) {
    const float u = float(i) / float(1 << 20);
    float s, c;
    sinCosTwoPi(u, s, c);
    const double phi = 2.0 * M_PI * double(u);
    worst = std::max({worst, std::abs(double(s) - std::sin(phi)), std::abs(double(c) - std::cos(phi))});
    const float t = 2.0f * u - 1.0f;
    sinCosQuarterPi(t, s, c);
    worst =
        std::max({worst, std::abs(double(s) - std::sin(M_PI / 4 * t)), std::abs(double(c) - std::cos(M_PI / 4 * t))});
  }
  EXPECT_LT(worst, 2.5e-7);  // a few float ulps of 1
  float s, c;
  sinCosTwoPi(0.25f, s, c);
  EXPECT_EQ(s, 1.0f);
  EXPECT_EQ(c, 0.0f);
}

namespace {
// sinCosTwoPi8 on the eight uniforms from k (k 2^-24, ... (k + 7) 2^-24).
VSL_AVX2 void sinCosTwoPiLanes(uint32_t k, float s[8], float c[8]) {
  const __m256i ks = _mm256_add_epi32(_mm256_set1_epi32(int32_t(k)), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  __m256 sv, cv;
  simd::sinCosTwoPi8(_mm256_mul_ps(_mm256_cvtepi32_ps(ks), _mm256_set1_ps(0x1p-24f)), sv, cv);
  _mm256_storeu_ps(s, sv);
  _mm256_storeu_ps(c, cv);
}
}  // namespace

// The AVX2 sin and cos give the scalar bits on every uniform Rng can return
// (k 2^-24 for k < 2^24), so the samplers' two forms agree.
TEST(Sampling, SinCosLanesEqualScalar) {
  if (!simdAvailable()) GTEST_SKIP() << "no AVX2";
  float s[8], c[8];
  for (uint32_t k = 0; k < (1u << 24); k += 8) {
    sinCosTwoPiLanes(k, s, c);
    for (int j = 0; j < 8; ++j) {
      float ws, wc;
      sinCosTwoPi(float(k + uint32_t(j)) * 0x1p-24f, ws, wc);
      ASSERT_EQ(std::memcmp(&s[j], &ws, 4), 0) << "k " << k + j;
      ASSERT_EQ(std::memcmp(&c[j], &wc, 4), 0) << "k " << k + j;
    }
  }
}
