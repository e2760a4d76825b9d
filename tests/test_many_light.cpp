// Many-light rendering: light tracing, radii, the VSL cone integral, and the
// VSL/VPL gathers against analytic values, the path-traced reference and
// each other.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>

#include "chi2.h"
#include "core/gather.h"
#include "core/lobe_gather.h"
#include "core/many_light.h"
#include "core/mrcs.h"
#include "core/parallel.h"
#include "core/pathtracer.h"
#include "core/point_tree.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/vsl_integral.h"
#include "support.h"

using namespace vsl;
using namespace vsl::test;

namespace {

ManyLightImages renderMany(const Loaded& l, const ManyLightSettings& s, ManyLightRun* runOut = nullptr) {
  ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
  ManyLightRenderer r(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
  for (int b = 0; b < r.batchCount(); ++b) EXPECT_TRUE(r.renderBatch(b));
  EXPECT_EQ(r.stats().nonFinite.load(), 0u);
  ManyLightImages im = r.images();
  if (runOut) *runOut = std::move(run);
  return im;
}

bool allFinite(const Image& img) {
  for (float v : img.rgb)
    if (!std::isfinite(v)) return false;
  return true;
}

double greyMean(const Image& img) { return channelMean(img); }

// The mean of independent estimates and its standard error (from their
// sample variance).
std::pair<double, double> meanAndError(const std::vector<double>& x) {
  double m = 0, v = 0;
  for (double e : x) m += e / double(x.size());
  for (double e : x) v += (e - m) * (e - m) / double(x.size() - 1);
  return {m, std::sqrt(v / double(x.size()))};
}

// One eye sample per pixel of l's image, in pixel order (pixel i's stream
// seeded by i), as the gather tests share them.
std::vector<EyeSample> eyeSamples(const Loaded& l, const Gatherer& g) {
  GatherCounters c;
  std::vector<EyeSample> eyes;
  for (int y = 0; y < l.height; ++y)
    for (int x = 0; x < l.width; ++x) {
      Rng rng = Rng::forItem(uint64_t(y * l.width + x), 0, 2, 1);
      eyes.push_back(g.eyePath(x, y, l.width, l.height, rng, c));
    }
  return eyes;
}

// Every step-th light of the run against the gather points of each index k:
// perPoints(pts) once per k (returns the receivers packed for it, or an
// empty vector), then perLight(pts, packed, j, L, geo, list, c) with the
// batched connection's geometry and the points that see light j.
template <class PerPoints, class PerLight>
void forEachLightAndVisiblePoints(const Gatherer& g, const ManyLightRun& run, const std::vector<EyeSample>& eyes,
                                  size_t step, PerPoints&& perPoints, PerLight&& perLight) {
  Gatherer::ConnectScratch scratch;
  for (int k = 0; k < kMaxGatherPoints; ++k) {
    std::vector<const GatherPoint*> pts;
    for (const EyeSample& es : eyes) pts.push_back(es.point(k));
    const std::vector<float> packed = perPoints(pts);
    for (size_t j = 0; j < run.set.lights.size(); j += step) {
      const GatherLight L = decodeGatherLight(run.set.lights[j], run.radii[j]);
      std::vector<PairGeometry> geo(pts.size());
      std::vector<uint8_t> visible(pts.size());
      GatherCounters c;
      g.connectMany(pts, L, geo.data(), visible.data(), scratch, c);
      std::vector<uint32_t> list;
      for (size_t i = 0; i < pts.size(); ++i)
        if (visible[i]) list.push_back(uint32_t(i));
      perLight(pts, packed, j, L, geo, list, c);
    }
  }
}

// A small VPL-only render of one light set in one batch.
ManyLightSettings vplOnly(int width, int height, uint32_t lights, uint64_t seed) {
  ManyLightSettings s;
  s.lights = lights;
  s.width = width;
  s.height = height;
  s.batches = 1;
  s.seed = seed;
  s.computeVsl = false;
  return s;
}

}  // namespace

// ---- Encoding and light tracing ------------------------------------------------------

TEST(VirtualLights, UnitVectorEncodingIsAccurate) {
  Rng rng(1, 1);
  for (int i = 0; i < 100000; ++i) {
    Vec3 v = sampleUniformSphere({rng.uniform(), rng.uniform()});
    Vec3 d = decodeUnit(encodeUnit(v));
    ASSERT_NEAR(length(d), 1.0f, 1e-5f);
    ASSERT_LT(length(v - d), 1e-4f) << v.x << " " << v.y << " " << v.z;
  }
  for (Vec3 v : {Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(1, 0, 0), Vec3(0, -1, 0)})
    EXPECT_GT(dot(decodeUnit(encodeUnit(v)), v), 0.99999f);
}

// In the closed furnace every light path hits a wall, and every path starts
// with the same throughput (the total emitted power), so the first-bounce
// virtual lights carry exactly the emitted power.
TEST(VirtualLights, FirstBounceFluxEqualsEmittedPowerInAClosedScene) {
  Loaded l = loadAsset("furnace");
  LightTracingSettings s;
  s.count = 20000;
  s.seed = 5;
  VirtualLightSet set = traceVirtualLights(*l.scene, *l.accel, *l.lights, s);
  ASSERT_GE(set.lights.size(), s.count);
  double flux = 0;
  uint64_t firstBounce = 0;
  for (const VirtualLight& v : set.lights)
    if (v.depth == 1) flux += luminance(v.Phi), ++firstBounce;
  EXPECT_EQ(firstBounce, set.paths);
  EXPECT_NEAR(flux, l.lights->totalPower(), 1e-4 * l.lights->totalPower());
  // Albedo 0.5: each bounce keeps half the flux on average (Russian roulette
  // adds noise, not bias): depth-2 flux is about half the depth-1 flux.
  double flux2 = 0;
  for (const VirtualLight& v : set.lights)
    if (v.depth == 2) flux2 += luminance(v.Phi);
  EXPECT_NEAR(flux2 / flux, 0.5, 0.03);
  EXPECT_EQ(set.nonFiniteRejected, 0u);
  EXPECT_EQ(sizeof(VirtualLight), 64u);
}

TEST(VirtualLights, DeterministicAcrossThreadCounts) {
  Loaded l = loadAsset("cornell-glossy");
  LightTracingSettings s;
  s.count = 5000;
  s.seed = 11;
  setThreadCount(1);
  VirtualLightSet a = traceVirtualLights(*l.scene, *l.accel, *l.lights, s);
  setThreadCount(2);
  VirtualLightSet b = traceVirtualLights(*l.scene, *l.accel, *l.lights, s);
  setThreadCount(0);
  ASSERT_EQ(a.lights.size(), b.lights.size());
  EXPECT_EQ(a.paths, b.paths);
  EXPECT_EQ(0, std::memcmp(a.lights.data(), b.lights.data(), a.bytes()));
  s.seed = 12;
  VirtualLightSet c = traceVirtualLights(*l.scene, *l.accel, *l.lights, s);
  EXPECT_NE(c.lights[0].p.x, a.lights[0].p.x);
}

TEST(VirtualLights, KnnRadiiMatchBruteForce) {
  Rng rng(3, 3);
  std::vector<VirtualLight> lights(500);
  for (auto& v : lights) v.p = Vec3(rng.uniform(), rng.uniform(), rng.uniform() * 0.1f);
  for (int k : {1, 3, 10}) {
    std::vector<float> r = knnRadii(lights, k, 2.0f, 1.0f, 1e-9f);
    for (size_t i = 0; i < lights.size(); i += 7) {
      std::vector<float> d;
      for (size_t j = 0; j < lights.size(); ++j)
        if (j != i) d.push_back(length(lights[j].p - lights[i].p));
      std::nth_element(d.begin(), d.begin() + (k - 1), d.end());
      EXPECT_NEAR(r[i], 2.0f * d[k - 1], 1e-5f) << "k " << k << " light " << i;
    }
  }
  // Degenerate sets: one light gets scale x fallback; coincident lights the minimum.
  std::vector<VirtualLight> one(1);
  EXPECT_FLOAT_EQ(knnRadii(one, 10, 0.5f, 3.0f, 1e-9f)[0], 1.5f);
  std::vector<VirtualLight> same(4);
  for (float r : knnRadii(same, 2, 1.0f, 1.0f, 1e-6f)) EXPECT_FLOAT_EQ(r, 1e-6f);
}

// kthNearestSquared (the k-NN radii's search) gives the k-d tree's values
// exactly, on clusters of very different densities, coincident points and
// far outliers, for k from 1 to past a leaf.
TEST(VirtualLights, KthNearestEqualsTheTrees) {
  Rng rng(17, 4);
  std::vector<VirtualLight> pts(30000);
  for (size_t i = 0; i < pts.size(); ++i) {
    const float spread = i % 3 == 0 ? 1e-4f : i % 3 == 1 ? 0.05f : 2.0f;
    const Vec3 centre(float(i % 7), float(i % 5) * 0.5f, 0.0f);
    pts[i].p = centre + spread * Vec3(rng.uniform(), rng.uniform(), rng.uniform() * 0.01f);
  }
  for (size_t i = 0; i < 200; ++i) pts[i].p = pts[i + 200].p;                        // coincident pairs
  for (size_t i = 400; i < 410; ++i) pts[i].p = Vec3(1e4f * float(i), -3e3f, 7.0f);  // far outliers
  const MortonSorted m = mortonSorted(packedPositions(pts));
  const PointTree tree(m.xyz);
  for (size_t want : {size_t(1), size_t(2), size_t(11), size_t(40), size_t(100)}) {
    const std::vector<float> d2 = kthNearestSquared(m, want);
    std::vector<uint32_t> idx(want);
    std::vector<float> ref(want);
    size_t differ = 0;
    for (size_t o = 0; o < pts.size(); ++o) {
      const float* q = tree.point(o);
      const size_t found = tree.nearest(Vec3(q[0], q[1], q[2]), want, idx.data(), ref.data());
      differ += d2[o] != ref[found - 1];
    }
    EXPECT_EQ(differ, 0u) << "want " << want;
  }
  // The work per point stays small where one far light makes the Morton
  // grid coarse and a dense cluster shares one code: 100,000 points in a
  // unit cube and one 1,000 away (an index-order split of the shared cell
  // computed about 100,000 distances per point; 0.1 s became 9 s).
  std::vector<float> cluster;
  for (int i = 0; i < 100000; ++i) cluster.insert(cluster.end(), {rng.uniform(), rng.uniform(), rng.uniform()});
  cluster.insert(cluster.end(), {1000, 1000, 1000});
  uint64_t distances = 0;
  const MortonSorted mc = mortonSorted(cluster);
  const std::vector<float> dc = kthNearestSquared(mc, 11, nullptr, &distances);
  EXPECT_LT(double(distances) / 100001, 500.0);
  const PointTree ct(mc.xyz);
  std::vector<uint32_t> cidx(11);
  std::vector<float> cd2(11);
  size_t cdiffer = 0;
  for (size_t o = 0; o < mc.order.size(); o += 97) {
    const float* q = ct.point(o);
    cdiffer += dc[o] != cd2[ct.nearest(Vec3(q[0], q[1], q[2]), 11, cidx.data(), cd2.data()) - 1];
  }
  EXPECT_EQ(cdiffer, 0u);
  // Fewer points than asked: the farthest.
  const MortonSorted three = mortonSorted({0, 0, 0, 1, 0, 0, 3, 0, 0});
  EXPECT_EQ(kthNearestSquared(three, 10), (std::vector<float>{9, 4, 9}));
}

TEST(VirtualLights, PointTreeFindsTheNearestInOrder) {
  Rng rng(5, 1);
  std::vector<VirtualLight> pts(300);
  for (auto& v : pts) v.p = Vec3(rng.uniform(), rng.uniform() * 0.2f, rng.uniform());
  const PointTree tree(packedPositions(pts));
  ASSERT_EQ(tree.size(), pts.size());
  for (int q = 0; q < 40; ++q) {
    const Vec3 at(rng.uniform(), rng.uniform(), rng.uniform());
    std::vector<std::pair<float, uint32_t>> all;
    for (size_t j = 0; j < pts.size(); ++j) all.push_back({lengthSquared(pts[j].p - at), uint32_t(j)});
    std::sort(all.begin(), all.end());
    for (size_t k : {size_t(1), size_t(7), size_t(32)}) {
      std::vector<uint32_t> idx(k);
      std::vector<float> d2(k);
      ASSERT_EQ(tree.nearest(at, k, idx.data(), d2.data()), k);
      for (size_t i = 0; i < k; ++i) {
        EXPECT_EQ(idx[i], all[i].second) << "query " << q << " k " << k << " rank " << i;
        EXPECT_NEAR(d2[i], all[i].first, 1e-6f);
      }
    }
  }
  // More wanted than there are: all of them; none in an empty tree.
  std::vector<uint32_t> idx(400);
  std::vector<float> d2(400);
  EXPECT_EQ(tree.nearest(Vec3(0.5f), 400, idx.data(), d2.data()), pts.size());
  // Morton order: a permutation, and the eight corners of a cube in x-fastest order.
  std::vector<uint32_t> order = mortonOrder(packedPositions(pts));
  std::sort(order.begin(), order.end());
  for (size_t i = 0; i < order.size(); ++i) ASSERT_EQ(order[i], i);
  std::vector<float> corners;
  for (int c = 7; c >= 0; --c) corners.insert(corners.end(), {float(c & 1), float((c >> 1) & 1), float(c >> 2)});
  EXPECT_EQ(mortonOrder(corners), (std::vector<uint32_t>{7, 6, 5, 4, 3, 2, 1, 0}));
  const PointTree empty(std::vector<float>{});
  EXPECT_EQ(empty.size(), 0u);
  EXPECT_EQ(empty.nearest(Vec3(0.0f), 3, idx.data(), d2.data()), 0u);
}

// ---- The VSL cone integral ---------------------------------------------------------

namespace {
VslReceiver receiver(const Brdf& b, const Vec3& n, const Vec3& wo) {
  VslReceiver x;
  x.frame = Frame(n, Vec3(1, 0, 0));
  x.ng = n;
  x.f = BrdfAt(b, x.frame.toLocal(wo));
  return x;
}
VslEmitter emitter(const Brdf& b, const Vec3& n, const Vec3& wi) {
  VslEmitter p;
  p.frame = Frame(n, Vec3(0, 1, 0));
  p.f = BrdfAt(b, p.frame.toLocal(wi));
  return p;
}
// Dense uniform-cone quadrature of the VSL integrand (the reference).
Vec3 coneReference(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double r, int n) {
  double d = length(toLight);
  double omc = vslConeOneMinusCos(r, d);
  Frame f(toLight / float(d));
  double s[3] = {0, 0, 0};
  int m = int(std::sqrt(double(n)));
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) {
      Vec3 l = f.toWorld(sampleUniformConeOmc({(i + 0.5f) / m, (j + 0.5f) / m}, float(omc)));
      Vec3 lx = x.frame.toLocal(l), lp = p.frame.toLocal(-l);
      if (lx.z <= 0 || lp.z <= 0 || dot(l, x.ng) <= 0) continue;
      Vec3 v = x.f.eval(lx) * p.f.eval(lp) * (lx.z * lp.z);
      for (int c = 0; c < 3; ++c) s[c] += v[c];
    }
  double scale = 2 * M_PI * omc / (double(m) * m) / (M_PI * r * r);
  return Vec3(float(s[0] * scale), float(s[1] * scale), float(s[2] * scale));
}

// The mean of `runs` independent vslTransfer estimates (green channel) and its
// standard error, for z-tests against coneReference.
std::pair<double, double> meanOfRuns(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double r,
                                     const VslOptions& options, int runs) {
  double s = 0, s2 = 0;
  for (int i = 0; i < runs; ++i) {
    Rng g(i, 9);
    double v = vslTransfer(x, p, toLight, r, options, g).transfer.y;
    s += v;
    s2 += v * v;
  }
  const double mean = s / runs;
  return {mean, std::sqrt(std::max(s2 / runs - mean * mean, 0.0) / runs)};
}

}  // namespace

TEST(VslIntegral, ConeSolidAngleIsPreciseForTinyCones) {
  EXPECT_DOUBLE_EQ(vslConeOneMinusCos(2, 1), 1.0);
  EXPECT_DOUBLE_EQ(vslConeOneMinusCos(1, 1), 1.0);
  EXPECT_NEAR(vslConeOneMinusCos(1e-6, 1), 0.5e-12, 1e-24);
  EXPECT_NEAR(vslConeOneMinusCos(0.5, 1), 1 - std::sqrt(0.75), 1e-15);
  EXPECT_EQ(vslAutoSamples(1e-9), 1);
  // The authors' rule, 1 + floor(100 theta / (pi/2)): 6 at 5 degrees, 17 at
  // 15, 101 for a hemisphere (x inside the sphere).
  auto omc = [](double deg) { return 1 - std::cos(deg * M_PI / 180); };
  EXPECT_EQ(vslAutoSamples(omc(5)), 6);
  EXPECT_EQ(vslAutoSamples(omc(15)), 17);
  EXPECT_EQ(vslAutoSamples(omc(45)), 51);
  EXPECT_EQ(vslAutoSamples(1.0), 101);
  EXPECT_EQ(vslAutoSamples(vslConeOneMinusCos(std::sin(10 * M_PI / 180), 1)), 12);
  // The one-sample shortcut below 0.9 degrees agrees with the rule on both
  // sides of its bound.
  for (double deg = 0.85; deg < 0.95; deg += 0.0001) {
    const double theta = 2.0 * std::asin(std::sqrt(0.5 * omc(deg)));
    EXPECT_EQ(vslAutoSamples(omc(deg)), 1 + int(std::floor(100.0 * theta / (0.5 * M_PI) + 1e-9))) << deg;
  }
  EXPECT_EQ(vslAutoSamples(omc(0.89)), 1);
  EXPECT_EQ(vslAutoSamples(omc(0.91)), 2);
  // The ends: 1 - cos at most 2 (201 samples, a cone of the whole sphere), and
  // 1 for a NaN cone (int(NaN) is undefined).
  EXPECT_EQ(vslAutoSamples(2.0), 201);
  EXPECT_EQ(vslAutoSamples(1e300), 201);
  EXPECT_EQ(vslAutoSamples(-1.0), 1);
  EXPECT_EQ(vslAutoSamples(std::nan("")), 1);
}

