// Bidirectional path tracing (core/bdpt.h): MIS weights that sum to one,
// each strategy alone unbiased, and agreement with the path tracer.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "core/bdpt.h"
#include "core/environment.h"
#include "core/pathtracer.h"
#include "core/reference.h"
#include "support.h"

using namespace vsl;
using vsl::test::addQuad;
using vsl::test::emitterMaterial;
using vsl::test::loadAsset;
using vsl::test::Loaded;
using vsl::test::loadedFrom;
using vsl::test::testMaterial;

namespace {

// ---- Per-pass statistics of image regions --------------------------------------------

// The grey mean of each block x block region of the direct and indirect
// layers, pass by pass: each pass is an independent estimate of the image
// (BDPT's light subpaths splat anywhere, so pixels of one pass are not
// independent; passes are), hence a standard error per region.
struct RegionStats {
  int bw = 0, bh = 0, passes = 0;
  std::vector<double> sum[2], sum2[2];
  double mean(int c, int b) const { return sum[c][b] / passes; }
  double se(int c, int b) const {
    const double m = mean(c, b);
    return std::sqrt(std::max(sum2[c][b] / passes - m * m, 0.0) / (passes - 1));
  }
};

template <class R>
RegionStats regionStats(const R& r, int passes, int block) {
  RegionStats st;
  st.bw = (r.width() + block - 1) / block;
  st.bh = (r.height() + block - 1) / block;
  st.passes = passes;
  const size_t nb = size_t(st.bw) * st.bh;
  for (int c = 0; c < 2; ++c) {
    st.sum[c].assign(nb, 0);
    st.sum2[c].assign(nb, 0);
  }
  PtCounters counters;
  std::vector<double> blockSum(nb), blockCount(nb);
  for (int p = 0; p < passes; ++p) {
    Film d(r.width(), r.height()), i(r.width(), r.height());
    EXPECT_TRUE(r.renderPass(p, d, i, counters));
    EXPECT_EQ(d.rejected() + i.rejected(), 0u);
    const Image layers[2] = {d.image(), i.image()};
    for (int c = 0; c < 2; ++c) {
      std::fill(blockSum.begin(), blockSum.end(), 0.0);
      std::fill(blockCount.begin(), blockCount.end(), 0.0);
      for (int y = 0; y < r.height(); ++y)
        for (int x = 0; x < r.width(); ++x) {
          const Vec3 v = layers[c].at(x, y);
          const size_t b = size_t(y / block) * st.bw + x / block;
          blockSum[b] += (double(v.x) + v.y + v.z) / 3;
          blockCount[b] += 1;
        }
      for (size_t b = 0; b < nb; ++b) {
        const double m = blockSum[b] / blockCount[b];
        st.sum[c][b] += m;
        st.sum2[c][b] += m * m;
      }
    }
  }
  EXPECT_EQ(counters.nonFinite.load(), 0u);
  return st;
}

// Regions (both layers) whose means differ by more than z standard errors.
int regionOutliers(const RegionStats& a, const RegionStats& b, double z, const std::string& what) {
  int bad = 0;
  for (int c = 0; c < 2; ++c)
    for (size_t k = 0; k < a.sum[c].size(); ++k) {
      const double d = a.mean(c, int(k)) - b.mean(c, int(k));
      const double se = std::hypot(a.se(c, int(k)), b.se(c, int(k)));
      if (std::abs(d) > z * se + 1e-7) {
        ++bad;
        std::printf("%s: %s region %zu: %.5g vs %.5g (z = %.2f)\n", what.c_str(), c ? "indirect" : "direct", k,
                    a.mean(c, int(k)), b.mean(c, int(k)), d / se);
      }
    }
  return bad;
}

// ---- Paths for the MIS tests -----------------------------------------------------------

// A glossy floor and wall lit by an area light and by a point, a spot and a
// directional light: every kind of endpoint the MIS weights handle.
std::shared_ptr<Scene> everyLightScene() {
  auto s = std::make_shared<Scene>();
  s->path = "<every-light>";
  Material anisotropic = testMaterial("brushed", Vec3(0.9f, 0.8f, 0.6f), 1, 0.3f);
  anisotropic.anisotropyStrength = 0.6f;
  s->materials = {testMaterial("floor", Vec3(0.6f), 0, 0.4f), anisotropic, emitterMaterial(Vec3(4.0f)), Material()};
  addQuad(*s, {-2, 0, 2}, {4, 0, 0}, {0, 0, -4}, 0);                 // floor, faces +y
  addQuad(*s, {-2, 0, -2}, {4, 0, 0}, {0, 3, 0}, 1);                 // back wall, faces +z
  addQuad(*s, {-0.3f, 2.5f, -0.3f}, {0.6f, 0, 0}, {0, 0, 0.6f}, 2);  // faces -y
  for (Vec3& t : s->tangents) t = Vec3(1, 0, 0);
  PunctualLight point, spot, sun;
  point.type = PunctualLight::Type::Point;
  point.position = Vec3(1, 1.5f, 0.5f);
  point.intensity = Vec3(2.0f);
  spot.type = PunctualLight::Type::Spot;
  spot.position = Vec3(-1, 2, 1);
  spot.direction = normalize(Vec3(0.3f, -1, -0.5f));
  spot.intensity = Vec3(5.0f);
  spot.cosInner = 0.95f;
  spot.cosOuter = 0.8f;
  sun.type = PunctualLight::Type::Directional;
  sun.direction = normalize(Vec3(0.2f, -1, -0.4f));
  sun.intensity = Vec3(0.5f);
  s->punctualLights = {point, spot, sun};
  s->camera.position = Vec3(0, 1.2f, 3.5f);
  s->camera.forward = normalize(Vec3(0, -0.25f, -1));
  s->camera.right = Vec3(1, 0, 0);
  s->camera.up = cross(s->camera.right, s->camera.forward);
  return s;
}

// The subpaths strategy k of the joined path x would have generated, their
// densities set as cameraSubpath/lightSubpath set them; the ones a
// connection must recompute are set to a poison value.
void splitPath(const BdptRenderer& r, const std::vector<BdptVertex>& x, int k, std::vector<BdptVertex>& L,
               std::vector<BdptVertex>& C) {
  const int n = int(x.size()), t = n - k;
  constexpr double kPoison = -123;
  L.assign(x.begin(), x.begin() + k);
  C.assign(x.rbegin(), x.rbegin() + t);
  for (int i = 0; i < k; ++i) {
    L[i].pdfFwd = i == 0 ? r.originDensity(x[0]) : r.density(x[i - 1], i >= 2 ? &x[i - 2] : nullptr, x[i]);
    L[i].pdfRev = i + 2 < k ? r.density(x[i + 1], &x[i + 2], x[i]) : kPoison;
  }
  for (int j = 0; j < t; ++j) {
    const int i = n - 1 - j;
    C[j].pdfFwd = j == 0 ? 1.0 : r.density(x[i + 1], j >= 2 ? &x[i + 2] : nullptr, x[i]);
    C[j].pdfRev = j + 2 < t ? r.density(x[i - 1], &x[i - 2], x[i]) : kPoison;
  }
}

// Checks the weights of every strategy of joined paths of real subpaths.
void checkMisWeights(const Loaded& l, MisHeuristic h, int& checked) {
  RenderSettings rs;
  rs.width = rs.height = 16;
  BdptRenderer r(*l.scene, *l.accel, *l.lights, rs, {.heuristic = h});
  std::vector<BdptVertex> cam(size_t(r.maxCameraVertices())), light(size_t(r.maxLightVertices()));
  std::vector<BdptVertex> x, L, C;
  uint64_t rays = 0;
  for (int k = 0; k < 250; ++k) {
    Rng rng = Rng::forItem(uint64_t(k), 1, 2, 3);
    const int nC = r.cameraSubpath(k % 16, (k / 16) % 16, rng, cam.data(), rays);
    const int nL = r.lightSubpath(rng, light.data(), rays);
    for (int s = 2; s <= nL; ++s)
      for (int t = 2; t <= nC; ++t) {
        // An escaped vertex (the environment) ends a path; it joins nothing.
        if (cam[size_t(t - 1)].infinite) continue;
        const int n = s + t;
        x.assign(light.begin(), light.begin() + s);
        for (int j = t - 1; j >= 0; --j) x.push_back(cam[size_t(j)]);
        // Fresh densities of every vertex from either side, and p_k.
        std::vector<double> pL(static_cast<size_t>(n)), pE(static_cast<size_t>(n)), p(static_cast<size_t>(n), 1.0);
        for (int i = 0; i < n; ++i) {
          pL[i] = i == 0 ? r.originDensity(x[0]) : r.density(x[i - 1], i >= 2 ? &x[i - 2] : nullptr, x[i]);
          pE[i] = i == n - 1 ? 1.0 : r.density(x[i + 1], i + 2 < n ? &x[i + 2] : nullptr, x[i]);
        }
        double norm = 0;
        for (int j = 0; j < n; ++j) {
          for (int i = 0; i < n; ++i) p[j] *= i < j ? pL[i] : pE[i];
          norm += h == MisHeuristic::Power ? p[j] * p[j] : p[j];
        }
        if (!(p[s] > 0) || !(norm > 0)) continue;
        double sum = 0;
        for (int j = 0; j < n; ++j) {
          if (!(p[j] > 0)) continue;
          splitPath(r, x, j, L, C);
          const double w = r.misWeight(L.data(), j, C.data(), n - j, j == 1 ? &L[0] : nullptr);
          const double expected = (h == MisHeuristic::Power ? p[j] * p[j] : p[j]) / norm;
          ASSERT_NEAR(w, expected, 1e-4 + 1e-3 * expected) << "strategy s=" << j << " of a path of " << n;
          sum += w;
        }
        ASSERT_NEAR(sum, 1.0, 1e-4) << "path of " << n << " vertices";
        // The densities the subpaths kept while they were generated give the
        // same weight as the fresh ones.
        const double fromWalk = r.misWeight(light.data(), s, cam.data(), t);
        splitPath(r, x, s, L, C);
        ASSERT_NEAR(fromWalk, r.misWeight(L.data(), s, C.data(), t), 1e-9 + 1e-6 * fromWalk);
        ++checked;
      }
  }
}

// everyLightScene under a sky and a sun (core/environment.h): the
// environment as a light at infinity in every strategy.
Loaded everyLightUnderTheSky() {
  EnvironmentSettings env;
  env.sky = Vec3(0.3f, 0.35f, 0.45f);
  env.sunDirection = Vec3(-0.5f, 1, 0.6f);
  env.sunDiameterDeg = 3;
  env.sunIrradiance = 2;
  return loadedFrom(RenderContext::create(std::shared_ptr<const Scene>(everyLightScene()), 0, env), 16);
}

}  // namespace

