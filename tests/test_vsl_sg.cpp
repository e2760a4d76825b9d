// The closed-form VSL transfer by spherical Gaussians (core/vsl_sg.h): the SG
// product integral against numerical integration of the same SGs, the cone
// SG's solid angle, the VPL limit, agreement with the quadrature VSL on random
// pairs (the error distribution printed, a tolerance on its median), and
// finite results at the extremes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "core/material.h"
#include "core/rng.h"
#include "core/simd.h"
#include "core/vsl_sg.h"

using namespace vsl;

namespace {

Vec3 randomUnit(Rng& rng) {
  for (;;) {
    Vec3 v(2 * rng.uniform() - 1, 2 * rng.uniform() - 1, 2 * rng.uniform() - 1);
    const float l2 = lengthSquared(v);
    if (l2 > 1e-4f && l2 <= 1) return v / std::sqrt(l2);
  }
}

// A unit vector in the hemisphere about n, at least cosMin above it.
Vec3 randomAbove(Rng& rng, const Vec3& n, float cosMin) {
  for (;;) {
    const Vec3 v = randomUnit(rng);
    const float c = dot(v, n);
    if (c >= cosMin) return v;
    if (-c >= cosMin) return -v;
  }
}

// The integral over the sphere of the product, by the midpoint rule in
// (cos theta, phi) about the pole `pole` (fine near the pole, where sharp
// products sit when the pole is their peak).
double numericalIntegral(const std::vector<SphericalGaussian>& g, const Vec3& pole, int nu, int nphi) {
  const Frame f(pole);
  double sum = 0;
  for (int i = 0; i < nu; ++i) {
    // Nodes dense near u = 1: u = 1 - 2 s^2, s uniform (du = 4 s ds).
    const double s = (i + 0.5) / nu, u = 1.0 - 2.0 * s * s, du = 4.0 * s / nu;
    const double st = std::sqrt(std::max(0.0, 1.0 - u * u));
    for (int j = 0; j < nphi; ++j) {
      const double phi = 2.0 * M_PI * (j + 0.5) / nphi;
      const Vec3 l = f.toWorld(Vec3(float(st * std::cos(phi)), float(st * std::sin(phi)), float(u)));
      double v = 1;
      for (const SphericalGaussian& sg : g) v *= sg.eval(l);
      sum += v * du * (2.0 * M_PI / nphi);
    }
  }
  return sum;
}

}  // namespace

// Formula (1) of core/vsl_sg.h against the midpoint rule on products of two
// to four SGs with random axes, sharpnesses from 0.1 to 300 and amplitudes.
// The rule's pole is a random direction for broad products and the product's
// own peak for sharp ones (a coordinate choice; the integrand is evaluated
// SG by SG). Tolerance 1e-3 relative: the rule's error at 1,200 x 96 nodes.
TEST(VslSg, ProductIntegralMatchesNumericalIntegration) {
  Rng rng(51, 1);
  for (int trial = 0; trial < 8; ++trial) {
    std::vector<SphericalGaussian> g(2 + rng.uniformInt(3));
    Vec3 v(0.0f);
    for (SphericalGaussian& s : g) {
      s.axis = randomUnit(rng);
      s.lambda = std::pow(10.0, -1.0 + 3.5 * rng.uniform());
      s.logAmplitude = rng.uniform() - 0.5;
      v += s.axis * float(s.lambda);
    }
    const Vec3 pole = length(v) > 20 ? normalize(v) : randomUnit(rng);
    const double closed = sgProductIntegral(g), numeric = numericalIntegral(g, pole, 1200, 96);
    EXPECT_NEAR(closed / numeric, 1.0, 1e-3) << "trial " << trial << " closed " << closed << " numeric " << numeric;
  }
}

// The cone's SG has the cone's solid angle, 2 pi omc, from needle cones to
// the hemisphere.
TEST(VslSg, ConeSharpnessGivesTheSolidAngle) {
  for (double omc : {1e-9, 1e-4, 0.01, 0.049, 0.051, 0.2, 0.5, 0.9, 1.0}) {
    const double lambda = sgSharpnessForSolidAngle(omc);
    const double solidAngle = 2.0 * M_PI * (-std::expm1(-2.0 * lambda)) / lambda;
    EXPECT_NEAR(solidAngle / (2.0 * M_PI * omc), 1.0, 1e-9) << "omc " << omc << " lambda " << lambda;
  }
  EXPECT_NEAR(sgSharpnessForSolidAngle(1.0), 0.7968, 1e-3);  // 1 - exp(-2 l) = l
}