// The clipped disk's area: pi r^2 when the receiver's tangent plane misses the
// disk, half of it when the plane passes through p, against a dense count of
// grid points of the disk on the kept side; and in the r -> 0 limit (h fixed)
// the VSL with the clipped disk tends to the unclipped one.
TEST(VslIntegral, ClippedDiskAreaMatchesDenseQuadrature) {
  EXPECT_DOUBLE_EQ(vslClippedDiskArea(2, 3), M_PI * 4);
  EXPECT_DOUBLE_EQ(vslClippedDiskArea(2, -3), 0);
  EXPECT_NEAR(vslClippedDiskArea(2, 0), M_PI * 2, 1e-12);
  for (double t : {-0.9, -0.5, -0.1, 0.2, 0.6, 0.95}) {
    const int n = 2000;
    const double r = 1.5, h = t * r;
    long inside = 0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        double x = (i + 0.5) / n * 2 - 1, y = (j + 0.5) / n * 2 - 1;  // in units of r
        // The plane's line is y = -h/r: the kept side holds the centre when h > 0.
        if (x * x + y * y <= 1 && y >= -t) ++inside;
      }
    double dense = 4 * r * r * double(inside) / (double(n) * n);
    EXPECT_NEAR(vslClippedDiskArea(r, h), dense, 2e-3 * r * r) << "h/r " << t;
  }
  Brdf b = Brdf::fromGltf(Vec3(0.8f), 0.0f, 0.5f, 0.5f);
  VslReceiver x = receiver(b, Vec3(0, 0, 1), normalize(Vec3(0.2f, 0, 1)));
  VslEmitter p = emitter(b, Vec3(0, 0, -1), normalize(Vec3(0.1f, 0, -1)));
  Vec3 toLight(0.1f, 0.0f, 0.05f);  // p 0.05 above x's tangent plane
  for (double r : {1e-3, 1e-5}) {
    Rng g1(1, 1), g2(1, 1);
    Vec3 plain = vslTransfer(x, p, toLight, r, {4, false}, g1).transfer;
    Vec3 clipped = vslTransfer(x, p, toLight, r, {4, true}, g2).transfer;
    EXPECT_NEAR(clipped.y, plain.y, 1e-6 * plain.y) << "r " << r;
  }
  // Close to the plane, the clipped disk is smaller and the VSL brighter.
  Rng g1(2, 2), g2(2, 2);
  Vec3 plain = vslTransfer(x, p, toLight, 0.1, {4, false}, g1).transfer;
  Vec3 clipped = vslTransfer(x, p, toLight, 0.1, {4, true}, g2).transfer;
  EXPECT_NEAR(clipped.y / plain.y, M_PI * 0.01 / vslClippedDiskArea(0.1, 0.05), 1e-4);
}

// As r -> 0 the VSL transfer tends to the unclamped VPL transfer.
TEST(VslIntegral, TendsToVplAsRadiusVanishes) {
  Rng rng(7, 7);
  for (int trial = 0; trial < 200; ++trial) {
    float rough = trial % 2 ? 0.5f : 0.2f;
    Brdf bx = Brdf::fromGltf(Vec3(0.8f, 0.6f, 0.4f), trial % 3 == 0 ? 1.0f : 0.0f, rough, 0.3f);
    Brdf bp = Brdf::fromGltf(Vec3(0.7f), trial % 4 == 0 ? 1.0f : 0.0f, 0.6f, 0);
    Vec3 nx(0, 0, 1);
    Vec3 wo = normalize(Vec3(rng.uniform() - 0.5f, rng.uniform() - 0.5f, 0.3f + rng.uniform()));
    Vec3 toLight = Vec3(rng.uniform() * 2 - 1, rng.uniform() * 2 - 1, 0.2f + rng.uniform());
    float d = length(toLight);
    Vec3 l = toLight / d;
    Vec3 np = normalize(-l + Vec3(rng.uniform() - 0.5f, rng.uniform() - 0.5f, rng.uniform() - 0.5f) * 0.8f);
    Vec3 wip = normalize(np + Vec3(rng.uniform() - 0.5f, rng.uniform() - 0.5f, 0) * 0.5f);
    VslReceiver x = receiver(bx, nx, wo);
    VslEmitter p = emitter(bp, np, wip);
    Vec3 lp = p.frame.toLocal(-l), lx = x.frame.toLocal(l);
    Vec3 vpl(0.0f);
    if (lx.z > 0 && lp.z > 0) vpl = bx.eval(x.f.w(), lx) * bp.eval(p.f.w(), lp) * (lx.z * lp.z / (d * d));
    for (double r : {1e-4 * d, 1e-7 * d}) {
      Rng g(trial, 1);
      VslResult v = vslTransfer(x, p, toLight, r, {}, g);
      for (int c = 0; c < 3; ++c)
        ASSERT_NEAR(v.transfer[c], vpl[c], 2e-3f * vpl[c] + 1e-7f) << "trial " << trial << " r " << r;
      // Auto: one sample for a tiny cone, and rough lobes cannot put samples
      // into it, so the cone strategy alone is used.
      ASSERT_EQ(v.evaluations, 1);
    }
  }
}

// BRDF strategies are dropped exactly when their samples could not land in the
// cone, and kept for lobes narrower than the cone (near-mirror surfaces).
TEST(VslIntegral, StrategySelectionKeepsNarrowLobes) {
  Vec3 toLight(0, 0, 1);
  Vec3 wo = normalize(Vec3(0.1f, 0, 1));
  auto evaluations = [&](float roughX, float roughP, double r) {
    VslReceiver x = receiver(Brdf::fromGltf(Vec3(0.9f), 1.0f, roughX, 0), Vec3(0, 0, 1), wo);
    // The light faces down at x, lit from just off its normal.
    VslEmitter p = emitter(Brdf::fromGltf(Vec3(0.9f), 1.0f, roughP, 0), Vec3(0, 0, -1), normalize(Vec3(0.05f, 0, -1)));
    Rng g(3, 3);
    return vslTransfer(x, p, toLight, r, {1}, g).evaluations;
  };
  EXPECT_EQ(evaluations(0.5f, 0.5f, 1e-3), 1);   // rough lobes, tiny cone: cone only
  EXPECT_EQ(evaluations(0.02f, 0.5f, 1e-3), 2);  // near-mirror receiver keeps its strategy
  EXPECT_EQ(evaluations(0.5f, 0.02f, 1e-3), 2);  // near-mirror light keeps its strategy
  EXPECT_EQ(evaluations(0.5f, 0.5f, 0.5), 3);    // wide cone: all three
  // The bound behind the choice is a bound: no direction exceeds it.
  Rng rng(5, 5);
  for (float rough : {0.02f, 0.2f, 0.7f})
    for (float metallic : {0.0f, 1.0f}) {
      BrdfAt b(Brdf::fromGltf(Vec3(0.7f), metallic, rough, 0.5f), normalize(Vec3(0.5f, 0.2f, 0.4f)));
      for (int i = 0; i < 20000; ++i) {
        Vec3 wi = sampleUniformSphere({rng.uniform(), rng.uniform()});
        ASSERT_LE(b.pdf(wi), b.pdfBound() * 1.0001f) << "rough " << rough << " metallic " << metallic;
      }
    }
}

// The MIS estimate is unbiased: its average over many runs matches a dense
// quadrature of the same integral, for wide and narrow cones and glossy lobes.
TEST(VslIntegralStats, MatchesDenseQuadrature) {
  struct Case {
    float roughX, roughP, r;
  };
  // Lobes down to roughness 0.25 (alpha 0.06): narrower lobes need more than
  // the dense grid's 2000 x 2000 points to be a trustworthy reference.
  for (Case c : {Case{0.3f, 0.3f, 0.2f}, Case{0.25f, 0.8f, 0.5f}, Case{0.8f, 0.25f, 0.3f}, Case{0.5f, 0.5f, 1.5f},
                 // Narrow cones: rough lobes drop their strategies (one of them, or both).
                 Case{0.25f, 0.9f, 0.05f}, Case{0.4f, 0.5f, 0.02f}}) {
    Brdf bx = Brdf::fromGltf(Vec3(0.9f), 1.0f, c.roughX, 0);
    Brdf bp = Brdf::fromGltf(Vec3(0.9f), 1.0f, c.roughP, 0);
    Vec3 toLight(0.3f, 0.1f, 1.0f);
    Vec3 l = normalize(toLight);
    Vec3 wo = reflect(l, Vec3(0, 0, 1));  // the receiver looks at its mirror direction
    Vec3 np = normalize(Vec3(0.2f, 0.0f, -1.0f));
    Vec3 wip = reflect(-l, np);  // the light reflects toward x
    VslReceiver x = receiver(bx, Vec3(0, 0, 1), wo);
    VslEmitter p = emitter(bp, np, wip);
    Vec3 ref = coneReference(x, p, toLight, c.r, 4000000);
    const int runs = 20000;
    double s = 0, s2 = 0;
    for (int i = 0; i < runs; ++i) {
      Rng g(i, 5);
      double v = vslTransfer(x, p, toLight, c.r, {2}, g).transfer.y;
      s += v;
      s2 += v * v;
    }
    double mean = s / runs, se = std::sqrt(std::max(s2 / runs - mean * mean, 0.0) / runs);
    std::printf("VSL cone integral (rx %.2f, rp %.2f, r %.2f): MIS %.6g +- %.2g, quadrature %.6g\n", c.roughX, c.roughP,
                c.r, mean, se, ref.y);
    EXPECT_NEAR(mean, ref.y, 4 * se + 2e-3 * ref.y) << "rx " << c.roughX << " rp " << c.roughP << " r " << c.r;
  }
}

// vslIntegrand is the quadrature's integrand: over directions drawn from
// the receiver's BRDF (as stochastic lightcuts' lobe strategy draws them,
// core/estimators/slc/slc.cpp), its mean over the pdf matches the dense
// quadrature of the cone integral (z of 4 plus 0.2%), with the plain and
// the clipped disk's area; it is zero outside the cone and below the
// receiver.
TEST(VslIntegralStats, IntegrandOverReceiverSamplesIsTheTransfer) {
  struct Case {
    float roughX, roughP, r;
    bool clipped;
  };
  for (Case c : {Case{0.3f, 0.3f, 0.2f, false}, Case{0.25f, 0.8f, 0.5f, false}, Case{0.8f, 0.25f, 0.3f, true},
                 Case{0.5f, 0.5f, 1.5f, false}, Case{0.25f, 0.9f, 0.05f, false}}) {
    const Vec3 toLight(0.3f, 0.1f, 1.0f), l = normalize(toLight);
    const Vec3 np = normalize(Vec3(0.2f, 0.0f, -1.0f));
    const VslReceiver x =
        receiver(Brdf::fromGltf(Vec3(0.9f), 1.0f, c.roughX, 0), Vec3(0, 0, 1), reflect(l, Vec3(0, 0, 1)));
    const VslEmitter p = emitter(Brdf::fromGltf(Vec3(0.9f), 1.0f, c.roughP, 0), np, reflect(-l, np));
    VslOptions options;
    options.clippedDisk = c.clipped;
    Vec3 ref = coneReference(x, p, toLight, c.r, 4000000);
    if (c.clipped) ref = ref * float(M_PI * c.r * c.r / vslClippedDiskArea(c.r, dot(toLight, x.ng)));
    const int n = 400000;
    double s = 0, s2 = 0;
    Rng g(11, 7);
    for (int i = 0; i < n; ++i) {
      const float u0 = g.uniform(), u1 = g.uniform(), u2 = g.uniform();
      const std::optional<BrdfSample> smp = x.f.sample(u0, {u1, u2});
      const double v = smp ? vslIntegrand(x, p, toLight, c.r, options, x.frame.toWorld(smp->wi)).y / smp->pdf : 0.0;
      s += v;
      s2 += v * v;
    }
    const double mean = s / n, se = std::sqrt(std::max(s2 / n - mean * mean, 0.0) / n);
    std::printf("integrand (rx %.2f, rp %.2f, r %.2f%s): %.6g +- %.2g, quadrature %.6g\n", c.roughX, c.roughP, c.r,
                c.clipped ? ", clipped" : "", mean, se, ref.y);
    EXPECT_NEAR(mean, ref.y, 4 * se + 2e-3 * ref.y) << "rx " << c.roughX << " rp " << c.roughP << " r " << c.r;
    // Outside the cone (the opposite side of the sphere's axis) and below x.
    EXPECT_TRUE(isBlack(vslIntegrand(x, p, toLight, c.r, options, normalize(Vec3(-0.9f, -0.3f, 0.1f)))));
    EXPECT_TRUE(isBlack(vslIntegrand(x, p, toLight, c.r, options, Vec3(0, 0, -1))));
  }
}

// The lobe-aware count: the angle's count where a lobe could put at least
// kVslStrategyMass of its samples into the cone, scaled down in proportion
// below that (at least 1). Two rough (diffuse) lobes and a 5-degree cone:
// one cone sample instead of six, and the estimate is still unbiased
// (z-test against the dense quadrature); a narrow lobe keeps the full count.
TEST(VslIntegralStats, LobeAwareCountIsSmallerForBroadLobesAndUnbiased) {
  EXPECT_EQ(vslLobeAwareSamples(17, kVslStrategyMass), 17);
  EXPECT_EQ(vslLobeAwareSamples(17, 0.5), 17);
  EXPECT_EQ(vslLobeAwareSamples(20, 0.5 * kVslStrategyMass), 10);
  EXPECT_EQ(vslLobeAwareSamples(6, 0.01 * kVslStrategyMass), 1);
  EXPECT_EQ(vslLobeAwareSamples(6, 0), 1);
  Vec3 toLight(0.3f, 0.1f, 1.0f);
  Vec3 l = normalize(toLight);
  const double r = length(toLight) * std::sin(5 * M_PI / 180);  // a 5-degree cone
  Vec3 np = normalize(Vec3(0.2f, 0.0f, -1.0f));
  for (float roughX : {1.0f, 0.05f}) {
    VslReceiver x = receiver(Brdf::fromGltf(Vec3(0.8f), 0.0f, roughX, 0), Vec3(0, 0, 1), reflect(l, Vec3(0, 0, 1)));
    VslEmitter p = emitter(Brdf::fromGltf(Vec3(0.7f), 0.0f, 1.0f, 0), np, reflect(-l, np));
    VslOptions lobe;
    lobe.count = VslCount::Lobe;
    Rng g0(1, 1), g1(1, 1);
    const int angleEvaluations = vslTransfer(x, p, toLight, r, {}, g0).evaluations;
    const int lobeEvaluations = vslTransfer(x, p, toLight, r, lobe, g1).evaluations;
    if (roughX == 1.0f) {
      EXPECT_EQ(angleEvaluations, 6);  // cone samples only: both lobes are broad
      EXPECT_EQ(lobeEvaluations, 1);
    } else {
      EXPECT_EQ(lobeEvaluations, angleEvaluations) << "a narrow receiver lobe keeps the full count";
    }
    Vec3 ref = coneReference(x, p, toLight, r, 1000000);
    const auto [mean, se] = meanOfRuns(x, p, toLight, r, lobe, 20000);
    EXPECT_NEAR(mean, ref.y, 4 * se + 2e-3 * ref.y) << "receiver roughness " << roughX;
  }
}

// The shares count (VslCount::Shares) gives a BRDF strategy n x min(1, mass)
// samples and the cone n x min(1, 1 / the larger mass), each at least one, and
// stays unbiased (z-test against the dense quadrature): a 30-degree cone with
// a narrow metal receiver (its lobe fits inside the cone) and a broad light
// (most of its samples would miss the cone), and the same with two broad lobes.
TEST(VslIntegralStats, SharesCountFitsEachStrategyAndIsUnbiased) {
  VslStrategyCounts c = vslStrategyCounts(20, 0.1, 5.0);
  EXPECT_EQ(c.cone, 4);
  EXPECT_EQ(c.x, 2);
  EXPECT_EQ(c.p, 20);
  c = vslStrategyCounts(20, 0.5, 0.01);
  EXPECT_EQ(c.cone, 20) << "no lobe narrower than the cone: the cone keeps the count";
  EXPECT_EQ(c.x, 10);
  EXPECT_EQ(c.p, 0) << "a strategy not in use gets nothing";
  c = vslStrategyCounts(3, 0.06, 1e6);
  EXPECT_EQ(c.cone, 1);
  EXPECT_EQ(c.x, 1) << "every strategy in use keeps one sample";
  EXPECT_EQ(vslStrategyCounts(3, kVslStrategyMass, 1e6).x, 0) << "a mass at the threshold is not used";
  Vec3 toLight(0.3f, 0.1f, 1.0f);
  Vec3 l = normalize(toLight);
  const double r = length(toLight) * std::sin(30 * M_PI / 180);
  Vec3 np = normalize(Vec3(0.2f, 0.0f, -1.0f));
  for (float roughX : {0.15f, 1.0f}) {
    VslReceiver x = receiver(Brdf::fromGltf(Vec3(0.8f), roughX < 1 ? 1.0f : 0.0f, roughX, 0), Vec3(0, 0, 1),
                             reflect(l, Vec3(0, 0, 1)));
    VslEmitter p = emitter(Brdf::fromGltf(Vec3(0.7f), 0.0f, 1.0f, 0), np, reflect(-l, np));
    VslOptions lobe, shares;
    lobe.count = VslCount::Lobe;
    shares.count = VslCount::Shares;
    Rng g0(1, 1), g1(1, 1);
    const int lobeEvaluations = vslTransfer(x, p, toLight, r, lobe, g0).evaluations;
    const int sharesEvaluations = vslTransfer(x, p, toLight, r, shares, g1).evaluations;
    EXPECT_LT(sharesEvaluations, lobeEvaluations * 0.75) << "receiver roughness " << roughX;
    Vec3 ref = coneReference(x, p, toLight, r, 1000000);
    const auto [mean, se] = meanOfRuns(x, p, toLight, r, shares, 20000);
    EXPECT_GT(ref.y, 0);
    EXPECT_NEAR(mean, ref.y, 4 * se + 2e-3 * ref.y) << "receiver roughness " << roughX;
  }
}