// Veach 1997, section 10.2: with p_k the density of strategy k, the weights
// p_s^b / sum_k p_k^b of a path's strategies sum to one. Checked against a
// direct evaluation of every p_k on joined random subpaths, for glossy and
// anisotropic vertices and every kind of light.
TEST(Bdpt, MisWeightsOfEveryStrategySumToOne) {
  Loaded every = loadedFrom(std::shared_ptr<const Scene>(everyLightScene()), 16);
  Loaded cornell = loadAsset("cornell-glossy", 16);
  Loaded sky = everyLightUnderTheSky();
  int checked = 0;
  for (MisHeuristic h : {MisHeuristic::Power, MisHeuristic::Balance}) {
    checkMisWeights(every, h, checked);
    checkMisWeights(cornell, h, checked);
    checkMisWeights(sky, h, checked);
  }
  std::printf("checked %d joined paths\n", checked);
  EXPECT_GT(checked, 150);
}

// The white furnace: a closed box emitting Le = 1 with Lambertian albedo
// a = 0.5 has radiance sum_k a^k Le, the paths of n vertices (n - 2
// scattering events) carrying a^(n-2). Each strategy (s, t) alone,
// unweighted, must estimate exactly its path length's share.
TEST(Bdpt, EachStrategyAloneIsUnbiasedInTheFurnace) {
  Loaded l = loadAsset("furnace", 8);
  const int passes = 48;
  for (int n = 2; n <= 5; ++n)
    for (int s = 0; s < n; ++s) {
      const int t = n - s;
      RenderSettings rs;
      rs.width = rs.height = 8;
      BdptRenderer r(*l.scene, *l.accel, *l.lights, rs, {.onlyS = s, .onlyT = t, .unweighted = true});
      RegionStats st = regionStats(r, passes, 8);
      const double expected = std::pow(0.5, n - 2);
      const int layer = n <= 3 ? 0 : 1;
      const double mean = st.mean(layer, 0), se = st.se(layer, 0);
      std::printf("(s, t) = (%d, %d): %.5f +- %.5f (expected %.5f)\n", s, t, mean, se, expected);
      EXPECT_NEAR(mean, expected, 4 * se + 1e-6) << "strategy (" << s << ", " << t << ")";
      EXPECT_NEAR(st.mean(1 - layer, 0), 0.0, 1e-9) << "the other layer";
    }
}

