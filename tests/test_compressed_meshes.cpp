// Compressed glTF geometry (core/mesh_compression.h): small meshes encoded
// here with meshoptimizer's and Draco's own encoders, written as .gltf + .bin
// or .glb, must load to the same triangles, normals and UVs as the
// uncompressed file (bit for bit for meshopt without a filter; within the
// quantisation bound for Draco and the EXPONENTIAL filter), with no warning;
// corrupted compressed bytes must give an error naming the file, the
// extension and the reason.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>

#include "core/mesh_compression.h"
#include "core/scene.h"
#include "run_vsl.h"
#include "support.h"

#if VSL_HAVE_MESHOPT
#include <meshoptimizer.h>
#endif
#if VSL_HAVE_DRACO
#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>
#endif

using namespace vsl;
using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

// ---- The original mesh and files ------------------------------------------------

// A 5 x 5 vertex grid, gently curved (32 triangles), with unit normals and UVs.
struct Mesh {
  std::vector<float> pos, nrm, uv;  // 3, 3, 2 per vertex
  std::vector<uint32_t> idx;
  size_t vertices() const { return pos.size() / 3; }
};

Mesh gridMesh() {
  Mesh m;
  const int n = 5;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      float x = -1 + 2.0f * i / (n - 1), y = -1 + 2.0f * j / (n - 1), z = 0.2f * std::sin(1.3f * x + 0.7f * y);
      m.pos.insert(m.pos.end(), {x, y, z});
      Vec3 nn = normalize(Vec3(-0.26f * std::cos(1.3f * x + 0.7f * y), -0.14f * std::cos(1.3f * x + 0.7f * y), 1.0f));
      m.nrm.insert(m.nrm.end(), {nn.x, nn.y, nn.z});
      m.uv.insert(m.uv.end(), {float(i) / (n - 1), 1.0f - float(j) / (n - 1) * 0.75f});
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      uint32_t a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      m.idx.insert(m.idx.end(), {a, b, d, a, d, c});
    }
  return m;
}

template <typename T>
size_t appendBytes(std::vector<uint8_t>& bin, const T* data, size_t bytes) {
  while (bin.size() % 4 != 0) bin.push_back(0);
  size_t at = bin.size();
  bin.resize(at + bytes);
  std::memcpy(bin.data() + at, data, bytes);
  return at;
}

// The scene around one primitive: an emissive material and a camera, so that
// a correct load reports no warning at all.
json sceneJson(const json& primitive) {
  return json{{"asset", {{"version", "2.0"}}},
              {"scene", 0},
              {"scenes", {{{"nodes", {0, 1}}}}},
              {"nodes", {{{"mesh", 0}}, {{"camera", 0}, {"translation", {0.0, 0.0, 4.0}}}}},
              {"cameras", {{{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.01}}}}}},
              {"materials", {{{"emissiveFactor", {1.0, 1.0, 1.0}}}}},
              {"meshes", {{{"primitives", {primitive}}}}},
              {"accessors", json::array()},
              {"bufferViews", json::array()},
              {"buffers", json::array()}};
}

json accessor(int view, size_t count, const char* type, int componentType = 5126) {
  json a{{"componentType", componentType}, {"count", count}, {"type", type}};
  if (view >= 0) a["bufferView"] = view;
  return a;
}

// Writes doc and bin as DIR/NAME.gltf + DIR/NAME.bin (buffer 0's uri), or as
// DIR/NAME.glb with bin as its binary chunk. Returns the scene's path.
std::string writeScene(const fs::path& dir, const std::string& name, json doc, const std::vector<uint8_t>& bin,
                       bool glb) {
  if (!glb) {
    doc["buffers"][0]["uri"] = name + ".bin";
    std::ofstream(dir / (name + ".bin"), std::ios::binary).write(reinterpret_cast<const char*>(bin.data()), bin.size());
    std::ofstream(dir / (name + ".gltf")) << doc.dump();
    return (dir / (name + ".gltf")).string();
  }
  std::string text = doc.dump();
  while (text.size() % 4 != 0) text += ' ';
  std::vector<uint8_t> body = bin;
  while (body.size() % 4 != 0) body.push_back(0);
  auto u32 = [](std::string& s, uint32_t v) { s.append(reinterpret_cast<const char*>(&v), 4); };
  std::string out = "glTF";
  u32(out, 2);
  u32(out, uint32_t(12 + 8 + text.size() + 8 + body.size()));
  u32(out, uint32_t(text.size()));
  out += "JSON" + text;
  u32(out, uint32_t(body.size()));
  out += "BIN";
  out += '\0';
  out.append(reinterpret_cast<const char*>(body.data()), body.size());
  std::ofstream(dir / (name + ".glb"), std::ios::binary) << out;
  return (dir / (name + ".glb")).string();
}