// The lobe floor widens only lobes narrower than factor x the cone's
// half-angle, to exactly that (at most kVslLobeFloorMaxAlpha), vanishes with
// the radius, so the VSL -> VPL limit is the same with it, and leaves the light
// unchanged for receivers whose gathered lobe is narrow on either axis and for
// lights that are not metal.
TEST(VslIntegral, LobeFloorWidensNarrowLobesOnlyAndVanishesWithTheRadius) {
  const Vec3 n(0, 0, 1), wi = normalize(Vec3(0.3f, 0, 1));
  VslEmitter narrow = emitter(Brdf::fromGltf(Vec3(0.9f), 1.0f, 0.15f, 0), n, wi);  // alpha 0.0225
  VslEmitter broad = emitter(Brdf::fromGltf(Vec3(0.9f), 1.0f, 0.8f, 0), n, wi);    // alpha 0.64
  VslEmitter out;
  // Receivers: a Lambertian (alpha 1), one just at the bound, and narrow ones.
  const Vec3 wo = normalize(Vec3(-0.2f, 0.1f, 1));
  const VslReceiver lambert = receiver(Brdf::fromGltf(Vec3(0.8f), 0.0f, 1.0f, 0), n, wo);
  Brdf atBound = Brdf::fromGltf(Vec3(0.8f), 1.0f, 0.5f, 0);
  atBound.ggx.ax = atBound.ggx.ay = kVslLobeFloorMinReceiverAlpha;
  Brdf justBelow = atBound;
  justBelow.ggx.ay = std::nextafter(kVslLobeFloorMinReceiverAlpha, 0.0f);  // brushed: narrow on one axis
  justBelow.ggx.ax = 0.6f;
  const Brdf polished = Brdf::fromGltf(Vec3(0.5f), 0.0f, 0.1f, 0);  // a dielectric, alpha 0.01
  VslReceiver polishedDiffuse = receiver(polished, n, wo);
  polishedDiffuse.f = polishedDiffuse.f.diffuseLobe();  // a split gather point's gathered lobe
  EXPECT_TRUE(vslLobeFloor(receiver(atBound, n, wo), narrow, 0.25, 1.0, 1.0, out));
  EXPECT_FALSE(vslLobeFloor(receiver(justBelow, n, wo), narrow, 0.25, 1.0, 1.0, out));
  EXPECT_FALSE(vslLobeFloor(receiver(polished, n, wo), narrow, 0.25, 1.0, 1.0, out));
  EXPECT_TRUE(vslLobeFloor(polishedDiffuse, narrow, 0.25, 1.0, 1.0, out));
  // Where it applies (the gather's wider sphere follows this too), whatever the
  // light's width: a metal light at a wide receiver, broad or narrow.
  EXPECT_TRUE(vslLobeFloorApplies(receiver(atBound, n, wo), narrow));
  EXPECT_TRUE(vslLobeFloorApplies(polishedDiffuse, broad));
  EXPECT_FALSE(vslLobeFloorApplies(receiver(justBelow, n, wo), broad));
  EXPECT_FALSE(vslLobeFloorApplies(receiver(polished, n, wo), narrow));
  EXPECT_FALSE(vslLobeFloorApplies(polishedDiffuse, emitter(Brdf::fromGltf(Vec3(0.9f), 0.0f, 0.15f, 0), n, wi)));
  const Brdf noSpecular = Brdf::fromGltf(Vec3(0.5f), 0.0f, 0.1f, 0, 0.0f);  // a Lambertian with alpha 0.01
  EXPECT_TRUE(vslLobeFloor(receiver(noSpecular, n, wo), narrow, 0.25, 1.0, 1.0, out));
  // Lights: metals only (metallic at least kVslLobeFloorMinLightMetallic); a
  // polished dielectric light is left as it is.
  const Vec3 dielectricColour(0.9f);
  EXPECT_FALSE(
      vslLobeFloor(lambert, emitter(Brdf::fromGltf(dielectricColour, 0.0f, 0.15f, 0), n, wi), 0.25, 1.0, 1.0, out));
  EXPECT_FALSE(vslLobeFloor(
      lambert,
      emitter(Brdf::fromGltf(dielectricColour, std::nextafter(kVslLobeFloorMinLightMetallic, 0.0f), 0.15f, 0), n, wi),
      0.25, 1.0, 1.0, out));
  EXPECT_TRUE(vslLobeFloor(lambert,
                           emitter(Brdf::fromGltf(dielectricColour, kVslLobeFloorMinLightMetallic, 0.15f, 0), n, wi),
                           0.25, 1.0, 1.0, out));
  ASSERT_TRUE(vslLobeFloor(lambert, narrow, 0.25, 1.0, 1.0, out));
  EXPECT_FLOAT_EQ(out.f.brdf().ggx.ax, float(std::asin(0.25)));
  EXPECT_FLOAT_EQ(out.f.brdf().ggx.ay, float(std::asin(0.25)));
  EXPECT_EQ(out.f.brdf().metallic, 1.0f);
  for (int c = 0; c < 3; ++c) {  // the same incoming direction and frame
    EXPECT_EQ(out.f.w()[c], narrow.f.w()[c]);
    EXPECT_EQ(out.frame.n[c], narrow.frame.n[c]);
    EXPECT_EQ(out.frame.s[c], narrow.frame.s[c]);
    EXPECT_EQ(out.frame.t[c], narrow.frame.t[c]);
  }
  ASSERT_TRUE(vslLobeFloor(lambert, narrow, 2.0, 1.0, 1.0, out));  // inside the sphere: pi/2, capped
  EXPECT_FLOAT_EQ(out.f.brdf().ggx.ax, kVslLobeFloorMaxAlpha);
  EXPECT_FLOAT_EQ(out.f.brdf().ggx.ay, kVslLobeFloorMaxAlpha);
  EXPECT_FALSE(vslLobeFloor(lambert, narrow, 0.3, 1.0, 0.0, out));   // off
  EXPECT_FALSE(vslLobeFloor(lambert, broad, 0.3, 1.0, 1.0, out));    // already wider than the cone
  EXPECT_FALSE(vslLobeFloor(lambert, narrow, 1e-3, 1.0, 1.0, out));  // r -> 0: the light unchanged
  // An anisotropic lobe keeps its wide axis.
  Brdf brushedBrdf = Brdf::fromGltf(Vec3(0.9f), 1.0f, 0.15f, 0);
  brushedBrdf.ggx.ax = 0.6f;
  VslEmitter brushed = emitter(brushedBrdf, n, wi);
  const Brdf& bb = brushed.f.brdf();
  ASSERT_TRUE(vslLobeFloor(lambert, brushed, 0.2, 1.0, 1.0, out));
  EXPECT_FLOAT_EQ(std::max(out.f.brdf().ggx.ax, out.f.brdf().ggx.ay), std::max(bb.ggx.ax, bb.ggx.ay));
  EXPECT_FLOAT_EQ(std::min(out.f.brdf().ggx.ax, out.f.brdf().ggx.ay), float(std::asin(0.2)));
}

// What the floor is for: a narrow metal light seen through 11.5-degree cones
// lights its receivers as a beam (most of its flux within a few degrees);
// with the floor at 1 its peak transfer falls to under half, while the
// transfer integrated over every direction around the light (its emitted
// energy, for Lambertian receivers facing it) changes only as the widened
// lobe's albedo does (GGX without multiple scattering loses some energy as
// alpha grows): the two ratios agree within 2%.
TEST(VslIntegralStats, LobeFloorSpreadsABeamAndKeepsItsEnergy) {
  const Vec3 n(0, 0, 1);
  VslEmitter p = emitter(Brdf::fromGltf(Vec3(0.9f), 1.0f, 0.15f, 0), n, normalize(Vec3(0.3f, 0, 1)));
  const double D = 1.0, r = 0.2;
  VslEmitter floored;
  const Brdf lambert = Brdf::fromGltf(Vec3(0.8f), 0.0f, 1.0f, 0);
  ASSERT_TRUE(vslLobeFloor(receiver(lambert, n, n), p, r, D, 1.0, floored));
  const int nTheta = 60, nPhi = 120;
  double energy[2] = {0, 0}, peak[2] = {0, 0};
  for (int i = 0; i < nTheta; ++i)
    for (int j = 0; j < nPhi; ++j) {
      const double th = (i + 0.5) * 0.5 * M_PI / nTheta, ph = (j + 0.5) * 2 * M_PI / nPhi;
      const Vec3 w(float(std::sin(th) * std::cos(ph)), float(std::sin(th) * std::sin(ph)), float(std::cos(th)));
      VslReceiver x = receiver(lambert, -w, -w);  // at p + D w, facing p
      const double dOmega = std::sin(th) * (0.5 * M_PI / nTheta) * (2 * M_PI / nPhi);
      for (int k = 0; k < 2; ++k) {
        Rng g(uint64_t(i * nPhi + j), 11);
        const double t = vslTransfer(x, k ? floored : p, -w * float(D), r, {32}, g).transfer.y;
        energy[k] += t * dOmega;
        peak[k] = std::max(peak[k], t);
      }
    }
  // The two lobes' albedos at the light's incoming direction, by sampling.
  double albedo[2] = {0, 0};
  const int nAlbedo = 400000;
  for (int k = 0; k < 2; ++k) {
    Rng g(5, 17);
    const BrdfAt& f = k ? floored.f : p.f;
    for (int i = 0; i < nAlbedo; ++i)
      if (auto s = f.sample(g.uniform(), {g.uniform(), g.uniform()}); s && s->pdf > 0)
        albedo[k] += double(s->f.y) * double(s->wi.z) / double(s->pdf) / nAlbedo;
  }
  std::printf("lobe floor: energy %.5g -> %.5g (albedo %.5g -> %.5g), peak transfer %.5g -> %.5g\n", energy[0],
              energy[1], albedo[0], albedo[1], peak[0], peak[1]);
  ASSERT_GT(energy[0], 0);
  EXPECT_NEAR((energy[1] / energy[0]) / (albedo[1] / albedo[0]), 1.0, 0.02);
  EXPECT_GT(energy[1] / energy[0], 0.9);
  EXPECT_LT(peak[1], 0.5 * peak[0]);
}

// BRDF sampling restricted to the cone: the directions that land inside it
// follow the BRDF pdf restricted to the cone (chi-square).
TEST(VslIntegralStats, BrdfSamplingRestrictedToConeChiSquare) {
  Brdf b = Brdf::fromGltf(Vec3(0.8f), 0.5f, 0.5f, 0.4f);
  Vec3 wo = normalize(Vec3(0.4f, 0.2f, 1.0f));
  Vec3 axis = normalize(Vec3(-0.3f, 0.1f, 1.0f));
  double omc = vslConeOneMinusCos(0.6, 1.0);  // half-angle ~37 degrees
  auto inCone = [&](const Vec3& w) { return 0.5 * double(lengthSquared(w - axis)) <= omc; };
  test::Chi2Config cfg;
  cfg.samples = 1000000;
  cfg.subdiv = 16;
  auto r = test::chi2Directions(
      [&](Rng& g) -> std::optional<Vec3> {
        auto s = b.sample(wo, g.uniform(), {g.uniform(), g.uniform()});
        if (!s || !inCone(s->wi)) return std::nullopt;
        return s->wi;
      },
      [&](const Vec3& w) { return inCone(w) ? double(b.pdf(wo, w)) : 0.0; }, cfg, "brdf_in_cone");
  EXPECT_TRUE(r.message.empty()) << r.message;
  EXPECT_GT(r.pValue, 1e-3) << "chi2 " << r.statistic << " dof " << r.dof;
  std::printf("BRDF sampling restricted to a cone: chi2 %.1f dof %d p %.4f\n", r.statistic, r.dof, r.pValue);
}

TEST(VslIntegral, ExtremesStayFinite) {
  Rng rng(2, 9);
  for (float rough : {1e-4f, 0.01f, 1.0f}) {
    Brdf b = Brdf::fromGltf(Vec3(1.0f), 1.0f, rough, 0.9f);
    Brdf d = Brdf::fromGltf(Vec3(1.0f), 0.0f, rough, 0.0f);
    for (const Brdf& bx : {b, d})
      for (double r : {1e-9, 1e-3, 0.5, 1.0, 1e6})
        for (Vec3 toLight : {Vec3(0, 0, 1), Vec3(1, 0, 1e-4f), Vec3(0.0f), Vec3(1e-7f, 0, 0), Vec3(0, 0, 1e4f)}) {
          // Grazing view and grazing light.
          VslReceiver x = receiver(bx, Vec3(0, 0, 1), normalize(Vec3(1, 0, 1e-3f)));
          VslEmitter p = emitter(b, Vec3(0, 0, -1), normalize(Vec3(-1, 0, -1e-3f)));
          VslResult res = vslTransfer(x, p, toLight, r, {}, rng);
          ASSERT_TRUE(isFinite(res.transfer)) << "rough " << rough << " r " << r;
          ASSERT_GE(res.transfer.x, 0.0f);
          // Bounded: the integrand is at most f_max^2 over a hemisphere and
          // the normalisation is 1/(pi r^2).
          ASSERT_LT(res.transfer.x, 1e30f);
        }
  }
}

// ---- Gathering --------------------------------------------------------------------

TEST(ManyLight, VslMatchesUnclampedVplForTinyRadii) {
  Loaded l = loadAsset("cornell-glossy");
  ManyLightSettings s;
  s.lights = 300;
  s.width = s.height = 24;
  s.batches = 1;
  s.globalRadius = 1e-6f;
  s.seed = 4;
  ManyLightImages im = renderMany(l, s);
  int far = 0, close = 0;
  for (size_t i = 0; i < im.vsl.rgb.size(); ++i) {
    float a = im.vsl.rgb[i], b = im.vplUnclamped.rgb[i];
    ++far;
    if (std::abs(a - b) <= 2e-3f * b + 1e-7f) ++close;
  }
  // Away from the singular corners (where d ~ r) they agree to 0.2%.
  EXPECT_GE(close, int(0.99 * far)) << close << " of " << far;
  EXPECT_NEAR(channelMean(im.vsl), channelMean(im.vplUnclamped), 1e-3 * channelMean(im.vplUnclamped));
}

// Unclamped full-BRDF VPL, averaged over independent light sets, converges to
// the path-traced indirect image: z-test on the image mean and on 4x4 blocks.
TEST(ManyLightStats, UnclampedVplConvergesToPathTracedIndirect) {
  Loaded l = loadAsset("cornell-glossy");
  const int W = 16, H = 16, sets = 24;
  Reference ref = ptIndirect(l, W, H, 2048, 77);
  std::vector<double> means;
  Image avg(W, H);
  for (int k = 0; k < sets; ++k) {
    ManyLightImages im = renderMany(l, vplOnly(W, H, 1500, 1000 + k));
    means.push_back(greyMean(im.vplUnclamped));
    for (size_t i = 0; i < avg.rgb.size(); ++i) avg.rgb[i] += im.vplUnclamped.rgb[i] / sets;
  }
  auto [m, se] = meanAndError(means);
  double z = (m - ref.mean) / std::sqrt(se * se + ref.se * ref.se);
  std::printf("unclamped VPL %.6f +- %.6f vs PT indirect %.6f +- %.6f (z = %.2f)\n", m, se, ref.mean, ref.se, z);
  EXPECT_LT(std::abs(z), 4.0);
}

TEST(ManyLightStats, ClampedVplIsNeverBrighterAndLosesLessAsTheBoundRises) {
  Loaded l = loadAsset("cornell-glossy");
  const int W = 16, H = 16, sets = 8;
  Reference ref = ptIndirect(l, W, H, 2048, 78);
  const float factors[3] = {0.01f, 1.0f, 100.0f};
  std::vector<double> means[3], lostMeans[3];
  float autoBound = 0;
  for (int k = 0; k < sets; ++k) {
    ManyLightSettings s = vplOnly(W, H, 2000, 21 + k);
    ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
    autoBound = ManyLightRenderer(*l.scene, *l.accel, *l.lights, run.set, run.radii, s).clampBound();
    std::vector<Image> lost;
    for (int f = 0; f < 3; ++f) {
      ManyLightSettings c = s;
      c.clamp = autoBound * factors[f];
      ManyLightRenderer r(*l.scene, *l.accel, *l.lights, run.set, run.radii, c);
      ASSERT_TRUE(r.renderBatch(0));
      ManyLightImages im = r.images();
      // Clamped light is the unclamped light minus a non-negative loss.
      for (float x : im.lostToClamping.rgb) ASSERT_GE(x, -1e-6f);
      means[f].push_back(greyMean(im.vpl));
      lostMeans[f].push_back(greyMean(im.lostToClamping));
      lost.push_back(im.lostToClamping);
    }
    // Per pixel, a higher bound never loses more (same lights, same pairs).
    for (size_t i = 0; i < lost[0].rgb.size(); ++i) {
      ASSERT_GE(lost[0].rgb[i] + 1e-6f, lost[1].rgb[i]);
      ASSERT_GE(lost[1].rgb[i] + 1e-6f, lost[2].rgb[i]);
    }
  }
  const auto& meanSe = meanAndError;
  for (int f = 0; f < 3; ++f) {
    auto [m, se] = meanSe(means[f]);
    std::printf("clamped VPL at %gx the auto bound %.4g: %.5f +- %.5f (PT %.5f +- %.5f), lost %.5f\n", factors[f],
                autoBound, m, se, ref.mean, ref.se, meanSe(lostMeans[f]).first);
    // Never brighter than the reference beyond noise (one-sided, 4 sigma).
    EXPECT_LT(m, ref.mean + 4 * std::sqrt(se * se + ref.se * ref.se)) << "factor " << factors[f];
  }
  // The loss shrinks as the bound rises.
  EXPECT_GT(meanSe(lostMeans[0]).first, meanSe(lostMeans[1]).first);
  EXPECT_GT(meanSe(lostMeans[1]).first, meanSe(lostMeans[2]).first);
}

// Furnace: indirect radiance is Le a / (1 - a) = 0.5 everywhere. VPL is
// unbiased (z-test over independent light sets); VSL with the default radius
// is within its stated bias (2%).
TEST(ManyLightStats, FurnaceIndirectMatchesAnalyticValue) {
  Loaded l = loadAsset("furnace");
  const int sets = 12;
  std::vector<double> vpl, vsl;
  for (int k = 0; k < sets; ++k) {
    ManyLightSettings s;
    s.lights = 4000;
    s.width = s.height = 12;
    s.batches = 2;
    s.seed = 300 + k;
    ManyLightImages im = renderMany(l, s);
    vpl.push_back(greyMean(im.vplUnclamped));
    vsl.push_back(greyMean(im.vsl));
    EXPECT_NEAR(greyMean(im.direct), 1.5, 0.02);
  }
  auto [mp, sp] = meanAndError(vpl);
  auto [ms, ss] = meanAndError(vsl);
  std::printf("furnace indirect: VPL %.5f +- %.5f, VSL %.5f +- %.5f (analytic 0.5)\n", mp, sp, ms, ss);
  EXPECT_NEAR(mp, 0.5, 4 * sp);
  EXPECT_NEAR(ms, 0.5, 0.02 * 0.5 + 4 * ss);
}

