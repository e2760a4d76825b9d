// The gather's block (SIMD) forms against their scalar references: BRDF
// evaluation and sampling over blocks of directions and the VSL cone
// quadrature. The block forms repeat the scalar arithmetic in the same order,
// so the results agree bit for bit on random pairs.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "core/material.h"
#include "core/rng.h"
#include "core/vsl_integral.h"

using namespace vsl;

namespace {

Vec3 randomDirection(Rng& rng, float zMin) {
  for (;;) {
    Vec3 v(2 * rng.uniform() - 1, 2 * rng.uniform() - 1, 2 * rng.uniform() - 1);
    float l2 = lengthSquared(v);
    if (l2 > 1e-4f && l2 <= 1 && v.z / std::sqrt(l2) >= zMin) return v / std::sqrt(l2);
  }
}

// Dielectrics, metals and mixtures from mirror-like to rough, some
// anisotropic, some without a specular weight.
Brdf randomBrdf(Rng& rng) {
  Vec3 c(rng.uniform(), rng.uniform(), rng.uniform());
  float metallic = rng.uniform() < 0.3f ? 0.0f : rng.uniform() < 0.5f ? 1.0f : rng.uniform();
  float roughness = rng.uniform() < 0.2f ? 0.02f * rng.uniform() : rng.uniform();
  float aniso = rng.uniform() < 0.3f ? rng.uniform() : 0.0f;
  float specular = rng.uniform() < 0.1f ? 0.0f : 1.0f;
  return Brdf::fromGltf(c, metallic, roughness, aniso, specular);
}

// One of the full BRDF, its diffuse lobe and its specular lobe.
BrdfAt randomBrdfAt(Rng& rng) {
  BrdfAt f(randomBrdf(rng), randomDirection(rng, -0.2f));
  float u = rng.uniform();
  return u < 0.15f ? f.diffuseLobe() : u < 0.3f ? f.specularLobe() : f;
}

}  // namespace

// The same float, bit for bit (any NaN matches any NaN).
static bool sameBits(float a, float b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  return std::memcmp(&a, &b, sizeof a) == 0;
}

// BrdfAt::evalTotalsAvx2 equals evalParts(wi, pdf).total() per direction, and
// evalPartsMany its lobes, for directions above and below the surface and
// block lengths that are not a multiple of eight.
TEST(GatherSimd, BrdfBlockEqualsScalar) {
  if (!simdAvailable()) GTEST_SKIP() << "this CPU has no AVX2";
  Rng rng(10, 4);
  constexpr int kMax = 37;
  for (int trial = 0; trial < 400; ++trial) {
    const BrdfAt f = randomBrdfAt(rng);
    const int n = 1 + int(rng.uniformInt(kMax));
    float wx[kMax], wy[kMax], wz[kMax];
    for (int i = 0; i < n; ++i) {
      Vec3 w = randomDirection(rng, -0.3f);
      wx[i] = w.x;
      wy[i] = w.y;
      wz[i] = w.z;
    }
    float s[3][kMax], v[3][kMax], sPdf[kMax], vPdf[kMax];
    float* const sRows[3] = {s[0], s[1], s[2]};
    float* const vRows[3] = {v[0], v[1], v[2]};
    f.evalTotalsScalar(n, wx, wy, wz, sRows, sPdf);
    f.evalTotalsAvx2(n, wx, wy, wz, vRows, vPdf);
    for (int i = 0; i < n; ++i) {
      for (int c = 0; c < 3; ++c) ASSERT_TRUE(sameBits(v[c][i], s[c][i])) << "trial " << trial << " lane " << i;
      ASSERT_TRUE(sameBits(vPdf[i], sPdf[i])) << "trial " << trial << " lane " << i;
    }
    // Without a pdf the values are the same.
    f.evalTotalsAvx2(n, wx, wy, wz, vRows, nullptr);
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) ASSERT_TRUE(sameBits(v[c][i], s[c][i])) << "trial " << trial << " lane " << i;
    // The lobes apart (the VPL transfer's light side), a NaN direction now
    // and then: evalPartsMany's forms give evalParts' bits, and write
    // nothing past n.
    if (trial % 40 == 0) wz[n - 1] = std::nanf("");
    constexpr float kUntouched = -12345.0f;
    float d[2][3][kMax + 1], sp[2][3][kMax + 1];
    for (int form = 0; form < 2; ++form) {
      for (int c = 0; c < 3; ++c) d[form][c][n] = sp[form][c][n] = kUntouched;
      float* const dRows[3] = {d[form][0], d[form][1], d[form][2]};
      float* const spRows[3] = {sp[form][0], sp[form][1], sp[form][2]};
      if (form == 0)
        f.evalPartsManyAvx2(n, wx, wy, wz, dRows, spRows);
      else
        f.evalPartsMany(n, wx, wy, wz, dRows, spRows);  // scalar where n < 4
    }
    for (int i = 0; i < n; ++i) {
      const BrdfAt::Parts p = f.evalParts(Vec3(wx[i], wy[i], wz[i]));
      for (int form = 0; form < 2; ++form)
        for (int c = 0; c < 3; ++c) {
          ASSERT_TRUE(sameBits(d[form][c][i], p.diffuse[c])) << "trial " << trial << " lane " << i << " form " << form;
          ASSERT_TRUE(sameBits(sp[form][c][i], p.specular[c]))
              << "trial " << trial << " lane " << i << " form " << form;
        }
    }
    for (int form = 0; form < 2; ++form)
      for (int c = 0; c < 3; ++c) ASSERT_TRUE(d[form][c][n] == kUntouched && sp[form][c][n] == kUntouched);
  }
}