namespace {

struct Pair {
  VslReceiver x;
  VslEmitter p;
  Vec3 toLight;
  double radius = 0;
};

// The materials of the bundled scenes' kinds: diffuse, glossy dielectric,
// rough and glossy metal, brushed (anisotropic) metal.
Brdf materialOf(int k) {
  switch (k) {
    case 0:
      return Brdf::fromGltf(Vec3(0.7f, 0.6f, 0.5f), 0.0f, 1.0f, 0.0f);
    case 1:
      return Brdf::fromGltf(Vec3(0.5f, 0.3f, 0.2f), 0.0f, 0.3f, 0.0f);
    case 2:
      return Brdf::fromGltf(Vec3(0.9f, 0.8f, 0.6f), 1.0f, 0.6f, 0.0f);
    case 3:
      return Brdf::fromGltf(Vec3(0.9f), 1.0f, 0.35f, 0.0f);
    default:
      return Brdf::fromGltf(Vec3(0.9f, 0.9f, 0.95f), 1.0f, 0.4f, 0.7f);
  }
}
constexpr int kMaterials = 5;
const char* const kMaterialNames[kMaterials] = {"diffuse", "glossy-dielectric", "rough-metal", "glossy-metal",
                                                "brushed-metal"};

// x at the origin; p at distance dist toward a direction above x, facing x;
// the light's incoming direction and the viewer above their surfaces.
Pair makePair(Rng& rng, int mx, int mp, float dist, double sinHalfAngle) {
  Pair q;
  const Vec3 nx = randomUnit(rng);
  q.x.frame = Frame(nx, randomUnit(rng));
  q.x.ng = nx;
  q.x.f = BrdfAt(materialOf(mx), q.x.frame.toLocal(randomAbove(rng, nx, 0.1f)));
  const Vec3 a = randomAbove(rng, nx, 0.1f);
  q.toLight = a * dist;
  const Vec3 np = randomAbove(rng, -a, 0.1f);
  q.p.frame = Frame(np, randomUnit(rng));
  q.p.f = BrdfAt(materialOf(mp), q.p.frame.toLocal(randomAbove(rng, np, 0.1f)));
  q.radius = dist * sinHalfAngle;
  return q;
}

float luminanceOf(const Vec3& v) { return 0.2126f * v.x + 0.7152f * v.y + 0.0722f * v.z; }

}  // namespace

// As r -> 0 the closed form is the unclamped VPL transfer f_x cos f_p cos /
// d^2 for every lobe (core/vsl_sg.h, "Limits"): the cone SG concentrates at
// the axis, where every factor is exact. r/d = 1e-6 (lambda_c 2e12) leaves
// the near-mirror lobe (alpha 1e-4, sharpness up to 5e9) at w >= 0.997.
TEST(VslSg, VanishingRadiusGivesTheVplTransfer) {
  Rng rng(51, 2);
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Pair q =
        makePair(rng, int(rng.uniformInt(kMaterials)), int(rng.uniformInt(kMaterials)), 0.5f + rng.uniform(), 1e-6);
    if (trial % 4 == 0) q.p.f = BrdfAt(Brdf::fromGltf(Vec3(0.9f), 1.0f, 0.0f, 0.0f), q.p.f.w());
    const float d = length(q.toLight);
    const Vec3 l = q.toLight / d;
    const Vec3 lx = q.x.frame.toLocal(l), lp = q.p.frame.toLocal(-l);
    const Vec3 vpl = q.x.f.eval(lx) * q.p.f.eval(lp) * (lx.z * lp.z / (d * d));
    const Vec3 sg = vslTransferSg(q.x, q.p, q.toLight, q.radius, {}).transfer;
    const float want = luminanceOf(vpl);
    if (!(want > 1e-6f)) continue;
    ++checked;
    EXPECT_NEAR(luminanceOf(sg) / want, 1.0f, 2e-3f) << "trial " << trial;
  }
  EXPECT_GT(checked, 150);
}

