// glTF alphaMode MASK and BLEND (docs/REFERENCE.md, "Alpha: MASK and BLEND")
// and KHR_texture_transform, on small glTF files written by the tests.
//
// The masked scene: a grey floor y = 0, x and z in [-1, 1]; above it at
// y = 0.5 a "fence" quad, x and z in [-0.5, 0.5], whose base colour texture is
// a 4 x 4 checkerboard of alpha 1 and 0 (MASK, cutoff 0.5); a point light at
// (0, 2, 0) and a camera at (0, 3, 0) looking down. Its twin cuts the same
// squares out of the geometry: eight opaque squares of the fence's material.
// With bilinear filtering the alpha = 0.5 contour of a checkerboard runs
// exactly along the texel edges, so the two scenes have the same holes.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/image_io.h"
#include "core/rng.h"
#include "core/scene.h"
#include "core/virtual_lights.h"
#include "support.h"

using namespace vsl;
using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

// ---- A small glTF writer: quads, materials, textures, one light, one camera --------

struct QuadSpec {
  Vec3 o, eu, ev;  // corners o, o+eu, o+eu+ev, o+ev; front face along cross(eu, ev)
  int material = 0;
};

struct GltfSpec {
  std::vector<QuadSpec> quads;
  json materials = json::array();
  json images = json::array();  // {"uri": ...}, files in the scene's folder
  json textures = json::array();
  std::vector<std::string> extensionsUsed, extensionsRequired;
  bool texCoord1 = false;  // also write TEXCOORD_1 = (1 - u, v) on every quad
  Vec3 light{0, 2, 0};
  float intensity = 4;
};

template <typename T>
void appendBytes(std::vector<uint8_t>& b, const std::vector<T>& v) {
  size_t off = b.size();
  b.resize(off + v.size() * sizeof(T));
  std::memcpy(b.data() + off, v.data(), v.size() * sizeof(T));
}

// An accessor over the next bytes of bin (one buffer view each).
int addAccessor(json& j, std::vector<uint8_t>& bin, const std::vector<float>& data, const char* type, size_t count) {
  size_t off = bin.size();
  appendBytes(bin, data);
  j["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", off}, {"byteLength", data.size() * 4}});
  json acc = {{"bufferView", j["bufferViews"].size() - 1}, {"componentType", 5126}, {"count", count}, {"type", type}};
  if (std::string(type) == "VEC3") {
    std::vector<float> lo(3, 1e30f), hi(3, -1e30f);
    for (size_t i = 0; i < data.size(); ++i) {
      lo[i % 3] = std::min(lo[i % 3], data[i]);
      hi[i % 3] = std::max(hi[i % 3], data[i]);
    }
    acc["min"] = lo;
    acc["max"] = hi;
  }
  j["accessors"].push_back(acc);
  return int(j["accessors"].size() - 1);
}

