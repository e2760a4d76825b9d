// Normal maps (glTF normalTexture) and the tangent frames they need: tangent
// generation against dP/du, the loader, and renders of normal-mapped scenes
// against geometry, the white furnace's closed form and the path tracer
// (docs/REFERENCE.md, "Normal maps and shading normals").
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "core/image_io.h"
#include "core/many_light.h"
#include "core/tangents.h"
#include "support.h"

using namespace vsl;
using namespace vsl::test;

namespace {

// ---- Tangent generation -----------------------------------------------------------

// An n x n grid in the plane z = 0 whose uv maps to P = A (u, v) + c, with
// the triangles wound counter-clockwise seen from +z.
struct Grid {
  std::vector<Vec3> p, n;
  std::vector<Vec2> uv;
  std::vector<uint32_t> tris;
};
Grid uvGrid(int n, float a00, float a01, float a10, float a11, bool smoothNormals) {
  Grid g;
  // Invert P = A uv for the uv of each grid point (x, y).
  const float det = a00 * a11 - a01 * a10;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const float x = float(i) / n, y = float(j) / n;
      g.p.push_back({x, y, 0});
      g.n.push_back(smoothNormals ? Vec3(0, 0, 1) : Vec3(0.0f));
      g.uv.push_back({(a11 * x - a01 * y) / det, (-a10 * x + a00 * y) / det});
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const uint32_t v = uint32_t(j * (n + 1) + i), w = uint32_t(n + 1);
      g.tris.insert(g.tris.end(), {v, v + 1, v + w + 1, v, v + w + 1, v + w});
    }
  return g;
}

void generate(const Grid& g, std::vector<Vec3>& t, std::vector<float>& s) {
  t.assign(g.p.size(), Vec3(0.0f));
  s.assign(g.p.size(), 0.0f);
  generateMikkTangents(g.p, g.n, g.uv, g.tris, 0, t, s);
}

}  // namespace

TEST(Tangents, GeneratedTangentIsDpduAndHandednessFollowsTheMirror) {
  // Cases: P = A (u, v); dP/du is A's first column, dP/dv its second. The
  // glTF bitangent cross(n, t) w points along -dP/dv (v runs down the image).
  struct Case {
    float a00, a01, a10, a11;
    float sign;
    const char* what;
  };
  const float c = std::cos(0.5f), s = std::sin(0.5f);
  const Case cases[] = {
      {1, 0, 0, -1, 1, "u right, v down (the usual glTF mapping)"},
      {-1, 0, 0, -1, -1, "u mirrored"},
      {1, 0, 0, 1, -1, "v mirrored"},
      {2 * c, 3 * s, 2 * s, -3 * c, 1, "rotated and stretched"},
      {0.5f, 0.8f, 0.3f, -1.2f, 1, "sheared"},
  };
  for (const Case& k : cases)
    for (bool smooth : {false, true}) {
      const Grid g = uvGrid(3, k.a00, k.a01, k.a10, k.a11, smooth);
      std::vector<Vec3> t;
      std::vector<float> sg;
      generate(g, t, sg);
      const Vec3 dpdu = normalize(Vec3(k.a00, k.a10, 0));
      for (size_t v = 0; v < g.p.size(); ++v) {
        EXPECT_NEAR(length(t[v] - dpdu), 0.0f, 1e-5f) << k.what << ", vertex " << v;
        EXPECT_EQ(sg[v], k.sign) << k.what << ", vertex " << v;
      }
    }
}

TEST(Tangents, TangentIsOrthogonalisedAgainstABentNormal) {
  // A vertex normal tilted toward +x: the tangent is dP/du with its part
  // along the normal removed (Gram-Schmidt), still unit.
  Grid g = uvGrid(2, 1, 0, 0, -1, true);
  const Vec3 bent = normalize(Vec3(0.5f, 0, 1));
  for (Vec3& n : g.n) n = bent;
  std::vector<Vec3> t;
  std::vector<float> sg;
  generate(g, t, sg);
  const Vec3 want = normalize(Vec3(1, 0, 0) - bent * bent.x);
  for (size_t v = 0; v < g.p.size(); ++v) {
    EXPECT_NEAR(length(t[v] - want), 0.0f, 1e-5f) << "vertex " << v;
    EXPECT_NEAR(dot(t[v], bent), 0.0f, 1e-6f);
    EXPECT_EQ(sg[v], 1.0f);
  }
}

// ---- Loader -----------------------------------------------------------------------------