namespace {

struct Agreement {
  std::vector<double> relErr;  // |SG - Q| / Q in luminance, per pair
  double sumSg = 0, sumQ = 0;
};

// The closed form against the quadrature at 512 samples per strategy on
// random pairs of the given materials, half-angles from lo to hi degrees.
Agreement agreement(int mx, int mp, int pairs, double lo, double hi, uint64_t seed) {
  Rng rng(seed, 3);
  Agreement a;
  VslOptions q;
  q.samplesPerStrategy = 512;
  for (int i = 0; i < pairs; ++i) {
    const double halfAngle = (lo + (hi - lo) * rng.uniform()) * M_PI / 180.0;
    const Pair pr = makePair(rng, mx, mp, 1.0f, std::sin(halfAngle));
    Rng qr(seed + uint64_t(i), 4);
    const float quad = luminanceOf(vslTransfer(pr.x, pr.p, pr.toLight, pr.radius, q, qr).transfer);
    const float sg = luminanceOf(vslTransferSg(pr.x, pr.p, pr.toLight, pr.radius, {}).transfer);
    if (!(quad > 0)) continue;
    a.relErr.push_back(std::abs(double(sg) - quad) / quad);
    a.sumSg += sg;
    a.sumQ += quad;
  }
  std::sort(a.relErr.begin(), a.relErr.end());
  return a;
}

double quantileOf(const std::vector<double>& v, double q) { return v[size_t(q * double(v.size() - 1))]; }

// Every pair of material kinds at half-angles lo-hi degrees: prints the
// distribution of the per-pair relative error in luminance (median, 90th
// percentile, worst) and the ratio of the sums, per pair of kinds and
// pooled, and checks the pooled median and sum ratio and each kind pair's
// median against the tolerances.
void checkAgreement(double lo, double hi, double pooledMedian, double pooledSum, double kindMedian) {
  std::printf("half-angles %.1f-%.1f degrees\n%-18s %-18s %8s %8s %8s %9s\n", lo, hi, "receiver", "light", "median",
              "p90", "max", "sum-ratio");
  Agreement all;
  for (int mx = 0; mx < kMaterials; ++mx)
    for (int mp = 0; mp < kMaterials; ++mp) {
      const Agreement a = agreement(mx, mp, 30, lo, hi, 1000 + 10 * mx + mp);
      ASSERT_GT(a.relErr.size(), 15u);
      const double med = quantileOf(a.relErr, 0.5);
      std::printf("%-18s %-18s %8.4f %8.4f %8.4f %9.4f\n", kMaterialNames[mx], kMaterialNames[mp], med,
                  quantileOf(a.relErr, 0.9), a.relErr.back(), a.sumSg / a.sumQ);
      EXPECT_LT(med, kindMedian) << kMaterialNames[mx] << " <- " << kMaterialNames[mp];
      all.relErr.insert(all.relErr.end(), a.relErr.begin(), a.relErr.end());
      all.sumSg += a.sumSg / a.sumQ;  // each kind pair weighs the same
      all.sumQ += 1;
    }
  std::sort(all.relErr.begin(), all.relErr.end());
  const double med = quantileOf(all.relErr, 0.5), ratio = all.sumSg / all.sumQ;
  std::printf("%-37s %8.4f %8.4f %8.4f %9.4f\n", "pooled (sum ratio: mean over kinds)", med,
              quantileOf(all.relErr, 0.9), all.relErr.back(), ratio);
  EXPECT_LT(med, pooledMedian);
  EXPECT_NEAR(ratio, 1.0, pooledSum);
}

}  // namespace

// Narrow cones, 0.5-5 degrees: the cones of most pairs at 10,000 lights.
// The quadrature's own relative noise at 512 samples per strategy is a few
// percent at most. Measured (printed): pooled median error 0.4%, sum ratios
// 0.965-1.042. Tolerances: pooled median error 2%, mean sum ratio within 3%,
// each kind pair's median under 3%.
TEST(VslSg, AgreesWithTheQuadratureOnNarrowCones) { checkAgreement(0.5, 5.0, 0.02, 0.03, 0.03); }

// Wide cones, 1-25 degrees (few lights, near neighbours), with axes down to
// 84 degrees from either normal, where approximations A1, A2 and A5 of
// core/vsl_sg.h show. Measured: pooled median error 6.7%, 90th percentile
// 39%, sum ratios 0.64-1.38 (mean 0.96). Tolerances: pooled median error
// 10%, mean sum ratio within 10%, each kind pair's median under 20%.
TEST(VslSg, AgreesWithTheQuadratureOnWideCones) { checkAgreement(1.0, 25.0, 0.10, 0.10, 0.20); }