// BrdfAt::evalTotalsPackedAvx2 (eight packed BRDFs to a register, each at
// its own direction: the lobe gather's map lights) equals evalParts per BRDF,
// the total or the diffuse lobe alone, with BRDFs below their surfaces,
// mixed lobes, records at any alignment, a NaN direction now and then and
// block lengths that are not a multiple of eight, bit for bit (the images'
// byte-for-byte claims rest on it); unpack(pack(b)) is b, and no output past
// n is written.
TEST(GatherSimd, ManyBrdfsBlockEqualsScalar) {
  if (!simdAvailable()) GTEST_SKIP() << "this CPU has no AVX2";
  Rng rng(10, 6);
  constexpr int kMax = 45;
  int nonZero = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int n = 1 + int(rng.uniformInt(kMax));
    std::vector<BrdfAt> brdfs;
    float wx[kMax], wy[kMax], wz[kMax];
    const size_t shift = trial % 8;
    std::vector<float> packed(size_t(n) * BrdfAt::kPackedFloats + shift);
    const float* rec[kMax];
    for (int i = 0; i < n; ++i) {
      brdfs.push_back(randomBrdfAt(rng));
      float* r = &packed[shift + size_t(i) * BrdfAt::kPackedFloats];
      brdfs.back().pack(r);
      rec[i] = r;
      Vec3 w = randomDirection(rng, -0.3f);
      wx[i] = w.x;
      wy[i] = w.y;
      wz[i] = w.z;
    }
    if (trial % 50 == 0) wz[n - 1] = std::nanf("");  // no crash, and zero as evalParts gives
    for (bool diffuseOnly : {false, true}) {
      constexpr float kUntouched = -12345.0f;  // slots past n keep it
      float v[3][kMax + 1], q[3][kMax + 1];
      for (int c = 0; c < 3; ++c) v[c][n] = q[c][n] = kUntouched;
      float* const vRows[3] = {v[0], v[1], v[2]};
      float* const qRows[3] = {q[0], q[1], q[2]};
      BrdfAt::evalTotalsPackedAvx2(n, rec, wx, wy, wz, diffuseOnly, vRows);
      BrdfAt::evalTotalsPacked(n, rec, wx, wy, wz, diffuseOnly, qRows);  // scalar where n < 4
      for (int i = 0; i < n; ++i) {
        const Vec3 w(wx[i], wy[i], wz[i]);
        const BrdfAt::Parts p = brdfs[size_t(i)].evalParts(w), u = BrdfAt::unpack(rec[i]).evalParts(w);
        const Vec3 want = diffuseOnly ? p.diffuse : p.total();
        for (int c = 0; c < 3; ++c) {
          ASSERT_EQ((diffuseOnly ? u.diffuse : u.total())[c], want[c]) << "trial " << trial << " lane " << i;
          ASSERT_TRUE(sameBits(v[c][i], want[c])) << "trial " << trial << " lane " << i << " diffuse only "
                                                  << diffuseOnly << ": " << v[c][i] << " " << want[c];
          ASSERT_TRUE(sameBits(q[c][i], want[c])) << "trial " << trial << " lane " << i;
        }
        nonZero += want.y > 0;
      }
      for (int c = 0; c < 3; ++c) ASSERT_TRUE(v[c][n] == kUntouched && q[c][n] == kUntouched) << "trial " << trial;
    }
  }
  EXPECT_GT(nonZero, 4000);  // most lanes evaluate to something
}