// Progressive batches: every batch leaves an unbiased estimate of the all-N
// image; after the last batch the result equals a single-batch render of the
// same lights up to the VSL's random streams (VPL is exactly equal).
TEST(ManyLight, BatchesConvergeToTheAllLightImage) {
  // The furnace keeps the gather's variance low, so image means must agree
  // closely (gather points are jittered per batch, so pixels differ).
  Loaded l = loadAsset("furnace");
  ManyLightSettings s;
  s.lights = 1000;
  s.width = s.height = 16;
  s.seed = 8;
  s.computeVsl = false;
  s.directSamples = 8;
  ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
  s.batches = 1;
  ManyLightRenderer one(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
  ASSERT_TRUE(one.renderBatch(0));
  s.batches = 6;
  ManyLightRenderer many(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
  ASSERT_EQ(many.batchCount(), 6);
  size_t last = 0;
  for (int b = 0; b < 6; ++b) {
    ASSERT_TRUE(many.renderBatch(b));
    EXPECT_GT(many.lightsProcessed(), last);
    last = many.lightsProcessed();
  }
  EXPECT_EQ(many.lightsProcessed(), run.set.lights.size());
  EXPECT_FALSE(many.renderBatch(6));  // no batch left
  double a = greyMean(one.images().vplUnclamped), b = greyMean(many.images().vplUnclamped);
  EXPECT_NEAR(a, b, 0.03 * a);
  EXPECT_NEAR(b, 0.5, 0.03);
  // A stopped batch changes nothing.
  ManyLightRenderer stopped(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
  std::atomic<bool> stop{true};
  EXPECT_FALSE(stopped.renderBatch(0, &stop));
  EXPECT_EQ(stopped.lightsProcessed(), 0u);
  EXPECT_EQ(greyMean(stopped.images().vplUnclamped), 0.0);
}

TEST(ManyLight, ExtremeSettingsStayFiniteAndBounded) {
  Loaded l = loadAsset("cornell-glossy");
  struct Case {
    const char* name;
    uint32_t lights;
    float scale;
    int knn;
    float global;
  };
  for (Case c : {Case{"radius scale 1e-6", 500, 1e-6f, 10, 0}, Case{"radius scale 1e6", 500, 1e6f, 10, 0},
                 Case{"k = 1", 500, 1.0f, 1, 0}, Case{"one light", 1, 1.0f, 10, 0},
                 Case{"global radius 1e-6", 200, 1.0f, 10, 1e-6f}}) {
    ManyLightSettings s;
    s.lights = c.lights;
    s.radiusScale = c.scale;
    s.knn = c.knn;
    s.globalRadius = c.global;
    s.width = s.height = 12;
    s.batches = 3;
    ManyLightImages im = renderMany(l, s);
    for (const Image* img : {&im.vsl, &im.vpl, &im.vplUnclamped, &im.vplDiffuse, &im.direct}) {
      ASSERT_TRUE(allFinite(*img)) << c.name;
      for (float v : img->rgb) ASSERT_LT(v, 1e6f) << c.name;
    }
    if (c.scale >= 1e6f) {
      EXPECT_LT(channelMean(im.vsl), 1e-6) << "a huge sphere spreads the light thin";
    }
  }
}

TEST(ManyLight, MillionLightsTraceAndGather) {
  Loaded l = loadAsset("kitchen");
  ManyLightSettings s;
  s.lights = 1000000;
  s.width = s.height = 2;
  s.batches = 2;
  s.vslSamples = 1;
  ManyLightRun run;
  ManyLightImages im = renderMany(l, s, &run);
  EXPECT_GE(run.set.lights.size(), 1000000u);
  EXPECT_LT(run.set.bytes(), 64u * 1000000u + 64u * 64u);
  for (const Image* img : {&im.vsl, &im.vpl, &im.vplUnclamped})
    for (float v : img->rgb) ASSERT_TRUE(std::isfinite(v) && v >= 0 && v < 1e6f);
  for (float r : run.radii) ASSERT_TRUE(std::isfinite(r) && r > 0);
}

// Near-mirror and fully rough materials, a grazing camera, and a receiver at
// a light's position, in one constructed scene.
TEST(ManyLight, NearMirrorRoughAndGrazingStayFinite) {
  auto s = std::make_shared<Scene>();
  auto quad = [&](Vec3 o, Vec3 eu, Vec3 ev, uint32_t m) {
    uint32_t b = uint32_t(s->positions.size());
    for (Vec3 p : {o, o + eu, o + eu + ev, o + ev}) {
      s->positions.push_back(p);
      s->normals.push_back(Vec3(0.0f));
      s->tangents.push_back(Vec3(0.0f));
      s->tangentSigns.push_back(1);
      s->uvs.push_back({0, 0});
      s->boundsMin = min(s->boundsMin, p);
      s->boundsMax = max(s->boundsMax, p);
    }
    s->indices.insert(s->indices.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
    s->triMaterial.insert(s->triMaterial.end(), {m, m});
  };
  Material mirror, rough, light;
  mirror.metallic = 1;
  mirror.roughness = 1e-4f;
  rough.metallic = 0;
  rough.roughness = 1;
  rough.baseColor = Vec3(0.8f);
  light.emission = Vec3(5.0f);
  light.baseColor = Vec3(0.5f);
  light.metallic = 0;
  s->materials = {mirror, rough, light, Material()};
  quad({-2, 0, 2}, {4, 0, 0}, {0, 0, -4}, 0);                  // mirror floor
  quad({-2, 0, -2}, {4, 0, 0}, {0, 2, 0}, 1);                  // rough back wall
  quad({-2, 2, -2}, {4, 0, 0}, {0, 0, 4}, 1);                  // rough ceiling
  quad({-0.3f, 1.99f, -0.3f}, {0.6f, 0, 0}, {0, 0, 0.6f}, 2);  // light, facing down
  s->camera.position = Vec3(0, 0.02f, 1.9f);                   // grazing over the mirror
  s->camera.forward = normalize(Vec3(0, -0.01f, -1));
  s->camera.right = Vec3(1, 0, 0);
  s->camera.up = cross(s->camera.right, s->camera.forward);
  Loaded l = loadedFrom(s);
  ASSERT_TRUE(l.context);
  ManyLightSettings ms;
  ms.lights = 800;
  ms.width = ms.height = 16;
  ms.batches = 2;
  ManyLightImages im = renderMany(l, ms);
  for (const Image* img : {&im.vsl, &im.vpl, &im.vplUnclamped, &im.direct}) ASSERT_TRUE(allFinite(*img));
  EXPECT_GT(channelMean(im.vsl), 0.0);
}

// The hall's walls are pure metal: diffuse-only VPLs on them emit nothing,
// while full-BRDF VPLs on them do light the hall.
TEST(ManyLight, DiffuseOnlyVplsOnPureMetalEmitNothing) {
  Loaded l = loadAsset("hall");
  ManyLightSettings s;
  s.lights = 3000;
  s.width = 24;
  s.height = 14;
  s.batches = 1;
  s.computeVsl = false;
  ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
  // Keep only the lights on metal.
  VirtualLightSet metal;
  metal.paths = run.set.paths;
  for (const VirtualLight& v : run.set.lights)
    if (v.brdf().metallic >= 1.0f) metal.lights.push_back(v);
  ASSERT_GT(metal.lights.size(), 100u) << "the stage light must reach the metal walls";
  std::vector<float> radii(metal.lights.size(), 0.1f);
  ManyLightRenderer r(*l.scene, *l.accel, *l.lights, metal, radii, s);
  ASSERT_TRUE(r.renderBatch(0));
  ManyLightImages im = r.images();
  for (float v : im.vplDiffuse.rgb) ASSERT_EQ(v, 0.0f);
  EXPECT_GT(channelMean(im.vplUnclamped), 0.0);
  EXPECT_GT(channelMean(im.lostToDiffuse), 0.0);
}

TEST(ManyLight, ProgressiveRadiiShrinkTowardZero) {
  EXPECT_FLOAT_EQ(progressiveRadiusFactor(0, 0.7f), 1.0f);
  EXPECT_NEAR(progressiveRadiusFactor(1, 0.7f), std::sqrt(0.85f), 1e-6f);
  float prev = 1;
  for (int i = 1; i < 2000; ++i) {
    float f = progressiveRadiusFactor(i, 0.7f);
    ASSERT_LT(f, prev);
    prev = f;
  }
  // prod (k + alpha)/(k + 1) ~ C n^(alpha - 1): r^2 falls like n^-0.3.
  EXPECT_LT(progressiveRadiusFactor(1999, 0.7f), 0.4f);
  EXPECT_GT(progressiveRadiusFactor(1999, 0.7f), 0.1f);
}

// ---- Thin surfaces ------------------------------------------------------------------

namespace {

// A large zero-thickness sheet, tilted so that its points' coordinates are not
// exact, lit from behind by a small emitter that faces its back. The camera
// looks at the front. Nothing in front of the sheet reflects, so every light
// path that reaches the front face would have to pass through the sheet: the
// front's indirect light is exactly zero for the path tracer, and must be for
// every many-light method, however large the VSL radius (virtual lights on
// the back lie within r of front points).
std::shared_ptr<Scene> backLitSheet(bool doubleSided) {
  auto s = std::make_shared<Scene>();
  s->path = doubleSided ? "<back-lit double-sided sheet>" : "<back-lit one-sided sheet>";
  Material sheet = testMaterial("sheet", Vec3(0.8f), 0, 0.4f);
  sheet.doubleSided = doubleSided;
  s->materials = {sheet, emitterMaterial(Vec3(10.0f)), Material()};
  Vec3 n = normalize(Vec3(0.3f, 0.2f, 1.0f));  // the sheet's front normal
  Frame f(n);
  addQuad(*s, f.toWorld(Vec3(-20, -20, 0)), f.toWorld(Vec3(40, 0, 0)), f.toWorld(Vec3(0, 40, 0)), 0);
  // The emitter, 0.5 behind the sheet, facing it (+n).
  addQuad(*s, f.toWorld(Vec3(-0.3f, -0.3f, -0.5f)), f.toWorld(Vec3(0.6f, 0, 0)), f.toWorld(Vec3(0, 0.6f, 0)), 1);
  s->camera.position = n * 1.5f;
  s->camera.forward = -n;
  s->camera.right = f.toWorld(Vec3(1, 0, 0));
  s->camera.up = cross(s->camera.right, s->camera.forward);
  s->camera.yfov = 1.2f;
  return s;
}

}  // namespace

// The lobe floor in the renderer: on by default at 1; at 0 it is off; on,
// only the VSL layers change, and on cornell-glossy, whose metal box holds
// lights on a lobe (alpha 0.0625) narrower than 600 lights' cones, they change.
TEST(ManyLight, LobeFloorChangesVslOnly) {
  Loaded l = loadAsset("cornell-glossy", 16);
  ASSERT_TRUE(l.context);
  ManyLightSettings s;
  s.lights = 600;
  s.width = s.height = 16;
  s.batches = 1;
  s.directSamples = 1;
  s.seed = 4;
  EXPECT_EQ(s.lobeFloor, 1.0f) << "on by default";
  const ManyLightImages byDefault = renderMany(l, s);
  s.lobeFloor = 0;
  EXPECT_NE(s.describe().find("--lobe-floor 0"), std::string::npos) << s.describe();
  const ManyLightImages off = renderMany(l, s);
  s.lobeFloor = 1;
  const ManyLightImages on = renderMany(l, s);
  EXPECT_EQ(byDefault.vsl.rgb, on.vsl.rgb);
  EXPECT_EQ(on.vpl.rgb, off.vpl.rgb);
  EXPECT_EQ(on.vplUnclamped.rgb, off.vplUnclamped.rgb);
  EXPECT_NE(on.vsl.rgb, off.vsl.rgb);
  EXPECT_TRUE(allFinite(on.vsl));
  EXPECT_NE(s.describe().find("--lobe-floor 1"), std::string::npos) << s.describe();
  s.lobeFloor = -1;
  EXPECT_FALSE(s.validate());
}

TEST(ManyLight, NoLightThroughThinSheets) {
  for (bool doubleSided : {false, true}) {
    SCOPED_TRACE(doubleSided ? "double-sided" : "one-sided");
    Loaded l = loadedFrom(backLitSheet(doubleSided));
    ASSERT_TRUE(l.context);
    Reference ref = ptIndirect(l, 16, 16, 64, 3);
    EXPECT_EQ(ref.mean, 0.0) << "the path tracer finds no indirect light on the front";
    // Radii well above the light spacing (so that back lights sit inside the
    // spheres of front points), as k-NN radii and as one global radius.
    for (float globalRadius : {0.0f, 0.02f}) {
      ManyLightSettings s;
      s.lights = 3000;
      s.width = s.height = 16;
      s.batches = 1;
      s.radiusScale = 4;
      s.globalRadius = globalRadius;
      s.clamp = std::numeric_limits<float>::infinity();
      s.seed = 11;
      ManyLightRun run;
      ManyLightImages im = renderMany(l, s, &run);
      ASSERT_GT(run.set.lights.size(), 1000u) << "the back of the sheet must hold virtual lights";
      EXPECT_EQ(channelMean(im.vsl), 0.0) << "VSL, global radius " << globalRadius;
      EXPECT_EQ(channelMean(im.vplUnclamped), 0.0);
      EXPECT_EQ(channelMean(im.vplDiffuse), 0.0);
      EXPECT_EQ(channelMean(im.vpl), 0.0);
      MrcsSettings ms;
      ms.rows = 16;
      ms.clusters = 64;
      MrcsResult mr = renderMrcs(*l.scene, *l.accel, *l.lights, run.set, run.radii, s, ms);
      EXPECT_EQ(channelMean(mr.images.vsl), 0.0) << "MRCS VSL";
      EXPECT_EQ(channelMean(mr.images.vpl), 0.0) << "MRCS VPL";
    }
  }
}

// The VPL transfers of one light against a tile's points, with the BRDFs
// evaluated in blocks (Gatherer::vplBrdfs: the receivers packed once, the
// light's lobes at every direction at once), add up to the same sums, bit for
// bit, as addVpl pair by pair (kitchen: dielectrics, metals and glossy
// lobes, split points). Directions below a surface, BRDFs restricted to one
// lobe and NaN directions are GatherSimd.BrdfBlockEqualsScalar's.
TEST(ManyLight, VplTransfersInBlocksEqualOneByOne) {
  Loaded l = loadAsset("kitchen", 64);
  ASSERT_TRUE(l.context);
  ManyLightSettings s;
  s.lights = 2000;
  s.seed = 7;
  s.splitAlpha = 0.3f;
  ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
  Gatherer g(*l.scene, *l.accel, *l.lights, s, 0.05f, false, true);
  const std::vector<EyeSample> eyes = eyeSamples(l, g);
  size_t pairs = 0, clampedPairs = 0;
  Gatherer::VplBrdfs blocks;
  auto pack = [&](const std::vector<const GatherPoint*>& pts) {
    std::vector<float> packed;
    g.packReceivers(pts, packed);
    return packed;
  };
  forEachLightAndVisiblePoints(
      g, run, eyes, 13, pack,
      [&](const std::vector<const GatherPoint*>& pts, const std::vector<float>& packed, size_t j, const GatherLight& L,
          const std::vector<PairGeometry>& geo, const std::vector<uint32_t>& list, GatherCounters& c) {
        g.vplBrdfs(pts, packed.data(), list.data(), list.size(), L, geo.data(), blocks);
        for (size_t v = 0; v < list.size(); ++v) {
          const uint32_t i = list[v];
          double one[kGatherLayers][3] = {}, block[kGatherLayers][3] = {};
          g.addVpl(*pts[i], L, geo[i], one, c);
          g.addVpl(*pts[i], L, geo[i], blocks.fx(v), blocks.fp(v), block, c);
          for (int layer = 0; layer < kGatherLayers; ++layer)
            for (int ch = 0; ch < 3; ++ch)
              ASSERT_EQ(std::memcmp(&one[layer][ch], &block[layer][ch], sizeof(double)), 0)
                  << "light " << j << ", point " << i << ", layer " << layer << ": " << one[layer][ch] << " against "
                  << block[layer][ch];
          ++pairs;
          clampedPairs += one[kVplFullClamped][1] < one[kVplFull][1];
        }
      });
  std::printf("%zu pairs (%zu clamped) agree\n", pairs, clampedPairs);
  EXPECT_GT(pairs, 50000u);
  EXPECT_GT(clampedPairs, 10u);  // the clamp is exercised too
}

// The VSL transfers of one light against a tile's points prepared together
// (Gatherer::vslPrepare: the closed-form pairs on AVX2 lanes) against addVsl
// pair by pair (kitchen, --vsl-integral sg with cones up to 10 degrees in
// closed form, split points, the lobe floor): the quadrature's pairs bit for
// bit (the same streams), the closed form's to the lanes' rounding: median
// relative difference in luminance under 1e-5, worst under 1e-3 (measured
// 2026-12-07: 83,819 closed-form pairs, median 1.8e-7, worst 2e-5; 31,832
// by the quadrature).
TEST(ManyLight, VslTransfersPreparedEqualOneByOne) {
  Loaded l = loadAsset("kitchen", 64);
  ASSERT_TRUE(l.context);
  ManyLightSettings s;
  s.lights = 2000;
  s.seed = 7;
  s.splitAlpha = 0.3f;
  s.vslIntegral = VslIntegral::Sg;
  s.vslSgMaxAngle = 10.0f;
  ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
  Gatherer g(*l.scene, *l.accel, *l.lights, s, 0.05f, true, false);
  const std::vector<EyeSample> eyes = eyeSamples(l, g);
  size_t quadrature = 0;
  std::vector<double> rel;
  Gatherer::VslBlock block;
  auto pack = [&](const std::vector<const GatherPoint*>& pts) {
    std::vector<float> packedRx;  // every other light: the receivers packed once
    g.packVslReceivers(pts, packedRx);
    return packedRx;
  };
  forEachLightAndVisiblePoints(
      g, run, eyes, 29, pack,
      [&](const std::vector<const GatherPoint*>& pts, const std::vector<float>& packedRx, size_t j,
          const GatherLight& L, const std::vector<PairGeometry>& geo, const std::vector<uint32_t>& list,
          GatherCounters&) {
        ASSERT_EQ(packedRx.size(), pts.size() * BrdfAt::kPackedFloats);
        g.vslPrepare(pts, j % 2 ? packedRx.data() : nullptr, list.data(), list.size(), L, geo.data(), block);
        for (size_t v = 0; v < list.size(); ++v) {
          const uint32_t i = list[v];
          double one[kGatherLayers][3] = {}, prepared[kGatherLayers][3] = {};
          GatherCounters c1, c2;
          g.addVsl(*pts[i], L, geo[i], j, i, one, c1);
          g.addVslPrepared(block, v, *pts[i], L, geo[i], j, i, prepared, c2);
          ASSERT_EQ(c1.vslEvaluations, c2.vslEvaluations) << "light " << j << ", point " << i;
          const double a = one[kVslLayer][1], b = prepared[kVslLayer][1];
          if (c1.vslEvaluations > 0) {  // the quadrature
            ++quadrature;
            ASSERT_EQ(std::memcmp(&one[kVslLayer], &prepared[kVslLayer], sizeof one[kVslLayer]), 0)
                << "light " << j << ", point " << i;
          } else if (a > 1e-30) {
            rel.push_back(std::abs(b - a) / a);
          } else {
            ASSERT_LE(b, 1e-30) << "light " << j << ", point " << i;
          }
        }
      });
  std::sort(rel.begin(), rel.end());
  ASSERT_GT(rel.size(), 5000u);
  const double median = rel[rel.size() / 2], worst = rel.back();
  std::printf("%zu closed-form pairs (median relative difference %.2g, worst %.2g), %zu by the quadrature\n",
              rel.size(), median, worst, quadrature);
  EXPECT_GT(quadrature, 500u);
  EXPECT_LT(median, 1e-5);
  EXPECT_LT(worst, 1e-3);
}

// The batched connection (one light against many gather points, shadow
// rays traced as one batch) agrees with connect() pair by pair: the same
// visibility, the same geometry and the same counters, on kitchen's gather
// points of neighbouring pixels (coherent batches, as the gathers use) and
// on scattered ones, with null entries for points that do not exist; and
// with the outcomes of an earlier call given instead of tracing.
TEST(ManyLight, BatchedConnectionEqualsOneByOne) {
  Loaded l = loadAsset("kitchen", 64);
  ASSERT_TRUE(l.context);
  ManyLightSettings s;
  s.lights = 2000;
  s.seed = 5;
  ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
  ASSERT_GT(run.set.lights.size(), 1000u);
  Gatherer g(*l.scene, *l.accel, *l.lights, s, 1.0f, true, true);
  const std::vector<EyeSample> eyes = eyeSamples(l, g);
  Rng pick(3, 4);
  std::vector<const GatherPoint*> rowPts, scattered;
  for (const EyeSample& es : eyes) rowPts.push_back(es.point(0));
  for (int i = 0; i < 300; ++i) {
    const EyeSample& es = eyes[pick.uniformInt(uint32_t(eyes.size()))];
    scattered.push_back(es.points[0].valid && i % 7 ? &es.points[0] : nullptr);
  }
  size_t visibleSeen = 0, blockedSeen = 0;
  Gatherer::ConnectScratch scratch;
  for (const auto* pts : {&rowPts, &scattered})
    for (size_t j = 0; j < run.set.lights.size(); j += 37) {
      const GatherLight L = decodeGatherLight(run.set.lights[j], run.radii[j]);
      std::vector<PairGeometry> geo(pts->size());
      std::vector<uint8_t> visible(pts->size());
      GatherCounters batched, single;
      g.connectMany(*pts, L, geo.data(), visible.data(), scratch, batched);
      for (size_t i = 0; i < pts->size(); ++i) {
        if (!(*pts)[i]) {
          ASSERT_EQ(visible[i], 0) << "a missing point is not visible";
          continue;
        }
        PairGeometry one;
        const bool v = g.connect(*(*pts)[i], L, one, single);
        ASSERT_EQ(bool(visible[i]), v) << "light " << j << ", point " << i;
        if (!v) {
          ++blockedSeen;
          continue;
        }
        ++visibleSeen;
        EXPECT_EQ(one.d2, geo[i].d2);
        EXPECT_EQ(one.cosX, geo[i].cosX);
        EXPECT_EQ(one.cosP, geo[i].cosP);
        EXPECT_EQ(one.l.x, geo[i].l.x);
      }
      EXPECT_EQ(batched.pairs, single.pairs);
      EXPECT_EQ(batched.shadowRays, single.shadowRays);
      // Kept outcomes stand in for the rays (MRCS's second method's rows):
      // the same pairs, none traced.
      std::vector<uint8_t> again(pts->size());
      std::vector<PairGeometry> geo2(pts->size());
      GatherCounters reused;
      g.connectMany(*pts, L, geo2.data(), again.data(), scratch, reused, visible);
      EXPECT_EQ(again, visible);
      EXPECT_EQ(reused.pairs, 0u);
      EXPECT_EQ(reused.shadowRays, 0u);
      for (size_t i = 0; i < pts->size(); ++i)
        if (again[i]) {
          EXPECT_EQ(geo2[i].d2, geo[i].d2);
        }
    }
  std::printf("%zu visible and %zu rejected pairs agree\n", visibleSeen, blockedSeen);
  EXPECT_GT(visibleSeen, 10000u);
  EXPECT_GT(blockedSeen, 10000u);
}

// Each method's own clock (ManyLightStats): the gather's wall time less the
// other method's own transfer, so each is at most the wall time, together
// they cover it, and a method that is not computed costs the other nothing
// of its own. Invariants of the accounting, not timings.
TEST(ManyLight, EachMethodIsChargedItsOwnTime) {
  Loaded l = loadAsset("cornell-glossy");
  ManyLightSettings s;
  s.lights = 400;
  s.width = s.height = 16;
  s.batches = 2;
  ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
  ManyLightRenderer both(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
  for (int b = 0; b < both.batchCount(); ++b) ASSERT_TRUE(both.renderBatch(b));
  const ManyLightStats& st = both.stats();
  ASSERT_GT(st.gatherSeconds, 0);
  EXPECT_LE(st.vslSeconds, st.gatherSeconds);
  EXPECT_LE(st.vplSeconds, st.gatherSeconds);
  EXPECT_GE(st.vslSeconds + st.vplSeconds, st.gatherSeconds * (1 - 1e-9));
  s.computeVsl = false;
  ManyLightRenderer vplOnly(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
  for (int b = 0; b < vplOnly.batchCount(); ++b) ASSERT_TRUE(vplOnly.renderBatch(b));
  EXPECT_DOUBLE_EQ(vplOnly.stats().vplSeconds, vplOnly.stats().gatherSeconds);
}

// The pair roulette (ManyLightSettings::pairRoulette): VSL's share of a pair
// whose estimate from above (Gatherer::vslBound) is under the threshold is
// kept with probability bound / threshold and weighted by its inverse. On
// hall (metal lights and walls: most pairs carry almost nothing), over many
// seeds: the sum of the weighted contributions agrees with the sum without
// the roulette (a z-test on paired differences, the same quadrature streams),
// the estimate is at least the converged transfer for nearly every pair, and
// dropped pairs trace no ray.
TEST(ManyLightStats, PairRouletteIsUnbiasedAndDropsMostPairs) {
  Loaded l = loadAsset("hall", 24);
  ASSERT_TRUE(l.context);
  ManyLightSettings s;
  s.lights = 600;
  s.seed = 3;
  s.computeVpl = false;
  ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
  ASSERT_GT(run.set.lights.size(), 300u);
  Gatherer g0(*l.scene, *l.accel, *l.lights, s, 1.0f, true, false);
  const std::vector<EyeSample> eyes = eyeSamples(l, g0);
  std::vector<const GatherPoint*> pts;
  std::vector<uint64_t> streams;
  for (size_t pix = 0; pix < eyes.size(); ++pix) {
    pts.push_back(eyes[pix].point(0));
    streams.push_back(gatherStream(pix, 0));
  }
  std::vector<GatherLight> lights;
  for (size_t j = 0; j < run.set.lights.size(); j += 3)
    lights.push_back(decodeGatherLight(run.set.lights[j], run.radii[j]));
  // Every oriented pair's bound (the threshold below comes from them).
  std::vector<float> bounds;
  {
    GatherCounters c;
    for (size_t j = 0; j < lights.size(); j += 4)
      for (size_t i = 0; i < pts.size(); ++i) {
        PairGeometry geo;
        if (pts[i] && g0.connect(*pts[i], lights[j], geo, c)) bounds.push_back(g0.vslBound(*pts[i], lights[j], geo));
      }
  }
  ASSERT_GT(bounds.size(), 5000u);
  // The threshold: the 80th percentile of the bounds, so that most pairs play.
  std::sort(bounds.begin(), bounds.end());
  const float threshold = bounds[bounds.size() * 8 / 10];
  ASSERT_GT(threshold, 0.0f);
  std::vector<double> diff;
  uint64_t dropped = 0, played = 0, raysWith = 0, raysWithout = 0;
  for (int trial = 0; trial < 40; ++trial) {
    ManyLightSettings t = s;
    t.seed = 100 + uint64_t(trial);
    Gatherer g(*l.scene, *l.accel, *l.lights, t, 1.0f, true, false);
    Gatherer::ConnectScratch scratch;
    double with = 0, without = 0;
    for (size_t j = 0; j < lights.size(); ++j) {
      std::vector<PairGeometry> geo(pts.size()), geoPlain(pts.size());
      std::vector<uint8_t> vis(pts.size()), visPlain(pts.size());
      GatherCounters cw, cp;
      const PairRoulette roulette{threshold, uint64_t(j), streams.data()};
      g.connectMany(pts, lights[j], geo.data(), vis.data(), scratch, cw, {}, &roulette);
      g.connectMany(pts, lights[j], geoPlain.data(), visPlain.data(), scratch, cp);
      dropped += cw.rouletteDropped;
      raysWith += cw.shadowRays;
      raysWithout += cp.shadowRays;
      for (size_t i = 0; i < pts.size(); ++i) {
        if (vis[i]) {
          EXPECT_TRUE(visPlain[i]) << "the roulette only removes pairs";
        }
        if (vis[i] && geo[i].weight != 1) ++played;
        double a[kGatherLayers][3] = {}, b[kGatherLayers][3] = {};
        if (vis[i]) g.addVsl(*pts[i], lights[j], geo[i], j, streams[i], a, cw);
        if (visPlain[i]) g.addVsl(*pts[i], lights[j], geoPlain[i], j, streams[i], b, cp);
        for (int c = 0; c < 3; ++c) {
          with += a[kVslLayer][c];
          without += b[kVslLayer][c];
        }
      }
    }
    diff.push_back(with - without);
    if (trial == 0) std::printf("trial 0: with the roulette %.6g, without %.6g\n", with, without);
  }
  const auto [m, se] = meanAndError(diff);
  std::printf("roulette - plain: %.4g +- %.4g; %llu pairs dropped, %llu kept with a weight; rays %llu -> %llu\n", m, se,
              (unsigned long long)dropped, (unsigned long long)played, (unsigned long long)raysWithout,
              (unsigned long long)raysWith);
  EXPECT_LT(std::abs(m), 4 * se + 1e-12);
  EXPECT_GT(played, 0u);
  // Most pairs are under the threshold, and most of those are dropped, rays and all.
  EXPECT_LT(double(raysWith), 0.5 * double(raysWithout));
  // A dropped pair's ray is not traced (a pair whose ends coincide has none).
  EXPECT_LE(raysWithout - raysWith, dropped);
  EXPECT_GE(double(raysWithout - raysWith), 0.99 * double(dropped));
}

// Gatherer::vslBound is at least the pair's converged VSL contribution (256
// samples per strategy) on every bundled glossy scene: colours (gold walls,
// a red light), anisotropic metals (kitchen's range hood, tableau's panels),
// near-mirror dielectrics, lobe-gathered points and the lobe floor.
TEST(ManyLightStats, VslBoundIsAtLeastTheTransfer) {
  for (const char* name : {"hall", "kitchen", "tableau", "cornell-glossy"}) {
    Loaded l = loadAsset(name, 20);
    ASSERT_TRUE(l.context);
    ManyLightSettings s;
    s.lights = 300;
    s.seed = 4;
    s.computeVpl = false;
    s.vslSamples = 256;
    s.lobeGather = 1000;
    ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
    std::atomic<uint64_t> rejected{0};
    std::unique_ptr<LobeGatherMap> map = buildLobeGatherMap(*l.scene, *l.accel, *l.lights, s, nullptr, rejected);
    ASSERT_TRUE(map);
    Gatherer g(*l.scene, *l.accel, *l.lights, s, 1.0f, true, false, map.get());
    GatherCounters c;
    size_t under = 0, pairs = 0;
    double worst = 0;
    const std::vector<EyeSample> eyes = eyeSamples(l, g);
    for (size_t pix = 0; pix < eyes.size(); ++pix) {
      const EyeSample& es = eyes[pix];
      for (int k = 0; k < es.count; ++k) {
        const GatherPoint* gp = es.point(k);
        if (!gp) continue;
        for (size_t j = 0; j < run.set.lights.size(); j += 3) {
          const GatherLight L = decodeGatherLight(run.set.lights[j], run.radii[j]);
          PairGeometry geo;
          if (!g.connect(*gp, L, geo, c)) continue;
          const double b = g.vslBound(*gp, L, geo);
          double acc[kGatherLayers][3] = {};
          g.addVsl(*gp, L, geo, j, gatherStream(pix, k), acc, c);
          const double v = 0.2126 * acc[kVslLayer][0] + 0.7152 * acc[kVslLayer][1] + 0.0722 * acc[kVslLayer][2];
          ++pairs;
          if (b < 0.9 * v) ++under;
          if (v > 0) worst = std::max(worst, v / b);
        }
      }
    }
    std::printf("%s: bound under 0.9 x the transfer on %zu of %zu pairs (largest transfer / bound %.3g)\n", name, under,
                pairs, worst);
    EXPECT_GT(pairs, 3000u) << name;
    // The converged transfer still has a few percent of noise.
    EXPECT_EQ(under, 0u) << name;
    EXPECT_LT(worst, 1.1) << name;
  }
}

// The renderer plays the roulette from the second batch on, with the mean
// gathered pair of the batches before as its scale: fewer rays (and, for
// VSL, quadrature samples) for the same light set, each method's image mean
// kept, for VSL alone, clamped VPL alone and both from shared rays, and the
// images the same from run to run.
TEST(ManyLight, PairRouletteSavesRaysAndKeepsTheMean) {
  Loaded l = loadAsset("hall", 48);
  ASSERT_TRUE(l.context);
  ManyLightSettings s;
  s.lights = 1500;
  s.seed = 2;
  s.batches = 4;
  s.width = l.width;
  s.height = l.height;
  ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
  for (int which = 0; which < 3; ++which) {
    s.computeVsl = which != 1;
    s.computeVpl = which != 0;
    auto render = [&](float roulette, ManyLightImages& im) {
      ManyLightSettings t = s;
      t.pairRoulette = roulette;
      ManyLightRenderer r(*l.scene, *l.accel, *l.lights, run.set, run.radii, t);
      for (int b = 0; b < r.batchCount(); ++b) EXPECT_TRUE(r.renderBatch(b));
      EXPECT_EQ(r.stats().nonFinite.load(), 0u);
      im = r.images();
      return std::make_pair(r.stats().shadowRays.load(), r.stats().rouletteDropped.load());
    };
    ManyLightImages plain, played;
    const auto [raysPlain, droppedPlain] = render(0, plain);
    const auto [raysPlayed, droppedPlayed] = render(1, played);
    EXPECT_EQ(droppedPlain, 0u);
    EXPECT_GT(droppedPlayed, 0u);
    std::printf("VSL %d VPL %d: rays %llu -> %llu, VSL mean %.5f -> %.5f, VPL mean %.5f -> %.5f\n", s.computeVsl,
                s.computeVpl, (unsigned long long)raysPlain, (unsigned long long)raysPlayed, greyMean(plain.vsl),
                greyMean(played.vsl), greyMean(plain.vpl), greyMean(played.vpl));
    EXPECT_LT(double(raysPlayed), 0.7 * double(raysPlain));
    if (s.computeVsl) {
      EXPECT_NEAR(greyMean(played.vsl), greyMean(plain.vsl), 0.02 * greyMean(plain.vsl));
    }
    if (s.computeVpl) {
      EXPECT_NEAR(greyMean(played.vpl), greyMean(plain.vpl), 0.02 * greyMean(plain.vpl));
    }
    EXPECT_TRUE(allFinite(played.vsl) && allFinite(played.vpl) && allFinite(played.vplUnclamped));
    // The threshold is summed in pixel order: the same images again, whichever
    // thread finished its tiles first.
    ManyLightImages again;
    render(1, again);
    EXPECT_EQ(again.vsl.rgb, played.vsl.rgb);
    EXPECT_EQ(again.vplUnclamped.rgb, played.vplUnclamped.rgb);
  }
}

// ---- Lobe splitting ----------------------------------------------------------------

TEST(ManyLight, LobeRestrictionsSumToTheBrdfAndSampleTheirOwnPdf) {
  Rng rng(5, 1);
  for (float metallic : {0.0f, 0.5f, 1.0f})
    for (float roughness : {0.05f, 0.3f, 0.9f}) {
      Brdf b = Brdf::fromGltf(Vec3(0.7f, 0.5f, 0.3f), metallic, roughness, 0.6f);
      Vec3 wo = normalize(Vec3(0.3f, -0.2f, 0.8f));
      BrdfAt full(b, wo), d = full.diffuseLobe(), s = full.specularLobe();
      for (int i = 0; i < 200; ++i) {
        Vec3 wi = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
        Vec3 sum = d.eval(wi) + s.eval(wi), f = full.eval(wi);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(sum[k], f[k], 1e-5f * (1 + f[k]));
        for (const BrdfAt* lobe : {&d, &s}) {
          auto bs = lobe->sample(rng.uniform(), {rng.uniform(), rng.uniform()});
          if (!bs) continue;
          EXPECT_NEAR(bs->pdf, lobe->pdf(bs->wi), 1e-4f * bs->pdf);
          Vec3 fe = lobe->eval(bs->wi);
          for (int k = 0; k < 3; ++k) EXPECT_NEAR(bs->f[k], fe[k], 1e-5f * (1 + fe[k]));
        }
      }
      // The diffuse lobe never samples specular directions and vice versa.
      EXPECT_EQ(d.specularProbability(), 0.0f);
      EXPECT_EQ(s.specularProbability(), 1.0f);
    }
}

// Splitting every gather point by lobe (the specular lobe continues to a
// second gather point) changes how the image is estimated, not what: the
// unclamped VPL indirect image still converges to the path tracer's, and on
// the same light sets it agrees with gathering the whole BRDF (paired).
namespace {

// cornell-glossy with a mostly metal floor, so that most of what it reflects
// goes through the split-off specular lobe and dropping or double counting
// that lobe shows.
Loaded splitScene() {
  Loaded l = loadAsset("cornell-glossy");
  // (The scene is shared as const; nothing has rendered it yet.)
  for (Material& m : const_cast<Scene&>(*l.scene).materials)
    if (m.name == "glossy-floor") {
      m.metallic = 0.9f;
      m.baseColor = Vec3(0.9f);
    }
  return l;
}

void expectSplitUnbiased(const Loaded& l, uint64_t seed) {
  const int W = 16, H = 16, sets = 24;
  Reference ref = ptIndirect(l, W, H, 2048, 77);
  std::vector<double> means, diffs;
  int splitPixels = 0;
  for (int k = 0; k < sets; ++k) {
    ManyLightSettings s = vplOnly(W, H, 1500, seed + k);
    s.splitAlpha = 0.5f;  // glossy dielectrics split, the metal box continues whole
    ManyLightImages im = renderMany(l, s);
    s.splitAlpha = 0;
    ManyLightImages plain = renderMany(l, s);
    for (size_t i = 0; i < im.vplUnclamped.rgb.size(); ++i)
      splitPixels += im.vplUnclamped.rgb[i] != plain.vplUnclamped.rgb[i];
    means.push_back(greyMean(im.vplUnclamped));
    diffs.push_back(means.back() - greyMean(plain.vplUnclamped));
  }
  auto [m, se] = meanAndError(means);
  auto [dm, dse] = meanAndError(diffs);
  double z = (m - ref.mean) / std::sqrt(se * se + ref.se * ref.se), zd = dm / dse;
  std::printf("split VPL %.6f +- %.6f vs PT indirect %.6f +- %.6f (z = %.2f); split - whole %.6f +- %.6f (z = %.2f)\n",
              m, se, ref.mean, ref.se, z, dm, dse, zd);
  EXPECT_LT(std::abs(z), 4.0);
  EXPECT_LT(std::abs(zd), 4.0);
  EXPECT_GT(splitPixels, sets * W * H / 4);  // the setting reached the floor and box
}

}  // namespace

TEST(ManyLightStats, LobeSplittingKeepsUnclampedVplUnbiased) { expectSplitUnbiased(splitScene(), 2000); }

namespace {
// cornell-glossy's floor a near-mirror metal (alpha 0.01: eye paths continue)
// and its walls and ceiling ("white") glossy with the given metallic and
// roughness.
void setMirrorRoom(Scene& scene, float wallMetallic, float wallRoughness) {
  for (Material& m : scene.materials) {
    if (m.name == "white") {
      m.baseColor = Vec3(0.9f);
      m.metallic = wallMetallic;
      m.roughness = wallRoughness;
    }
    if (m.name == "glossy-floor") {
      m.baseColor = Vec3(0.9f);
      m.metallic = 1.0f;
      m.roughness = 0.1f;
    }
  }
}
// A point light of intensity 4 above the scene's centre.
void addPointLightAbove(Scene& scene) {
  PunctualLight p;
  p.position = scene.center() + Vec3(0, 0.4f * (scene.boundsMax.y - scene.center().y), 0);
  p.intensity = Vec3(4.0f);
  scene.punctualLights.push_back(p);
}
}  // namespace

// Eye path -> mirror floor (continued) -> glossy wall (split) -> point light:
// a continued ray can never hit a point light, so the wall's highlight in its
// split-off specular lobe must come from next-event light there. Nothing
// else emits and nothing is gathered, so the first gather point's own light
// is the wall's direct light alone, which splitting must not change (the
// split-off point's light is the next bounce, which gathering would add).
TEST(ManyLightStats, LobeSplittingKeepsPunctualLightsBehindMirrors) {
  Loaded l = loadAsset("cornell-glossy");
  Scene& scene = const_cast<Scene&>(*l.scene);  // not rendered yet
  for (Material& m : scene.materials) {
    m.emission = Vec3(0.0f);
    m.baseColor = Vec3(0.0f);
  }
  setMirrorRoom(scene, 0.9f, 0.15f);  // back wall and ceiling: mostly metal, glossy
  addPointLightAbove(scene);
  LightSampler lights(scene);
  const int W = 16, H = 16, samples = 400;
  // Per eye path, paired: the same random numbers drive both runs up to the
  // wall, so the difference isolates what splitting changes there.
  auto run = [&](float splitAlpha, int* splits) {
    ManyLightSettings s;
    s.splitAlpha = splitAlpha;
    Gatherer g(scene, *l.accel, lights, s, 1.0f, false, false);
    GatherCounters c;
    std::vector<double> values;
    for (int y = H / 2; y < H; ++y)
      for (int x = 0; x < W; ++x)
        for (int i = 0; i < samples; ++i) {
          Rng rng = Rng::forItem(uint64_t(y * W + x), uint64_t(i), 11, 0);
          EyeSample es = g.eyePath(x, y, W, H, rng, c);
          *splits += es.count > 1;
          values.push_back(luminance(es.points[0].shared));  // not the split-off point's
        }
    return values;
  };
  int splitsOff = 0, splitsOn = 0;
  std::vector<double> whole = run(0.0f, &splitsOff);
  std::vector<double> split = run(0.05f, &splitsOn);  // the walls (alpha 0.0225) split, the box (0.0625) gathers
  double mw = 0, md = 0, vd = 0;
  const double n = double(whole.size());
  for (size_t i = 0; i < whole.size(); ++i) {
    mw += whole[i] / n;
    md += (split[i] - whole[i]) / n;
  }
  for (size_t i = 0; i < whole.size(); ++i) vd += sqr(split[i] - whole[i] - md) / (n - 1);
  double z = md / std::max(std::sqrt(vd / n), 1e-12 * mw);
  std::printf("walls seen in the mirror: whole %.6f, split - whole %.3g +- %.3g (z = %.2f; %d split eye paths)\n", mw,
              md, std::sqrt(vd / n), z, splitsOn);
  EXPECT_GT(mw, 0.0);
  EXPECT_EQ(splitsOff, 0);
  EXPECT_GT(splitsOn, W * H / 8 * samples);
  EXPECT_LT(std::abs(z), 4.0);
}

// The shared light (what eye paths find behind specular chains) from several
// eye paths per pixel (Gatherer::sharedLight): the same mean as one eye path
// with all of kSharedLightSamples next-event samples, and less variance per
// pixel, where a mirror floor reflects glossy walls lit by a point light (the
// highlight a pixel's footprint reflects only in part: tableau's pot rims).
// Then with lobe splitting on the walls, seen directly and in the mirror:
// the split-off point's light must be in every eye path's share (a path
// traced for the shared light alone ends early only at an unsplit first
// point).
TEST(ManyLightStats, SharedLightFromSeveralEyePathsIsUnbiasedAndLessNoisy) {
  Loaded l = loadAsset("cornell-glossy");
  Scene& scene = const_cast<Scene&>(*l.scene);                  // not rendered yet
  for (Material& m : scene.materials) m.emission = Vec3(0.0f);  // the point light alone, for the sampler below
  addPointLightAbove(scene);
  LightSampler lights(scene);
  const int W = 16, H = 16, trials = 300;
  // Over pixel rows [y0, H) and independent trials: the mean and its
  // standard error, and the mean per-pixel variance, with `paths` eye paths.
  auto run = [&](const Gatherer& g, int y0, int paths, double& mean, double& variance, double& se) {
    GatherCounters c;
    std::vector<double> all;
    variance = 0;
    for (int y = y0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        double m = 0, m2 = 0;
        for (int i = 0; i < trials; ++i) {
          Rng rng = Rng::forItem(uint64_t(y * W + x), uint64_t(i), 12, uint64_t(paths));
          const EyeSample es = g.eyePath(x, y, W, H, rng, c, Gatherer::eyePathOptions(paths));
          const double v = luminance(g.sharedLight(es, paths, x, y, W, H, uint64_t(i) + 1000 * uint64_t(paths), c));
          all.push_back(v);
          m += v / trials;
          m2 += v * v / trials;
        }
        variance += (m2 - m * m) * trials / (trials - 1.0);
      }
    variance /= W * (H - y0);
    std::tie(mean, se) = meanAndError(all);
    EXPECT_EQ(c.nonFinite, 0u);
  };
  {
    setMirrorRoom(scene, 1.0f, 0.4f);  // glossy metal walls
    ManyLightSettings s;
    Gatherer g(scene, *l.accel, lights, s, 1.0f, false, false);
    double m1, v1, se1, m4, v4, se4;
    run(g, H / 2, 1, m1, v1, se1);  // the floor
    run(g, H / 2, 4, m4, v4, se4);
    const double z = (m4 - m1) / std::sqrt(se1 * se1 + se4 * se4);
    std::printf(
        "shared light: 1 eye path %.6f +- %.6f (variance %.3g), 4 eye paths %.6f +- %.6f (variance %.3g), z = "
        "%.2f, variance ratio %.3f\n",
        m1, se1, v1, m4, se4, v4, z, v4 / v1);
    EXPECT_GT(m1, 0.0);
    EXPECT_LT(std::abs(z), 4.0);
    EXPECT_LT(v4, 0.6 * v1) << "four eye paths per pixel should cut the variance (about 0.34x here)";
  }
  {
    setMirrorRoom(scene, 0.9f, 0.15f);  // mostly metal, alpha 0.0225: split at 0.05
    ManyLightSettings s;
    s.splitAlpha = 0.05f;
    Gatherer g(scene, *l.accel, lights, s, 1.0f, false, false);
    double m1, v1, se1, m4, v4, se4;
    run(g, 0, 1, m1, v1, se1);  // the whole image
    run(g, 0, 4, m4, v4, se4);
    const double z = (m4 - m1) / std::sqrt(se1 * se1 + se4 * se4);
    std::printf("shared light with split walls: 1 eye path %.6f +- %.6f, 4 eye paths %.6f +- %.6f, z = %.2f\n", m1, se1,
                m4, se4, z);
    EXPECT_GT(m1, 0.0);
    EXPECT_LT(std::abs(z), 4.0);
  }
}

// ---- The lobe gather (core/lobe_gather.h) --------------------------------------------

namespace {
// A square grid of lights on the plane z = zPlane, spacing h, each with flux
// Phi, facing +z or -z, on a Lambertian surface of albedo rho (or a pure
// metal), arrived along the normal.
// n x n lights of flux Phi on the plane z = zPlane, one per h x h cell: on
// the grid's points, or (random) uniformly over the whole square (seed), as
// light tracing places them.
void addLightGrid(VirtualLightSet& set, int n, float h, float zPlane, bool up, float Phi, float rho, bool metal,
                  uint64_t randomSeed = 0) {
  const Vec3 nrm(0, 0, up ? 1.0f : -1.0f);
  Rng rng(randomSeed, 5);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      VirtualLight v{};
      v.p = randomSeed ? Vec3((rng.uniform() - 0.5f) * n * h, (rng.uniform() - 0.5f) * n * h, zPlane)
                       : Vec3((i - n / 2) * h, (j - n / 2) * h, zPlane);
      v.Phi = Vec3(Phi);
      v.n = v.ng = v.wi = encodeUnit(nrm);
      v.s = encodeUnit(Vec3(1, 0, 0));
      const uint16_t base = uint16_t(std::lround((metal ? 0.9f : rho) * 65535.0f));
      v.base[0] = v.base[1] = v.base[2] = base;
      v.metallic = metal ? 65535 : 0;
      v.roughX = v.roughY = 65535;  // roughness 1
      v.specular = 0;               // no specular lobe on the dielectric
      v.depth = 1;
      set.lights.push_back(v);
    }
}
}  // namespace

// The density estimate on a uniform Lambertian plane of lights is the
// analytic radiance Phi / h^2 x rho / pi, in every direction above it, and
// stays so with a second plane of lights on the back of a thin sheet (about
// half of the k nearest lights, facing away, are left out, and the radius
// still counts them: the front's density is unchanged). Nothing leaves the
// back side toward the front, and a metal's diffuse lobe is empty.
// The lights are placed at random, as light tracing places them: the mean
// over eight independent planes of 40,000 lights and 500 points each is
// within 2% (its own noise, mostly the planes' realised densities: about
// 0.4%); with the k-th light counted in the sum it would be k / (k - 1)
// high, 3.2% at k = 32.
TEST(LobeGather, DensityEstimateIsTheAnalyticRadianceOfAUniformPlane) {
  const int n = 200;
  const float h = 0.01f, Phi = 2e-4f, rho = 0.5f;
  const double expected = Phi / (h * h) * rho / M_PI;
  const Vec3 up(0, 0, 1);
  const std::vector<Vec3> dirs = {Vec3(0, 0, 1), normalize(Vec3(0.7f, 0.2f, 0.4f)), normalize(Vec3(-0.2f, 0.9f, 0.1f))};
  const int planes = 8;
  std::vector<double> front(dirs.size(), 0.0), sheet(dirs.size(), 0.0);
  double back = 0;
  for (int k = 0; k < planes; ++k) {
    VirtualLightSet f;
    addLightGrid(f, n, h, 0.0f, true, Phi, rho, false, 11 + 2 * k);
    VirtualLightSet both = f;
    addLightGrid(both, n, h, -0.004f, false, Phi, rho, false, 12 + 2 * k);
    LobeGatherMap mf(f, ManyLightSettings::kLobeGatherK), mb(both, ManyLightSettings::kLobeGatherK);
    Rng rng(3, uint64_t(k));
    for (int q = 0; q < 500; ++q) {  // in the square's central half
      const float x = (rng.uniform() - 0.5f) * 0.5f * n * h, y = (rng.uniform() - 0.5f) * 0.5f * n * h;
      for (size_t d = 0; d < dirs.size(); ++d) {
        const Vec3 L = mf.radiance(Vec3(x, y, 0.0f), up, dirs[d], false);
        front[d] += L.y / (planes * 500.0);
        sheet[d] += mb.radiance(Vec3(x, y, 0.0f), up, dirs[d], false).y / (planes * 500.0);
        if (q == 0) {
          EXPECT_FLOAT_EQ(mf.radiance(Vec3(x, y, 0.0f), up, dirs[d], true).y, L.y)
              << "a Lambertian light is all diffuse lobe";
        }
      }
      back += mb.radiance(Vec3(x, y, -0.004f), -up, -up, false).y / (planes * 500.0);
    }
    EXPECT_EQ(mb.radiance(Vec3(0, 0, 0), up, Vec3(0, 0, -1), false).y, 0.0f) << "below the surface";
  }
  for (size_t d = 0; d < dirs.size(); ++d) {
    EXPECT_NEAR(front[d], expected, 0.02 * expected) << "direction " << d;
    EXPECT_NEAR(sheet[d], expected, 0.02 * expected) << "direction " << d << ", a sheet's front";
  }
  EXPECT_NEAR(back, expected, 0.02 * expected) << "the back's own radiance, from its own lights";
  std::printf("density estimate / analytic: front %.4f, a sheet's front %.4f, its back %.4f\n", front[0] / expected,
              sheet[0] / expected, back / expected);
  VirtualLightSet metal;
  addLightGrid(metal, 40, h, 0.0f, true, Phi, rho, true);
  LobeGatherMap metalMap(metal, 64);
  EXPECT_GT(metalMap.radiance(Vec3(0, 0, 0), up, up, false).y, 0.0f);
  EXPECT_EQ(metalMap.radiance(Vec3(0, 0, 0), up, up, true).y, 0.0f) << "a metal has no diffuse lobe";
  EXPECT_EQ(LobeGatherMap(VirtualLightSet{}, 8).radiance(Vec3(0, 0, 0), up, up, false).y, 0.0f);
}

// The map widens its indirect lights' lobes to LobeGatherMap::
// kIndirectAlphaFloor on each axis (a first-hit light keeps its own, a wide
// lobe stays as it is), and its estimate on a uniform plane of narrow metal
// lights is then the analytic radiance with the widened lobe: Phi / h^2 x
// f(wi, wo) (grid lights: within 5%). Seen in the mirror direction, the
// first-hit plane's radiance is that of its own narrow lobe, 10-100x higher.
// An estimate asked for lobes at least kLobeGatherChainAlpha wide (past a
// narrow landing surface) is the analytic radiance with those lobes.
TEST(LobeGather, IndirectLightsLobesAreWidenedFirstHitsKept) {
  const float h = 0.01f, Phi = 2e-4f, a = LobeGatherMap::kIndirectAlphaFloor;
  const Vec3 up(0, 0, 1), wi = normalize(Vec3(0.3f, 0.1f, 1.0f));
  const Vec3 mirror(-wi.x, -wi.y, wi.z);
  auto plane = [&](int depth, float alphaX, float alphaY) {
    VirtualLightSet set;
    addLightGrid(set, 40, h, 0.0f, true, Phi, 0.5f, true);
    for (VirtualLight& v : set.lights) {
      v.wi = encodeUnit(wi);
      v.roughX = uint16_t(std::lround(std::sqrt(alphaX) * 65535.0f));
      v.roughY = uint16_t(std::lround(std::sqrt(alphaY) * 65535.0f));
      v.depth = uint16_t(depth);
    }
    return set;
  };
  struct Case {
    int depth;
    float ax, ay;        // the lights' own lobe
    float wantX, wantY;  // in the map
  };
  const Case cases[] = {{1, 0.01f, 0.01f, 0.01f, 0.01f},
                        {2, 0.01f, 0.01f, a, a},
                        {5, 0.01f, 0.01f, a, a},
                        {2, 0.5f, 0.02f, 0.5f, a},
                        {3, 0.3f, 0.2f, 0.3f, 0.2f}};
  std::vector<double> mirrorRadiance;
  for (const Case& k : cases) {
    const VirtualLightSet set = plane(k.depth, k.ax, k.ay);
    const LobeGatherMap map(set, ManyLightSettings::kLobeGatherK);
    for (size_t i = 0; i < map.size(); i += 97) {
      const Brdf b = map.light(i).em.f.brdf();
      EXPECT_NEAR(b.ggx.ax, k.wantX, 2e-4f) << "depth " << k.depth << ", alpha " << k.ax;
      EXPECT_NEAR(b.ggx.ay, k.wantY, 2e-4f) << "depth " << k.depth << ", alpha " << k.ay;
      EXPECT_NEAR(map.light(i).alpha, std::min(k.wantX, k.wantY), 2e-4f);
    }
    // The analytic radiance of the plane with the map's lobe.
    Brdf want = set.lights[0].brdf();
    want.ggx.ax = std::max(want.ggx.ax, k.wantX);
    want.ggx.ay = std::max(want.ggx.ay, k.wantY);
    const Frame frame = set.lights[0].frame();
    for (const Vec3& wo : {mirror, normalize(Vec3(0.1f, -0.4f, 1.0f))}) {
      const double expected = Phi / (h * h) * want.eval(frame.toLocal(wi), frame.toLocal(wo)).y;
      const double got = map.radiance(Vec3(0.0005f, 0.0003f, 0.0f), up, wo, false).y;
      EXPECT_NEAR(got, expected, 0.05 * expected) << "depth " << k.depth << ", alpha " << k.ax << ", " << k.ay;
      // Past a narrow landing surface (Gatherer::lobeGather): every light's
      // lobe at least ManyLightSettings::kLobeGatherChainAlpha wide.
      const float c = ManyLightSettings::kLobeGatherChainAlpha;
      Brdf chained = want;
      chained.ggx.ax = std::max(chained.ggx.ax, c);
      chained.ggx.ay = std::max(chained.ggx.ay, c);
      const double expectedC = Phi / (h * h) * chained.eval(frame.toLocal(wi), frame.toLocal(wo)).y;
      const double gotC = map.radiance(Vec3(0.0005f, 0.0003f, 0.0f), up, wo, false, c).y;
      EXPECT_NEAR(gotC, expectedC, 0.05 * expectedC) << "chain, depth " << k.depth << ", alpha " << k.ax;
    }
    mirrorRadiance.push_back(map.radiance(Vec3(0.0005f, 0.0003f, 0.0f), up, mirror, false).y);
  }
  EXPECT_GT(mirrorRadiance[0], 10.0 * mirrorRadiance[1]) << "a first-hit light's narrow lobe is kept";
}

// The context's kept lobe-gather map (LobeGatherCache): reused where the
// lobe gather's light count, seed and depth agree (other settings may
// differ), rebuilt where they do not (one map kept), never kept when its
// build was stopped, and a render with the reused map is bit for bit the
// render with a map of its own.
TEST(LobeGather, KeptMapIsReusedOnlyWhereTheSettingsAgree) {
  Loaded l = loadAsset("tableau", 24);
  ASSERT_TRUE(l.context);
  LobeGatherCache cache;
  ManyLightSettings s;
  s.width = l.width;
  s.height = l.height;
  s.lights = 200;
  s.seed = 5;
  s.lobeGather = 3000;
  s.lobeGatherRays = 4;
  s.batches = 2;
  s.directSamples = 1;
  std::atomic<uint64_t> nf1{0}, nf2{0};
  const std::shared_ptr<const LobeGatherMap> a = cache.get(*l.scene, *l.accel, *l.lights, s, nullptr, nf1);
  ASSERT_TRUE(a);
  EXPECT_EQ(cache.builds(), 1u);
  ManyLightSettings other = s;  // what the map does not depend on
  other.lights = 400;
  other.radiusScale = 2.0f;
  other.lobeGatherRays = 16;
  other.batches = 4;
  EXPECT_EQ(cache.get(*l.scene, *l.accel, *l.lights, other, nullptr, nf2).get(), a.get());
  EXPECT_EQ(cache.builds(), 1u);
  EXPECT_EQ(nf1.load(), nf2.load()) << "a reused map reports its rejected lights again";
  for (int change = 0; change < 3; ++change) {
    ManyLightSettings t = s;
    if (change == 0) t.seed = 6;
    if (change == 1) t.lobeGather = 3001;
    if (change == 2) t.lightMaxDepth = 3;
    const uint64_t before = cache.builds();
    const std::shared_ptr<const LobeGatherMap> b = cache.get(*l.scene, *l.accel, *l.lights, t, nullptr, nf2);
    ASSERT_TRUE(b);
    EXPECT_NE(b.get(), a.get()) << "change " << change;
    EXPECT_EQ(cache.builds(), before + 1) << "change " << change;
  }
  ManyLightSettings none = s;
  none.lobeGather = 0;
  EXPECT_FALSE(cache.get(*l.scene, *l.accel, *l.lights, none, nullptr, nf2));
  std::atomic<bool> stop{true};
  const uint64_t before = cache.builds();
  EXPECT_FALSE(cache.get(*l.scene, *l.accel, *l.lights, s, &stop, nf2)) << "a stopped build gives no map";
  EXPECT_EQ(cache.builds(), before);
  const std::shared_ptr<const LobeGatherMap> again = cache.get(*l.scene, *l.accel, *l.lights, s, nullptr, nf2);
  ASSERT_TRUE(again);
  EXPECT_EQ(cache.builds(), before + 1) << "nor keeps one";
  // Renders: with a map of its own, then twice through the cache (built, then
  // reused with other settings in between).
  const ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
  auto render = [&](LobeGatherCache* c) {
    ManyLightRenderer r(*l.scene, *l.accel, *l.lights, run.set, run.radii, s, nullptr, c);
    for (int b = 0; b < r.batchCount(); ++b) EXPECT_TRUE(r.renderBatch(b));
    return r.images().vsl;
  };
  LobeGatherCache fresh;
  const Image own = render(nullptr), first = render(&fresh);
  fresh.get(*l.scene, *l.accel, *l.lights, other, nullptr, nf2);
  const Image reused = render(&fresh);
  EXPECT_EQ(fresh.builds(), 1u);
  double sum = 0;
  for (size_t i = 0; i < own.rgb.size(); ++i) {
    EXPECT_EQ(own.rgb[i], first.rgb[i]) << i;
    EXPECT_EQ(own.rgb[i], reused.rgb[i]) << i;
    sum += own.rgb[i];
  }
  EXPECT_GT(sum, 0.0);
}

// The map keeps its lights in an order of its own (Morton order, for the
// cache): the estimate must not depend on the order the lights come in. The
// lights carry different fluxes, so a different neighbour set would show.
TEST(LobeGather, EstimateDoesNotDependOnTheLightsOrder) {
  VirtualLightSet a;
  addLightGrid(a, 60, 0.01f, 0.0f, true, 2e-4f, 0.5f, false, 21);
  Rng rng(7, 1);
  for (VirtualLight& v : a.lights) v.Phi = Vec3(1e-4f + 4e-4f * rng.uniform());
  VirtualLightSet b = a;
  std::shuffle(b.lights.begin(), b.lights.end(), std::mt19937(5));
  ASSERT_NE(a.lights[0].p.x, b.lights[0].p.x) << "the copy is shuffled";
  const LobeGatherMap ma(a, ManyLightSettings::kLobeGatherK), mb(b, ManyLightSettings::kLobeGatherK);
  const Vec3 up(0, 0, 1);
  double sum = 0;
  for (int q = 0; q < 200; ++q) {
    const Vec3 z((rng.uniform() - 0.5f) * 0.6f, (rng.uniform() - 0.5f) * 0.6f, 0.0f);
    const Vec3 w = normalize(Vec3(rng.uniform() - 0.5f, rng.uniform() - 0.5f, 0.3f + rng.uniform()));
    const float la = ma.radiance(z, up, w, false).y;
    EXPECT_FLOAT_EQ(la, mb.radiance(z, up, w, false).y) << "query " << q;
    sum += la;
  }
  EXPECT_GT(sum, 0.0);
}

// LobeGatherMap::radiance (packed records, eight lights to a register)
// equals its scalar definition, summed from nearest() and light() in the
// order found, bit for bit: random lights of every kind (metals,
// dielectrics, anisotropic, narrow to rough, first hits and indirect ones,
// some facing away), the full BRDF and the diffuse lobe alone, the lobes as
// kept, widened to the chains' alpha (kept packed) and to other alphas
// (widened per query).
TEST(LobeGather, EstimateEqualsItsScalarDefinition) {
  Rng rng(21, 3);
  auto direction = [&](float zMin) {
    for (;;) {
      const Vec3 v(2 * rng.uniform() - 1, 2 * rng.uniform() - 1, 2 * rng.uniform() - 1);
      const float l = length(v);
      if (l > 0.1f && l < 1 && v.z / l >= zMin) return v / l;
    }
  };
  auto unorm = [](float x) { return uint16_t(std::lround(std::clamp(x, 0.0f, 1.0f) * 65535.0f)); };
  VirtualLightSet set;
  for (int i = 0; i < 6000; ++i) {
    VirtualLight v{};
    v.p = Vec3(rng.uniform(), rng.uniform(), 0.03f * rng.uniform());
    const Vec3 n = normalize(Vec3(0.3f * (rng.uniform() - 0.5f), 0.3f * (rng.uniform() - 0.5f), 1.0f));
    v.n = v.ng = encodeUnit(rng.uniform() < 0.1f ? -n : n);
    v.s = encodeUnit(normalize(cross(n, Vec3(0, 1, 0))));
    v.wi = encodeUnit(direction(0.05f));
    v.Phi = Vec3(rng.uniform(), rng.uniform(), rng.uniform()) * 1e-3f;
    for (uint16_t& b : v.base) b = unorm(rng.uniform());
    const float u = rng.uniform();
    v.metallic = unorm(u < 0.35f ? 0.0f : u < 0.7f ? 1.0f : rng.uniform());
    v.roughX = unorm(rng.uniform() < 0.3f ? 0.15f * rng.uniform() : rng.uniform());
    v.roughY = rng.uniform() < 0.5f ? v.roughX : unorm(rng.uniform());
    v.specular = unorm(rng.uniform() < 0.1f ? 0.0f : 1.0f);
    v.depth = uint16_t(1 + rng.uniformInt(3));
    set.lights.push_back(v);
  }
  const int k = ManyLightSettings::kLobeGatherK;
  const LobeGatherMap map(set, k);
  auto scalar = [&](const Vec3& z, const Vec3& nz, const Vec3& wOut, bool diffuseOnly, float minAlpha) {
    uint32_t idx[64];
    float d2[64];
    const size_t found = map.nearest(z, size_t(k), idx, d2);
    if (found == 0 || !(d2[found - 1] > 0)) return Vec3(0.0f);
    Vec3 sum(0.0f);
    for (size_t i = 0; i + 1 < found; ++i) {
      const GatherLight& L = map.light(idx[i]);
      if (!(dot(L.ng, nz) >= 0.5f) || !(dot(L.n, wOut) > 0) || !(dot(L.ng, wOut) > 0)) continue;
      VslEmitter wide;
      const VslEmitter& em = !diffuseOnly && L.alpha < minAlpha && widenLobeTo(L.em, minAlpha, wide) ? wide : L.em;
      const BrdfAt::Parts p = em.f.evalParts(em.frame.toLocal(wOut));
      sum += L.Phi * (diffuseOnly ? p.diffuse : p.total());
    }
    return sum / float(kPi * d2[found - 1]);
  };
  int compared = 0, nonZero = 0, widened = 0;
  for (int q = 0; q < 1500; ++q) {
    const Vec3 z(rng.uniform(), rng.uniform(), 0.03f * rng.uniform());
    const Vec3 wOut = direction(0.0f), nz(0, 0, 1);
    for (bool diffuseOnly : {false, true})
      for (float minAlpha : {0.0f, ManyLightSettings::kLobeGatherChainAlpha, 0.05f, 0.3f}) {
        const Vec3 got = map.radiance(z, nz, wOut, diffuseOnly, minAlpha);
        const Vec3 want = scalar(z, nz, wOut, diffuseOnly, minAlpha);
        ASSERT_EQ(std::memcmp(&got, &want, sizeof got), 0)
            << "query " << q << " diffuse only " << diffuseOnly << " minAlpha " << minAlpha << ": " << got.y
            << " against " << want.y;
        ++compared;
        nonZero += want.y > 0;
        widened += minAlpha == 0.3f && !diffuseOnly && got.y != map.radiance(z, nz, wOut, false, 0.0f).y;
      }
  }
  EXPECT_EQ(compared, 12000);
  EXPECT_GT(nonZero, 9000);  // most estimates see lights
  EXPECT_GT(widened, 1000);  // and widening changes them
}

// The map answers most queries from the candidate list of the light nearest
// to the query (each light's 2k nearest) and falls back to its tree where
// that list might miss one: either way the k nearest lights must be exactly
// the brute-force answer. The lights: a random plane, a second one just
// behind it (a thin sheet's back), a dense cluster and a sparse line, so that
// densities change abruptly; the queries: on and off the planes, in the
// cluster, and far from every light (where the list cannot be trusted).
TEST(LobeGather, NearestLightsAreTheBruteForceAnswer) {
  VirtualLightSet set;
  addLightGrid(set, 40, 0.01f, 0.0f, true, 2e-4f, 0.5f, false, 31);
  addLightGrid(set, 30, 0.01f, -0.004f, false, 2e-4f, 0.5f, false, 32);
  Rng rng(9, 2);
  for (int i = 0; i < 300; ++i) {  // a dense cluster
    VirtualLight v = set.lights[0];
    v.p = Vec3(0.1f + 0.004f * rng.uniform(), 0.05f + 0.004f * rng.uniform(), 0.02f * rng.uniform());
    set.lights.push_back(v);
  }
  for (int i = 0; i < 50; ++i) {  // a sparse line
    VirtualLight v = set.lights[0];
    v.p = Vec3(-0.3f + 0.012f * float(i), 0.25f, 0.1f);
    set.lights.push_back(v);
  }
  const LobeGatherMap map(set, ManyLightSettings::kLobeGatherK);
  ASSERT_EQ(map.size(), set.lights.size());
  std::vector<std::pair<float, uint32_t>> all(map.size());
  std::vector<uint32_t> idx(128);
  std::vector<float> d2(128);
  auto d2To = [&](const Vec3& z, size_t i) {
    const Vec3 p = map.light(i).p;
    const float dx = p.x - z.x, dy = p.y - z.y, dz = p.z - z.z;
    return dx * dx + dy * dy + dz * dz;
  };
  int checked = 0, fromList32 = 0, fromTree32 = 0;
  for (int q = 0; q < 700; ++q) {
    Vec3 z;
    if (q < 600) {
      const float spread = q < 400 ? 0.25f : (q < 500 ? 0.005f : 3.0f);
      const Vec3 c = q >= 400 && q < 500 ? Vec3(0.102f, 0.052f, 0.01f) : Vec3(0.0f);
      z = c + Vec3((rng.uniform() - 0.5f) * 2 * spread, (rng.uniform() - 0.5f) * 2 * spread,
                   q % 3 == 0 ? 0.0f : (rng.uniform() - 0.5f) * 0.2f * spread);
    } else {  // at a light, or just beside it
      z = map.light(size_t(rng.uniform() * float(map.size() - 1))).p + Vec3(q % 2 ? 0.0f : 1e-4f, 0.0f, 0.0f);
    }
    for (size_t i = 0; i < map.size(); ++i) all[i] = {d2To(z, i), uint32_t(i)};
    std::sort(all.begin(), all.end());
    for (size_t k : {size_t(1), size_t(5), size_t(32), size_t(64), size_t(65), size_t(128)}) {
      bool fromList = false;
      const size_t found = map.nearest(z, k, idx.data(), d2.data(), &fromList);
      ASSERT_EQ(found, k);
      if (k == 32) ++(fromList ? fromList32 : fromTree32);
      std::vector<uint32_t> got(idx.begin(), idx.begin() + long(k)), want;
      for (size_t j = 0; j < k; ++j) {
        want.push_back(all[j].second);
        EXPECT_EQ(d2[j], d2To(z, idx[j])) << "query " << q << ", k = " << k << ": each distance its light's";
        EXPECT_LE(d2[j], d2[k - 1]) << "query " << q << ", k = " << k << ": the farthest last";
      }
      EXPECT_EQ(d2[k - 1], all[k - 1].first) << "query " << q << ", k = " << k << ": r_k";
      std::sort(got.begin(), got.end());
      std::sort(want.begin(), want.end());
      EXPECT_EQ(got, want) << "query " << q << ", k = " << k;
      ++checked;
    }
  }
  // Both ways of answering were taken (the list for most queries near the
  // lights, the tree far from them).
  std::printf("k = 32: %d queries answered from the candidate lists, %d from the tree\n", fromList32, fromTree32);
  EXPECT_GT(fromList32, 250);
  EXPECT_GT(fromTree32, 100);
  EXPECT_EQ(checked, 4200);
  // Fewer lights than the list: every light is every light's candidate.
  VirtualLightSet small;
  addLightGrid(small, 6, 0.01f, 0.0f, true, 2e-4f, 0.5f, false, 33);
  const LobeGatherMap few(small, ManyLightSettings::kLobeGatherK);
  bool fromList = false;
  EXPECT_EQ(few.nearest(Vec3(5, 5, 5), 32, idx.data(), d2.data(), &fromList), size_t(32));
  EXPECT_TRUE(fromList) << "a list that holds every light answers every query";
  EXPECT_EQ(few.nearest(Vec3(5, 5, 5), 100, idx.data(), d2.data()), size_t(36));
}

namespace {
// A polished floor (GGX alpha 0.029: gathered, not continued, and
// lobe-gathered) in front of a white Lambertian wall that an emitter behind
// the camera lights. The camera looks down at the floor, which reflects the
// lit wall. A metal floor's indirect light is all its narrow specular
// lobe's; a dielectric one's is also its diffuse lobe's, which the light set
// gathers. brushed: a metal floor brushed along x (GGX alpha 0.648 x 0.0225,
// as tableau's panels), narrow along one axis only.
std::shared_ptr<Scene> mirrorFloorRoom(bool metalFloor, bool brushed = false, float metalRoughness = 0.17f) {
  auto s = std::make_shared<Scene>();
  s->path = "<metal floor before a lit wall>";
  s->materials = {metalFloor ? testMaterial("metal", Vec3(0.9f), 1, brushed ? 0.15f : metalRoughness)
                             : testMaterial("glaze", Vec3(0.5f), 0, 0.17f),
                  testMaterial("wall", Vec3(0.8f), 0, 1, 0), emitterMaterial(Vec3(20.0f))};
  if (brushed) s->materials[0].anisotropyStrength = 0.8f;
  addQuad(*s, Vec3(-3, 0, 3), Vec3(6, 0, 0), Vec3(0, 0, -5), 0);           // floor y = 0, facing +y
  addQuad(*s, Vec3(-3, 0, -2), Vec3(6, 0, 0), Vec3(0, 3, 0), 1);           // wall z = -2, facing +z
  addQuad(*s, Vec3(-0.5f, 2.5f, 2.5f), Vec3(1, 0, 0), Vec3(0, -1, 0), 2);  // emitter z = 2.5, facing -z
  s->camera.position = Vec3(0, 1.0f, 1.5f);
  s->camera.forward = normalize(Vec3(0, -0.55f, -1));
  s->camera.right = Vec3(1, 0, 0);
  s->camera.up = cross(s->camera.right, s->camera.forward);
  s->camera.yfov = 0.9f;
  return s;
}

// Per value (pixel and colour) over independent renders: the mean and the
// unbiased sample variance.
struct RenderSpread {
  std::vector<double> mean, variance;
};
RenderSpread renderSpread(const std::vector<Image>& renders) {
  const double n = double(renders.size());
  RenderSpread r;
  r.mean.resize(renders[0].rgb.size());
  r.variance.resize(renders[0].rgb.size());
  for (size_t i = 0; i < r.mean.size(); ++i) {
    double m = 0, m2 = 0;
    for (const Image& im : renders) {
      const double v = im.rgb[i];
      m += v / n;
      m2 += v * v / n;
    }
    r.mean[i] = m;
    r.variance[i] = (m2 - m * m) * n / (n - 1.0);
  }
  return r;
}

// The lobe gather on mirrorFloorRoom's metal floor at 24 x 24: one direct
// sample, a second light set of 30,000 and eight lights (the floor's light
// is all the lobe gather's).
ManyLightSettings floorLobeGatherSettings() {
  ManyLightSettings s;
  s.width = s.height = 24;
  s.directSamples = 1;
  s.lobeGather = 30000;
  s.lights = 8;
  return s;
}

// The mean over colours of mirrorFloorRoom's floor: the image's lower half.
double floorMean(const Image& im) {
  double sum = 0;
  int count = 0;
  for (int y = im.height / 2; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x, ++count)
      for (int c = 0; c < 3; ++c) sum += im.rgb[(size_t(y) * im.width + x) * 3 + c] / 3.0;
  return sum / count;
}
}  // namespace

// In the renderer: off by default; on, clamped and unclamped VPL do not
// change and VSL does, and it keeps the light: over six light sets the mean
// of a narrow metal floor that reflects a lit wall (all of its indirect light
// is the lobe gather's there) is within 5% of the path tracer's and of the
// VSL gather's without the lobe gather (a wrong normalisation, a lost batch
// share or a double count would move it by far more).
TEST(ManyLightStats, LobeGatherChangesVslOnlyAndKeepsTheLight) {
  ManyLightSettings s;
  EXPECT_EQ(s.lobeGather, 0u) << "off by default";
  // The quadrature: the light checked is the lobe gather's, against VSL's
  // integral without the closed form's fit.
  s.vslIntegral = VslIntegral::Quadrature;
  s.lights = 1500;
  s.width = s.height = 24;
  s.batches = 2;
  s.directSamples = 1;
  for (int floor = 0; floor < 3; ++floor) {
    const bool metal = floor != 1, brushed = floor == 2;
    const char* name = brushed ? "brushed metal" : metal ? "metal" : "dielectric";
    SCOPED_TRACE(name);
    Loaded l = loadedFrom(mirrorFloorRoom(metal, brushed), 24);
    ASSERT_TRUE(l.context);
    double off = 0, on = 0, onFirst = 0;
    const int sets = 6;
    for (int k = 0; k < sets; ++k) {
      s.seed = 40 + k;
      s.lobeGather = 0;
      const ManyLightImages without = renderMany(l, s);
      s.lobeGather = 30000;
      // After the first batch too: each batch's estimate stands alone.
      ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
      ManyLightRenderer r(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
      ASSERT_TRUE(r.renderBatch(0));
      onFirst += floorMean(r.images().vsl) / sets;
      ASSERT_TRUE(r.renderBatch(1));
      EXPECT_EQ(r.stats().nonFinite.load(), 0u);
      const ManyLightImages with = r.images();
      if (k == 0) {
        EXPECT_EQ(with.vpl.rgb, without.vpl.rgb);
        EXPECT_EQ(with.vplUnclamped.rgb, without.vplUnclamped.rgb);
        EXPECT_NE(with.vsl.rgb, without.vsl.rgb);
        EXPECT_TRUE(allFinite(with.vsl));
        EXPECT_NE(s.describe().find("--lobe-gather 30000 --lobe-gather-rays " +
                                    std::to_string(ManyLightSettings::kDefaultLobeGatherRays)),
                  std::string::npos)
            << s.describe();
      }
      off += floorMean(without.vsl) / sets;
      on += floorMean(with.vsl) / sets;
    }
    const Reference ref = ptIndirect(l, 24, 24, 1024, 91);
    const double refFloor = floorMean(ref.indirect);
    std::printf(
        "the %s floor's indirect mean: VSL %.5f without the lobe gather, %.5f with (%.5f after one batch); "
        "path tracer %.5f\n",
        name, off, on, onFirst, refFloor);
    ASSERT_GT(refFloor, 0.0);
    EXPECT_NEAR(on, refFloor, 0.05 * refFloor);
    EXPECT_NEAR(on, off, 0.05 * off);
    EXPECT_NEAR(onFirst, on, 0.08 * on);
  }
  s.lobeGatherRays = 0;
  EXPECT_FALSE(s.validate());
  s.lobeGatherRays = 8;
  s.lobeGather = 60'000'000;
  EXPECT_FALSE(s.validate());
}

// The lobe gather's receiver threshold (ManyLightSettings::lobeGatherAlpha):
// a glossy metal floor (GGX alpha 0.09) is not lobe-gathered at the default
// 0.05 (the image is the one without the lobe gather, bit for bit) and is at
// 0.15, where all of its indirect light is the lobe gather's: over four
// light sets its mean is within 5% of the path tracer's and of VSL's without
// the lobe gather. Out-of-range thresholds are refused, and the settings'
// description names a threshold that is not the default.
TEST(ManyLightStats, LobeGatherAlphaChoosesTheReceivers) {
  Loaded l = loadedFrom(mirrorFloorRoom(true, false, 0.3f), 24);
  ASSERT_TRUE(l.context);
  ManyLightSettings s;
  EXPECT_EQ(s.lobeGatherAlpha, ManyLightSettings::kLobeGatherAlpha);
  s.lights = 1500;
  s.width = s.height = 24;
  s.batches = 2;
  s.directSamples = 1;
  s.lobeGatherRays = 32;
  double off = 0, wide = 0;
  const int sets = 4;
  for (int k = 0; k < sets; ++k) {
    s.seed = 60 + k;
    s.lobeGather = 0;
    const Image without = renderMany(l, s).vsl;
    s.lobeGather = 30000;
    s.lobeGatherAlpha = ManyLightSettings::kLobeGatherAlpha;
    EXPECT_EQ(renderMany(l, s).vsl.rgb, without.rgb) << "alpha 0.09 is not narrower than 0.05";
    s.lobeGatherAlpha = 0.15f;
    ASSERT_TRUE(s.validate());
    const Image with = renderMany(l, s).vsl;
    EXPECT_NE(with.rgb, without.rgb) << "the floor is lobe-gathered at 0.15";
    EXPECT_TRUE(allFinite(with));
    if (k == 0) {
      EXPECT_NE(s.describe().find(" --lobe-gather-alpha 0.15"), std::string::npos) << s.describe();
    }
    off += floorMean(without) / sets;
    wide += floorMean(with) / sets;
  }
  const Reference ref = ptIndirect(l, 24, 24, 1024, 93);
  const double refFloor = floorMean(ref.indirect);
  std::printf("glossy metal floor's indirect mean: VSL %.5f, lobe-gathered at alpha 0.15 %.5f; path tracer %.5f\n", off,
              wide, refFloor);
  ASSERT_GT(refFloor, 0.0);
  EXPECT_NEAR(wide, refFloor, 0.05 * refFloor);
  EXPECT_NEAR(wide, off, 0.05 * off);
  s.lobeGatherAlpha = ManyLightSettings::kLobeGatherAlpha;
  EXPECT_EQ(s.describe().find("--lobe-gather-alpha"), std::string::npos) << "the default is not named";
  // The range is the CLI's and the studio control's: [0.001, 1].
  for (float good : {ManyLightSettings::kMinLobeGatherAlpha, 1.0f}) {
    s.lobeGatherAlpha = good;
    EXPECT_TRUE(s.validate()) << good;
  }
  for (float bad : {0.0f, 0.0005f, -0.1f, 1.5f, std::nanf("")}) {
    s.lobeGatherAlpha = bad;
    EXPECT_FALSE(s.validate()) << bad;
  }
}

// The lobe gather's estimates do not depend on the batch's lights, so each
// batch's is weighted by its directions (ManyLightRenderer::lobeRays, as the
// eye paths' own light is by its eye paths), not by the batch's share of the
// lights: weighted by shares (1, 2, 4, 8, 16, 16, 16, 16 at eight batches)
// they had 1.4x the variance. On the metal floor all of VSL's indirect light
// is the lobe gather's, and its eye paths and second light set do not
// depend on the first set's size: eight batches of one light each (equal
// shares) and of 1,000 lights in growing batches give the same floor, which
// a share-weighted mean does not.
TEST(ManyLightStats, LobeGatherWeightsDoNotDependOnTheLightBatches) {
  Loaded l = loadedFrom(mirrorFloorRoom(true), 24);
  ASSERT_TRUE(l.context);
  ManyLightSettings s = floorLobeGatherSettings();
  s.batches = 8;
  s.lobeGatherRays = 4;
  s.seed = 5;
  const Image even = renderMany(l, s).vsl;
  s.lights = 1000;
  const Image growing = renderMany(l, s).vsl;
  double maxRel = 0, mean = 0;
  int count = 0;
  for (int y = 12; y < 24; ++y)
    for (int x = 0; x < 24; ++x)
      for (int c = 0; c < 3; ++c) {
        const float a = even.rgb[(size_t(y) * 24 + x) * 3 + c], b = growing.rgb[(size_t(y) * 24 + x) * 3 + c];
        mean += a;
        ++count;
        maxRel = std::max(maxRel, double(std::abs(a - b)) / std::max(1e-6, double(std::abs(a))));
      }
  mean /= count;
  std::printf("floor VSL mean %.5f, largest relative difference between the batchings %.2e\n", mean, maxRel);
  ASSERT_GT(mean, 0.0);
  EXPECT_LT(maxRel, 1e-4);
}

// The first of several batches takes an eighth of the lobe gather's
// directions and the others share the rest (ManyLightRenderer::lobeRays),
// and each batch's estimate is weighted by its directions: on the metal
// floor (all of its light the lobe gather's), two batches at 8 directions
// (1, then 15) have the per-pixel variance of one batch of 16 over eight
// seeds and the same mean; weighted equally they have several times it,
// and without the rest shared (1 + 8) 1.3x. (Few directions, so that theirs
// and not the second light set's is most of the variance; the two-batch run
// also has two eye samples per pixel, which on this smooth floor add little.)
TEST(ManyLightStats, LobeGatherFirstBatchTakesFewerDirectionsWeighted) {
  Loaded l = loadedFrom(mirrorFloorRoom(true), 24);
  ASSERT_TRUE(l.context);
  ManyLightSettings s = floorLobeGatherSettings();
  const int seeds = 8;
  // The floor's (the lower half's) mean and mean per-value variance.
  auto stats = [&](int batches, int rays, double& mean) {
    s.batches = batches;
    s.lobeGatherRays = rays;
    std::vector<Image> ims;
    for (int k = 0; k < seeds; ++k) {
      s.seed = 300 + uint64_t(k);
      ims.push_back(renderMany(l, s).vsl);
    }
    const RenderSpread r = renderSpread(ims);
    double var = 0;
    mean = 0;
    const size_t begin = size_t(12) * 24 * 3, end = size_t(24) * 24 * 3;
    for (size_t i = begin; i < end; ++i) {
      var += r.variance[i];
      mean += r.mean[i];
    }
    mean /= double(end - begin);
    return var / double(end - begin);
  };
  double meanTwo = 0, meanOne = 0;
  const double two = stats(2, 8, meanTwo), one = stats(1, 16, meanOne);
  std::printf("floor lobe gather: 1 + 15 directions variance %.3e mean %.5f, 16 directions %.3e mean %.5f\n", two,
              meanTwo, one, meanOne);
  ASSERT_GT(one, 0.0);
  EXPECT_LT(two / one, 1.2) << "weighted equally, or the rest not shared";
  EXPECT_GT(two / one, 0.8);
  EXPECT_NEAR(meanTwo, meanOne, 0.03 * meanOne);
  // The lobe gather is what these runs measure: without it the floor is
  // gathered from the light set, another image.
  s.batches = 2;
  s.lobeGatherRays = 8;
  s.seed = 300;
  const Image with = renderMany(l, s).vsl;
  s.lobeGather = 0;
  const Image without = renderMany(l, s).vsl;
  double diff = 0;
  for (size_t i = 0; i < with.rgb.size(); ++i) diff += std::abs(double(with.rgb[i]) - without.rgb[i]);
  EXPECT_GT(diff / double(with.rgb.size()), 0.01 * meanOne);
}

// A point light's highlight seen through two narrow lobes: a polished metal
// floor (alpha 0.029, lobe-gathered) reflects a polished metal wall (alpha
// 0.04, narrow along both axes: a narrow landing surface) that mirrors a
// point light. All of the floor's indirect light takes that path, which the
// lobe gather finds by next-event estimation at the wall (the density
// estimate there takes diffuse lobes only, and a metal has none). Over six
// light sets its mean is within 10% of the path tracer's, and one render's
// relative variance is below what the wall's own narrow lobe gives (the
// regularised next-event estimate; fails at 3.5x without it).
TEST(ManyLightStats, LobeGatherFindsAPointLightThroughTwoNarrowLobes) {
  auto scene = std::make_shared<Scene>();
  scene->path = "<point light in a polished wall, seen in a polished floor>";
  scene->materials = {testMaterial("floor", Vec3(0.9f), 1, 0.17f), testMaterial("wall", Vec3(0.9f), 1, 0.2f)};
  addQuad(*scene, Vec3(-3, 0, 3), Vec3(6, 0, 0), Vec3(0, 0, -5), 0);  // floor y = 0, facing +y
  addQuad(*scene, Vec3(-3, 0, -2), Vec3(6, 0, 0), Vec3(0, 3, 0), 1);  // wall z = -2, facing +z
  PunctualLight p;
  p.name = "bulb";
  p.position = Vec3(0, 1.5f, 1.0f);
  p.intensity = Vec3(5.0f);
  scene->punctualLights.push_back(p);
  scene->camera.position = Vec3(0, 1.0f, 1.5f);
  scene->camera.forward = normalize(Vec3(0, -0.36f, -0.93f));
  scene->camera.right = Vec3(1, 0, 0);
  scene->camera.up = cross(scene->camera.right, scene->camera.forward);
  scene->camera.yfov = 0.9f;
  Loaded l = loadedFrom(scene, 24);
  ASSERT_TRUE(l.context);
  ManyLightSettings s;
  s.lights = 1500;
  s.width = s.height = 24;
  s.batches = 2;
  s.directSamples = 1;
  s.lobeGather = 30000;
  auto mean = [](const Image& im) {
    double sum = 0;
    for (float v : im.rgb) sum += v;
    return sum / double(im.rgb.size());
  };
  double on = 0;
  const int sets = 6;
  std::vector<Image> images;
  for (int k = 0; k < sets; ++k) {
    s.seed = 70 + k;
    images.push_back(renderMany(l, s).vsl);
    on += mean(images.back()) / sets;
  }
  const Reference ref = ptIndirect(l, 24, 24, 4096, 93);
  const double pt = mean(ref.indirect);
  // One render's relative variance over the image: the sum over pixels of
  // the variance between the sets over the sum of the squared means.
  const RenderSpread spread = renderSpread(images);
  double var = 0, sq = 0;
  for (size_t i = 0; i < spread.mean.size(); ++i) {
    var += spread.variance[i];
    sq += spread.mean[i] * spread.mean[i];
  }
  std::printf("indirect mean: VSL with the lobe gather %.5f, path tracer %.5f; relative variance %.4f\n", on, pt,
              var / sq);
  ASSERT_GT(pt, 0.0);
  EXPECT_NEAR(on, pt, 0.1 * pt);
  // The wall's next-event light through its lobe widened to alpha 0.1
  // (ManyLightSettings::kLobeGatherChainAlpha): 0.028; through its own
  // alpha 0.04 lobe, 0.097.
  EXPECT_LT(var / sq, 0.035) << "spikes of the point light seen through two narrow lobes";
}

// ---- Directional lights (KHR_lights_punctual "directional"; docs/REFERENCE.md
// "Lights").

namespace {
// A diffuse floor (albedo 0.5, facing +y) and a white diffuse wall (facing
// +z) lit by a directional light of irradiance E travelling along dir, seen
// from above (the wall edge-on).
std::shared_ptr<Scene> sunScene(Vec3 dir, float E, bool wall) {
  auto s = std::make_shared<Scene>();
  s->path = "<sun>";
  s->materials = {testMaterial("floor", Vec3(0.5f), 0, 1, 0), testMaterial("wall", Vec3(0.8f), 0, 1, 0), Material()};
  addQuad(*s, {-2, 0, 2}, {4, 0, 0}, {0, 0, -4}, 0);
  if (wall) addQuad(*s, {-2, 0, -1}, {4, 0, 0}, {0, 3, 0}, 1);
  PunctualLight sun;
  sun.type = PunctualLight::Type::Directional;
  sun.direction = normalize(dir);
  sun.intensity = Vec3(E);
  s->punctualLights = {sun};
  s->camera.position = Vec3(0, 3, 0.5f);  // looking down: the floor fills the view
  s->camera.forward = Vec3(0, -1, 0);
  s->camera.right = Vec3(1, 0, 0);
  s->camera.up = Vec3(0, 0, -1);
  s->camera.yfov = 0.9f;
  return s;
}
}  // namespace

// The direct light of a directional light on a Lambertian floor is
// rho / pi x E x cos(theta) everywhere (no falloff, no shadow), and light
// tracing's rays carry E x pi R^2 over the disk of the bounding sphere: the
// share that lands on the floor is its projected area over that disk.
TEST(DirectionalLight, DirectLightAndEmissionMatchTheClosedForm) {
  const Vec3 dir = normalize(Vec3(0.3f, -1.0f, -0.4f));
  const float E = 2.0f, cosTheta = -dir.y;
  Loaded l = loadedFrom(sunScene(dir, E, false), 16);
  std::optional<LightSample> ls = l.lights->sampleLi(Vec3(0.3f, 0, 0.2f), 0.5f, {0.5f, 0.5f});
  ASSERT_TRUE(ls);
  EXPECT_TRUE(ls->delta);
  EXPECT_NEAR(length(ls->wi + dir), 0, 1e-6);
  EXPECT_EQ(ls->Li.x, E);
  EXPECT_GT(length(ls->pLight - l.scene->center()), l.scene->boundingRadius()) << "the shadow ray leaves the scene";

  RenderSettings rs;
  rs.width = rs.height = 8;
  PathTracer pt(*l.scene, *l.accel, *l.lights, rs);
  const double expected = 0.5 / M_PI * E * cosTheta;
  for (int s = 0; s < 4; ++s)
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) {
        Vec3 Ld, Lind;
        uint64_t rays = 0, nonFinite = 0;
        pt.samplePixel(x, y, s, Ld, Lind, rays, nonFinite);
        ASSERT_NEAR(Ld.x, expected, 1e-4 * expected) << x << "," << y;
        ASSERT_EQ(Lind.x, 0.0f) << "nothing else reflects";
      }

  // Emission: N rays; the floor (area 16) takes a binomial share of them.
  const float R = l.scene->boundingRadius();
  const int N = 20000;
  int hits = 0;
  double flux = 0;
  Rng rng(5, 0);
  for (int i = 0; i < N; ++i) {
    std::optional<EmissionSample> e =
        l.lights->sampleLe(rng.uniform(), {rng.uniform(), rng.uniform()}, {rng.uniform(), rng.uniform()});
    ASSERT_TRUE(e);
    EXPECT_NEAR(length(e->w - dir), 0, 1e-6);
    EXPECT_GE(length(e->p - l.scene->center()), R);
    flux += e->beta.x / N;
    if (e->w.y < 0) {
      const float t = -e->p.y / e->w.y;
      const Vec3 p = e->p + e->w * t;
      hits += std::abs(p.x) <= 2 && std::abs(p.z) <= 2;
    }
  }
  EXPECT_NEAR(flux, E * M_PI * R * R, 1e-3 * flux) << "every ray carries the beam's power";
  const double share = 16 * cosTheta / (M_PI * R * R), se = std::sqrt(share * (1 - share) / N);
  EXPECT_NEAR(double(hits) / N, share, 4 * se);
}

// Light tracing from a directional light agrees with the path tracer: the
// unclamped VPLs' indirect mean against the path-traced indirect (z-test).
TEST(DirectionalLight, UnclampedVplAgreesWithThePathTracer) {
  Loaded l = loadedFrom(sunScene(Vec3(0.2f, -1.0f, -0.6f), 3.0f, true), 16);
  const int W = 16, H = 16, sets = 12;
  Reference ref = ptIndirect(l, W, H, 1024, 91);
  ASSERT_GT(ref.mean, 0);
  std::vector<double> means;
  for (int k = 0; k < sets; ++k) means.push_back(greyMean(renderMany(l, vplOnly(W, H, 800, 300 + k)).vplUnclamped));
  auto [m, se] = meanAndError(means);
  double z = (m - ref.mean) / std::sqrt(se * se + ref.se * ref.se);
  std::printf("sun: unclamped VPL %.6f +- %.6f vs PT indirect %.6f +- %.6f (z = %.2f)\n", m, se, ref.mean, ref.se, z);
  EXPECT_LT(std::abs(z), 4.0);
}