// Finite, non-negative results at the extremes: zero roughness at both ends,
// grazing viewer and incoming directions, grazing axes, coincident points,
// the receiver inside the sphere, needle and huge radii.
TEST(VslSg, FiniteAtTheExtremes) {
  Rng rng(51, 5);
  const Brdf mirror = Brdf::fromGltf(Vec3(1.0f), 1.0f, 0.0f, 0.0f);
  const Brdf brushedMirror = Brdf::fromGltf(Vec3(1.0f), 1.0f, 0.0f, 1.0f);
  const Brdf glossy = Brdf::fromGltf(Vec3(0.5f), 0.0f, 0.0f, 0.0f);
  const Brdf kinds[] = {mirror, brushedMirror, glossy, materialOf(0), materialOf(4)};
  int nonZero = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    Pair q = makePair(rng, 0, 0, float(std::pow(10.0, -3.0 + 4.0 * rng.uniform())), 0.1);
    const float graze = trial % 3 == 0 ? 1e-6f : 0.1f;
    q.x.f = BrdfAt(kinds[rng.uniformInt(5)], normalize(Vec3(1.0f, 0.0f, graze)));
    q.p.f = BrdfAt(kinds[rng.uniformInt(5)], normalize(Vec3(0.3f, 1.0f, trial % 5 == 0 ? 1e-6f : 1.0f)));
    if (trial % 7 == 0) {  // a grazing axis at x
      const Vec3 t = q.x.frame.s;
      q.toLight = normalize(t + q.x.frame.n * 1e-6f) * length(q.toLight);
    }
    if (trial % 11 == 0) q.toLight = Vec3(0.0f);  // coincident points
    q.radius = length(q.toLight) * std::pow(10.0, -7.0 + 8.0 * rng.uniform());
    if (trial % 13 == 0) q.radius = 1e-30;
    if (trial % 17 == 0) q.radius = 1e3;
    VslOptions o;
    o.clippedDisk = trial % 2 == 0;
    const Vec3 t = vslTransferSg(q.x, q.p, q.toLight, q.radius, o).transfer;
    ASSERT_TRUE(isFinite(t)) << "trial " << trial << ": " << t.x << " " << t.y << " " << t.z;
    ASSERT_GE(std::min({t.x, t.y, t.z}), 0.0f) << "trial " << trial;
    nonZero += t.y > 0;
  }
  EXPECT_GT(nonZero, 1000);
}

// ---- The lanes (vslTransferSgManyAvx2, core/vsl_sg_avx2.cpp) --------------------

namespace {

// Relative errors sorted, with their worst case's index.
struct LaneErrors {
  std::vector<double> rel;
  double worst = 0;
  int worstAt = -1;
  int zeroMismatch = 0;  // one form zero, the other not
};

// The lanes against the scalar double form over the pairs, channel by
// channel: |lane - scalar| / scalar where the scalar value is above 1e-30
// of the pair's largest channel (smaller ones are float's noise).
LaneErrors compareLanes(const std::vector<Pair>& pairs, const VslOptions& o) {
  std::vector<VslSgPair> in(pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i)
    in[i] = {&pairs[i].x, &pairs[i].p, nullptr, nullptr, pairs[i].toLight, float(pairs[i].radius)};
  std::vector<Vec3> lanes(pairs.size());
  vslTransferSgManyAvx2(int(in.size()), in.data(), o, lanes.data());
  LaneErrors e;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const Vec3 s = vslTransferSg(pairs[i].x, pairs[i].p, pairs[i].toLight, pairs[i].radius, o).transfer;
    const Vec3 l = lanes[i];
    EXPECT_TRUE(isFinite(l)) << "pair " << i;
    EXPECT_GE(std::min({l.x, l.y, l.z}), 0.0f) << "pair " << i;
    // Values below 1e-30 count as zero (float's denormals; no film sees them).
    const float top = std::max({s.x, s.y, s.z});
    if ((top > 1e-30f) != (std::max({l.x, l.y, l.z}) > 1e-30f)) ++e.zeroMismatch;
    for (int c = 0; c < 3; ++c) {
      if (!(s[c] > 1e-30f * top) || !(top > 1e-30f)) continue;
      const double r = std::abs(double(l[c]) - s[c]) / s[c];
      e.rel.push_back(r);
      if (r > e.worst) {
        e.worst = r;
        e.worstAt = int(i);
      }
    }
  }
  std::sort(e.rel.begin(), e.rel.end());
  return e;
}