// BrdfAt::evalPartsPacked (the closed-form VSL's BRDFs at the cone's axis,
// core/vsl_sg_avx2.cpp): each lobe of each packed BRDF, bit for bit
// evalParts's, AVX2 and scalar forms, block lengths that are not a multiple
// of eight; no output past n is written.
TEST(GatherSimd, ManyBrdfPartsBlockEqualsScalar) {
  if (!simdAvailable()) GTEST_SKIP() << "this CPU has no AVX2";
  Rng rng(10, 16);
  constexpr int kMax = 21;
  int nonZero = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 1 + int(rng.uniformInt(kMax));
    std::vector<BrdfAt> brdfs;
    std::vector<float> packed(size_t(n) * BrdfAt::kPackedFloats);
    const float* rec[kMax];
    float wx[kMax], wy[kMax], wz[kMax];
    for (int i = 0; i < n; ++i) {
      brdfs.push_back(randomBrdfAt(rng));
      brdfs.back().pack(&packed[size_t(i) * BrdfAt::kPackedFloats]);
      rec[i] = &packed[size_t(i) * BrdfAt::kPackedFloats];
      const Vec3 w = randomDirection(rng, -0.3f);
      wx[i] = w.x;
      wy[i] = w.y;
      wz[i] = w.z;
    }
    for (int form = 0; form < 2; ++form) {
      constexpr float kUntouched = -12345.0f;
      float d[3][kMax + 1], sp[3][kMax + 1];
      for (int c = 0; c < 3; ++c) d[c][n] = sp[c][n] = kUntouched;
      float* const dRows[3] = {d[0], d[1], d[2]};
      float* const sRows[3] = {sp[0], sp[1], sp[2]};
      if (form == 0)
        BrdfAt::evalPartsPackedAvx2(n, rec, wx, wy, wz, dRows, sRows);
      else
        BrdfAt::evalPartsPackedScalar(n, rec, wx, wy, wz, dRows, sRows);
      for (int i = 0; i < n; ++i) {
        const BrdfAt::Parts p = brdfs[size_t(i)].evalParts(Vec3(wx[i], wy[i], wz[i]));
        for (int c = 0; c < 3; ++c) {
          ASSERT_TRUE(sameBits(d[c][i], p.diffuse[c])) << "trial " << trial << " lane " << i << " form " << form;
          ASSERT_TRUE(sameBits(sp[c][i], p.specular[c])) << "trial " << trial << " lane " << i << " form " << form;
        }
        nonZero += p.specular.y > 0 && p.diffuse.y > 0;
      }
      for (int c = 0; c < 3; ++c) ASSERT_TRUE(d[c][n] == kUntouched && sp[c][n] == kUntouched) << "trial " << trial;
    }
  }
  EXPECT_GT(nonZero, 300);  // both lobes lit on many lanes
}

// BrdfAt::sampleDirections' AVX2 form gives sampleDirection's bits: random
// BRDFs (both lobes, one lobe alone, w below the surface), uniforms including
// 0 and the concentric map's centre, every count up to three registers; the
// slots past n stay untouched.
TEST(GatherSimd, SampleDirectionsBlockEqualsScalar) {
  Rng rng(21, 4);
  constexpr int kMax = 24;
  constexpr float kUntouched = 12345.0f;
  int specular = 0, diffuse = 0, failed = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const BrdfAt f = randomBrdfAt(rng);
    const int n = 1 + int(rng.uniformInt(kMax));
    float u[3][kMax + 1], wi[3][kMax + 1];
    int32_t ok[kMax + 1];
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k) {
        const float pick = rng.uniform();
        u[k][i] = pick < 0.05f ? 0.0f : pick < 0.1f ? 0.5f : rng.uniform();
      }
    for (int k = 0; k < 3; ++k) wi[k][n] = kUntouched;
    ok[n] = 7;
    const float* const uRows[3] = {u[0], u[1], u[2]};
    float* const wiRows[3] = {wi[0], wi[1], wi[2]};
    f.sampleDirections(n, uRows, wiRows, ok);
    for (int i = 0; i < n; ++i) {
      Vec3 w;
      bool spec = false;
      const bool sampled = f.sampleDirection(u[0][i], {u[1][i], u[2][i]}, w, spec);
      ASSERT_EQ(ok[i] != 0, sampled) << "trial " << trial << " i " << i;
      failed += !sampled;
      if (!sampled) continue;
      (spec ? specular : diffuse) += 1;
      for (int c = 0; c < 3; ++c)
        ASSERT_TRUE(sameBits(wi[c][i], w[c]))
            << "trial " << trial << " i " << i << " c " << c << ": " << wi[c][i] << " " << w[c];
    }
    for (int k = 0; k < 3; ++k) ASSERT_EQ(wi[k][n], kUntouched) << "trial " << trial;
    ASSERT_EQ(ok[n], 7) << "trial " << trial;
  }
  EXPECT_GT(specular, 5000);
  EXPECT_GT(diffuse, 5000);
  EXPECT_GT(failed, 500);
}

