// Scene loading: the bundled scenes, and crafted malformed or hostile files.
// Every bad file must give an error naming the file and the element, and
// never crash; every unmodelled feature must give a warning.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/image_io.h"
#include "core/rng.h"
#include "core/scene.h"
#include "support.h"

using namespace vsl;
using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

std::string base64(const std::vector<uint8_t>& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    uint32_t v = (in[i] << 16) | (in[i + 1] << 8) | in[i + 2];
    for (int k = 3; k >= 0; --k) out += t[(v >> (6 * k)) & 63];
  }
  if (i + 1 == in.size()) {
    uint32_t v = in[i] << 16;
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == in.size()) {
    uint32_t v = (in[i] << 16) | (in[i + 1] << 8);
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += t[(v >> 6) & 63];
    out += "=";
  }
  return out;
}

template <typename T>
void append(std::vector<uint8_t>& b, const std::vector<T>& v) {
  size_t off = b.size();
  b.resize(off + v.size() * sizeof(T));
  std::memcpy(b.data() + off, v.data(), v.size() * sizeof(T));
}

// A valid one-quad (two triangle) glTF with an emissive material, positions
// given by `pos` (4 vertices) and indices by `idx`.
struct Doc {
  json j;
  std::vector<uint8_t> bin;
};

Doc quadDoc(std::vector<float> pos = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0},
            std::vector<uint32_t> idx = {0, 1, 2, 0, 2, 3}) {
  Doc d;
  append(d.bin, pos);
  size_t idxOff = d.bin.size();
  append(d.bin, idx);
  size_t nv = pos.size() / 3;
  d.j = {{"asset", {{"version", "2.0"}}},
         {"scene", 0},
         {"scenes", {{{"nodes", {0}}}}},
         {"nodes", {{{"name", "quad-node"}, {"mesh", 0}}}},
         {"meshes",
          {{{"name", "quad"}, {"primitives", {{{"attributes", {{"POSITION", 0}}}, {"indices", 1}, {"material", 0}}}}}}},
         {"materials",
          {{{"name", "glow"},
            {"pbrMetallicRoughness",
             {{"baseColorFactor", {0.5, 0.5, 0.5, 1}}, {"metallicFactor", 0}, {"roughnessFactor", 0.5}}},
            {"emissiveFactor", {1, 1, 1}}}}},
         {"accessors",
          {{{"bufferView", 0},
            {"componentType", 5126},
            {"count", nv},
            {"type", "VEC3"},
            {"min", {0, 0, 0}},
            {"max", {1, 1, 0}}},
           {{"bufferView", 1}, {"componentType", 5125}, {"count", idx.size()}, {"type", "SCALAR"}}}},
         {"bufferViews",
          {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", idxOff}},
           {{"buffer", 0}, {"byteOffset", idxOff}, {"byteLength", idx.size() * 4}}}},
         {"buffers", json::array()}};
  return d;
}

class LoaderTest : public ::testing::Test {
 protected:
  fs::path dir;
  void SetUp() override {
    dir =
        fs::temp_directory_path() / ("vsl_loader_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
                                     "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  std::string write(const std::string& name, const std::string& text) {
    fs::path p = dir / name;
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }
  // Embeds the binary as a data URI unless the document already has buffers.
  std::string writeDoc(Doc d, const std::string& name = "scene.gltf") {
    if (d.j["buffers"].empty())
      d.j["buffers"] = {
          {{"byteLength", d.bin.size()}, {"uri", "data:application/octet-stream;base64," + base64(d.bin)}}};
    return write(name, d.j.dump());
  }
  std::string writeGlb(const Doc& d, const std::string& name, size_t truncateTo = 0) {
    json j = d.j;
    j["buffers"] = {{{"byteLength", d.bin.size()}}};
    std::string js = j.dump();
    while (js.size() % 4) js += ' ';
    std::vector<uint8_t> bin = d.bin;
    while (bin.size() % 4) bin.push_back(0);
    std::vector<uint8_t> out;
    auto u32 = [&](uint32_t v) { append(out, std::vector<uint32_t>{v}); };
    u32(0x46546C67);
    u32(2);
    u32(uint32_t(12 + 8 + js.size() + 8 + bin.size()));
    u32(uint32_t(js.size()));
    u32(0x4E4F534A);
    out.insert(out.end(), js.begin(), js.end());
    u32(uint32_t(bin.size()));
    u32(0x004E4942);
    out.insert(out.end(), bin.begin(), bin.end());
    if (truncateTo) out.resize(truncateTo);
    return write(name, std::string(out.begin(), out.end()));
  }
  SceneResult load(const std::string& path, const LoadOptions& o = {}) { return loadScene(path, o); }
};

bool hasWarning(const Scene& s, const std::string& needle) {
  for (const auto& w : s.warnings)
    if (w.find(needle) != std::string::npos) return true;
  return false;
}

std::string allWarnings(const Scene& s) {
  std::string r;
  for (const auto& w : s.warnings) r += w + "\n";
  return r;
}

}  // namespace

TEST(BundledScenes, LoadCleanlyWithLightsAndCameras) {
  for (const char* name : {"furnace", "cornell-glossy", "tableau", "kitchen", "hall", "waterbottle"}) {
    std::string path = std::string(VSL_SOURCE_DIR) + "/assets/scenes/" + name + ".gltf";
    SceneResult r = loadScene(path);
    ASSERT_TRUE(r) << r.error();
    const Scene& s = **r;
    EXPECT_GT(s.triangleCount(), 0u) << name;
    EXPECT_TRUE(s.cameraFromFile) << name;
    EXPECT_TRUE(s.warnings.empty()) << name << ":\n" << allWarnings(s);
    bool emissive = !s.punctualLights.empty();
    for (uint32_t t = 0; t < s.triangleCount(); ++t) emissive |= s.materials[s.triMaterial[t]].isEmissive();
    EXPECT_TRUE(emissive) << name;
  }
  // The scenes that promise anisotropic metal have it, with tangents.
  for (const char* name : {"tableau", "kitchen"}) {
    SceneResult r = loadScene(std::string(VSL_SOURCE_DIR) + "/assets/scenes/" + name + ".gltf");
    ASSERT_TRUE(r);
    bool aniso = false;
    for (const Material& m : (*r)->materials) aniso |= m.anisotropyStrength > 0 && m.metallic == 1;
    EXPECT_TRUE(aniso) << name;
  }
  // The bundled real asset (README, "Scenes") brings its textures and its
  // normal map into the scene: two bottles of 4,510 triangles each.
  SceneResult bottle = loadScene(std::string(VSL_SOURCE_DIR) + "/assets/scenes/waterbottle.gltf");
  ASSERT_TRUE(bottle) << bottle.error();
  int bottleTriangles = 0;
  for (uint32_t t = 0; t < (*bottle)->triangleCount(); ++t) {
    const Material& m = (*bottle)->materials[(*bottle)->triMaterial[t]];
    if (m.name != "BottleMat") continue;
    ++bottleTriangles;
    EXPECT_GE(m.normalTexture, 0);
    EXPECT_GE(m.baseColorTexture, 0);
  }
  EXPECT_EQ(bottleTriangles, 2 * 4510);
  // The hall's walls are pure metal (no diffuse component).
  SceneResult hall = loadScene(std::string(VSL_SOURCE_DIR) + "/assets/scenes/hall.gltf");
  ASSERT_TRUE(hall);
  bool found = false;
  for (const Material& m : (*hall)->materials)
    if (m.name == "hall-metal") found = m.metallic == 1.0f;
  EXPECT_TRUE(found);
}

TEST_F(LoaderTest, MinimalQuadLoads) {
  SceneResult r = load(writeDoc(quadDoc()));
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ((*r)->triangleCount(), 2u);
  EXPECT_FALSE((*r)->cameraFromFile);
  EXPECT_TRUE(hasWarning(**r, "default camera"));
  EXPECT_NEAR((*r)->triangleArea(0) + (*r)->triangleArea(1), 1.0f, 1e-6f);
  EXPECT_NEAR((*r)->triangleNormal(0).z, 1.0f, 1e-6f);  // CCW seen from +z
}