Brdf mirrorOf(int k) {
  switch (k) {
    case 0:
      return Brdf::fromGltf(Vec3(1.0f, 0.8f, 0.6f), 1.0f, 0.0f, 0.0f);  // alpha 1e-4
    case 1:
      return Brdf::fromGltf(Vec3(0.9f), 1.0f, 0.0f, 0.9f);  // brushed: alpha 1e-4 x 0.81
    default:
      return Brdf::fromGltf(Vec3(0.5f), 0.0f, 0.02f, 0.0f);  // glossy dielectric
  }
}

// Random pairs of every kind the gather sends to the closed form, and the
// extremes: 0 ordinary (materials x half-angles 0.05-25 degrees), 1 zero
// roughness at either end, 2 grazing viewer or incoming direction, 3
// grazing axis, 4 coincident points, 5 x inside the sphere, 6 lobe-gathered
// receivers (the diffuse lobe only), 7 a light with the geometric cosine.
std::vector<Pair> lanePairs(int kind, int n, uint64_t seed) {
  Rng rng(seed, 7);
  std::vector<Pair> v;
  for (int i = 0; i < n; ++i) {
    const double halfAngle = (0.05 + 25.0 * std::pow(rng.uniform(), 2.0f)) * M_PI / 180.0;
    Pair q = makePair(rng, int(rng.uniformInt(kMaterials)), int(rng.uniformInt(kMaterials)),
                      0.01f + 3.0f * rng.uniform(), std::sin(halfAngle));
    if (kind == 1) {
      if (rng.uniform() < 0.7f) q.x.f = BrdfAt(mirrorOf(int(rng.uniformInt(3))), q.x.f.w());
      if (rng.uniform() < 0.7f) q.p.f = BrdfAt(mirrorOf(int(rng.uniformInt(3))), q.p.f.w());
      if (rng.uniform() < 0.3f) q.radius *= 1e-3;
    } else if (kind == 2) {
      const float z = float(std::pow(10.0, -6.0 + 5.0 * rng.uniform()));
      if (rng.uniform() < 0.5f)
        q.x.f = BrdfAt(q.x.f.brdf(), normalize(Vec3(1.0f, 0.3f, z)));
      else
        q.p.f = BrdfAt(q.p.f.brdf(), normalize(Vec3(0.2f, 1.0f, z)));
    } else if (kind == 3) {
      const float z = float(std::pow(10.0, -5.0 + 4.0 * rng.uniform()));
      q.toLight = normalize(q.x.frame.s + q.x.frame.n * z) * length(q.toLight);
      q.p.frame = Frame(-normalize(q.toLight + q.p.frame.s * 0.2f), randomUnit(rng));
    } else if (kind == 4) {
      q.toLight = Vec3(0.0f);
      q.radius = 0.01 + rng.uniform();
      q.p.frame = Frame(-q.x.frame.n, randomUnit(rng));
    } else if (kind == 5) {
      q.radius = length(q.toLight) * (1.0 + 3.0 * rng.uniform());
    } else if (kind == 6) {
      q.x.f = q.x.f.diffuseLobe();
    } else if (kind == 7) {
      q.p.geometricCosine = true;
      q.p.ngLocal = normalize(Vec3(0.3f * rng.uniform(), -0.3f * rng.uniform(), 1.0f));
    }
    v.push_back(q);
  }
  return v;
}

// exp8 and log8 on eight floats (callers check simdAvailable()).
VSL_FMA void simdExpLog8(const float* x, const float* y, float* e, float* l) {
  _mm256_store_ps(e, simd::exp8(_mm256_load_ps(x)));
  _mm256_store_ps(l, simd::log8(_mm256_load_ps(y)));
}

}  // namespace