// The uncompressed file: the reference every decoded load is compared with.
std::string writePlain(const fs::path& dir, const Mesh& m) {
  std::vector<uint8_t> bin;
  json doc =
      sceneJson({{"attributes", {{"POSITION", 0}, {"NORMAL", 1}, {"TEXCOORD_0", 2}}}, {"indices", 3}, {"material", 0}});
  auto view = [&](const void* data, size_t bytes) {
    size_t at = appendBytes(bin, static_cast<const uint8_t*>(data), bytes);
    doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", at}, {"byteLength", bytes}});
    return int(doc["bufferViews"].size()) - 1;
  };
  doc["accessors"].push_back(accessor(view(m.pos.data(), m.pos.size() * 4), m.vertices(), "VEC3"));
  doc["accessors"].back()["min"] = {-1.0, -1.0, -1.0};
  doc["accessors"].back()["max"] = {1.0, 1.0, 1.0};
  doc["accessors"].push_back(accessor(view(m.nrm.data(), m.nrm.size() * 4), m.vertices(), "VEC3"));
  doc["accessors"].push_back(accessor(view(m.uv.data(), m.uv.size() * 4), m.vertices(), "VEC2"));
  doc["accessors"].push_back(accessor(view(m.idx.data(), m.idx.size() * 4), m.idx.size(), "SCALAR", 5125));
  doc["buffers"].push_back({{"byteLength", bin.size()}});
  return writeScene(dir, "plain", doc, bin, false);
}

std::shared_ptr<const Scene> load(const std::string& path) {
  SceneResult r = loadScene(path);
  EXPECT_TRUE(r.ok()) << r.error();
  return r.ok() ? *r : nullptr;
}

// Each triangle of a matches one of b's (in any order, corners rotated: both
// codecs may reorder) with positions, normals and UVs within the tolerances.
void expectSameTriangleSet(const Scene& a, const Scene& b, float posTol, float nrmTol, float uvTol) {
  ASSERT_EQ(a.triangleCount(), b.triangleCount());
  auto near = [](Vec3 p, Vec3 q, float tol) {
    return std::abs(p.x - q.x) <= tol && std::abs(p.y - q.y) <= tol && std::abs(p.z - q.z) <= tol;
  };
  for (size_t t = 0; t < a.triangleCount(); ++t) {
    bool found = false;
    for (size_t s = 0; s < b.triangleCount() && !found; ++s)
      for (int r = 0; r < 3 && !found; ++r) {
        bool all = true;
        for (int k = 0; k < 3 && all; ++k) {
          uint32_t i = a.indices[3 * t + k], j = b.indices[3 * s + (k + r) % 3];
          all = near(a.positions[i], b.positions[j], posTol) && near(a.normals[i], b.normals[j], nrmTol) &&
                std::abs(a.uvs[i].x - b.uvs[j].x) <= uvTol && std::abs(a.uvs[i].y - b.uvs[j].y) <= uvTol;
        }
        found = all;
      }
    EXPECT_TRUE(found) << "decoded triangle " << t << " matches no original triangle";
  }
}

// `vsl info` on a good compressed file: exit 0 and no warning at all.
void expectCleanInfo(const std::string& path) {
  test::Proc p = test::runVsl("info '" + path + "'");
  EXPECT_EQ(p.code, 0) << p.out;
  EXPECT_NE(p.out.find("warnings   0"), std::string::npos) << p.out;
}