// The furnace with every strategy weighted: Le / (1 - a) = 2, of which
// 1.5 direct (emission and one bounce) and 0.5 indirect.
TEST(Bdpt, FurnaceMatchesAnalyticRadiance) {
  Loaded l = loadAsset("furnace", 12);
  RenderSettings rs;
  rs.width = rs.height = 12;
  rs.maxDepth = 200;  // truncation bias a^200: negligible
  BdptRenderer r(*l.scene, *l.accel, *l.lights, rs);
  RegionStats st = regionStats(r, 32, 12);
  std::printf("direct %.5f +- %.5f, indirect %.5f +- %.5f\n", st.mean(0, 0), st.se(0, 0), st.mean(1, 0), st.se(1, 0));
  EXPECT_NEAR(st.mean(0, 0), 1.5, 4 * st.se(0, 0) + 1e-4);
  EXPECT_NEAR(st.mean(1, 0), 0.5, 4 * st.se(1, 0) + 1e-4);
  EXPECT_NEAR(st.mean(0, 0) + st.mean(1, 0), 2.0, 0.01 * 2.0) << "within 1%";
}

// BDPT against the path tracer region by region (4x4-pixel regions, both
// layers, z-test at 4 standard errors; with 32 regions of a 16x16 image a
// Sidak-corrected 1% level needs 3.6): the regions that differ. bdOut, when
// given, receives BDPT's region statistics.
int bdptOutliersAgainstPathTracer(const Loaded& l, int width, int height, uint32_t seed, int ptPasses, int bdPasses,
                                  const std::string& what, RegionStats* bdOut = nullptr) {
  RenderSettings rs;
  rs.width = width;
  rs.height = height;
  rs.seed = seed;
  PathTracer pt(*l.scene, *l.accel, *l.lights, rs);
  BdptRenderer bd(*l.scene, *l.accel, *l.lights, rs);
  RegionStats a = regionStats(pt, ptPasses, 4), b = regionStats(bd, bdPasses, 4);
  const int outliers = regionOutliers(a, b, 4.0, what);
  if (bdOut) *bdOut = std::move(b);
  return outliers;
}