// Writes DIR/NAME.gltf and DIR/NAME.bin; returns the .gltf path.
std::string writeGltf(const fs::path& dir, const std::string& name, const GltfSpec& s) {
  json j = {{"asset", {{"version", "2.0"}}},
            {"scene", 0},
            {"accessors", json::array()},
            {"bufferViews", json::array()},
            {"materials", s.materials}};
  std::vector<uint8_t> bin;
  std::vector<uint32_t> idx = {0, 1, 2, 0, 2, 3};
  appendBytes(bin, idx);
  j["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 24}});
  j["accessors"].push_back({{"bufferView", 0}, {"componentType", 5125}, {"count", 6}, {"type", "SCALAR"}});
  int uv0 = addAccessor(j, bin, {0, 0, 1, 0, 1, 1, 0, 1}, "VEC2", 4);
  int uv1 = addAccessor(j, bin, {1, 0, 0, 0, 0, 1, 1, 1}, "VEC2", 4);
  json prims = json::array();
  for (const QuadSpec& q : s.quads) {
    std::vector<float> pos;
    for (Vec3 p : {q.o, q.o + q.eu, q.o + q.eu + q.ev, q.o + q.ev}) pos.insert(pos.end(), {p.x, p.y, p.z});
    json attr = {{"POSITION", addAccessor(j, bin, pos, "VEC3", 4)}, {"TEXCOORD_0", uv0}};
    if (s.texCoord1) attr["TEXCOORD_1"] = uv1;
    prims.push_back({{"attributes", attr}, {"indices", 0}, {"material", q.material}});
  }
  j["meshes"] = {{{"primitives", prims}}};
  // The camera looks down -y: a rotation of -90 degrees about x.
  const double h = std::sqrt(0.5);
  j["nodes"] = {
      {{"mesh", 0}},
      {{"camera", 0}, {"translation", {0, 3, 0}}, {"rotation", {-h, 0, 0, h}}},
      {{"translation", {s.light.x, s.light.y, s.light.z}}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}}};
  j["scenes"] = {{{"nodes", {0, 1, 2}}}};
  j["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 0.7}, {"aspectRatio", 1.0}, {"znear", 0.01}}}}};
  j["extensions"] = {{"KHR_lights_punctual", {{"lights", {{{"type", "point"}, {"intensity", s.intensity}}}}}}};
  std::vector<std::string> used = s.extensionsUsed;
  used.push_back("KHR_lights_punctual");
  j["extensionsUsed"] = used;
  if (!s.extensionsRequired.empty()) j["extensionsRequired"] = s.extensionsRequired;
  if (!s.images.empty()) {
    j["images"] = s.images;
    j["textures"] = s.textures;
  }
  j["buffers"] = {{{"byteLength", bin.size()}, {"uri", name + ".bin"}}};
  std::ofstream(dir / (name + ".bin"), std::ios::binary).write(reinterpret_cast<const char*>(bin.data()), bin.size());
  fs::path path = dir / (name + ".gltf");
  std::ofstream(path) << j.dump();
  return path.string();
}

json greyMaterial(const char* name) {
  return {{"name", name}, {"pbrMetallicRoughness", {{"baseColorFactor", {0.5, 0.5, 0.5, 1}}, {"metallicFactor", 0}}}};
}

const QuadSpec kFloor{{-1, 0, -1}, {0, 0, 2}, {2, 0, 0}, 0};
constexpr float kFenceY = 0.5f;
constexpr int kChecker = 4;  // squares per side

// Whether the fence square holding (x, z) is opaque: texel (column, row) =
// (floor(4u), floor(4v)) with u = z + 0.5 and v = x + 0.5 (the quad's UVs).
bool fenceOpaqueAt(float x, float z) {
  int col = int(std::floor((z + 0.5f) * kChecker)), row = int(std::floor((x + 0.5f) * kChecker));
  return (col + row) % 2 == 0;
}
// Distance of (x, z) from the nearest square edge of the fence.
float distanceToSquareEdge(float x, float z) {
  auto d = [](float t) {
    float s = (t + 0.5f) * kChecker;
    return std::abs(s - std::round(s)) / kChecker;
  };
  return std::min(d(x), d(z));
}
bool insideFence(float x, float z) { return std::abs(x) < 0.5f && std::abs(z) < 0.5f; }

// The checkerboard RGBA texture: white, alpha 255 on opaque squares, 0 elsewhere.
void writeChecker(const fs::path& file) {
  std::vector<uint8_t> px;
  for (int row = 0; row < kChecker; ++row)
    for (int col = 0; col < kChecker; ++col)
      px.insert(px.end(), {255, 255, 255, uint8_t((col + row) % 2 == 0 ? 255 : 0)});
  Result<void> r = writePng8(file.string(), kChecker, kChecker, 4, px);
  ASSERT_TRUE(r) << r.error();
}

enum class Fence { Mask, Opaque, Geometry, Blend, None };

// The floor and the fence, one way or another.
GltfSpec fenceScene(const fs::path& dir, Fence fence) {
  GltfSpec s;
  s.extensionsUsed = {"KHR_materials_specular"};
  s.quads.push_back(kFloor);
  s.materials.push_back(greyMaterial("floor"));
  // A black fence that reflects nothing (KHR_materials_specular factor 0): the
  // images then show the floor's light alone, through and beside it.
  json fenceMat = greyMaterial("fence");
  fenceMat["pbrMetallicRoughness"]["baseColorFactor"] = {0, 0, 0, 1};
  fenceMat["extensions"] = {{"KHR_materials_specular", {{"specularFactor", 0}}}};
  if (fence == Fence::Mask || fence == Fence::Opaque) {
    writeChecker(dir / "checker.png");
    s.images = {{{"uri", "checker.png"}}};
    s.textures = {{{"source", 0}}};
    fenceMat["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
    fenceMat["alphaMode"] = fence == Fence::Mask ? "MASK" : "OPAQUE";
  }
  if (fence == Fence::Blend) {
    fenceMat["pbrMetallicRoughness"]["baseColorFactor"] = {0, 0, 0, 0.5};
    fenceMat["alphaMode"] = "BLEND";
  }
  s.materials.push_back(fenceMat);
  const Vec3 o{-0.5f, kFenceY, -0.5f};
  if (fence == Fence::Geometry) {
    const float w = 1.0f / kChecker;
    for (int row = 0; row < kChecker; ++row)
      for (int col = 0; col < kChecker; ++col)
        if ((col + row) % 2 == 0) s.quads.push_back({o + Vec3(row * w, 0, col * w), {0, 0, w}, {w, 0, 0}, 1});
  } else if (fence != Fence::None) {
    s.quads.push_back({o, {0, 0, 1}, {1, 0, 0}, 1});
  }
  return s;
}

class AlphaTest : public ::testing::Test {
 protected:
  fs::path dir;
  void SetUp() override {
    dir = vsl::test::scratchDir(std::string("vsl_alpha_") +
                                ::testing::UnitTest::GetInstance()->current_test_info()->name());
  }
  void TearDown() override { fs::remove_all(dir); }
  vsl::test::Loaded load(Fence fence, int width = 24) {
    return vsl::test::loadedFrom(
        RenderContext::load(writeGltf(dir, "fence" + std::to_string(int(fence)), fenceScene(dir, fence))), width);
  }
};

// Mean grey radiance of a path-traced image (direct + indirect) and the
// standard error of that mean (from per-pixel sample variances).
struct ImageMean {
  double mean = 0, se = 0;
};
ImageMean pathTracedMean(const vsl::test::Loaded& l, int size, int spp, uint64_t seed) {
  RenderSettings rs;
  rs.width = rs.height = size;
  rs.seed = seed;
  PathTracer pt(*l.scene, *l.accel, *l.lights, rs);
  double sum = 0, var = 0;
  const double n = double(size) * size;
  uint64_t rays = 0, nonFinite = 0;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      vsl::test::MeanAccumulator px;
      for (int k = 0; k < spp; ++k) {
        Vec3 Ld, Li;
        pt.samplePixel(x, y, k, Ld, Li, rays, nonFinite);
        px.add((double(Ld.x) + Li.x + Ld.y + Li.y + Ld.z + Li.z) / 3);
      }
      sum += px.mean();
      var += px.variance() / spp;
    }
  EXPECT_EQ(nonFinite, 0u);
  return {sum / n, std::sqrt(var) / n};
}

double zScore(const ImageMean& a, const ImageMean& b) {
  return (a.mean - b.mean) / std::sqrt(a.se * a.se + b.se * b.se);
}

bool hasWarningWith(const Scene& s, const std::string& needle) {
  for (const auto& w : s.warnings)
    if (w.find(needle) != std::string::npos) return true;
  return false;
}

}  // namespace