// A bad compressed file: an error naming the file, the extension and the
// reason, from the loader and as `vsl info`'s exit status 1.
void expectClearError(const std::string& path, const char* extension, const std::string& reason) {
  SceneResult r = loadScene(path);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find(path), std::string::npos) << r.error();
  EXPECT_NE(r.error().find(extension), std::string::npos) << r.error();
  EXPECT_NE(r.error().find(reason), std::string::npos) << r.error();
  test::Proc p = test::runVsl("info '" + path + "'");
  EXPECT_EQ(p.code, 1) << p.out;
  EXPECT_NE(p.out.find(extension), std::string::npos) << p.out;
}

}  // namespace

// ---- EXT_meshopt_compression ----------------------------------------------------

#if VSL_HAVE_MESHOPT
namespace {

struct MeshoptCase {
  const char* name;
  bool glb;
  bool indexSequence;  // mode INDICES with 16-bit indices, else TRIANGLES with 32-bit
  bool expFilterUv;    // UVs through the EXPONENTIAL filter (16-bit mantissa)
};

std::vector<uint8_t> encodeVertices(const void* data, size_t count, size_t stride) {
  std::vector<uint8_t> out(meshopt_encodeVertexBufferBound(count, stride));
  out.resize(meshopt_encodeVertexBuffer(out.data(), out.size(), data, count, stride));
  return out;
}

// The compressed streams go to buffer 0; the bufferViews decode into the
// fallback buffer 1, which has no uri (as gltfpack writes them).
json meshoptDoc(const Mesh& m, const MeshoptCase& c, std::vector<uint8_t>& bin) {
  json doc =
      sceneJson({{"attributes", {{"POSITION", 0}, {"NORMAL", 1}, {"TEXCOORD_0", 2}}}, {"indices", 3}, {"material", 0}});
  doc["extensionsUsed"] = {kMeshoptExtension};
  doc["extensionsRequired"] = {kMeshoptExtension};
  size_t fallbackBytes = 0;
  auto view = [&](const std::vector<uint8_t>& encoded, size_t count, size_t stride, const char* mode,
                  const char* filter) {
    size_t at = appendBytes(bin, encoded.data(), encoded.size());
    json ext{{"buffer", 0},          {"byteOffset", at}, {"byteLength", encoded.size()},
             {"byteStride", stride}, {"count", count},   {"mode", mode}};
    if (filter) ext["filter"] = filter;
    fallbackBytes = (fallbackBytes + 3) / 4 * 4;
    json bv{{"buffer", 1}, {"byteOffset", fallbackBytes}, {"byteLength", count * stride}};
    if (std::strcmp(mode, "ATTRIBUTES") == 0) bv["byteStride"] = stride;
    bv["extensions"] = {{kMeshoptExtension, ext}};
    fallbackBytes += count * stride;
    doc["bufferViews"].push_back(bv);
    return int(doc["bufferViews"].size()) - 1;
  };
  const size_t nv = m.vertices();
  doc["accessors"].push_back(
      accessor(view(encodeVertices(m.pos.data(), nv, 12), nv, 12, "ATTRIBUTES", nullptr), nv, "VEC3"));
  doc["accessors"].back()["min"] = {-1.0, -1.0, -1.0};
  doc["accessors"].back()["max"] = {1.0, 1.0, 1.0};
  doc["accessors"].push_back(
      accessor(view(encodeVertices(m.nrm.data(), nv, 12), nv, 12, "ATTRIBUTES", nullptr), nv, "VEC3"));
  std::vector<float> uv = m.uv;
  if (c.expFilterUv) meshopt_encodeFilterExp(uv.data(), nv, 8, 16, m.uv.data());
  doc["accessors"].push_back(
      accessor(view(encodeVertices(uv.data(), nv, 8), nv, 8, "ATTRIBUTES", c.expFilterUv ? "EXPONENTIAL" : nullptr), nv,
               "VEC2"));
  const size_t ni = m.idx.size();
  std::vector<uint8_t> enc(c.indexSequence ? meshopt_encodeIndexSequenceBound(ni, nv)
                                           : meshopt_encodeIndexBufferBound(ni, nv));
  enc.resize(c.indexSequence ? meshopt_encodeIndexSequence(enc.data(), enc.size(), m.idx.data(), ni)
                             : meshopt_encodeIndexBuffer(enc.data(), enc.size(), m.idx.data(), ni));
  int iv = view(enc, ni, c.indexSequence ? 2 : 4, c.indexSequence ? "INDICES" : "TRIANGLES", nullptr);
  doc["accessors"].push_back(accessor(iv, ni, "SCALAR", c.indexSequence ? 5123 : 5125));
  doc["buffers"].push_back({{"byteLength", bin.size()}});
  doc["buffers"].push_back(
      {{"byteLength", fallbackBytes}, {"extensions", {{kMeshoptExtension, {{"fallback", true}}}}}});
  return doc;
}

class Meshopt : public ::testing::TestWithParam<MeshoptCase> {};

TEST_P(Meshopt, DecodesToTheUncompressedMesh) {
  const MeshoptCase& c = GetParam();
  fs::path dir = test::scratchDir(std::string("vsl_meshopt_") + c.name);
  Mesh m = gridMesh();
  std::vector<uint8_t> bin;
  json doc = meshoptDoc(m, c, bin);
  std::string path = writeScene(dir, "packed", doc, bin, c.glb);
  auto plain = load(writePlain(dir, m));
  auto packed = load(path);
  ASSERT_TRUE(plain && packed);
  EXPECT_TRUE(packed->warnings.empty()) << packed->warnings.front();
  // Triangles (meshopt_encodeIndexBuffer may rotate their corners), positions
  // and normals exactly; UVs exactly without a filter, and
  // within the EXPONENTIAL filter's rounding (16-bit mantissa shared by u, v
  // in [0, 1]: 2^-16 relative to the larger, so below 2^-15) with it.
  expectSameTriangleSet(*packed, *plain, 0, 0, c.expFilterUv ? std::ldexp(1.0f, -15) : 0);
  expectCleanInfo(path);
}

INSTANTIATE_TEST_SUITE_P(Files, Meshopt,
                         ::testing::Values(MeshoptCase{"gltf_triangles", false, false, false},
                                           MeshoptCase{"glb_indices_exp", true, true, true}),
                         [](const auto& param) { return std::string(param.param.name); });

// Each corruption of a good file, and the reason its error must give.
TEST(MeshoptErrors, CorruptCompressedDataIsAClearError) {
  fs::path dir = test::scratchDir("vsl_meshopt_errors");
  Mesh m = gridMesh();
  std::vector<uint8_t> bin;
  const json good = meshoptDoc(m, {"errors", false, false, false}, bin);
  auto ext = [](json& d, int view) -> json& { return d["bufferViews"][view]["extensions"][kMeshoptExtension]; };
  struct Case {
    const char* name;
    std::function<void(json&, std::vector<uint8_t>&)> corrupt;
    const char* reason;
  };
  const Case cases[] = {
      {"header", [&](json& d, std::vector<uint8_t>& b) { b[ext(d, 0)["byteOffset"].get<size_t>()] = 0x11; },
       "corrupt or truncated"},
      {"truncated",
       [&](json& d, std::vector<uint8_t>&) { ext(d, 3)["byteLength"] = ext(d, 3)["byteLength"].get<int>() / 2; },
       "corrupt or truncated"},
      {"past_end", [&](json& d, std::vector<uint8_t>&) { ext(d, 1)["byteOffset"] = 1u << 30; }, "runs past the end"},
      {"mode", [&](json& d, std::vector<uint8_t>&) { ext(d, 2)["mode"] = "ZIP"; }, "mode must be"},
      {"stride", [&](json& d, std::vector<uint8_t>&) { ext(d, 0)["byteStride"] = 6; }, "byteStride"},
      {"fallback_huge", [&](json& d, std::vector<uint8_t>&) { d["buffers"][1]["byteLength"] = 1ull << 40; },
       "can decode to"},
      {"ratio", [&](json& d, std::vector<uint8_t>&) { ext(d, 0)["byteLength"] = 1; }, "cannot decode to"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    json d = good;
    std::vector<uint8_t> b = bin;
    c.corrupt(d, b);
    expectClearError(writeScene(dir, c.name, d, b, false), kMeshoptExtension, c.reason);
  }
}

}  // namespace
#else
TEST(Meshopt, DecodesToTheUncompressedMesh) {
  GTEST_SKIP() << "built without meshoptimizer: install " << kMeshoptPackage << " (scripts/setup.sh) and rebuild";
}
#endif

// ---- KHR_draco_mesh_compression -------------------------------------------------

#if VSL_HAVE_DRACO
namespace {

// Quantisation (bits) of the encoded attributes, and the errors they allow:
// positions span 2 units in 2^14 - 1 steps, UVs 1 unit in 2^12 - 1 steps
// (rounding: half a step; one step allowed), normals are octahedral with 10
// bits (about 2^-8 per component; 0.01 allowed).
constexpr int kPosBits = 14, kNrmBits = 10, kUvBits = 12;
const float kPosTol = 2.0f / ((1 << kPosBits) - 1), kUvTol = 1.0f / ((1 << kUvBits) - 1), kNrmTol = 0.01f;

struct DracoData {
  std::vector<uint8_t> bytes;
  uint32_t posId = 0, nrmId = 0, uvId = 0;
  size_t points = 0, faces = 0;
};

DracoData encodeDraco(const Mesh& m, int method) {
  draco::TriangleSoupMeshBuilder builder;
  const int nf = int(m.idx.size() / 3);
  builder.Start(nf);
  int pa = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
  int na = builder.AddAttribute(draco::GeometryAttribute::NORMAL, 3, draco::DT_FLOAT32);
  int ta = builder.AddAttribute(draco::GeometryAttribute::TEX_COORD, 2, draco::DT_FLOAT32);
  for (int f = 0; f < nf; ++f) {
    const uint32_t* v = &m.idx[3 * f];
    builder.SetAttributeValuesForFace(pa, draco::FaceIndex(f), &m.pos[3 * v[0]], &m.pos[3 * v[1]], &m.pos[3 * v[2]]);
    builder.SetAttributeValuesForFace(na, draco::FaceIndex(f), &m.nrm[3 * v[0]], &m.nrm[3 * v[1]], &m.nrm[3 * v[2]]);
    builder.SetAttributeValuesForFace(ta, draco::FaceIndex(f), &m.uv[2 * v[0]], &m.uv[2 * v[1]], &m.uv[2 * v[2]]);
  }
  std::unique_ptr<draco::Mesh> mesh = builder.Finalize();
  draco::Encoder encoder;
  encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, kPosBits);
  encoder.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, kNrmBits);
  encoder.SetAttributeQuantization(draco::GeometryAttribute::TEX_COORD, kUvBits);
  encoder.SetEncodingMethod(method);
  draco::EncoderBuffer out;
  EXPECT_TRUE(encoder.EncodeMeshToBuffer(*mesh, &out).ok());
  DracoData d;
  d.bytes.assign(out.data(), out.data() + out.size());
  d.posId = mesh->attribute(pa)->unique_id();
  d.nrmId = mesh->attribute(na)->unique_id();
  d.uvId = mesh->attribute(ta)->unique_id();
  // The accessors' counts are the decoded mesh's (the encoder merges points).
  draco::DecoderBuffer in;
  in.Init(out.data(), out.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&in);
  EXPECT_TRUE(decoded.ok());
  if (decoded.ok()) {
    d.points = decoded.value()->num_points();
    d.faces = decoded.value()->num_faces();
  }
  return d;
}