TEST_F(LoaderTest, GlbLoadsAndTruncatedGlbFails) {
  Doc d = quadDoc();
  SceneResult ok = load(writeGlb(d, "ok.glb"));
  ASSERT_TRUE(ok) << ok.error();
  EXPECT_EQ((*ok)->triangleCount(), 2u);
  for (size_t cut : {size_t(10), size_t(30), size_t(100)}) {
    std::string p = writeGlb(d, "cut" + std::to_string(cut) + ".glb", cut);
    SceneResult r = load(p);
    EXPECT_FALSE(r) << "cut at " << cut;
    EXPECT_NE(r.error().find(p), std::string::npos) << r.error();
  }
}

TEST_F(LoaderTest, UnreadableAndGarbageFilesFail) {
  SceneResult missing = load((dir / "nope.gltf").string());
  EXPECT_FALSE(missing);
  EXPECT_NE(missing.error().find("nope.gltf"), std::string::npos);
  EXPECT_NE(missing.error().find("cannot be read"), std::string::npos);
  EXPECT_FALSE(load(write("empty.gltf", "")));
  SceneResult garbage = load(write("garbage.gltf", "{ this is not json"));
  EXPECT_FALSE(garbage);
  EXPECT_NE(garbage.error().find("garbage.gltf"), std::string::npos) << garbage.error();
  EXPECT_FALSE(load(write("array.gltf", "[1,2,3]")));
  std::string binary(4096, '\xff');
  EXPECT_FALSE(load(write("noise.gltf", binary)));
  // A file that is not glTF at all is named as such (a PNG image's bytes
  // were once refused as "JSON nests deeper than 64 levels").
  std::string png = "\x89PNG\r\n\x1a\n";
  png += std::string(300, '[');
  for (const char* name : {"picture.png", "picture.gltf"}) {
    SceneResult image = load(write(name, png));
    ASSERT_FALSE(image);
    EXPECT_NE(image.error().find(std::string(name) + ": not a glTF file"), std::string::npos) << image.error();
    EXPECT_NE(image.error().find("it is a PNG image"), std::string::npos) << image.error();
  }
  SceneResult text = load(write("text.gltf", "hello, not a scene\n"));
  ASSERT_FALSE(text);
  EXPECT_NE(text.error().find("text.gltf: not a glTF file"), std::string::npos) << text.error();
  // Leading white space and a UTF-8 byte-order mark are still JSON's.
  EXPECT_EQ(load(write("bom.gltf", "\xef\xbb\xbf  \n{")).error().find("not a glTF file"), std::string::npos);
}

TEST_F(LoaderTest, WrongJsonTypesFail) {
  Doc d = quadDoc();
  d.j["meshes"] = "not an array";
  EXPECT_FALSE(load(writeDoc(d, "a.gltf")));
  Doc e = quadDoc();
  e.j["accessors"][0]["count"] = "three";
  EXPECT_FALSE(load(writeDoc(e, "b.gltf")));
  Doc f = quadDoc();
  f.j["materials"][0]["extensions"] = {{"KHR_materials_emissive_strength", {{"emissiveStrength", "bright"}}}};
  SceneResult r = load(writeDoc(f, "c.gltf"));
  EXPECT_FALSE(r);
  EXPECT_NE(r.error().find("emissiveStrength"), std::string::npos) << r.error();
}

TEST_F(LoaderTest, IndexOutOfRangeFails) {
  SceneResult r = load(writeDoc(quadDoc({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, {0, 1, 2, 0, 2, 7})));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("out of range"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("mesh 0 'quad'"), std::string::npos) << r.error();
}

TEST_F(LoaderTest, NonFinitePositionsFail) {
  for (float bad : {std::nanf(""), INFINITY}) {
    SceneResult r = load(writeDoc(quadDoc({0, 0, 0, 1, bad, 0, 1, 1, 0, 0, 1, 0})));
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().find("POSITION[1] is not finite"), std::string::npos) << r.error();
  }
}