// ---- MASK ------------------------------------------------------------------------

// Shadow rays from a grid of floor points to the light agree between the
// masked fence and the fence with its holes cut in geometry, ray for ray
// (rays that cross the fence within 1e-3 of a square edge are left out:
// there float rounding may decide either way).
TEST_F(AlphaTest, MaskedShadowRaysMatchHolesCutInGeometry) {
  vsl::test::Loaded mask = load(Fence::Mask), geom = load(Fence::Geometry), opaque = load(Fence::Opaque);
  ASSERT_TRUE(mask.scene && geom.scene && opaque.scene);
  const Vec3 light{0, 2, 0};
  int compared = 0, lit = 0, disagree = 0, opaqueLit = 0;
  for (int i = 0; i < 64; ++i)
    for (int k = 0; k < 64; ++k) {
      Vec3 p{-1 + (i + 0.37f) / 32, 0, -1 + (k + 0.61f) / 32};
      // Where the segment crosses the fence's plane.
      float t = kFenceY / light.y;
      float x = p.x + (light.x - p.x) * t, z = p.z + (light.z - p.z) * t;
      if (insideFence(x, z) && distanceToSquareEdge(x, z) < 1e-3f) continue;
      Ray r;
      ASSERT_TRUE(segmentRay(p, Vec3(0, 1, 0), light, Vec3(0.0f), r));
      bool m = mask.accel->occluded(r), g = geom.accel->occluded(r);
      disagree += m != g;
      lit += !m;
      opaqueLit += !opaque.accel->occluded(r);
      ++compared;
      if (insideFence(x, z)) {
        EXPECT_EQ(m, fenceOpaqueAt(x, z)) << "floor point " << p.x << " " << p.z;
      }
    }
  EXPECT_EQ(disagree, 0) << "of " << compared << " shadow rays";
  EXPECT_GT(lit, opaqueLit) << "the holes let light through that the opaque fence blocks";
}