// The Draco data in bufferView 0 of buffer 0; accessors without bufferViews.
json dracoDoc(const DracoData& d) {
  json ext{{"bufferView", 0}, {"attributes", {{"POSITION", d.posId}, {"NORMAL", d.nrmId}, {"TEXCOORD_0", d.uvId}}}};
  json doc = sceneJson({{"attributes", {{"POSITION", 0}, {"NORMAL", 1}, {"TEXCOORD_0", 2}}},
                        {"indices", 3},
                        {"material", 0},
                        {"extensions", {{kDracoExtension, ext}}}});
  doc["extensionsUsed"] = {kDracoExtension};
  doc["extensionsRequired"] = {kDracoExtension};
  doc["accessors"].push_back(accessor(-1, d.points, "VEC3"));
  doc["accessors"].back()["min"] = {-1.0, -1.0, -1.0};
  doc["accessors"].back()["max"] = {1.0, 1.0, 1.0};
  doc["accessors"].push_back(accessor(-1, d.points, "VEC3"));
  doc["accessors"].push_back(accessor(-1, d.points, "VEC2"));
  doc["accessors"].push_back(accessor(-1, d.faces * 3, "SCALAR", 5125));
  doc["bufferViews"].push_back({{"buffer", 0}, {"byteLength", d.bytes.size()}});
  doc["buffers"].push_back({{"byteLength", d.bytes.size()}});
  return doc;
}