TEST_F(LoaderTest, ShortAndMissingBuffersFail) {
  Doc d = quadDoc();
  d.j["bufferViews"][1]["byteLength"] = 4000;  // past the end of the buffer
  SceneResult r = load(writeDoc(d, "a.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("past the end"), std::string::npos) << r.error();

  Doc e = quadDoc();
  e.j["accessors"][0]["count"] = 400;  // more elements than the view holds
  r = load(writeDoc(e, "b.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("POSITION"), std::string::npos) << r.error();

  Doc f = quadDoc();
  f.j["accessors"][0]["count"] = 1e12;  // hostile: absurd count
  EXPECT_FALSE(load(writeDoc(f, "c.gltf")));

  Doc g = quadDoc();
  g.j["buffers"] = {{{"byteLength", g.bin.size()}, {"uri", "missing.bin"}}};
  r = load(writeDoc(g, "d.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("d.gltf"), std::string::npos) << r.error();

  Doc h = quadDoc();
  h.j["accessors"][1]["bufferView"] = 9;
  r = load(writeDoc(h, "e.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("e.gltf"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("bufferView"), std::string::npos) << r.error();
}

TEST_F(LoaderTest, RecursiveNodesFail) {
  Doc d = quadDoc();
  d.j["nodes"] = {{{"name", "a"}, {"children", {1}}}, {{"name", "b"}, {"children", {0}}, {"mesh", 0}}};
  SceneResult r = load(writeDoc(d, "a.gltf"));
  EXPECT_FALSE(r);
  Doc e = quadDoc();
  e.j["nodes"] = {{{"name", "self"}, {"children", {0}}, {"mesh", 0}}};
  r = load(writeDoc(e, "b.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("recursive"), std::string::npos) << r.error();
}

TEST_F(LoaderTest, OutOfRangeMaterialValuesFail) {
  Doc d = quadDoc();
  d.j["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = 1.7;
  SceneResult r = load(writeDoc(d));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("material 0 'glow': roughnessFactor must be in [0,1] (got 1.7)"), std::string::npos)
      << r.error();
  Doc e = quadDoc();
  e.j["materials"][0]["extensions"] = {{"KHR_materials_anisotropy", {{"anisotropyStrength", 2.0}}}};
  EXPECT_FALSE(load(writeDoc(e, "b.gltf")));
  Doc f = quadDoc();
  f.j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 3}};
  r = load(writeDoc(f, "c.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("texture 3 does not exist"), std::string::npos) << r.error();
}

TEST_F(LoaderTest, UnmodelledFeaturesAreWarnedByName) {
  Doc d = quadDoc();
  // A points primitive, morph targets, a skin, transmission, an unknown
  // extension that is used but not required, an orthographic camera and a
  // directional light.
  json prim = d.j["meshes"][0]["primitives"][0];
  json points = prim;
  points["mode"] = 0;
  json morph = prim;
  morph["targets"] = {{{"POSITION", 0}}};
  d.j["meshes"][0]["primitives"] = {prim, points, morph};
  d.j["materials"][0]["extensions"] = {{"KHR_materials_transmission", {{"transmissionFactor", 1.0}}}};
  d.j["extensionsUsed"] = {"KHR_materials_transmission", "EXT_made_up", "KHR_lights_punctual"};
  d.j["cameras"] = {{{"name", "ortho"},
                     {"type", "orthographic"},
                     {"orthographic", {{"xmag", 1}, {"ymag", 1}, {"znear", 0.1}, {"zfar", 10}}}}};
  d.j["extensions"] = {{"KHR_lights_punctual", {{"lights", {{{"name", "sun"}, {"type", "directional"}}}}}}};
  d.j["nodes"] = {{{"name", "quad-node"}, {"mesh", 0}},
                  {{"name", "cam"}, {"camera", 0}},
                  {{"name", "sun-node"}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}}};
  d.j["scenes"][0]["nodes"] = {0, 1, 2};
  SceneResult r = load(writeDoc(d));
  ASSERT_TRUE(r) << r.error();
  const Scene& s = **r;
  EXPECT_EQ(s.triangleCount(), 4u) << "the triangle primitives load; points are skipped";
  EXPECT_TRUE(hasWarning(s, "primitive 1: points and lines are not modelled")) << allWarnings(s);
  EXPECT_TRUE(hasWarning(s, "primitive 2: morph targets")) << allWarnings(s);
  EXPECT_TRUE(hasWarning(s, "material 0 'glow': extension KHR_materials_transmission")) << allWarnings(s);
  EXPECT_TRUE(hasWarning(s, "extension EXT_made_up is used but not modelled")) << allWarnings(s);
  EXPECT_TRUE(hasWarning(s, "camera 0 'ortho': orthographic")) << allWarnings(s);
  // A directional light is modelled (docs/REFERENCE.md "Lights"): no warning.
  EXPECT_FALSE(hasWarning(s, "directional")) << allWarnings(s);
  ASSERT_EQ(s.punctualLights.size(), 1u);
  EXPECT_EQ(s.punctualLights[0].type, PunctualLight::Type::Directional);
  EXPECT_NEAR(s.punctualLights[0].direction.z, -1, 1e-6) << "it travels along the node's -z";
}

// Issue 12: an unsupported *required* extension (Draco-compressed geometry)
// is refused with the extension and the file named; required extensions the
// loader supports still load.
TEST_F(LoaderTest, UnsupportedRequiredExtensionsAreRefused) {
  Doc d = quadDoc();
  // Compressed geometry is decoded (tests/test_compressed_meshes.cpp);
  // quantised attributes and GPU instancing are not modelled.
  d.j["extensionsUsed"] = {"KHR_mesh_quantization"};
  d.j["extensionsRequired"] = {"KHR_mesh_quantization"};
  std::string path = writeDoc(d, "quantized.gltf");
  SceneResult r = load(path);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().rfind(path + ": required extension KHR_mesh_quantization is not supported", 0), 0u) << r.error();
  Doc g = quadDoc();
  g.j["extensionsUsed"] = {"EXT_mesh_gpu_instancing"};
  g.j["extensionsRequired"] = {"EXT_mesh_gpu_instancing"};
  SceneResult glb = load(writeGlb(g, "instancing.glb"));
  ASSERT_FALSE(glb);
  EXPECT_NE(glb.error().find("instancing.glb: required extension EXT_mesh_gpu_instancing"), std::string::npos)
      << glb.error();
  Doc ok = quadDoc();
  ok.j["extensionsUsed"] = {"KHR_materials_emissive_strength", "KHR_lights_punctual"};
  ok.j["extensionsRequired"] = {"KHR_materials_emissive_strength", "KHR_lights_punctual"};
  SceneResult fine = load(writeDoc(ok, "supported.gltf"));
  ASSERT_TRUE(fine) << fine.error();
  EXPECT_GT((*fine)->triangleCount(), 0u);
}

TEST_F(LoaderTest, ZeroAreaTrianglesAreSkippedWithAWarning) {
  SceneResult r = load(writeDoc(quadDoc({0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0}, {0, 1, 2, 0, 1, 3})));
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ((*r)->triangleCount(), 1u);
  EXPECT_TRUE(hasWarning(**r, "1 zero-area triangle(s) skipped")) << allWarnings(**r);
  // All triangles degenerate: nothing to render is an error.
  EXPECT_FALSE(load(writeDoc(quadDoc({0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0}, {0, 1, 2, 1, 2, 3}), "b.gltf")));
}

TEST_F(LoaderTest, TransformsStripsAndMirrors) {
  Doc d = quadDoc();
  d.j["nodes"][0]["translation"] = {0, 0, 5};
  d.j["nodes"][0]["scale"] = {2, 2, 2};
  SceneResult r = load(writeDoc(d));
  ASSERT_TRUE(r) << r.error();
  EXPECT_FLOAT_EQ((*r)->boundsMin.z, 5.0f);
  EXPECT_FLOAT_EQ((*r)->boundsMax.x, 2.0f);
  // A mirroring transform keeps the front face on the mirrored normal's side.
  Doc m = quadDoc();
  m.j["nodes"][0]["scale"] = {1, 1, -1};
  r = load(writeDoc(m, "m.gltf"));
  ASSERT_TRUE(r);
  EXPECT_NEAR((*r)->triangleNormal(0).z, -1.0f, 1e-6f);
  // A triangle strip of 4 indices is 2 triangles.
  Doc s = quadDoc({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0}, {0, 1, 2, 3});
  s.j["meshes"][0]["primitives"][0]["mode"] = 5;
  r = load(writeDoc(s, "s.gltf"));
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ((*r)->triangleCount(), 2u);
  EXPECT_GT((*r)->triangleNormal(0).z, 0.0f);
  EXPECT_GT((*r)->triangleNormal(1).z, 0.0f);
}

TEST_F(LoaderTest, CamerasByNameAndLights) {
  Doc d = quadDoc();
  d.j["cameras"] = {{{"name", "first"}, {"type", "perspective"}, {"perspective", {{"yfov", 0.5}, {"znear", 0.1}}}},
                    {{"name", "second"}, {"type", "perspective"}, {"perspective", {{"yfov", 0.9}, {"znear", 0.1}}}}};
  d.j["extensions"] = {{"KHR_lights_punctual",
                        {{"lights",
                          {{{"name", "bulb"}, {"type", "point"}, {"intensity", 10}, {"color", {1, 0.5, 0.25}}},
                           {{"name", "spot"},
                            {"type", "spot"},
                            {"intensity", 5},
                            {"spot", {{"innerConeAngle", 0.2}, {"outerConeAngle", 0.4}}}}}}}}};
  d.j["extensionsUsed"] = {"KHR_lights_punctual"};
  d.j["nodes"] = {{{"mesh", 0}},
                  {{"name", "c1"}, {"camera", 0}, {"translation", {0, 0, 3}}},
                  {{"name", "c2"}, {"camera", 1}, {"translation", {0, 0, 4}}},
                  {{"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}, {"translation", {0, 0, 1}}},
                  {{"extensions", {{"KHR_lights_punctual", {{"light", 1}}}}}, {"translation", {0, 0, 2}}}};
  d.j["scenes"][0]["nodes"] = {0, 1, 2, 3, 4};
  SceneResult r = load(writeDoc(d));
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ((*r)->camera.name, "first");
  EXPECT_FLOAT_EQ((*r)->camera.yfov, 0.5f);
  ASSERT_EQ((*r)->punctualLights.size(), 2u);
  EXPECT_FLOAT_EQ((*r)->punctualLights[0].intensity.y, 5.0f);
  EXPECT_NEAR((*r)->punctualLights[1].direction.z, -1.0f, 1e-6f);
  LoadOptions o;
  o.cameraName = "second";
  r = load(writeDoc(d, "b.gltf"), o);
  ASSERT_TRUE(r) << r.error();
  EXPECT_FLOAT_EQ((*r)->camera.position.z, 4.0f);
  o.cameraName = "third";
  r = load(writeDoc(d, "c.gltf"), o);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("no perspective camera named 'third'"), std::string::npos) << r.error();
  // A spot whose inner angle exceeds its outer angle is invalid.
  d.j["extensions"]["KHR_lights_punctual"]["lights"][1]["spot"]["innerConeAngle"] = 0.6;
  r = load(writeDoc(d, "d.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("light 1 'spot'"), std::string::npos) << r.error();
  // A node that names a light that does not exist.
  d.j["extensions"]["KHR_lights_punctual"]["lights"][1]["spot"]["innerConeAngle"] = 0.2;
  d.j["nodes"][3]["extensions"]["KHR_lights_punctual"]["light"] = 7;
  EXPECT_FALSE(load(writeDoc(d, "e.gltf")));
}

TEST_F(LoaderTest, EmissionStrengthAndAnisotropyParse) {
  Doc d = quadDoc();
  d.j["materials"][0]["emissiveFactor"] = {0.5, 0.25, 1.0};
  d.j["materials"][0]["extensions"] = {
      {"KHR_materials_emissive_strength", {{"emissiveStrength", 4.0}}},
      {"KHR_materials_anisotropy", {{"anisotropyStrength", 0.6}, {"anisotropyRotation", 1.0}}}};
  d.j["extensionsUsed"] = {"KHR_materials_emissive_strength", "KHR_materials_anisotropy"};
  SceneResult r = load(writeDoc(d));
  ASSERT_TRUE(r) << r.error();
  const Material& m = (*r)->materials[0];
  EXPECT_FLOAT_EQ(m.emission.x, 2.0f);
  EXPECT_FLOAT_EQ(m.emission.y, 1.0f);
  EXPECT_FLOAT_EQ(m.emission.z, 4.0f);
  EXPECT_FLOAT_EQ(m.anisotropyStrength, 0.6f);
  EXPECT_FLOAT_EQ(m.anisotropyRotation, 1.0f);
  // No TANGENT and no TEXCOORD_0: the direction is arbitrary, and we say so.
  EXPECT_TRUE(hasWarning(**r, "anisotropy direction is arbitrary")) << allWarnings(**r);
}

TEST_F(LoaderTest, TexturesAreLoadedAndSampled) {
  // A 2x1 PNG: left texel red, right texel blue, referenced as an external file.
  Result<void> png = writePngRgb8((dir / "tex.png").string(), 2, 1, {255, 0, 0, 0, 0, 255});
  ASSERT_TRUE(png) << png.error();
  std::vector<float> pos = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  std::vector<float> uv = {0.25f, 0.5f, 0.25f, 0.5f, 0.25f, 0.5f, 0.25f, 0.5f};  // all on the red texel
  Doc d = quadDoc(pos);
  size_t off = d.bin.size();
  append(d.bin, uv);
  d.j["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", off}, {"byteLength", uv.size() * 4}});
  d.j["accessors"].push_back({{"bufferView", 2}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}});
  d.j["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = 2;
  d.j["images"] = {{{"uri", "tex.png"}}};
  d.j["samplers"] = {{{"magFilter", 9728}}};
  d.j["textures"] = {{{"source", 0}, {"sampler", 0}}};
  d.j["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {1, 1, 1, 1};
  d.j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
  SceneResult r = load(writeDoc(d));
  ASSERT_TRUE(r) << r.error();
  ASSERT_EQ((*r)->textures.size(), 1u);
  SurfaceHit h = (*r)->surfaceHit(0, 0.3f, 0.3f, Vec3(0, 0, -1));
  EXPECT_NEAR(h.uv.x, 0.25f, 1e-6f);
  Brdf b = (*r)->brdf(h);
  EXPECT_NEAR(b.baseColor.x, 1.0f, 1e-3f);  // sRGB 255 decodes to linear 1
  EXPECT_NEAR(b.baseColor.z, 0.0f, 1e-3f);
  // A texture whose image file is missing is an error naming the file.
  fs::remove(dir / "tex.png");
  SceneResult missing = load(writeDoc(d, "b.gltf"));
  EXPECT_FALSE(missing);
  EXPECT_NE(missing.error().find("b.gltf"), std::string::npos) << missing.error();
}

// Hostile input: random byte corruptions of a valid .gltf and .glb must each
// give a scene or an error naming the file, never a crash (run under ASan).
TEST_F(LoaderTest, CorruptedFilesNeverCrash) {
  Doc d = quadDoc();
  std::string good = writeDoc(d, "good.gltf");
  std::string text = vsl::test::slurp(good);
  std::string glb = vsl::test::slurp(writeGlb(d, "good.glb"));
  Rng rng(99, 1);
  int scenes = 0, errors = 0;
  for (int i = 0; i < 400; ++i) {
    std::string m = i % 2 ? glb : text;
    int edits = 1 + int(rng.uniformInt(4));
    for (int e = 0; e < edits; ++e) {
      size_t at = rng.uniformInt(uint32_t(m.size()));
      switch (rng.uniformInt(3)) {
        case 0:
          m[at] = char(rng.uniformInt(256));
          break;
        case 1:
          m.erase(at, 1 + rng.uniformInt(8));
          break;
        default:
          static const char kTokens[] = "{}[]\":,0123456789eE-+.";
          m.insert(at, 1, kTokens[rng.uniformInt(uint32_t(sizeof kTokens - 1))]);
          break;
      }
    }
    std::string path = write(i % 2 ? "m.glb" : "m.gltf", m);
    SceneResult r = load(path);
    if (r) {
      ++scenes;
      EXPECT_GT((*r)->triangleCount(), 0u);
    } else {
      ++errors;
      EXPECT_NE(r.error().find(path), std::string::npos) << r.error();
    }
  }
  EXPECT_GT(errors, 0);
  std::printf("corrupted files: %d loaded, %d rejected with an error\n", scenes, errors);
}

// ---- Hostile files (issue 12) ---------------------------------------------------

namespace {

// A chain of `levels` nodes, the last one holding the quad.
Doc chainDoc(int levels) {
  Doc d = quadDoc();
  json nodes = json::array();
  for (int i = 0; i < levels; ++i) {
    json n = {{"translation", {0, 0, 0.0}}};
    if (i + 1 < levels)
      n["children"] = {i + 1};
    else
      n["mesh"] = 0;
    nodes.push_back(n);
  }
  d.j["nodes"] = nodes;
  return d;
}

// A DAG: each of `levels` nodes has two children, both the next node.
Doc dagDoc(int levels, bool withMesh) {
  Doc d = quadDoc();
  json nodes = json::array();
  for (int i = 0; i < levels; ++i)
    nodes.push_back(i + 1 < levels ? json{{"children", {i + 1, i + 1}}} : json::object());
  if (withMesh) nodes[levels - 1]["mesh"] = 0;
  d.j["nodes"] = nodes;
  return d;
}

std::string nested(size_t depth, const std::string& open, const std::string& close) {
  std::string s;
  for (size_t i = 0; i < depth; ++i) s += open;
  s += "1";
  for (size_t i = 0; i < depth; ++i) s += close;
  return s;
}

}  // namespace

// Defect 2: a hierarchy 100,000 levels deep overflowed the stack.
TEST_F(LoaderTest, DeepNodeHierarchiesFailWithoutRecursion) {
  SceneResult ok = load(writeDoc(chainDoc(1000), "ok.gltf"));
  ASSERT_TRUE(ok) << ok.error();
  EXPECT_EQ((*ok)->triangleCount(), 2u);
  SceneResult r = load(writeDoc(chainDoc(100000), "deep.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("deep.gltf"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("deeper than 1024 levels"), std::string::npos) << r.error();
}

// Defect 2: tinygltf converts extras recursively; 100,000 levels crashed.
TEST_F(LoaderTest, AbsurdJsonNestingIsRefusedBeforeParsing) {
  Doc d = quadDoc();
  std::string text = d.j.dump();
  // Splice nested arrays (and objects) into the material's extras.
  for (auto [open, close] : {std::pair<std::string, std::string>{"[", "]"}, {"{\"a\":", "}"}}) {
    std::string hostile = text;
    hostile.insert(hostile.find("\"name\":\"glow\""), "\"extras\":" + nested(100000, open, close) + ",");
    Doc e = d;
    SceneResult r =
        load(write("nested.gltf", hostile.substr(0, hostile.size() - 1) +
                                      ",\"buffers\":[{\"byteLength\":" + std::to_string(d.bin.size()) +
                                      ",\"uri\":\"data:application/octet-stream;base64," + base64(d.bin) + "\"}]}"));
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().find("nested.gltf"), std::string::npos) << r.error().substr(0, 300);
    EXPECT_NE(r.error().find("JSON nests deeper than 64 levels"), std::string::npos) << r.error().substr(0, 300);
  }
  // Brackets inside strings do not count; moderate nesting in extras loads.
  d.j["materials"][0]["extras"] = {{"note", std::string(1000, '[')}, {"deep", json::parse(nested(40, "[", "]"))}};
  SceneResult ok = load(writeDoc(d, "fine.gltf"));
  EXPECT_TRUE(ok) << ok.error();
  // The same check runs on a .glb's JSON chunk.
  Doc g = quadDoc();
  g.j["asset"]["extras"] = json::parse(nested(200, "[", "]"));
  SceneResult glb = load(writeGlb(g, "nested.glb"));
  ASSERT_FALSE(glb);
  EXPECT_NE(glb.error().find("JSON nests deeper"), std::string::npos) << glb.error();
}

// Defect 3: aspectRatio 1e-5 aborted (bad_alloc), 0.004 was OOM-killed and
// 1e30 rendered 512x1.
TEST_F(LoaderTest, CameraAspectRatioIsRangeChecked) {
  Doc d = quadDoc();
  d.j["nodes"] = {{{"mesh", 0}}, {{"name", "eye"}, {"camera", 0}, {"translation", {0.5, 0.5, 3}}}};
  d.j["scenes"][0]["nodes"] = {0, 1};
  int i = 0;
  for (double aspect : {1e-5, 0.004, 1e30, -1.0, 33.0}) {
    d.j["cameras"] = {{{"name", "cam"}, {"type", "perspective"}, {"perspective", {{"yfov", 0.5}, {"znear", 0.1}}}}};
    d.j["cameras"][0]["perspective"]["aspectRatio"] = aspect;
    SceneResult r = load(writeDoc(d, "a" + std::to_string(i++) + ".gltf"));
    ASSERT_FALSE(r) << aspect;
    EXPECT_NE(r.error().find("camera 0 'cam': aspectRatio must be in [0.03125,32]"), std::string::npos) << r.error();
  }
  d.j["cameras"][0]["perspective"]["aspectRatio"] = 1.5;
  SceneResult ok = load(writeDoc(d, "ok.gltf"));
  ASSERT_TRUE(ok) << ok.error();
  EXPECT_FLOAT_EQ((*ok)->camera.aspect, 1.5f);
}

// Defect 4: Embree aborted for a camera at z = 2e18 or a light at 1e30; only
// local POSITION values were checked.
TEST_F(LoaderTest, WorldSpacePositionsAreRangeChecked) {
  Doc d = quadDoc();
  d.j["cameras"] = {{{"name", "far"}, {"type", "perspective"}, {"perspective", {{"yfov", 0.5}, {"znear", 0.1}}}}};
  d.j["nodes"] = {{{"mesh", 0}}, {{"camera", 0}, {"translation", {0, 0, 2e18}}}};
  d.j["scenes"][0]["nodes"] = {0, 1};
  SceneResult r = load(writeDoc(d, "camera.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("node 1: its world transform has an entry of 2e+18, outside +-1e+12"), std::string::npos)
      << r.error();
  d.j["nodes"][1]["translation"] = {0, 0, 2e10};
  r = load(writeDoc(d, "camera2.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("camera 0 'far': position lies at (0 0 2e+10) in world space"), std::string::npos)
      << r.error();

  Doc e = quadDoc();
  e.j["extensions"] = {{"KHR_lights_punctual", {{"lights", {{{"name", "sun"}, {"type", "point"}, {"intensity", 1}}}}}}};
  e.j["nodes"] = {{{"mesh", 0}},
                  {{"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}, {"translation", {1e30, 0, 0}}}};
  e.j["scenes"][0]["nodes"] = {0, 1};
  r = load(writeDoc(e, "light.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("node 1: its world transform has an entry of 1e+30"), std::string::npos) << r.error();
  e.j["nodes"][1]["translation"] = {-3e9, 0, 0};
  r = load(writeDoc(e, "light2.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("light 0 'sun': position lies at (-3e+09 0 0) in world space, outside +-1e+09"),
            std::string::npos)
      << r.error();

  // Local positions are small, the node's scale makes them huge; an emitter
  // scaled like this used to be dropped (infinite power) and render black.
  Doc f = quadDoc();
  f.j["nodes"][0]["scale"] = {1e10, 1e10, 1};
  r = load(writeDoc(f, "scaled.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("POSITION[1] lies at (1e+10 0 0) in world space"), std::string::npos) << r.error();
  f.j["nodes"][0]["scale"] = {1e20, 1e20, 1};
  r = load(writeDoc(f, "scaled2.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("its world transform has an entry of 1e+20"), std::string::npos) << r.error();
}

// Defect 5: a 220-byte file declared 3e8 zero elements; a DAG of shared
// subtrees multiplied 882 triangles into billions.
TEST_F(LoaderTest, TinyFilesCannotDeclareHugeScenes) {
  Doc d = quadDoc();
  d.j["accessors"][0].erase("bufferView");
  d.j["accessors"][0]["count"] = 300000000;
  SceneResult r = load(writeDoc(d, "zeros.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("count 300000000 without a bufferView"), std::string::npos) << r.error();

  LoadOptions small;
  small.maxTriangles = 100000;
  r = load(writeDoc(dagDoc(17, true), "dag.gltf"), small);  // 2^16 instances of 2 triangles
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("expands to 131072 triangles, more than 100000"), std::string::npos) << r.error();
  // Counted before walking: the default limit with 2^29 instances fails at once.
  auto t0 = std::chrono::steady_clock::now();
  r = load(writeDoc(dagDoc(30, true), "bigdag.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("node instances"), std::string::npos) << r.error();
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0);
  r = load(writeDoc(dagDoc(12, true), "smalldag.gltf"), small);  // 2^11 instances: fine
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ((*r)->triangleCount(), 4096u);

  // No meshes at all, only node instances: bounded too, within seconds.
  r = load(writeDoc(dagDoc(40, false), "empty-dag.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("node instances"), std::string::npos) << r.error();
}

// Defect 6: URIs read outside the scene's folder, errors disclosed the size
// of files like /etc/shadow, a FIFO hung the loader, /dev/zero as the scene
// read until memory ran out.
TEST_F(LoaderTest, UrisResolveInsideTheScenesFolderOnly) {
  Doc d = quadDoc();
  fs::create_directories(dir / "scene" / "data");
  {
    std::ofstream f(dir / "scene" / "data" / "quad.bin", std::ios::binary);
    f.write(reinterpret_cast<const char*>(d.bin.data()), std::streamsize(d.bin.size()));
  }
  fs::copy_file(dir / "scene" / "data" / "quad.bin", dir / "outside.bin");
  auto withUri = [&](const std::string& uri, const std::string& name) {
    Doc e = d;
    e.j["buffers"] = {{{"byteLength", d.bin.size() + 1}, {"uri", uri}}};  // wrong size: would say "got N"
    return write("scene/" + name, e.j.dump());
  };
  // Inside the folder (and a subfolder) is fine.
  {
    Doc e = d;
    e.j["buffers"] = {{{"byteLength", d.bin.size()}, {"uri", "data/quad.bin"}}};
    SceneResult ok = load(write("scene/ok.gltf", e.j.dump()));
    ASSERT_TRUE(ok) << ok.error();
  }
  const std::string size = std::to_string(d.bin.size());
  const std::vector<std::string> hostile = {
      "../outside.bin", "data/../../outside.bin",       "/etc/passwd",
      "/etc/shadow",    "../../../../../../etc/passwd", (dir / "outside.bin").string()};
  for (const std::string& uri : hostile) {
    SceneResult r = load(withUri(uri, "bad.gltf"));
    ASSERT_FALSE(r) << uri;
    EXPECT_NE(r.error().find("bad.gltf"), std::string::npos) << r.error();
    EXPECT_TRUE(r.error().find("outside the scene's folder") != std::string::npos ||
                r.error().find("absolute paths are refused") != std::string::npos)
        << r.error();
    EXPECT_EQ(r.error().find("got " + size), std::string::npos) << "discloses the size: " << r.error();
    EXPECT_EQ(r.error().find("requestedBytes"), std::string::npos) << r.error();
  }
  // A symlink inside the folder that leads out is refused too.
  fs::create_symlink(dir / "outside.bin", dir / "scene" / "link.bin");
  SceneResult r = load(withUri("link.bin", "link.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("outside the scene's folder"), std::string::npos) << r.error();
  // No fallback to the current directory.
  auto cwd = fs::current_path();
  fs::current_path(dir);
  r = load(withUri("outside.bin", "cwd.gltf"));
  fs::current_path(cwd);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("URI 'outside.bin': cannot be read (no such file)"), std::string::npos) << r.error();
  // Special files: a FIFO must not hang, a directory is not "out of memory".
  ASSERT_EQ(mkfifo((dir / "scene" / "fifo.bin").c_str(), 0600), 0);
  r = load(withUri("fifo.bin", "fifo.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("not a regular file"), std::string::npos) << r.error();
  r = load(withUri("data", "dir.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("it is a directory"), std::string::npos) << r.error();
  EXPECT_EQ(r.error().find("memory"), std::string::npos) << r.error();
  // The scene file itself.
  r = load((dir / "scene" / "fifo.bin").string());
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("not a regular file"), std::string::npos) << r.error();
  r = load("/dev/zero");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("/dev/zero: cannot be read (not a regular file"), std::string::npos) << r.error();
  r = load((dir / "scene").string());
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("it is a directory"), std::string::npos) << r.error();
}

// Defect 9: wrong JSON types were silently replaced by defaults.
TEST_F(LoaderTest, WrongTypesOfKnownPropertiesAreNamed) {
  Doc d = quadDoc();
  d.j["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = "0.5";
  SceneResult r = load(writeDoc(d, "a.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("a.gltf: material 0 'glow': 'roughnessFactor' must be a number (got \"0.5\")"),
            std::string::npos)
      << r.error();
  Doc e = quadDoc();
  e.j["nodes"][0]["translation"] = {"1", 0, 0};
  r = load(writeDoc(e, "b.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("node 0 'quad-node': 'translation' must be an array of 3 numbers"), std::string::npos)
      << r.error();
  Doc f = quadDoc();
  f.j["materials"][0]["doubleSided"] = "yes";
  r = load(writeDoc(f, "c.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("'doubleSided' must be true or false"), std::string::npos) << r.error();
}

// Defect 5: textures are expanded to float RGBA per texture, also when many
// share one image; an image header may claim any size.
TEST_F(LoaderTest, TextureMemoryIsBounded) {
  std::vector<uint8_t> px(512 * 512 * 3, 128);
  Result<void> written = writePngRgb8((dir / "big.png").string(), 512, 512, px);
  ASSERT_TRUE(written) << written.error();
  Doc d = quadDoc();
  d.j["images"] = {{{"uri", "big.png"}}};
  d.j["textures"] = {{{"source", 0}}, {{"source", 0}}, {{"source", 0}}};
  auto& m = d.j["materials"][0];
  m["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
  m["pbrMetallicRoughness"]["metallicRoughnessTexture"] = {{"index", 1}};
  m["emissiveTexture"] = {{"index", 2}};
  LoadOptions o;
  o.maxTexels = 3 * 512 * 512;
  SceneResult ok = load(writeDoc(d, "ok.gltf"), o);
  ASSERT_TRUE(ok) << ok.error();
  o.maxTexels = 3 * 512 * 512 - 1;
  SceneResult r = load(writeDoc(d, "many.gltf"), o);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("texels in total"), std::string::npos) << r.error();
  // A PNG whose header claims 10000x10000 is refused before decoding (stb
  // itself refuses more than 2^30 bytes).
  std::string png = vsl::test::slurp(dir / "big.png");
  const uint8_t side[4] = {0, 0, 0x27, 0x10};  // 10000, big-endian, in IHDR
  std::memcpy(&png[16], side, 4);
  std::memcpy(&png[20], side, 4);
  write("huge.png", png);
  d.j["images"] = {{{"uri", "huge.png"}}};
  r = load(writeDoc(d, "huge.gltf"));
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("10000x10000 pixels is more than the texture limit"), std::string::npos) << r.error();
}

// ---- Files the Khronos validator refuses (loader hardening) ---------------------
// Each file below is invalid glTF 2.0 per the Khronos glTF validator (checked
// with scripts/validate-gltf.cjs on the same documents); each used to load,
// silently or misread.

namespace {

// The first occurrence of needle in the error, or a failure naming both.
::testing::AssertionResult errorHas(const SceneResult& r, const std::string& needle) {
  if (r) return ::testing::AssertionFailure() << "loaded, expected an error containing: " << needle;
  if (r.error().find(needle) == std::string::npos)
    return ::testing::AssertionFailure() << "error \"" << r.error() << "\" lacks \"" << needle << "\"";
  return ::testing::AssertionSuccess();
}

// quadDoc() with a second node, so that the quad still loads whatever the
// second node holds.
Doc twoNodeDoc(const json& other) {
  Doc d = quadDoc();
  json n = other;
  n["name"] = "other";
  d.j["nodes"] = {{{"name", "quad-node"}, {"mesh", 0}}, n};
  d.j["scenes"][0]["nodes"] = {0, 1};
  return d;
}

// Appends an accessor over new bytes (its own bufferView, with byteStride
// when given); returns its index.
template <typename T>
int addAccessor(Doc& d, const std::vector<T>& data, int componentType, const std::string& type, size_t count,
                bool normalized = false, size_t stride = 0) {
  while (d.bin.size() % 4) d.bin.push_back(0);
  size_t off = d.bin.size();
  append(d.bin, data);
  json view = {{"buffer", 0}, {"byteOffset", off}, {"byteLength", data.size() * sizeof(T)}};
  if (stride) view["byteStride"] = stride;
  d.j["bufferViews"].push_back(view);
  json acc = {{"bufferView", d.j["bufferViews"].size() - 1},
              {"componentType", componentType},
              {"count", count},
              {"type", type}};
  if (normalized) acc["normalized"] = true;
  d.j["accessors"].push_back(acc);
  return int(d.j["accessors"].size() - 1);
}

}  // namespace

// Defect 1: tinygltf stores -1 for "absent", so "mesh": -1 silently meant no
// mesh; an index of 2^32 wrapped to 0 and instanced mesh 0; a primitive's
// "indices": -1 made it non-indexed and "material": -1 the default material.
TEST_F(LoaderTest, NegativeAndOverflowingIndicesAreRefused) {
  SceneResult r = load(writeDoc(twoNodeDoc({{"mesh", -1}}), "mesh.gltf"));
  EXPECT_TRUE(errorHas(r, "mesh.gltf: node 1 'other': 'mesh' must be an index in [0, 2147483647] (got -1)"));
  r = load(writeDoc(twoNodeDoc({{"camera", -1}}), "camera.gltf"));
  EXPECT_TRUE(errorHas(r, "camera.gltf: node 1 'other': 'camera' must be an index"));
  r = load(writeDoc(twoNodeDoc({{"mesh", 4294967296}}), "wrap.gltf"));
  EXPECT_TRUE(errorHas(r, "wrap.gltf: node 1 'other': 'mesh' must be an index in [0, 2147483647] (got 4294967296)"));
  r = load(writeDoc(twoNodeDoc({{"children", {4294967296}}}), "child.gltf"));
  EXPECT_TRUE(errorHas(r, "child.gltf: node 1 'other': 'children' must be an array of indices"));
  Doc p = quadDoc();
  p.j["meshes"][0]["primitives"][0]["indices"] = -1;
  r = load(writeDoc(p, "indices.gltf"));
  EXPECT_TRUE(errorHas(r, "indices.gltf: mesh 0 'quad' primitive 0: 'indices' must be an index"));
  Doc m = quadDoc();
  m.j["meshes"][0]["primitives"][0]["material"] = -1;
  r = load(writeDoc(m, "material.gltf"));
  EXPECT_TRUE(errorHas(r, "material.gltf: mesh 0 'quad' primitive 0: 'material' must be an index"));
  Doc a = quadDoc();
  a.j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = -2;
  r = load(writeDoc(a, "attribute.gltf"));
  EXPECT_TRUE(errorHas(r, "attribute.gltf: mesh 0 'quad' primitive 0: attribute 'POSITION' must be an index"));
  Doc s = quadDoc();
  s.j["scenes"][0]["nodes"] = {-1};
  r = load(writeDoc(s, "roots.gltf"));
  EXPECT_TRUE(errorHas(r, "roots.gltf: scene 0: 'nodes' must be an array of indices"));
  // The same documents with valid indices load.
  SceneResult ok = load(writeDoc(twoNodeDoc({{"mesh", 0}}), "ok.gltf"));
  ASSERT_TRUE(ok) << ok.error();
  EXPECT_EQ((*ok)->triangleCount(), 4u);
}

// Defect 2: a negative byteOffset read as 0 (tinygltf drops what is not
// unsigned); own finding: offsets near 2^64 wrapped around in the bounds
// check and read before the buffer.
TEST_F(LoaderTest, NegativeAndWrappingByteOffsetsAreRefused) {
  Doc v = quadDoc();
  v.j["bufferViews"][1]["byteOffset"] = -4;
  SceneResult r = load(writeDoc(v, "view.gltf"));
  EXPECT_TRUE(errorHas(r, "view.gltf: bufferView 1: 'byteOffset' must be an integer >= 0 (got -4)"));
  Doc a = quadDoc();
  a.j["accessors"][0]["byteOffset"] = -4;
  r = load(writeDoc(a, "accessor.gltf"));
  EXPECT_TRUE(errorHas(r, "accessor.gltf: accessor 0: 'byteOffset' must be an integer >= 0 (got -4)"));
  Doc w = quadDoc();
  w.j["accessors"][0]["byteOffset"] = uint64_t(-4);
  r = load(writeDoc(w, "wrap-accessor.gltf"));
  EXPECT_TRUE(errorHas(r, "wrap-accessor.gltf: node 0 'quad-node' mesh 0 'quad' primitive 0 POSITION (accessor 0)"));
  Doc x = quadDoc();
  x.j["bufferViews"][0]["byteOffset"] = uint64_t(-8);
  x.j["bufferViews"][0]["byteLength"] = 56;
  r = load(writeDoc(x, "wrap-view.gltf"));
  EXPECT_TRUE(errorHas(r,
                       "wrap-view.gltf: node 0 'quad-node' mesh 0 'quad' primitive 0 POSITION (accessor 0): "
                       "bufferView 0 runs past the end of buffer 0"));
}

// Defect 3: POSITION as BYTE was read as integer coordinates, normalized
// unsigned-byte indices as x/255; glTF 2.0 without KHR_mesh_quantization
// allows FLOAT positions, normals and tangents only.
TEST_F(LoaderTest, AttributeFormatsOutsideGltf20AreRefused) {
  const std::string prefix = "node 0 'quad-node' mesh 0 'quad' primitive 0 ";
  // Integer positions, 4-byte aligned: (0 0 0) (1 0 0) (1 1 0) (0 1 0).
  const std::vector<int8_t> bytePos = {0, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0, 0, 0, 1, 0, 0};
  for (bool normalized : {false, true}) {
    Doc d = quadDoc();
    int acc = addAccessor(d, bytePos, 5120, "VEC3", 4, normalized, 4);
    d.j["accessors"][acc]["min"] = {0, 0, 0};
    d.j["accessors"][acc]["max"] = {1, 1, 0};
    d.j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = acc;
    std::string name = normalized ? "byte-normalized.gltf" : "byte.gltf";
    SceneResult r = load(writeDoc(d, name));
    EXPECT_TRUE(errorHas(r, name + ": " + prefix + "POSITION (accessor 2): VEC3 BYTE" +
                                (normalized ? " normalized" : "") + " is not a glTF 2.0 format for POSITION"));
    if (!r) {
      EXPECT_NE(r.error().find("KHR_mesh_quantization is not supported"), std::string::npos) << r.error();
    }
  }
  Doc f = quadDoc();
  f.j["accessors"][0]["normalized"] = true;
  EXPECT_TRUE(errorHas(load(writeDoc(f, "float-normalized.gltf")), "VEC3 FLOAT normalized is not a glTF 2.0 format"));
  Doc n = quadDoc();
  int nrm = addAccessor(n, std::vector<int16_t>{0, 0, 32767, 0, 0, 0, 32767, 0, 0, 0, 32767, 0, 0, 0, 32767, 0}, 5122,
                        "VEC3", 4, true, 8);
  n.j["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = nrm;
  EXPECT_TRUE(errorHas(load(writeDoc(n, "normal.gltf")), "NORMAL (accessor 2): VEC3 SHORT normalized is not"));
  Doc t = quadDoc();
  int tan = addAccessor(t, std::vector<float>(16, 0.0f), 5126, "MAT2", 4);
  t.j["meshes"][0]["primitives"][0]["attributes"]["TANGENT"] = tan;
  EXPECT_TRUE(errorHas(load(writeDoc(t, "tangent.gltf")), "TANGENT (accessor 2): MAT2 FLOAT is not"));
  Doc u = quadDoc();
  int uv = addAccessor(u, std::vector<uint8_t>{0, 0, 0, 0, 255, 0, 0, 0, 255, 255, 0, 0, 0, 255, 0, 0}, 5121, "VEC2", 4,
                       false, 4);
  u.j["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = uv;
  EXPECT_TRUE(errorHas(load(writeDoc(u, "uv.gltf")), "TEXCOORD_0 (accessor 2): VEC2 UNSIGNED_BYTE is not"));
  // Normalized indices: index 3 as a normalized byte would read as 3/255.
  Doc i = quadDoc();
  int idx = addAccessor(i, std::vector<uint8_t>{0, 1, 2, 0, 2, 3}, 5121, "SCALAR", 6, true);
  i.j["meshes"][0]["primitives"][0]["indices"] = idx;
  EXPECT_TRUE(
      errorHas(load(writeDoc(i, "indices.gltf")), "indices (accessor 2): SCALAR UNSIGNED_BYTE normalized is not"));
  // What glTF 2.0 allows still loads: normalized unsigned-byte UVs read as
  // x/255, unsigned-byte indices.
  Doc v = quadDoc();
  int okUv = addAccessor(v, std::vector<uint8_t>{0, 0, 0, 0, 255, 0, 0, 0, 255, 255, 0, 0, 0, 255, 0, 0}, 5121, "VEC2",
                         4, true, 4);
  v.j["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = okUv;
  v.j["meshes"][0]["primitives"][0]["indices"] =
      addAccessor(v, std::vector<uint8_t>{0, 1, 2, 0, 2, 3}, 5121, "SCALAR", 6);
  SceneResult ok = load(writeDoc(v, "ok.gltf"));
  ASSERT_TRUE(ok) << ok.error();
  EXPECT_EQ((*ok)->triangleCount(), 2u);
  EXPECT_FLOAT_EQ((*ok)->uvs[2].x, 1.0f);
  EXPECT_FLOAT_EQ((*ok)->uvs[2].y, 1.0f);
}

// Defect 4: an explicit aspectRatio of 0 read as "not given"; znear <= 0 and
// zfar <= znear were never checked; a camera no node uses was not checked at all.
TEST_F(LoaderTest, PerspectiveCameraParametersFollowTheSpec) {
  Doc d = quadDoc();
  d.j["nodes"] = {{{"mesh", 0}}, {{"name", "eye"}, {"camera", 0}, {"translation", {0.5, 0.5, 3}}}};
  d.j["scenes"][0]["nodes"] = {0, 1};
  auto withCamera = [&](const json& perspective, const std::string& name) {
    Doc e = d;
    e.j["cameras"] = {{{"name", "cam"}, {"type", "perspective"}, {"perspective", perspective}}};
    return load(writeDoc(e, name));
  };
  EXPECT_TRUE(errorHas(withCamera({{"yfov", 0.5}, {"znear", 0.1}, {"aspectRatio", 0}}, "aspect.gltf"),
                       "aspect.gltf: camera 0 'cam': aspectRatio must be in [0.03125,32] (got 0)"));
  EXPECT_TRUE(errorHas(withCamera({{"yfov", 0.5}, {"znear", 0}}, "znear0.gltf"),
                       "znear0.gltf: camera 0 'cam': znear must be greater than 0 (got 0)"));
  EXPECT_TRUE(errorHas(withCamera({{"yfov", 0.5}, {"znear", -1}}, "znear.gltf"),
                       "camera 0 'cam': znear must be greater than 0 (got -1)"));
  EXPECT_TRUE(errorHas(withCamera({{"yfov", 0.5}, {"znear", 0.1}, {"zfar", 0.05}}, "zfar.gltf"),
                       "camera 0 'cam': zfar must be greater than znear (got zfar 0.05, znear 0.1)"));
  EXPECT_TRUE(errorHas(withCamera({{"yfov", 0}, {"znear", 0.1}}, "yfov.gltf"), "camera 0 'cam': yfov must be in"));
  // A camera no node uses is checked too.
  Doc u = quadDoc();
  u.j["cameras"] = {{{"name", "spare"}, {"type", "perspective"}, {"perspective", {{"yfov", 0.5}, {"znear", 0}}}}};
  EXPECT_TRUE(
      errorHas(load(writeDoc(u, "unused.gltf")), "unused.gltf: camera 0 'spare': znear must be greater than 0"));
  u.j["cameras"][0]["perspective"] = {{"yfov", 0.5}, {"znear", 0.1}, {"aspectRatio", -2}};
  EXPECT_TRUE(errorHas(load(writeDoc(u, "unused2.gltf")), "camera 0 'spare': aspectRatio must be greater than 0"));
  // Valid: zfar above znear, no aspectRatio (the image's aspect is used).
  SceneResult ok = withCamera({{"yfov", 0.5}, {"znear", 0.1}, {"zfar", 100}}, "ok.gltf");
  ASSERT_TRUE(ok) << ok.error();
  EXPECT_FLOAT_EQ((*ok)->camera.aspect, 0.0f);
}

// Defect 5: "scene": -1 loaded scene 0; own finding: "scene": 0 in a file
// without scenes loaded every root node.
TEST_F(LoaderTest, DefaultSceneIndexIsChecked) {
  Doc d = quadDoc();
  d.j["scene"] = -1;
  EXPECT_TRUE(
      errorHas(load(writeDoc(d, "neg.gltf")), "neg.gltf: 'scene' must be an index in [0, 2147483647] (got -1)"));
  Doc e = quadDoc();
  e.j.erase("scenes");
  EXPECT_TRUE(
      errorHas(load(writeDoc(e, "none.gltf")), "none.gltf: default scene 0 does not exist (the file has no scenes)"));
  // Without "scene" and "scenes", every root node is rendered (valid glTF).
  e.j.erase("scene");
  SceneResult ok = load(writeDoc(e, "ok.gltf"));
  ASSERT_TRUE(ok) << ok.error();
  EXPECT_EQ((*ok)->triangleCount(), 2u);
}

// Defect 6: asset.version "3.0" loaded, and glTF 1.0 files were refused for
// their first dictionary ("'materials' must be an array").
TEST_F(LoaderTest, OnlyGltf2IsAccepted) {
  Doc d = quadDoc();
  d.j["asset"]["version"] = "3.0";
  EXPECT_TRUE(errorHas(load(writeDoc(d, "three.gltf")),
                       "three.gltf: asset.version is \"3.0\"; only glTF 2.0 (version 2.x) is supported"));
  d.j["asset"]["version"] = "1.0";
  EXPECT_TRUE(errorHas(load(writeDoc(d, "one.gltf")), "one.gltf: glTF 1.0 is not supported; convert it to glTF 2.0"));
  // A glTF 1.0 file: dictionaries instead of arrays.
  json v1 = {{"asset", {{"version", "1.0"}}},
             {"materials", {{"red", {{"values", {{"diffuse", {1, 0, 0, 1}}}}}}}},
             {"meshes", {{"box", {{"primitives", json::array()}}}}}};
  EXPECT_TRUE(
      errorHas(load(write("v1.gltf", v1.dump())), "v1.gltf: glTF 1.0 is not supported; convert it to glTF 2.0"));
  v1["asset"].erase("version");
  EXPECT_TRUE(errorHas(load(write("v1b.gltf", v1.dump())), "v1b.gltf: glTF 1.0 is not supported"));
  d.j["asset"]["version"] = "2";
  EXPECT_TRUE(errorHas(load(writeDoc(d, "two.gltf")), "two.gltf: asset.version must be \"major.minor\""));
  d.j["asset"].erase("version");
  EXPECT_TRUE(errorHas(load(writeDoc(d, "missing.gltf")), "missing.gltf: asset.version is missing"));
  d.j["asset"]["version"] = "2.0";
  d.j["asset"]["minVersion"] = "2.1";
  EXPECT_TRUE(errorHas(load(writeDoc(d, "min.gltf")), "min.gltf: asset.minVersion is \"2.1\""));
  // Minor versions of 2 are forward compatible, and minVersion 2.0 is fine.
  d.j["asset"]["version"] = "2.1";
  d.j["asset"]["minVersion"] = "2.0";
  SceneResult ok = load(writeDoc(d, "ok.gltf"));
  ASSERT_TRUE(ok) << ok.error();
}

// Defect 7: the GLB header's container version was ignored.
TEST_F(LoaderTest, GlbContainerVersionMustBe2) {
  Doc d = quadDoc();
  for (uint32_t version : {1u, 99u}) {
    std::string name = "v" + std::to_string(version) + ".glb";
    std::string bytes = vsl::test::slurp(writeGlb(d, name));
    std::memcpy(&bytes[4], &version, 4);
    std::string path = write(name, bytes);
    SceneResult r = load(path);
    if (version == 1)
      EXPECT_TRUE(errorHas(r, path + ": GLB container version 1 (glTF 1.0 binary) is not supported; convert it to "
                                     "glTF 2.0"));
    else
      EXPECT_TRUE(errorHas(r, path + ": GLB container version 99 is not supported (glTF 2.0 binary is version 2)"));
  }
  SceneResult ok = load(writeGlb(d, "ok.glb"));
  ASSERT_TRUE(ok) << ok.error();
}

// Defect 8: a data: URI that failed to decode was quoted whole in the error
// (megabytes for a real file); now at most its first 60 characters.
TEST_F(LoaderTest, DataUriErrorsQuoteOnlyAPrefix) {
  Doc d = quadDoc();
  std::vector<uint8_t> big(3000, 7);
  append(d.bin, big);
  const std::string uri = "data:application/octet-stream;base64," + base64(d.bin);
  for (int variant = 0; variant < 2; ++variant) {
    Doc e = d;
    std::string u = uri;
    if (variant == 1) u[uri.size() / 2] = '*';  // bad base64
    e.j["buffers"] = {{{"byteLength", d.bin.size() + (variant == 0 ? 4 : 0)}, {"uri", u}}};
    std::string path = writeDoc(e, "uri" + std::to_string(variant) + ".gltf");
    SceneResult r = load(path);
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().find(path), std::string::npos) << r.error().substr(0, 300);
    EXPECT_NE(r.error().find(u.substr(0, 60) + "..."), std::string::npos) << r.error().substr(0, 300);
    EXPECT_EQ(r.error().find(u.substr(0, 61)), std::string::npos) << r.error().substr(0, 300);
    EXPECT_LT(r.error().size(), 400u) << r.error().substr(0, 300);
  }
}