namespace {

// A unit quad in z = 0 (normals +z, uv with v down) under an emitter, with a
// normal-mapped material whose map is a 2x2 PNG written beside the file;
// with TANGENT (w = tangentW) if withTangent.
std::string writeNormalMappedQuad(const std::filesystem::path& dir, bool withTangent, float tangentW) {
  std::vector<uint8_t> rgb = {128, 128, 255, 160, 128, 240, 128, 160, 240, 100, 100, 240};
  EXPECT_TRUE(writePngRgb8((dir / "normal.png").string(), 2, 2, rgb));
  const float pos[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  const float nrm[] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
  const float uv[] = {0, 1, 1, 1, 1, 0, 0, 0};
  const float tan[] = {1, 0, 0, tangentW, 1, 0, 0, tangentW, 1, 0, 0, tangentW, 1, 0, 0, tangentW};
  const uint16_t idx[] = {0, 1, 2, 0, 2, 3};
  std::ofstream bin(dir / "quad.bin", std::ios::binary);
  bin.write(reinterpret_cast<const char*>(pos), sizeof pos);
  bin.write(reinterpret_cast<const char*>(nrm), sizeof nrm);
  bin.write(reinterpret_cast<const char*>(uv), sizeof uv);
  bin.write(reinterpret_cast<const char*>(tan), sizeof tan);
  bin.write(reinterpret_cast<const char*>(idx), sizeof idx);
  bin.close();
  std::string attributes = R"("POSITION":0,"NORMAL":1,"TEXCOORD_0":2)";
  if (withTangent) attributes += R"(,"TANGENT":3)";
  const std::string path = (dir / "quad.gltf").string();
  std::ofstream f(path);
  f << R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
    "extensionsUsed":["KHR_lights_punctual"],
    "extensions":{"KHR_lights_punctual":{"lights":[{"type":"point","intensity":10}]}},
    "nodes":[{"mesh":0},{"extensions":{"KHR_lights_punctual":{"light":0}},"translation":[0.5,0.5,2]}],
    "meshes":[{"primitives":[{"attributes":{)"
    << attributes << R"(},"indices":4,"material":0}]}],
    "materials":[{"name":"bumpy","normalTexture":{"index":0,"scale":0.5},
                  "pbrMetallicRoughness":{"metallicFactor":0,"roughnessFactor":0.4}}],
    "textures":[{"source":0}],"images":[{"uri":"normal.png"}],
    "accessors":[
      {"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
      {"bufferView":1,"componentType":5126,"count":4,"type":"VEC3"},
      {"bufferView":2,"componentType":5126,"count":4,"type":"VEC2"},
      {"bufferView":3,"componentType":5126,"count":4,"type":"VEC4"},
      {"bufferView":4,"componentType":5123,"count":6,"type":"SCALAR"}],
    "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":48},
      {"buffer":0,"byteOffset":96,"byteLength":32},{"buffer":0,"byteOffset":128,"byteLength":64},
      {"buffer":0,"byteOffset":192,"byteLength":12}],
    "buffers":[{"byteLength":204,"uri":"quad.bin"}]})";
  return path;
}

bool warnsAbout(const Scene& s, const std::string& word) {
  for (const std::string& w : s.warnings)
    if (w.find(word) != std::string::npos) return true;
  return false;
}

}  // namespace

TEST(NormalMapLoader, ReadsTheMapAndGeneratesTangentsWithoutWarning) {
  const auto dir = scratchDir("vsl-normal-map-loader");
  SceneResult r = loadScene(writeNormalMappedQuad(dir, false, 1));
  ASSERT_TRUE(r) << r.error();
  const Scene& s = *r.value();
  EXPECT_FALSE(warnsAbout(s, "normalTexture")) << "warnings: " << (s.warnings.empty() ? "" : s.warnings[0]);
  ASSERT_EQ(s.materials.size(), 2u);
  EXPECT_GE(s.materials[0].normalTexture, 0);
  EXPECT_FLOAT_EQ(s.materials[0].normalScale, 0.5f);
  for (size_t v = 0; v < s.positions.size(); ++v) {
    EXPECT_NEAR(length(s.tangents[v] - Vec3(1, 0, 0)), 0.0f, 1e-6f) << "vertex " << v;
    EXPECT_EQ(s.tangentSigns[v], 1.0f);
  }
  // The texel (128, 128, 255) at the first corner is the unperturbed normal.
  const Vec3 flat = s.normalMapTexel(s.materials[0], {0.25f, 0.25f});
  EXPECT_NEAR(flat.z, 1.0f, 1e-4f);
}

TEST(NormalMapLoader, KeepsTheFilesTangentAndItsHandedness) {
  const auto dir = scratchDir("vsl-normal-map-tangent");
  SceneResult r = loadScene(writeNormalMappedQuad(dir, true, -1));
  ASSERT_TRUE(r) << r.error();
  const Scene& s = *r.value();
  EXPECT_FALSE(warnsAbout(s, "normalTexture"));
  for (size_t v = 0; v < s.positions.size(); ++v) EXPECT_EQ(s.tangentSigns[v], -1.0f);
  // The map tilts the shading normal; it stays on the geometric side.
  const SurfaceHit h = s.surfaceHit(0, 0.3f, 0.3f, Vec3(0, 0, -1));
  EXPECT_TRUE(h.normalMapped);
  EXPECT_GT(dot(h.shading.n, h.ng), 0.2f - 1e-6f);
  EXPECT_GT(length(h.shading.n - h.ng), 1e-3f);
}

// ---- Renders -----------------------------------------------------------------------------

namespace {

// A quad as addQuad, with uv (0..1) and tangent eu (sign +1): a normal map's
// x runs along eu, its y along cross(n, eu).
void addMappedQuad(Scene& s, Vec3 o, Vec3 eu, Vec3 ev, uint32_t material) {
  const uint32_t b = uint32_t(s.positions.size());
  addQuad(s, o, eu, ev, material);
  const Vec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (uint32_t k = 0; k < 4; ++k) {
    s.uvs[b + k] = uv[k];
    s.tangents[b + k] = normalize(eu);
  }
}

// A texture of w x h tangent-space normals (stored as (n + 1) / 2).
Texture normalTexture(int w, int h, const std::vector<Vec3>& normals) {
  Texture t;
  t.name = "normals";
  t.width = w;
  t.height = h;
  for (const Vec3& n : normals) {
    const Vec3 u = normalize(n);
    t.rgba.insert(t.rgba.end(), {u.x * 0.5f + 0.5f, u.y * 0.5f + 0.5f, u.z * 0.5f + 0.5f, 1.0f});
  }
  return t;
}

void finish(Scene& s) { s.materials.push_back(testMaterial("default", Vec3(0.8f), 0)); }

// Mean grey value of a path-traced image (direct + indirect) with its
// standard error, spp samples per pixel.
std::pair<double, double> ptMean(const Loaded& l, int spp, uint64_t seed) {
  RenderSettings rs;
  rs.width = l.width;
  rs.height = l.height;
  rs.seed = seed;
  PathTracer pt(*l.scene, *l.accel, *l.lights, rs);
  MeanAccumulator acc;
  uint64_t rays = 0, nonFinite = 0;
  for (int y = 0; y < l.height; ++y)
    for (int x = 0; x < l.width; ++x) {
      double pix = 0;
      for (int k = 0; k < spp; ++k) {
        Vec3 Ld, Li;
        pt.samplePixel(x, y, k, Ld, Li, rays, nonFinite);
        pix += (double(Ld.x + Li.x) + Ld.y + Li.y + Ld.z + Li.z) / 3 / spp;
      }
      acc.add(pix);
    }
  EXPECT_EQ(nonFinite, 0u);
  return {acc.mean(), acc.standardError()};
}

// A glossy metal plane through the origin, lit by an emissive square placed
// where the camera's view reflects about the normal (0, cos t, sin t): the
// plane itself tilted to that normal (geometric), or flat (normal +y) with a
// 1x1 normal map encoding the tilt (mapped), or flat without the map.
enum class Tilt { Geometric, Mapped, None };
std::shared_ptr<Scene> tiltScene(Tilt kind, float tilt) {
  auto s = std::make_shared<Scene>();
  const float c = std::cos(tilt), sn = std::sin(tilt);
  Material metal = testMaterial("metal", Vec3(0.9f), 1, 0.35f);
  if (kind == Tilt::Mapped) {
    // The plane's tangent is its eu, +z: the tilt toward +z is +x in the map.
    s->textures.push_back(normalTexture(1, 1, {Vec3(sn, 0, c)}));
    metal.normalTexture = 0;
  }
  s->materials = {metal, emitterMaterial(Vec3(4.0f))};
  const Vec3 eu = kind == Tilt::Geometric ? Vec3(0, -sn, c) * 4.0f : Vec3(0, 0, 4);
  const Vec3 ev(4, 0, 0);
  addMappedQuad(*s, (eu + ev) * -0.5f, eu, ev, 0);
  // The light: a 15-wide square 30 away along the reflected view direction,
  // facing the origin (far, so that where the view meets the plane matters
  // little).
  const Vec3 cam(0, 2, 3), nTilt(0, c, sn);
  const Vec3 wo = normalize(cam), r = nTilt * (2 * dot(wo, nTilt)) - wo;
  const Vec3 lu = normalize(cross(r, Vec3(1, 0, 0))) * 15.0f, lv = normalize(cross(lu, r)) * 15.0f;
  // Winding so that the emitter faces -r (toward the origin).
  addQuad(*s, r * 30.0f - (lu + lv) * 0.5f, lu, lv, 1);
  EXPECT_LT(dot(s->triangleNormal(uint32_t(s->triangleCount() - 1)), r), 0.0f);
  s->camera.position = cam;
  s->camera.forward = -wo;
  s->camera.right = Vec3(1, 0, 0);
  s->camera.up = cross(s->camera.right, s->camera.forward);
  s->camera.yfov = 0.14f;  // 8 degrees: the plane's depth varies little
  s->camera.aspect = 1;
  s->cameraFromFile = true;
  finish(*s);
  return s;
}

}  // namespace

TEST(NormalMaps, ConstantTiltRendersLikeTheTiltedPlane) {
  // The glossy highlight depends on the normal only: the mapped flat plane
  // and the geometrically tilted one agree within noise plus a 2% allowance
  // for what the tilt moves (where the view meets the plane shifts by up to
  // 0.07, which turns the directions to the light by up to 0.15 degrees);
  // without the map the highlight is missed (the view reflects 2 x 15
  // degrees away from the light).
  const float tilt = 15 * kPi / 180;
  const Loaded geo = loadedFrom(tiltScene(Tilt::Geometric, tilt), 16);
  const Loaded mapped = loadedFrom(tiltScene(Tilt::Mapped, tilt), 16);
  const Loaded flat = loadedFrom(tiltScene(Tilt::None, tilt), 16);
  const auto [mg, sg] = ptMean(geo, 64, 11);
  const auto [mm, sm] = ptMean(mapped, 64, 12);
  const auto [mf, sf] = ptMean(flat, 64, 13);
  std::printf("tilted plane %.5f +- %.5f, normal-mapped %.5f +- %.5f, flat %.5f +- %.5f\n", mg, sg, mm, sm, mf, sf);
  EXPECT_LT(std::abs(mm - mg), 4 * std::hypot(sg, sm) + 0.02 * mg);
  EXPECT_LT(mf, 0.5 * mg);
}

namespace {

// The inside of a closed cube whose walls all emit Le = 1 and reflect
// diffusely with albedo 0.5 (pure Lambertian: specularWeight 0), their
// normal maps bumpy (2x2 texels tilted 35 degrees four ways) or absent.
// Radiance inside: Le / (1 - a) = 2 (docs/REFERENCE.md's furnace).
std::shared_ptr<Scene> furnaceBox(bool bumpy, float yfov = 1.4f) {
  auto s = std::make_shared<Scene>();
  Material wall = testMaterial("wall", Vec3(0.5f), 0, 1, 0);
  wall.emission = Vec3(1.0f);
  if (bumpy) {
    const float c = std::cos(0.61f), sn = std::sin(0.61f);
    s->textures.push_back(normalTexture(2, 2, {Vec3(sn, 0, c), Vec3(0, sn, c), Vec3(-sn, 0, c), Vec3(0, -sn, c)}));
    wall.normalTexture = 0;
    wall.normalScale = 1;
  }
  s->materials = {wall};
  // Six inward-facing faces of [-1, 1]^3.
  const Vec3 X(2, 0, 0), Y(0, 2, 0), Z(0, 0, 2), lo(-1, -1, -1), hi(1, 1, 1);
  addMappedQuad(*s, lo, X, Y, 0);    // z = -1, facing +z
  addMappedQuad(*s, hi, -Y, -X, 0);  // z = +1, facing -z
  addMappedQuad(*s, lo, Z, X, 0);    // y = -1, facing +y
  addMappedQuad(*s, hi, -X, -Z, 0);  // y = +1, facing -y
  addMappedQuad(*s, lo, Y, Z, 0);    // x = -1, facing +x
  addMappedQuad(*s, hi, -Z, -Y, 0);  // x = +1, facing -x
  s->camera.position = Vec3(0.1f, 0.2f, 0.3f);
  s->camera.yfov = yfov;
  s->camera.aspect = 1;
  s->cameraFromFile = true;
  finish(*s);
  return s;
}

}  // namespace

TEST(NormalMaps, WhiteFurnaceKeepsAtOrBelowTheClosedForm) {
  const Loaded bumpy = loadedFrom(furnaceBox(true), 12);
  const Loaded plain = loadedFrom(furnaceBox(false), 12);
  const auto [mb, sb] = ptMean(bumpy, 32, 21);
  const auto [mp, sp] = ptMean(plain, 32, 22);
  std::printf("furnace (closed form 2): normal-mapped %.5f +- %.5f, plain %.5f +- %.5f\n", mb, sb, mp, sp);
  EXPECT_NEAR(mp, 2.0, 4 * sp + 1e-3);
  // Shading normals lose energy (directions below the geometric surface are
  // rejected) but never gain it; they lose little at 35 degrees.
  EXPECT_LE(mb, 2.0 + 4 * sb);
  EXPECT_GT(mb, 1.6);
}

namespace {

// The z-score of the unclamped VPLs' indirect mean (12 independent light
// sets of 1,500 lights, seeds firstSeed...) against the path tracer's
// indirect image (512 spp, seed ptSeed); prints both with the label.
double vplAgainstPathTracer(const Loaded& l, uint64_t ptSeed, uint64_t firstSeed, const char* label) {
  ManyLightSettings base;
  base.lights = 1500;
  return unclampedVplZ(l, ptIndirect(l, l.width, l.height, 512, ptSeed), base, firstSeed, label);
}

}  // namespace

TEST(NormalMaps, LightTracedVplsAgreeWithThePathTracer) {
  // Indirect light in the bumpy furnace: unclamped VPLs from light tracing
  // (the adjoint with Veach's shading-normal correction, VirtualLight::
  // normalMapped) against the path tracer's indirect image, z-test over
  // independent light sets.
  // The view is narrow, on the middle of one wall: the VPLs' 1/d^2 spikes
  // in the box's corners would need many more light sets for a stable
  // standard error.
  const Loaded l = loadedFrom(furnaceBox(true, 0.6f), 8);
  EXPECT_LT(std::abs(vplAgainstPathTracer(l, 31, 500, "bumpy furnace")), 4.0);
}

namespace {

// A diffuse floor whose constant normal map tilts 40 degrees toward an
// emitter low on its side (the light arrives 14 degrees above the floor),
// and a white wall across the floor that the camera sees. The wall's
// indirect light is mostly the floor's reflection, which the adjoint
// factor |wo.ns| / |wo.ng| (about 3 here) changes most.
std::shared_ptr<Scene> grazingScene() {
  auto s = std::make_shared<Scene>();
  const float tilt = 40 * kPi / 180;
  // The floor's tangent is +z and its bitangent cross(+y, +z) = +x: toward
  // the light (-x) is -y in the map.
  s->textures.push_back(normalTexture(1, 1, {Vec3(0, -std::sin(tilt), std::cos(tilt))}));
  Material floor = testMaterial("floor", Vec3(0.8f), 0, 1, 0);
  floor.normalTexture = 0;
  s->materials = {floor, testMaterial("wall", Vec3(0.8f), 0, 1, 0), emitterMaterial(Vec3(20.0f))};
  addMappedQuad(*s, Vec3(-2, 0, -2), Vec3(0, 0, 4), Vec3(4, 0, 0), 0);   // floor, facing +y
  addQuad(*s, Vec3(2, 0, -2), Vec3(0, 0, 4), Vec3(0, 3, 0), 1);          // wall x = 2, facing -x
  addQuad(*s, Vec3(-6, 1, -0.75f), Vec3(0, 1, 0), Vec3(0, 0, 1.5f), 2);  // emitter, facing +x
  s->camera.position = Vec3(-1.5f, 1.2f, 0);
  s->camera.forward = Vec3(1, 0, 0);
  s->camera.right = Vec3(0, 0, 1);
  s->camera.up = Vec3(0, 1, 0);
  s->camera.yfov = 0.5f;
  s->camera.aspect = 1;
  s->cameraFromFile = true;
  finish(*s);
  return s;
}

}  // namespace

TEST(NormalMaps, LightTracingKeepsTheAdjointAtGrazingLight) {
  const Loaded l = loadedFrom(grazingScene(), 8);
  EXPECT_LT(std::abs(vplAgainstPathTracer(l, 41, 700, "grazing light on a tilted map")), 4.0);
}