class Draco : public ::testing::TestWithParam<int> {};

TEST_P(Draco, DecodesToTheUncompressedMeshWithinQuantisation) {
  fs::path dir = test::scratchDir("vsl_draco_" + std::to_string(GetParam()));
  Mesh m = gridMesh();
  DracoData d = encodeDraco(m, GetParam());
  ASSERT_EQ(d.faces, m.idx.size() / 3);
  std::string path = writeScene(dir, "packed", dracoDoc(d), d.bytes, GetParam() == draco::MESH_EDGEBREAKER_ENCODING);
  auto plain = load(writePlain(dir, m));
  auto packed = load(path);
  ASSERT_TRUE(plain && packed);
  EXPECT_TRUE(packed->warnings.empty()) << packed->warnings.front();
  expectSameTriangleSet(*packed, *plain, kPosTol, kNrmTol, kUvTol);
  expectCleanInfo(path);
}

INSTANTIATE_TEST_SUITE_P(Methods, Draco,
                         ::testing::Values(int(draco::MESH_SEQUENTIAL_ENCODING), int(draco::MESH_EDGEBREAKER_ENCODING)),
                         [](const auto& param) {
                           return param.param == draco::MESH_SEQUENTIAL_ENCODING ? "sequential_gltf"
                                                                                 : "edgebreaker_glb";
                         });

