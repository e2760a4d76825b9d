// KHR_materials_clearcoat: the loader (a generated clear-coated file loads
// without a warning), the layered BRDF (core/material.h: its sampling against
// its pdf by chi-square, the white furnace and its closed form over a
// Lambertian base, reciprocity, the block forms' scalar fallback), the VSL
// transfer's r -> 0 limit on coated ends, and light-traced unclamped VPLs
// against the path tracer in a coated room (docs/REFERENCE.md, "Clear coat").
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "chi2.h"
#include "core/image_io.h"
#include "core/many_light.h"
#include "core/material.h"
#include "core/sampling.h"
#include "core/scene.h"
#include "core/vsl_integral.h"
#include "run_vsl.h"
#include "support.h"

using namespace vsl;
using namespace vsl::test;

namespace {

Vec3 dirFromAngles(float thetaDeg, float phiDeg) {
  const float t = thetaDeg * kPi / 180, p = phiDeg * kPi / 180;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

// A red plastic under a coat; tilt bends the coat's normal by that many
// degrees (a clearcoatNormalTexture).
Brdf coated(float baseRough, float coatRough, float weight = 1, float tiltDeg = 0, float metallic = 0,
            Vec3 base = Vec3(0.8f, 0.1f, 0.1f), float specular = 1) {
  return Brdf::fromGltf(base, metallic, baseRough, 0, specular)
      .withClearcoat(weight, coatRough, dirFromAngles(tiltDeg, 40));
}

// Directional albedo E[f cos / pdf] (luminance) with its standard error.
std::pair<double, double> albedo(const BrdfAt& f, int n, uint64_t seed) {
  Rng rng(seed, 3);
  MeanAccumulator acc;
  for (int i = 0; i < n; ++i) {
    auto s = f.sample(rng.uniform(), {rng.uniform(), rng.uniform()});
    acc.add(s ? double(luminance(s->f)) * s->wi.z / s->pdf : 0.0);
  }
  return {acc.mean(), acc.standardError()};
}

}  // namespace

// ---- The BRDF ---------------------------------------------------------------------------

TEST(ClearcoatBrdf, NoCoatIsTheBaseBitForBit) {
  const Brdf base = Brdf::fromGltf(Vec3(0.8f, 0.1f, 0.1f), 0, 0.5f, 0);
  const Brdf zero = base.withClearcoat(0, 0.1f);
  Rng rng(3, 3);
  for (int i = 0; i < 500; ++i) {
    const Vec3 wo = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
    const Vec3 wi = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
    EXPECT_EQ(base.eval(wo, wi).x, zero.eval(wo, wi).x);
    EXPECT_EQ(base.pdf(wo, wi), zero.pdf(wo, wi));
  }
}

TEST(ClearcoatBrdf, SampleIsConsistentWithEvalAndPdf) {
  Rng rng(4, 4);
  for (float tilt : {0.0f, 25.0f})
    for (float cr : {0.02f, 0.3f})
      for (float m : {0.0f, 1.0f}) {
        const Brdf b = coated(0.5f, cr, 0.9f, tilt, m);
        for (int i = 0; i < 2000; ++i) {
          const Vec3 wo = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
          if (wo.z < 1e-3f) continue;
          auto s = b.sample(wo, rng.uniform(), {rng.uniform(), rng.uniform()});
          if (!s) continue;
          const Vec3 f = b.eval(wo, s->wi);
          const float p = b.pdf(wo, s->wi);
          ASSERT_NEAR(s->pdf, p, 1e-4f * std::max(1.0f, p));
          ASSERT_NEAR(s->f.x, f.x, 1e-4f * std::max(1.0f, f.x));
          ASSERT_GT(s->wi.z, 0.0f);
        }
      }
}

// Light tracing takes the BRDF's adjoint to be itself (Veach 1997, 5.3):
// the coat's transmission at both directions keeps it so.
TEST(ClearcoatBrdf, Reciprocity) {
  Rng rng(8, 1);
  for (float tilt : {0.0f, 30.0f})
    for (float m : {0.0f, 1.0f}) {
      const Brdf b = coated(0.4f, 0.2f, 0.7f, tilt, m);
      for (int i = 0; i < 2000; ++i) {
        const Vec3 wo = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
        const Vec3 wi = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
        const Vec3 f1 = b.eval(wo, wi), f2 = b.eval(wi, wo);
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(f1[c], f2[c], 2e-5f * std::max(1.0f, std::abs(f1[c])));
      }
    }
}

// The block forms (AVX2 where the CPU has it) run the scalar code for a
// coated BRDF: the same bits as evalParts and sampleDirection. Packed records
// keep the coat (its normal to 15 bits a component) in groups mixed with
// uncoated ones.
TEST(ClearcoatBrdf, BlockFormsAgreeWithTheScalarOnes) {
  constexpr int n = 16;
  Rng rng(5, 5);
  float wx[n], wy[n], wz[n], f0[n], f1[n], f2[n], pdf[n], d0[n], d1[n], d2[n], s0[n], s1[n], s2[n];
  for (int i = 0; i < n; ++i) {
    const Vec3 w = sampleCosineHemisphere({rng.uniform(), rng.uniform()});
    wx[i] = w.x, wy[i] = w.y, wz[i] = w.z;
  }
  float* const f[3] = {f0, f1, f2};
  float* const d[3] = {d0, d1, d2};
  float* const s[3] = {s0, s1, s2};
  const BrdfAt at(coated(0.5f, 0.1f, 0.8f, 20), dirFromAngles(40, 10));
  at.evalTotals(n, wx, wy, wz, f, pdf);
  at.evalPartsMany(n, wx, wy, wz, d, s);
  for (int i = 0; i < n; ++i) {
    float p = 0;
    const BrdfAt::Parts e = at.evalParts(Vec3(wx[i], wy[i], wz[i]), &p);
    EXPECT_EQ(f0[i], e.total().x);
    EXPECT_EQ(pdf[i], p);
    EXPECT_EQ(d1[i], e.diffuse.y);
    EXPECT_EQ(s2[i], e.specular.z);
  }
  // Packed: coated and uncoated records, whole and restricted, in one block.
  std::vector<BrdfAt> fs;
  for (int i = 0; i < n; ++i) {
    const BrdfAt full(
        i % 3 ? coated(0.3f + 0.03f * i, 0.2f + 0.03f * i, 0.1f * (i % 7), float(i)) : coated(0.5f, 0.1f, 0),
        dirFromAngles(5.0f * i, 20.0f * i));
    fs.push_back(i % 4 == 1 ? full.diffuseLobe() : i % 4 == 2 ? full.specularLobe() : full);
  }
  std::vector<float> rec(n * BrdfAt::kPackedFloats);
  const float* recs[n];
  for (int i = 0; i < n; ++i) {
    fs[i].pack(&rec[i * BrdfAt::kPackedFloats]);
    recs[i] = &rec[i * BrdfAt::kPackedFloats];
  }
  for (bool diffuseOnly : {false, true}) {
    BrdfAt::evalTotalsPacked(n, recs, wx, wy, wz, diffuseOnly, f);
    for (int i = 0; i < n; ++i) {
      const BrdfAt::Parts e = fs[i].evalParts(Vec3(wx[i], wy[i], wz[i]));
      const Vec3 want = diffuseOnly ? e.diffuse : e.total();
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(f[c][i], want[c], 1e-3f * std::max(1.0f, want[c])) << "record " << i;
    }
  }
}

// ---- Sampling against the pdf -------------------------------------------------------

// The coat's lobe alone (a base without a specular lobe, restricted to its
// specular lobes: the coat is then sampled with probability 1) and the
// whole mixture (coat, base specular, base diffuse), with the coat's normal
// tilted or not. Level: 1% over the cases (Sidak).
TEST(ClearcoatStats, SamplingMatchesPdfChiSquare) {
  struct Case {
    const char* name;
    BrdfAt f;
  };
  const Brdf coatOnly = coated(0.5f, 0.3f, 1, 0, 0, Vec3(0.5f), 0.0f);
  const std::vector<Case> cases = {
      {"coat_r0.3_t20", BrdfAt(coatOnly, dirFromAngles(20, 30)).specularLobe()},
      {"coat_r0.3_t70", BrdfAt(coatOnly, dirFromAngles(70, 30)).specularLobe()},
      {"mix_r0.5_c0.3_t45", BrdfAt(coated(0.5f, 0.3f, 0.8f), dirFromAngles(45, 30))},
      {"mix_tilted_t30", BrdfAt(coated(0.6f, 0.35f, 1, 20), dirFromAngles(30, 200))},
      {"metal_coat_t60", BrdfAt(coated(0.7f, 0.3f, 0.6f, 0, 1), dirFromAngles(60, 30))},
  };
  const double level = sidak(0.01, int(cases.size()));
  for (const Case& k : cases) {
    Chi2Config cfg;
    cfg.samples = 200000;
    cfg.subdiv = 10;
    auto r = chi2Directions(
        [&](Rng& g) -> std::optional<Vec3> {
          auto s = k.f.sample(g.uniform(), {g.uniform(), g.uniform()});
          if (!s) return std::nullopt;
          return s->wi;
        },
        [&](const Vec3& wi) { return double(k.f.pdf(wi)); }, cfg, std::string("clearcoat_") + k.name);
    EXPECT_TRUE(r.message.empty()) << k.name << ": " << r.message;
    EXPECT_GT(r.pValue, level) << k.name << ": chi2 " << r.statistic << " dof " << r.dof;
  }
}

// ---- Energy -------------------------------------------------------------------------

// White furnace: white bases (dielectric, metal, rough and smooth) under
// coats reflect at most what they receive from every direction: albedo - 1
// below 4 standard errors. The coat's own albedo is cc E_c(wo), so the sum
// stays below 1 when the base's is (core/material.h). A coat normal tilted
// off the shading normal is a shading normal of its own and is not bound so
// (as normal maps are not; docs/REFERENCE.md, "Clear coat").
TEST(ClearcoatStats, WhiteFurnaceAlbedoAtMostOne) {
  for (float m : {0.0f, 1.0f})
    for (float r : {0.05f, 0.5f})
      for (float cr : {0.03f, 0.4f})
        for (float th : {0.0f, 60.0f, 85.0f}) {
          const BrdfAt f(coated(r, cr, 1, 0, m, Vec3(1.0f)), dirFromAngles(th, 17));
          auto [mean, se] = albedo(f, 40000, 5);
          EXPECT_LE(mean, 1.0 + 4 * se + 1e-6)
              << "metallic " << m << " roughness " << r << " coat " << cr << " theta " << th << ": " << mean;
          EXPECT_GT(mean, 0.3) << "suspiciously dark: metallic " << m << " roughness " << r << " theta " << th;
        }
}

// The closed form over a Lambertian base (specularFactor 0, albedo c): the
// coat reflects cc E_c(wo) and the base c (1 - cc E_c(wo)) (1 - cc E_c,avg),
// since the cosine-weighted mean of E_c over the hemisphere is E_c,avg.
// Tolerance: 4 standard errors plus the albedo table's interpolation (0.01,
// as BrdfStats.AlbedoScalingConservesEnergy).
TEST(ClearcoatStats, AlbedoOverALambertianBaseIsTheClosedForm) {
  for (float cc : {0.5f, 1.0f})
    for (float cr : {0.1f, 0.5f})
      for (float th : {0.0f, 50.0f, 80.0f}) {
        const float c = 0.9f, alphaC = cr * cr;
        const BrdfAt f(coated(1, cr, cc, 0, 0, Vec3(c), 0.0f), dirFromAngles(th, 0));
        const double Ec = dielectricSpecularAlbedo(std::cos(th * kPi / 180), alphaC);
        const double want = cc * Ec + c * (1 - cc * Ec) * (1 - cc * dielectricSpecularAlbedoAverage(alphaC));
        auto [mean, se] = albedo(f, 40000, 7);
        EXPECT_NEAR(mean, want, 4 * se + 0.01) << "cc " << cc << " coat roughness " << cr << " theta " << th;
      }
}

// ---- The VSL transfer ----------------------------------------------------------------

// As r -> 0 the VSL transfer tends to the unclamped VPL one on coated
// receivers and lights, as it does without a coat (VslIntegral).
TEST(ClearcoatVsl, TendsToVplAsRadiusVanishes) {
  Rng rng(7, 7);
  for (int trial = 0; trial < 100; ++trial) {
    const Brdf bx = coated(0.5f, trial % 2 ? 0.3f : 0.45f, 1, trial % 3 ? 0.0f : 15.0f);
    const Brdf bp = trial % 4 ? coated(0.6f, 0.3f, 0.7f) : Brdf::fromGltf(Vec3(0.7f), 0, 0.6f, 0);
    const Vec3 wo = normalize(Vec3(rng.uniform() - 0.5f, rng.uniform() - 0.5f, 0.3f + rng.uniform()));
    const Vec3 toLight(rng.uniform() * 2 - 1, rng.uniform() * 2 - 1, 0.2f + rng.uniform());
    const float d = length(toLight);
    const Vec3 l = toLight / d;
    const Vec3 np = normalize(-l + Vec3(rng.uniform() - 0.5f, rng.uniform() - 0.5f, rng.uniform() - 0.5f) * 0.8f);
    const Vec3 wip = normalize(np + Vec3(rng.uniform() - 0.5f, rng.uniform() - 0.5f, 0) * 0.5f);
    VslReceiver x;
    x.frame = Frame(Vec3(0, 0, 1), Vec3(1, 0, 0));
    x.ng = x.frame.n;
    x.f = BrdfAt(bx, x.frame.toLocal(wo));
    VslEmitter p;
    p.frame = Frame(np, Vec3(0, 1, 0));
    p.f = BrdfAt(bp, p.frame.toLocal(wip));
    const Vec3 lp = p.frame.toLocal(-l), lx = x.frame.toLocal(l);
    Vec3 vpl(0.0f);
    if (lx.z > 0 && lp.z > 0) vpl = x.f.eval(lx) * p.f.eval(lp) * (lx.z * lp.z / (d * d));
    for (double r : {1e-4 * d, 1e-7 * d}) {
      Rng g(trial, 1);
      const VslResult v = vslTransfer(x, p, toLight, r, {}, g);
      for (int c = 0; c < 3; ++c)
        ASSERT_NEAR(v.transfer[c], vpl[c], 2e-3f * vpl[c] + 1e-7f) << "trial " << trial << " r " << r;
    }
  }
}

// ---- Light tracing ------------------------------------------------------------------

namespace {

// The inside of [-1, 1]^3, every face an emitter (Le 1) of grey plastic
// (0.5, roughness 0.6) under a clear coat (roughness 0.3) whose normal map
// tilts the coat 35 degrees four ways: light tracing must carry the coat and
// its normal into the virtual lights (VirtualLight::brdf).
std::shared_ptr<Scene> coatedFurnace() {
  auto s = std::make_shared<Scene>();
  const float c = std::cos(0.61f), sn = std::sin(0.61f);
  Texture t;
  t.name = "coat normals";
  t.width = t.height = 2;
  for (const Vec3& n : {Vec3(sn, 0, c), Vec3(0, sn, c), Vec3(-sn, 0, c), Vec3(0, -sn, c)})
    t.rgba.insert(t.rgba.end(), {n.x * 0.5f + 0.5f, n.y * 0.5f + 0.5f, n.z * 0.5f + 0.5f, 1.0f});
  s->textures.push_back(t);
  Material wall = testMaterial("wall", Vec3(0.5f), 0, 0.6f, 0);
  wall.emission = Vec3(1.0f);
  wall.clearcoat = 1;
  wall.clearcoatRoughness = 0.3f;
  wall.clearcoatNormalTexture = 0;
  s->materials = {wall};
  const Vec3 X(2, 0, 0), Y(0, 2, 0), Z(0, 0, 2), lo(-1, -1, -1), hi(1, 1, 1);
  const Vec3 faces[6][3] = {{lo, X, Y}, {hi, -Y, -X}, {lo, Z, X}, {hi, -X, -Z}, {lo, Y, Z}, {hi, -Z, -Y}};
  for (const auto& f : faces) {
    const uint32_t b = uint32_t(s->positions.size());
    addQuad(*s, f[0], f[1], f[2], 0);
    const Vec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (uint32_t k = 0; k < 4; ++k) {
      s->uvs[b + k] = uv[k];
      s->tangents[b + k] = normalize(f[1]);
    }
  }
  s->camera.position = Vec3(0.1f, 0.2f, 0.3f);
  s->camera.yfov = 0.6f;
  s->camera.aspect = 1;
  s->cameraFromFile = true;
  s->materials.push_back(testMaterial("default", Vec3(0.8f), 0));
  return s;
}

}  // namespace

// Unclamped VPLs (unbiased) against the path tracer's indirect image: the
// z-score of the mean over 12 independent light sets of 1,500 lights, the
// path tracer at 512 spp (as NormalMaps.LightTracedVplsAgreeWithThePathTracer).
TEST(ClearcoatRender, LightTracedVplsAgreeWithThePathTracer) {
  const Loaded l = loadedFrom(coatedFurnace(), 8);
  const Reference ref = ptIndirect(l, l.width, l.height, 512, 51);
  ManyLightSettings base;
  base.lights = 1500;
  const double z = unclampedVplZ(l, ref, base, 600, "coated furnace");
  EXPECT_LT(std::abs(z), 4.0);
  EXPECT_GT(ref.mean, 0.1);  // the coat leaves the room lit
}

// ---- The loader ---------------------------------------------------------------------

namespace {

// A unit quad in z = 0 (normals +z, uv with v down) under a point light,
// with a clear-coated red material: every clear coat property, each texture
// a 2x2 PNG beside the file, the weight's with a KHR_texture_transform.
std::string writeClearcoatQuad(const std::filesystem::path& dir) {
  // R: the coat's weight (1 everywhere), G: its roughness; the normal map
  // is flat (128, 128, 255).
  const std::vector<uint8_t> rgb = {255, 128, 0, 255, 255, 0, 255, 64, 0, 255, 32, 0};
  EXPECT_TRUE(writePngRgb8((dir / "coat.png").string(), 2, 2, rgb));
  const std::vector<uint8_t> flat = {128, 128, 255, 128, 128, 255, 128, 128, 255, 128, 128, 255};
  EXPECT_TRUE(writePngRgb8((dir / "flat.png").string(), 2, 2, flat));
  const float pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  const float nrm[] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
  const float uv[] = {0, 1, 1, 1, 1, 0, 0, 0};
  const uint16_t idx[] = {0, 1, 2, 0, 2, 3};
  std::ofstream bin(dir / "quad.bin", std::ios::binary);
  bin.write(reinterpret_cast<const char*>(pos), sizeof pos);
  bin.write(reinterpret_cast<const char*>(nrm), sizeof nrm);
  bin.write(reinterpret_cast<const char*>(uv), sizeof uv);
  bin.write(reinterpret_cast<const char*>(idx), sizeof idx);
  bin.close();
  const std::string path = (dir / "coated.gltf").string();
  std::ofstream f(path);
  f << R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1,2]}],
    "extensionsUsed":["KHR_lights_punctual","KHR_materials_clearcoat","KHR_texture_transform"],
    "extensions":{"KHR_lights_punctual":{"lights":[{"type":"point","intensity":10}]}},
    "nodes":[{"mesh":0},{"extensions":{"KHR_lights_punctual":{"light":0}},"translation":[0.5,0.5,2]},
      {"camera":0,"translation":[0.5,0.5,2]}],
    "cameras":[{"type":"perspective","perspective":{"yfov":0.8,"znear":0.01}}],
    "meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2},"indices":3,"material":0}]}],
    "materials":[{"name":"lacquer","pbrMetallicRoughness":{"baseColorFactor":[0.8,0.05,0.05,1],
      "metallicFactor":0,"roughnessFactor":0.5},
      "extensions":{"KHR_materials_clearcoat":{"clearcoatFactor":0.9,
        "clearcoatTexture":{"index":0,"extensions":{"KHR_texture_transform":{"scale":[2,2]}}},
        "clearcoatRoughnessFactor":0.2,"clearcoatRoughnessTexture":{"index":0},
        "clearcoatNormalTexture":{"index":1,"scale":0.5}}}}],
    "textures":[{"source":0},{"source":1}],"images":[{"uri":"coat.png"},{"uri":"flat.png"}],
    "accessors":[
      {"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
      {"bufferView":1,"componentType":5126,"count":4,"type":"VEC3"},
      {"bufferView":2,"componentType":5126,"count":4,"type":"VEC2"},
      {"bufferView":3,"componentType":5123,"count":6,"type":"SCALAR"}],
    "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":48},
      {"buffer":0,"byteOffset":96,"byteLength":32},{"buffer":0,"byteOffset":128,"byteLength":12}],
    "buffers":[{"byteLength":140,"uri":"quad.bin"}]})";
  return path;
}

}  // namespace