// BDPT against the path tracer on a glossy scene, region by region.
TEST(Bdpt, MatchesThePathTracerOnCornellGlossy) {
  Loaded l = loadAsset("cornell-glossy", 16);
  EXPECT_EQ(bdptOutliersAgainstPathTracer(l, 16, 16, 5, 256, 64, "cornell-glossy"), 0);
}

// Area, point, spot and directional lights on glossy and anisotropic
// surfaces, against the path tracer as above.
TEST(Bdpt, MatchesThePathTracerWithEveryLightType) {
  Loaded l = loadedFrom(std::shared_ptr<const Scene>(everyLightScene()), 16);
  RegionStats b;
  EXPECT_EQ(bdptOutliersAgainstPathTracer(l, 16, 16, 3, 256, 64, "every light", &b), 0);
  // Not vacuous: every light reaches the image, directly and after a bounce.
  for (int c = 0; c < 2; ++c) {
    double sum = 0, se2 = 0;
    for (size_t k = 0; k < b.sum[c].size(); ++k) {
      sum += b.mean(c, int(k));
      se2 += sqr(b.se(c, int(k)));
    }
    EXPECT_GT(sum, 10 * std::sqrt(se2)) << (c ? "indirect" : "direct");
  }
}

// The environment (a sky and a sun) beside every other light, against the
// path tracer as above: escaped camera paths (s = 0), the sky sampled from
// a surface (s = 1) and light subpaths entering from the bounding disk.
TEST(Bdpt, MatchesThePathTracerUnderAnEnvironment) {
  Loaded l = everyLightUnderTheSky();
  ASSERT_TRUE(l.scene);
  ASSERT_NE(l.lights->environment(), nullptr);
  RegionStats b;
  EXPECT_EQ(bdptOutliersAgainstPathTracer(l, 16, 16, 9, 256, 64, "under the sky", &b), 0);
  // The sky seen directly: the camera looks past the wall's top edge.
  double direct = 0;
  for (size_t k = 0; k < b.sum[0].size(); ++k) direct += b.mean(0, int(k));
  EXPECT_GT(direct, 0);
}