// The same as images: the path tracer's mean radiance over the image (the
// floor's shadow seen through and beside the black fence) agrees
// between the masked fence and the cut geometry (independent seeds, |z| < 4),
// and differs from the fence rendered OPAQUE (z > 8: the test can tell).
TEST_F(AlphaTest, MaskedShadowImageMatchesHolesCutInGeometry) {
  vsl::test::Loaded mask = load(Fence::Mask), geom = load(Fence::Geometry), opaque = load(Fence::Opaque);
  ASSERT_TRUE(mask.scene && geom.scene && opaque.scene);
  ImageMean m = pathTracedMean(mask, 16, 16, 1), g = pathTracedMean(geom, 16, 16, 2),
            o = pathTracedMean(opaque, 16, 16, 3);
  RecordProperty("z_mask_geometry", std::to_string(zScore(m, g)));
  RecordProperty("z_mask_opaque", std::to_string(zScore(m, o)));
  EXPECT_LT(std::abs(zScore(m, g)), 4.0) << "mask " << m.mean << " +- " << m.se << ", geometry " << g.mean << " +- "
                                         << g.se;
  EXPECT_GT(zScore(m, o), 8.0) << "mask " << m.mean << " +- " << m.se << ", opaque " << o.mean << " +- " << o.se;
}

// Camera rays through pixel centres hit the fence exactly where its square
// is opaque, and the floor below it through the holes.
TEST_F(AlphaTest, CameraRaysSeeThroughHoles) {
  vsl::test::Loaded l = load(Fence::Mask);
  ASSERT_TRUE(l.scene);
  const Scene& s = *l.scene;
  int throughHoles = 0, onFence = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      Ray r = s.camera.generateRay(x + 0.5f, y + 0.5f, 32, 32);
      float t = (kFenceY - r.o.y) / r.d.y;
      float fx = r.o.x + r.d.x * t, fz = r.o.z + r.d.z * t;
      if (!insideFence(fx, fz) || distanceToSquareEdge(fx, fz) < 1e-3f) continue;
      std::optional<Hit> hit = l.accel->intersect(r);
      ASSERT_TRUE(hit);
      Vec3 p = r.o + r.d * hit->t;
      if (fenceOpaqueAt(fx, fz)) {
        EXPECT_NEAR(p.y, kFenceY, 1e-4f);
        ++onFence;
      } else {
        EXPECT_NEAR(p.y, 0.0f, 1e-4f) << "the floor through a hole";
        ++throughHoles;
      }
    }
  EXPECT_GT(throughHoles, 50);
  EXPECT_GT(onFence, 50);
}