// exp8 and log8 (core/simd.h) against std::exp and std::log in double: at
// most 4e-7 relative (exp over [-87, 88]; log over 1e-38-1e38 and denormals,
// relative where |log x| > 0.1, else 3e-8 absolute: 3e-7 of 0.1), and their
// edge cases. Measured: 9.5e-8 and 1.6e-7.
TEST(VslSg, LaneExpAndLog) {
  if (!simdAvailable()) GTEST_SKIP() << "no AVX2";
  Rng rng(51, 8);
  double worstExp = 0, worstLog = 0;
  for (int i = 0; i < 20000; ++i) {
    alignas(32) float x[8], y[8], e[8], l[8];
    for (int j = 0; j < 8; ++j) {
      x[j] = -87.0f + 175.0f * rng.uniform();
      y[j] = float(std::pow(10.0, -44.0 + 82.0 * rng.uniform()));
    }
    simdExpLog8(x, y, e, l);
    for (int j = 0; j < 8; ++j) {
      const double want = std::exp(double(x[j]));
      if (want > 1.2e-38) worstExp = std::max(worstExp, std::abs(e[j] - want) / want);
      const double lw = std::log(double(y[j]));
      worstLog = std::max(worstLog, std::abs(l[j] - lw) / std::max(std::abs(lw), 0.1) * (std::abs(lw) > 0.1 ? 1 : 0.1));
    }
  }
  std::printf("exp8 worst relative error %.3g, log8 %.3g\n", worstExp, worstLog);
  EXPECT_LT(worstExp, 2e-7);
  EXPECT_LT(worstLog, 3e-7);
  alignas(32) float x[8] = {-1000, -87.5f, 0, 1, 88.0f, 1000, std::nanf(""), -0.0f};
  alignas(32) float y[8] = {0, -1, 1, 2, kInf, std::nanf(""), 1e-45f, 0.5f};
  alignas(32) float e[8], l[8];
  simdExpLog8(x, y, e, l);
  EXPECT_EQ(e[0], 0.0f);
  EXPECT_EQ(e[1], 0.0f);
  EXPECT_EQ(e[2], 1.0f);
  EXPECT_NEAR(e[3], std::exp(1.0f), 3e-7f * std::exp(1.0f));
  EXPECT_TRUE(std::isfinite(e[4]));
  EXPECT_EQ(e[5], kInf);
  EXPECT_TRUE(std::isnan(e[6]));
  EXPECT_EQ(e[7], 1.0f);
  EXPECT_EQ(l[0], -kInf);
  EXPECT_TRUE(std::isnan(l[1]));
  EXPECT_EQ(l[2], 0.0f);
  EXPECT_NEAR(l[3], std::log(2.0f), 1e-7f);
  EXPECT_EQ(l[4], kInf);
  EXPECT_TRUE(std::isnan(l[5]));
  EXPECT_NEAR(l[6], std::log(double(y[6])), 1e-5);
  EXPECT_NEAR(l[7], std::log(0.5f), 1e-7f);
}

// The lanes against the scalar double form, kind by kind (lanePairs), 1,003
// pairs each (not a multiple of eight: the last block is partial), with and
// without the clipped disk. Prints the distribution of the relative
// difference per channel (median, 99th percentile, worst). Measured
// (2026-12-08, the estimated reciprocals of core/vsl_sg_avx2.cpp): medians
// 1.9-3.4e-7, 99th percentiles 8e-7 to 1.1e-4 (zero roughness), worst
// 2.4e-3 (zero roughness: float's rounding times sharpnesses of 1e12). Tolerances: median 2e-6, 99th percentile 1e-3,
// worst 1e-2, and zero where the scalar form is zero (at most one pair of
// a kind on either side of float's denormal range).
TEST(VslSg, LanesAgreeWithTheScalarForm) {
  if (!simdAvailable()) GTEST_SKIP() << "no AVX2";
  const char* const names[] = {"ordinary",   "zero-roughness", "grazing-w",     "grazing-axis",
                               "coincident", "inside-sphere",  "lobe-gathered", "geometric-cos"};
  std::printf("%-15s %6s %10s %10s %10s %6s\n", "kind", "values", "median", "p99", "max", "zeros");
  for (int kind = 0; kind < 8; ++kind)
    for (int clipped = 0; clipped < 2; ++clipped) {
      VslOptions o;
      o.clippedDisk = clipped == 1;
      const std::vector<Pair> pairs = lanePairs(kind, 1003, 700 + uint64_t(kind) * 2 + uint64_t(clipped));
      const LaneErrors e = compareLanes(pairs, o);
      ASSERT_GT(e.rel.size(), 300u) << names[kind];
      const double med = quantileOf(e.rel, 0.5), p99 = quantileOf(e.rel, 0.99);
      std::printf("%-15s %6zu %10.2e %10.2e %10.2e %6d%s\n", names[kind], e.rel.size(), med, p99, e.worst,
                  e.zeroMismatch, clipped ? " (clipped disk)" : "");
      EXPECT_LT(med, 2e-6) << names[kind];
      EXPECT_LT(p99, 1e-3) << names[kind];
      EXPECT_LT(e.worst, 1e-2) << names[kind] << " worst at pair " << e.worstAt;
      EXPECT_LE(e.zeroMismatch, 1) << names[kind];
    }
}