// The bundled scenes, small (16 px wide, 1,024 path-traced and 256
// BDPT passes). Not spot-panel: there the path tracer's estimate rests on
// rare paths, and its per-pass spread understates its error (its indirect
// regions differ from BDPT's by 20-50 of its standard errors; docs/RESULTS.md,
// "Bidirectional path tracing as the reference", checks it at equal means
// with a long path-traced run).
TEST(Bdpt, MatchesThePathTracerOnBundledScenes) {
  for (const char* name : {"furnace", "cornell-glossy", "tableau", "kitchen", "hall", "waterbottle"}) {
    Loaded l = loadAsset(name, 16);
    if (!l.scene) continue;
    EXPECT_EQ(bdptOutliersAgainstPathTracer(l, l.width, l.height, 9, 1024, 256, name), 0) << name;
  }
}

// Light-traced splats are summed per tile in tile order: the image does not
// depend on the number of threads.
TEST(Bdpt, SameSeedSameImageRegardlessOfThreads) {
  Loaded l = loadAsset("cornell-glossy", 24);
  RenderSettings rs;
  rs.width = rs.height = 24;
  auto render = [&](int threads) {
    setThreadCount(threads);
    BdptRenderer bd(*l.scene, *l.accel, *l.lights, rs);
    Film d(24, 24), i(24, 24);
    PtCounters c;
    for (int p = 0; p < 2; ++p) EXPECT_TRUE(bd.renderPass(p, d, i, c));
    std::vector<float> out = d.image().rgb, ind = i.image().rgb;
    out.insert(out.end(), ind.begin(), ind.end());
    return out;
  };
  const std::vector<float> one = render(1), four = render(4);
  setThreadCount(0);
  EXPECT_EQ(one, four);
}

// The reference cache keeps the methods apart (core/reference.h): a BDPT
// reference's key is the path tracer's with "-bdpt", its file says
// vsl.method = bdpt, it is accepted for its scene, and a lookup for either
// method takes whichever cached entry has the lower own noise.
TEST(Bdpt, ReferenceCacheRecordsTheMethod) {
  Loaded l = loadAsset("cornell-glossy", 8);
  const Scene& scene = *l.scene;
  const std::string pt = referenceKey(scene, 8, 8, 64), bd = referenceKey(scene, 8, 8, 64, {}, ReferenceMethod::Bdpt);
  EXPECT_EQ(bd, pt + "-bdpt");
  RenderSettings rs;
  rs.width = rs.height = 8;
  auto render = [&](ReferenceMethod m, int steps) {
    ReferenceRenderer rr(scene, *l.accel, *l.lights, rs, m);
    EXPECT_EQ(rr.method(), m);
    for (int i = 0; i < steps; ++i) EXPECT_TRUE(rr.step());
    Reference r = rr.result();
    r.key = referenceKey(scene, 8, 8, 64, {}, m);
    return r;
  };
  const Reference a = render(ReferenceMethod::Bdpt, 8), b = render(ReferenceMethod::PathTracer, 1);
  EXPECT_EQ(a.method, "bdpt");
  EXPECT_EQ(b.method, "pt");
  EXPECT_TRUE(checkReferenceScene(a, scene, "a.exr"));
  ASSERT_GT(b.indirectNoise(), a.indirectNoise()) << "16 BDPT passes against 2 path-traced ones";

  const std::filesystem::path dir = vsl::test::scratchDir("vsl_bdpt_cache");
  setenv("VSL_REFERENCE_CACHE", dir.c_str(), 1);
  setenv("VSL_SHIPPED_REFERENCES", "", 1);
  ASSERT_TRUE(storeCachedReference(b, scene.path));
  std::unique_ptr<Reference> found = findCachedReferenceAnyMethod(scene, 8, 8, 64, {}, ReferenceMethod::Bdpt);
  ASSERT_TRUE(found) << "the path tracer's entry serves a BDPT lookup when it is the only one";
  EXPECT_EQ(found->method, "pt");
  ASSERT_TRUE(storeCachedReference(a, scene.path));
  Result<Reference> read = readReference(referenceCachePath(bd), 8, 8);
  ASSERT_TRUE(read) << read.error();
  EXPECT_EQ(read->method, "bdpt");
  found = findCachedReferenceAnyMethod(scene, 8, 8, 64, {}, ReferenceMethod::PathTracer);
  ASSERT_TRUE(found);
  EXPECT_EQ(found->key, bd) << "the lower-noise entry wins";
  unsetenv("VSL_REFERENCE_CACHE");
  unsetenv("VSL_SHIPPED_REFERENCES");
}