TEST(ClearcoatLoader, ReadsEveryPropertyWithoutWarning) {
  const auto dir = scratchDir("vsl-clearcoat-loader");
  SceneResult r = loadScene(writeClearcoatQuad(dir));
  ASSERT_TRUE(r) << r.error();
  const Scene& s = *r.value();
  EXPECT_TRUE(s.warnings.empty()) << "first warning: " << (s.warnings.empty() ? "" : s.warnings[0]);
  const Material& m = s.materials[0];
  EXPECT_FLOAT_EQ(m.clearcoat, 0.9f);
  EXPECT_FLOAT_EQ(m.clearcoatRoughness, 0.2f);
  EXPECT_GE(m.clearcoatTexture, 0);
  EXPECT_GE(m.clearcoatRoughnessTexture, 0);
  EXPECT_GE(m.clearcoatNormalTexture, 0);
  EXPECT_FLOAT_EQ(m.clearcoatNormalScale, 0.5f);
  EXPECT_EQ(m.clearcoatTransform.scale().x, 2.0f);
  EXPECT_TRUE(m.clearcoatRoughnessTransform.isIdentity());
  // The hit at uv (0.25, 0.25) (triangle 1: uv = (u, 1 - u - v)) reads
  // texel (0, 0) for roughness: weight 0.9 x 1, roughness 0.2 x 128/255,
  // the coat's normal +z (the map is flat).
  const SurfaceHit h = s.surfaceHit(1, 0.25f, 0.5f, Vec3(0, 0, -1));
  ASSERT_NEAR(h.uv.x, 0.25f, 1e-6f);
  ASSERT_NEAR(h.uv.y, 0.25f, 1e-6f);
  const Brdf b = s.brdf(h);
  EXPECT_NEAR(b.clearcoat, 0.9f, 1e-5f);
  EXPECT_NEAR(b.coat.ax, std::max(sqr(0.2f * 128 / 255), kMinAlpha), 1e-5f);
  EXPECT_NEAR(b.coatNormal.z, 1.0f, 1e-4f);
  // `vsl info` reports no warning either.
  const Proc info = runVsl("info " + writeClearcoatQuad(dir));
  EXPECT_EQ(info.code, 0) << info.out;
  EXPECT_NE(info.out.find("warnings   0"), std::string::npos) << info.out;
  EXPECT_EQ(info.out.find("not modelled"), std::string::npos) << info.out;
}