TEST(DracoErrors, CorruptCompressedDataIsAClearError) {
  fs::path dir = test::scratchDir("vsl_draco_errors");
  DracoData d = encodeDraco(gridMesh(), draco::MESH_EDGEBREAKER_ENCODING);
  const json good = dracoDoc(d);
  auto ext = [](json& doc) -> json& { return doc["meshes"][0]["primitives"][0]["extensions"][kDracoExtension]; };
  struct Case {
    const char* name;
    std::function<void(json&, std::vector<uint8_t>&)> corrupt;
    const char* reason;
  };
  const Case cases[] = {
      {"truncated", [&](json& doc, std::vector<uint8_t>&) { doc["bufferViews"][0]["byteLength"] = d.bytes.size() / 2; },
       "corrupt or truncated"},
      {"magic", [&](json&, std::vector<uint8_t>& b) { b[0] = 'X'; }, "corrupt or truncated"},
      {"attribute_id", [&](json& doc, std::vector<uint8_t>&) { ext(doc)["attributes"]["NORMAL"] = 77; },
       "no attribute with id 77"},
      {"count", [&](json& doc, std::vector<uint8_t>&) { doc["accessors"][0]["count"] = d.points + 1; }, "differs from"},
      {"view", [&](json& doc, std::vector<uint8_t>&) { ext(doc)["bufferView"] = 9; }, "does not exist"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    json doc = good;
    std::vector<uint8_t> b = d.bytes;
    c.corrupt(doc, b);
    expectClearError(writeScene(dir, c.name, doc, b, false), kDracoExtension, c.reason);
  }
}

}  // namespace
#else
TEST(Draco, DecodesToTheUncompressedMeshWithinQuantisation) {
  GTEST_SKIP() << "built without Draco: install " << kDracoPackage << " (scripts/setup.sh) and rebuild";
}
#endif