// Light tracing deposits no virtual light on a masked-out texel of the
// fence, and lights the floor through the holes.
TEST_F(AlphaTest, NoVirtualLightsOnMaskedTexels) {
  vsl::test::Loaded l = load(Fence::Mask);
  ASSERT_TRUE(l.scene);
  LightTracingSettings lt;
  lt.count = 4000;
  lt.seed = 7;
  VirtualLightSet set = traceVirtualLights(*l.scene, *l.accel, *l.lights, lt);
  int onFence = 0, underHoles = 0;
  for (const VirtualLight& v : set.lights) {
    if (std::abs(v.p.y - kFenceY) < 1e-4f) {
      ++onFence;
      if (distanceToSquareEdge(v.p.x, v.p.z) > 1e-4f) {
        EXPECT_TRUE(fenceOpaqueAt(v.p.x, v.p.z)) << v.p.x << " " << v.p.z;
      }
    } else if (std::abs(v.p.y) < 1e-4f && insideFence(v.p.x * 0.75f, v.p.z * 0.75f)) {
      // The light at y = 2 projects the fence at y = 0.5 onto the floor
      // scaled by 4/3: under a hole there when the fence point is open.
      if (!fenceOpaqueAt(v.p.x * 0.75f, v.p.z * 0.75f)) ++underHoles;
    }
  }
  EXPECT_GT(onFence, 100);
  EXPECT_GT(underHoles, 100);
}

// A masked emitter emits nothing from its holes: emitter sampling, which
// picks points over the whole triangle, gets zero there.
TEST_F(AlphaTest, MaskedEmitterEmitsNothingFromHoles) {
  GltfSpec s = fenceScene(dir, Fence::Mask);
  s.materials[1]["emissiveFactor"] = {1, 1, 1};
  SceneResult r = loadScene(writeGltf(dir, "glow", s));
  ASSERT_TRUE(r) << r.error();
  const Scene& scene = **r;
  // Triangle 2 is the fence's first: corners (-0.5, -0.5), (-0.5, 0.5), (0.5, 0.5) in (x, z).
  for (Vec2 b : {Vec2{0.1f, 0.05f}, Vec2{0.6f, 0.2f}, Vec2{0.3f, 0.45f}, Vec2{0.05f, 0.8f}}) {
    float x = -0.5f + b.y, z = -0.5f + b.x + b.y;
    if (distanceToSquareEdge(x, z) < 1e-3f) continue;
    EXPECT_EQ(scene.emission(2, b).x, fenceOpaqueAt(x, z) ? 1.0f : 0.0f) << x << " " << z;
  }
}

// ---- BLEND -----------------------------------------------------------------------

// A fence of alpha 0.5 passes half of the shadow rays (binomial z-test,
// |z| < 4), the same through single and batched queries, and the same ray
// always gets the same answer (the hash of the ray is the random number).
TEST_F(AlphaTest, BlendPassesAboutHalfTheLight) {
  vsl::test::Loaded l = load(Fence::Blend);
  ASSERT_TRUE(l.scene);
  Rng rng(11, 0);
  const Vec3 light{0, 2, 0};
  std::vector<Ray> rays;
  for (int i = 0; i < 20000; ++i) {
    // Floor points whose segment to the light crosses the fence.
    Vec3 p{(rng.uniform() - 0.5f) * 1.2f, 0, (rng.uniform() - 0.5f) * 1.2f};
    Ray r;
    ASSERT_TRUE(segmentRay(p, Vec3(0, 1, 0), light, Vec3(0.0f), r));
    rays.push_back(r);
  }
  std::vector<uint8_t> blocked(rays.size());
  l.accel->occluded(rays, blocked);
  int passed = 0, hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    bool single = l.accel->occluded(rays[i]);
    EXPECT_EQ(single, bool(blocked[i])) << "ray " << i;
    EXPECT_EQ(single, l.accel->occluded(rays[i])) << "ray " << i;
    passed += !single;
    // Closest hits see the same surface: the fence or, through it, nothing
    // before the light (rays start on the floor).
    hits += bool(l.accel->intersect(rays[i]));
  }
  const double n = double(rays.size()), z = (passed - 0.5 * n) / std::sqrt(0.25 * n);
  RecordProperty("passed", std::to_string(passed) + " of " + std::to_string(rays.size()));
  EXPECT_LT(std::abs(z), 4.0) << passed << " of " << n << " passed";
  const double zHit = (hits - 0.5 * n) / std::sqrt(0.25 * n);
  EXPECT_LT(std::abs(zHit), 4.0) << hits << " of " << n << " hit";
}