// A block whose pairs share one light (as the gather's do) fills the
// light's lanes by broadcast; it must give the bits of the same pairs each
// with its own copy of that light (filled lane by lane). 203 pairs of each
// kind: the last block is partial.
TEST(VslSg, LanesSharingOneLightMatchLaneByLane) {
  if (!simdAvailable()) GTEST_SKIP() << "no AVX2";
  for (int kind = 0; kind < 8; ++kind) {
    const std::vector<Pair> pairs = lanePairs(kind, 203, 900 + uint64_t(kind));
    std::vector<VslEmitter> copies(pairs.size());
    std::vector<VslSgPair> shared(pairs.size()), own(pairs.size());
    for (size_t i = 0; i < pairs.size(); ++i) {
      const VslEmitter& first = pairs[i / 8 * 8].p;
      copies[i] = first;
      shared[i] = {&pairs[i].x, &first, nullptr, nullptr, pairs[i].toLight, float(pairs[i].radius)};
      own[i] = {&pairs[i].x, &copies[i], nullptr, nullptr, pairs[i].toLight, float(pairs[i].radius)};
    }
    std::vector<Vec3> a(pairs.size()), b(pairs.size());
    vslTransferSgManyAvx2(int(pairs.size()), shared.data(), {}, a.data());
    vslTransferSgManyAvx2(int(pairs.size()), own.data(), {}, b.data());
    int lit = 0;
    for (size_t i = 0; i < pairs.size(); ++i) {
      for (int c = 0; c < 3; ++c) ASSERT_EQ(a[i][c], b[i][c]) << "kind " << kind << " pair " << i;
      lit += a[i].y > 0;
    }
    EXPECT_GT(lit, 20) << "kind " << kind;
  }
}

// vslTransferSgMany is the lanes where the CPU has them, and both keep
// the extremes of FiniteAtTheExtremes finite (needle and huge radii, zero
// radius).
TEST(VslSg, BlockFormIsFiniteAtTheExtremes) {
  Rng rng(51, 9);
  std::vector<Pair> pairs;
  for (int trial = 0; trial < 203; ++trial) {
    Pair q = makePair(rng, int(rng.uniformInt(kMaterials)), int(rng.uniformInt(kMaterials)),
                      float(std::pow(10.0, -3.0 + 4.0 * rng.uniform())), 0.1);
    q.radius = length(q.toLight) * std::pow(10.0, -12.0 + 13.0 * rng.uniform());
    if (trial % 13 == 0) q.radius = 1e-30;
    if (trial % 17 == 0) q.radius = 1e3;
    if (trial % 19 == 0) q.radius = 0;
    if (trial % 5 == 0) q.p.f = BrdfAt(mirrorOf(0), q.p.f.w());
    pairs.push_back(q);
  }
  std::vector<VslSgPair> in;
  for (const Pair& q : pairs) in.push_back({&q.x, &q.p, nullptr, nullptr, q.toLight, float(q.radius)});
  std::vector<Vec3> out(in.size());
  vslTransferSgMany(int(in.size()), in.data(), {}, out.data());
  int nonZero = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    ASSERT_TRUE(isFinite(out[i])) << "pair " << i;
    ASSERT_GE(std::min({out[i].x, out[i].y, out[i].z}), 0.0f) << "pair " << i;
    if (pairs[i].radius == 0) {
      EXPECT_EQ(out[i].y, 0.0f) << "pair " << i;
    }
    nonZero += out[i].y > 0;
  }
  EXPECT_GT(nonZero, 150);
}