// vslTransferBlock equals the scalar vslTransfer bit for bit on random
// (receiver, light) pairs: tiny to wide cones, the receiver inside the sphere, automatic and
// fixed sample counts (long blocks flush several times), both normalisations.
TEST(GatherSimd, VslBlockEqualsScalar) {
  Rng rng(10, 5);
  int nonZero = 0, unequalCounts = 0;
  for (int trial = 0; trial < 1200; ++trial) {
    VslReceiver x;
    x.frame = Frame(randomDirection(rng, -1.0f), randomDirection(rng, -1.0f));
    x.ng = normalize(x.frame.n + randomDirection(rng, -1.0f) * 0.2f);
    x.f = BrdfAt(randomBrdf(rng), normalize(randomDirection(rng, 0.05f)));
    if (rng.uniform() < 0.2f) x.f = x.f.diffuseLobe();
    VslEmitter p;
    p.frame = Frame(randomDirection(rng, -1.0f), randomDirection(rng, -1.0f));
    p.f = BrdfAt(randomBrdf(rng), randomDirection(rng, 0.05f));
    Vec3 toLight = randomDirection(rng, -1.0f) * (0.05f + 3 * rng.uniform());
    double radius = length(toLight) * std::pow(10.0, -4.0 + 4.5 * rng.uniform());
    VslOptions options;
    options.samplesPerStrategy = rng.uniform() < 0.5f ? 0 : 1 + int(rng.uniformInt(60));
    options.clippedDisk = rng.uniform() < 0.3f;
    options.count = VslCount(rng.uniformInt(3));
    const uint64_t stream = rng.uniformInt(1u << 30);
    Rng r1(stream, 7), r2(stream, 7);
    VslResult s = vslTransfer(x, p, toLight, radius, options, r1);
    VslResult v = vslTransferBlock(x, p, toLight, radius, options, r2);
    ASSERT_EQ(v.evaluations, s.evaluations) << "trial " << trial;
    for (int c = 0; c < 3; ++c)
      ASSERT_TRUE(sameBits(v.transfer[c], s.transfer[c]))
          << "trial " << trial << " c " << c << ": " << v.transfer[c] << " " << s.transfer[c];
    // Both consumed the same random numbers.
    ASSERT_EQ(r1.uniformInt(1u << 30), r2.uniformInt(1u << 30)) << "trial " << trial;
    nonZero += s.transfer.y > 0;
    if (options.count == VslCount::Shares && options.samplesPerStrategy == 0) {
      // The strategies' counts, as the quadrature chooses them.
      const double omc = vslConeOneMinusCos(radius, length(toLight)), solidAngle = 2 * M_PI * omc;
      const double massX = x.f.pdfBound() * solidAngle, massP = p.f.pdfBound() * solidAngle;
      VslStrategyCounts c =
          vslStrategyCounts(vslLobeAwareSamples(vslAutoSamples(omc), std::max(massX, massP)), massX, massP);
      unequalCounts += (c.x > 0 && c.x != c.cone) || (c.p > 0 && c.p != c.cone);
    }
  }
  // Most pairs face each other somewhere in the cone: the test compares
  // values, not zeros; and the block form's rounds with unequal counts (a
  // strategy past its count skips the round) are among them.
  EXPECT_GT(nonZero, 350);  // 388 with this stream
  EXPECT_GT(unequalCounts, 20);
}