// The path tracer's image under a fence of alpha 0.5 lies between the scene
// without a fence and the opaque one (z > 8 both ways).
TEST_F(AlphaTest, BlendImageIsBetweenNoFenceAndOpaque) {
  vsl::test::Loaded blend = load(Fence::Blend), none = load(Fence::None), geom = load(Fence::Opaque);
  ASSERT_TRUE(blend.scene && none.scene && geom.scene);
  ImageMean b = pathTracedMean(blend, 16, 16, 1), n = pathTracedMean(none, 16, 16, 2),
            o = pathTracedMean(geom, 16, 16, 3);
  EXPECT_GT(zScore(n, b), 8.0) << "no fence " << n.mean << ", blend " << b.mean;
  EXPECT_GT(zScore(b, o), 8.0) << "blend " << b.mean << ", opaque " << o.mean;
}

// ---- KHR_texture_transform ----------------------------------------------------------

// The specification's matrix T * R * S (column-major GLSL in the extension's
// README): a quarter turn takes u to v (counter-clockwise), then offsets.
TEST(TextureTransform, FollowsTheSpecification) {
  TextureTransform t = TextureTransform::make({0.25f, 0.5f}, float(M_PI / 2), {2, 3}, 0);
  Vec2 a = t.apply({1, 0});  // S: (2, 0); R: (0, 2); T: (0.25, 2.5)
  EXPECT_NEAR(a.x, 0.25f, 1e-6f);
  EXPECT_NEAR(a.y, 2.5f, 1e-6f);
  Vec2 b = t.apply({0, 1});  // S: (0, 3); R: (-3, 0); T: (-2.75, 0.5)
  EXPECT_NEAR(b.x, -2.75f, 1e-6f);
  EXPECT_NEAR(b.y, 0.5f, 1e-6f);
  EXPECT_TRUE(TextureTransform{}.isIdentity());
  EXPECT_FALSE(t.isIdentity());
}

namespace {

// A 4 x 4 RGB texture with a different colour in every texel.
void writeRainbow(const fs::path& file) {
  std::vector<uint8_t> px;
  for (int row = 0; row < 4; ++row)
    for (int col = 0; col < 4; ++col)
      px.insert(px.end(), {uint8_t(40 + 60 * col), uint8_t(30 + 70 * row), uint8_t(200 - 10 * (row + col))});
  Result<void> r = writePng8(file.string(), 4, 4, 3, px);
  ASSERT_TRUE(r) << r.error();
}

json transformed(int texture, json ext, int texCoord = 0) {
  json info = {{"index", texture}, {"extensions", {{"KHR_texture_transform", ext}}}};
  if (texCoord) info["texCoord"] = texCoord;
  return info;
}

}  // namespace

// Every slot samples its texture at the hand-transformed UV: base colour
// (offset, rotation and scale), metallic-roughness (texCoord 1 from the
// extension's override) and emissive (texCoord 1 from the textureInfo).
TEST_F(AlphaTest, TextureTransformMatchesHandTransformedUv) {
  writeRainbow(dir / "rainbow.png");
  GltfSpec s;
  s.texCoord1 = true;
  s.quads.push_back(kFloor);
  json m = greyMaterial("transformed");
  m["pbrMetallicRoughness"]["baseColorFactor"] = {1, 1, 1, 1};
  m["pbrMetallicRoughness"]["metallicFactor"] = 1;
  m["pbrMetallicRoughness"]["baseColorTexture"] =
      transformed(0, {{"offset", {0.1, -0.2}}, {"rotation", 0.3}, {"scale", {2.0, 0.5}}});
  m["pbrMetallicRoughness"]["metallicRoughnessTexture"] = transformed(0, {{"scale", {1.5, 1.5}}, {"texCoord", 1}});
  m["emissiveFactor"] = {1, 1, 1};
  m["emissiveTexture"] = transformed(0, {{"offset", {0.3, 0.0}}}, 1);
  s.materials.push_back(m);
  s.images = {{{"uri", "rainbow.png"}}};
  s.textures = {{{"source", 0}}};
  s.extensionsUsed = {"KHR_texture_transform"};
  s.extensionsRequired = {"KHR_texture_transform"};
  SceneResult r = loadScene(writeGltf(dir, "tt", s));
  ASSERT_TRUE(r) << r.error();
  const Scene& scene = **r;
  for (const std::string& w : scene.warnings) {
    EXPECT_EQ(w.find("KHR_texture_transform"), std::string::npos) << w;
    EXPECT_EQ(w.find("TEXCOORD"), std::string::npos) << w;
  }
  const Texture& tex = scene.textures.at(0);
  const float c = std::cos(0.3f), sn = std::sin(0.3f);
  for (Vec2 b : {Vec2{0.1f, 0.2f}, Vec2{0.5f, 0.3f}, Vec2{0.2f, 0.7f}}) {
    SurfaceHit h = scene.surfaceHit(0, b.x, b.y, Vec3(0, -1, 0));
    // Triangle 0 is corners 0, 1, 2 with UV0 (0,0), (1,0), (1,1) and UV1 (1,0), (0,0), (0,1).
    Vec2 uv0{b.x + b.y, b.y}, uv1{1 - b.x - b.y, b.y};
    Vec2 base{2 * c * uv0.x - 0.5f * sn * uv0.y + 0.1f, 2 * sn * uv0.x + 0.5f * c * uv0.y - 0.2f};
    float want[4], wantMr[4], wantE[4];
    tex.lookup(base, true, want);
    tex.lookup({1.5f * uv1.x, 1.5f * uv1.y}, false, wantMr);
    tex.lookup({uv1.x + 0.3f, uv1.y}, true, wantE);
    Brdf brdf = scene.brdf(h);
    EXPECT_NEAR(brdf.baseColor.x, want[0], 1e-5f);
    EXPECT_NEAR(brdf.baseColor.y, want[1], 1e-5f);
    EXPECT_NEAR(brdf.baseColor.z, want[2], 1e-5f);
    EXPECT_NEAR(brdf.metallic, wantMr[2], 1e-5f);
    Vec3 e = scene.emission(0, b);
    EXPECT_NEAR(e.x, wantE[0], 1e-5f);
    EXPECT_NEAR(e.z, wantE[2], 1e-5f);
    Vec3 e2 = scene.emitted(h, Vec3(0, 1, 0));
    EXPECT_NEAR(e2.y, wantE[1], 1e-5f);
  }
}

// ---- What the loader reports ------------------------------------------------------

// Masked, blended and transformed files load without the old warnings
// ("alphaMode ... is not modelled", "extension KHR_texture_transform is not
// supported", "only TEXCOORD_0 is modelled"); what stays unmodelled is named.
TEST_F(AlphaTest, LoaderReportsNoneOfTheOldWarnings) {
  for (Fence f : {Fence::Mask, Fence::Blend}) {
    SceneResult r = loadScene(writeGltf(dir, "w" + std::to_string(int(f)), fenceScene(dir, f)));
    ASSERT_TRUE(r) << r.error();
    EXPECT_FALSE(hasWarningWith(**r, "alphaMode"));
    EXPECT_FALSE(hasWarningWith(**r, "not modelled"));
    const Material& fence = (*r)->materials.at(1);
    EXPECT_EQ(fence.alphaMode, f == Fence::Mask ? AlphaMode::Mask : AlphaMode::Blend);
  }
  // TEXCOORD_2 is not read: named with the slot.
  GltfSpec s = fenceScene(dir, Fence::Mask);
  s.materials[1]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = 2;
  SceneResult r = loadScene(writeGltf(dir, "tc2", s));
  ASSERT_TRUE(r) << r.error();
  EXPECT_TRUE(hasWarningWith(**r, "baseColorTexture uses TEXCOORD_2"));
  // An alphaMode outside the specification's three is bad input.
  s = fenceScene(dir, Fence::Mask);
  s.materials[1]["alphaMode"] = "CUTOUT";
  r = loadScene(writeGltf(dir, "bad", s));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("alphaMode"), std::string::npos) << r.error();
  s.materials[1]["alphaMode"] = "MASK";
  s.materials[1]["alphaCutoff"] = -0.5;
  r = loadScene(writeGltf(dir, "bad2", s));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("alphaCutoff"), std::string::npos) << r.error();
}
