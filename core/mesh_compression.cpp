// Compressed glTF geometry (core/mesh_compression.h). Sections:
//   [1] reading the extensions' JSON values
//   [2] EXT_meshopt_compression: fallback buffers, bufferView decoding
//   [3] KHR_draco_mesh_compression: primitive decoding
#include "core/mesh_compression.h"

#include <tiny_gltf.h>

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <set>

#if VSL_HAVE_MESHOPT
#include <meshoptimizer.h>
#endif
#if VSL_HAVE_DRACO
#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/mesh/mesh.h>
#endif

namespace vsl {

bool meshoptAvailable() { return VSL_HAVE_MESHOPT != 0; }
bool dracoAvailable() { return VSL_HAVE_DRACO != 0; }

namespace {

// ---- [1] Extension JSON ---------------------------------------------------------

// obj[key] as an integer in [0, 2^53], or fallback when absent; an error
// names where, the key and the value.
Result<uint64_t> indexOr(const tinygltf::Value& obj, const char* key, int64_t fallback, const std::string& where) {
  if (!obj.Has(key)) {
    if (fallback < 0) return Error(where + ": " + key + " is required");
    return uint64_t(fallback);
  }
  const tinygltf::Value& v = obj.Get(key);
  double d = v.IsNumber() ? v.GetNumberAsDouble() : -1.0;
  if (!(d >= 0 && d <= 9007199254740992.0 && d == std::floor(d)))
    return Error(where + ": " + key + " must be a non-negative integer");
  return uint64_t(d);
}

std::string stringOr(const tinygltf::Value& obj, const char* key, const char* fallback) {
  if (!obj.Has(key) || !obj.Get(key).IsString()) return fallback;
  return obj.Get(key).Get<std::string>();
}

// A byte range [offset, offset + length) inside a buffer of size bytes.
bool rangeInside(uint64_t offset, uint64_t length, uint64_t size) { return offset <= size && length <= size - offset; }

// ---- [2] EXT_meshopt_compression ------------------------------------------------

// The extension object of a bufferView (EXT_meshopt_compression, section
// "JSON schema updates").
struct MeshoptView {
  uint64_t buffer = 0, byteOffset = 0, byteLength = 0, byteStride = 0, count = 0;
  std::string mode, filter;
};

Result<MeshoptView> parseMeshoptView(const tinygltf::Value& ext, const std::string& where) {
  if (!ext.IsObject()) return Error(where + ": the extension must be an object");
  MeshoptView m;
  for (auto [key, out, fallback] : {std::tuple{"buffer", &m.buffer, int64_t(-1)},
                                    {"byteOffset", &m.byteOffset, int64_t(0)},
                                    {"byteLength", &m.byteLength, int64_t(-1)},
                                    {"byteStride", &m.byteStride, int64_t(-1)},
                                    {"count", &m.count, int64_t(-1)}}) {
    Result<uint64_t> v = indexOr(ext, key, fallback, where);
    if (!v) return Error(v.error());
    *out = *v;
  }
  m.mode = stringOr(ext, "mode", "");
  m.filter = stringOr(ext, "filter", "NONE");
  return m;
}

// The specification's validity rules for mode, filter, byteStride and count
// (section "JSON schema updates"), and the decoded size against the parent
// bufferView.
Result<void> checkMeshoptLayout(const MeshoptView& m, const tinygltf::BufferView& bv, const std::string& where) {
  const bool attributes = m.mode == "ATTRIBUTES", indices = m.mode == "TRIANGLES" || m.mode == "INDICES";
  if (!attributes && !indices)
    return Error(where + ": mode must be ATTRIBUTES, TRIANGLES or INDICES (got '" + m.mode + "')");
  if (m.filter != "NONE" && m.filter != "OCTAHEDRAL" && m.filter != "QUATERNION" && m.filter != "EXPONENTIAL")
    return Error(where + ": filter must be NONE, OCTAHEDRAL, QUATERNION or EXPONENTIAL (got '" + m.filter + "')");
  const uint64_t s = m.byteStride;
  if (attributes && (s == 0 || s % 4 != 0 || s > 256))
    return Error(where + ": byteStride " + std::to_string(s) + " must be a multiple of 4 in [4, 256] for ATTRIBUTES");
  if (indices && s != 2 && s != 4) return Error(where + ": byteStride must be 2 or 4 for " + m.mode);
  if (indices && m.filter != "NONE") return Error(where + ": filter must be NONE for " + m.mode);
  if (m.mode == "TRIANGLES" && m.count % 3 != 0)
    return Error(where + ": count " + std::to_string(m.count) + " must be a multiple of 3 for TRIANGLES");
  if ((m.filter == "OCTAHEDRAL" && s != 4 && s != 8) || (m.filter == "QUATERNION" && s != 8))
    return Error(where + ": byteStride " + std::to_string(s) + " is not allowed with filter " + m.filter);
  if (bv.byteStride != 0 && uint64_t(bv.byteStride) != s)
    return Error(where + ": byteStride " + std::to_string(s) + " differs from the bufferView's " +
                 std::to_string(bv.byteStride));
  // count <= 2^53 and s <= 256: compare without overflow.
  if (m.count > (uint64_t(1) << 40) || m.count * s != bv.byteLength)
    return Error(where + ": count x byteStride (" + std::to_string(m.count) + " x " + std::to_string(s) +
                 ") must equal the bufferView's byteLength " + std::to_string(bv.byteLength));
  // Each 16 decoded bytes cost at least 2 header bits (Appendix A, mode 0);
  // index modes cost more. More output than that is corrupt.
  if (bv.byteLength / 64 > m.byteLength)
    return Error(where + ": " + std::to_string(m.byteLength) + " compressed bytes cannot decode to " +
                 std::to_string(bv.byteLength));
  return {};
}

#if VSL_HAVE_MESHOPT
// Decodes m's compressed bytes src (n bytes) into out, then applies the
// filter (Appendix B) in place.
Result<void> runMeshopt(const MeshoptView& m, const unsigned char* src, size_t n, std::vector<unsigned char>& out,
                        const std::string& where) {
  const size_t count = size_t(m.count), stride = size_t(m.byteStride);
  int rc = 0;
  const char* fn = "";
  if (m.mode == "ATTRIBUTES") {
    fn = "meshopt_decodeVertexBuffer";
    rc = meshopt_decodeVertexBuffer(out.data(), count, stride, src, n);
  } else if (m.mode == "TRIANGLES") {
    fn = "meshopt_decodeIndexBuffer";
    rc = meshopt_decodeIndexBuffer(out.data(), count, stride, src, n);
  } else {
    fn = "meshopt_decodeIndexSequence";
    rc = meshopt_decodeIndexSequence(out.data(), count, stride, src, n);
  }
  if (rc != 0)
    return Error(where + ": the compressed data is corrupt or truncated (" + fn + " returned " + std::to_string(rc) +
                 ")");
  if (m.filter == "OCTAHEDRAL") meshopt_decodeFilterOct(out.data(), count, stride);
  if (m.filter == "QUATERNION") meshopt_decodeFilterQuat(out.data(), count, stride);
  if (m.filter == "EXPONENTIAL") meshopt_decodeFilterExp(out.data(), count, stride);
  return {};
}
#endif

// Decodes bufferView index's EXT_meshopt_compression data into its bytes.
Result<void> decodeMeshoptView(tinygltf::Model& model, size_t index, const std::set<int>& fallbackIndices) {
  tinygltf::BufferView& bv = model.bufferViews[index];
  const std::string where = "bufferView " + std::to_string(index) + " " + kMeshoptExtension;
  Result<MeshoptView> parsed = parseMeshoptView(bv.extensions.at(kMeshoptExtension), where);
  if (!parsed) return Error(parsed.error());
  const MeshoptView& m = *parsed;
  if (Result<void> ok = checkMeshoptLayout(m, bv, where); !ok) return ok;
  if (m.buffer >= model.buffers.size())
    return Error(where + ": buffer " + std::to_string(m.buffer) + " does not exist");
  if (fallbackIndices.count(int(m.buffer)))
    return Error(where + ": buffer " + std::to_string(m.buffer) + " is a fallback buffer, which holds no data");
  const std::vector<unsigned char>& src = model.buffers[m.buffer].data;
  if (!rangeInside(m.byteOffset, m.byteLength, src.size()))
    return Error(where + ": byteOffset " + std::to_string(m.byteOffset) + " + byteLength " +
                 std::to_string(m.byteLength) + " runs past the end of buffer " + std::to_string(m.buffer) + " (" +
                 std::to_string(src.size()) + " bytes)");
  if (bv.buffer < 0 || size_t(bv.buffer) >= model.buffers.size())
    return Error(where + ": the bufferView's buffer " + std::to_string(bv.buffer) + " does not exist");
  std::vector<unsigned char>& dst = model.buffers[bv.buffer].data;
  if (!rangeInside(bv.byteOffset, bv.byteLength, dst.size()))
    return Error(where + ": the bufferView runs past the end of buffer " + std::to_string(bv.buffer) + " (" +
                 std::to_string(dst.size()) + " bytes)");
  if (m.count == 0) return {};
#if VSL_HAVE_MESHOPT
  // Decode aside: the source and destination ranges may overlap.
  std::vector<unsigned char> out(bv.byteLength);
  if (Result<void> ok = runMeshopt(m, src.data() + m.byteOffset, size_t(m.byteLength), out, where); !ok) return ok;
  std::memcpy(dst.data() + bv.byteOffset, out.data(), out.size());
  return {};
#else
  return Error(where + ": this build cannot decode it; install " + kMeshoptPackage + " (scripts/setup.sh) and rebuild");
#endif
}

// ---- [3] KHR_draco_mesh_compression ---------------------------------------------

#if VSL_HAVE_DRACO
// Appends bytes to the buffer that holds decoded Draco data, and a
// bufferView and accessor (a copy of the original's type) over them;
// returns the accessor's index.
int appendAccessor(tinygltf::Model& model, int bufferIndex, const tinygltf::Accessor& original,
                   const std::vector<unsigned char>& bytes, int componentType, size_t count) {
  std::vector<unsigned char>& data = model.buffers[bufferIndex].data;
  while (data.size() % 4 != 0) data.push_back(0);
  tinygltf::BufferView bv;
  bv.buffer = bufferIndex;
  bv.byteOffset = data.size();
  bv.byteLength = bytes.size();
  data.insert(data.end(), bytes.begin(), bytes.end());
  model.bufferViews.push_back(bv);
  tinygltf::Accessor acc;
  acc.name = original.name;
  acc.type = original.type;
  acc.componentType = componentType;
  acc.normalized = false;
  acc.count = count;
  acc.bufferView = int(model.bufferViews.size()) - 1;
  model.accessors.push_back(acc);
  return int(model.accessors.size()) - 1;
}

// The accessor index, checked to exist.
Result<int> accessorIndex(const tinygltf::Model& model, int index, const std::string& what) {
  if (index < 0 || size_t(index) >= model.accessors.size())
    return Error(what + ": accessor " + std::to_string(index) + " does not exist");
  return index;
}

// One decoded attribute (the Draco attribute with unique id) as floats, in a
// new accessor that replaces prim.attributes[name].
Result<void> replaceAttribute(tinygltf::Model& model, tinygltf::Primitive& prim, const draco::Mesh& mesh,
                              const std::string& name, uint64_t id, int bufferIndex, const std::string& where) {
  const std::string what = where + " attribute " + name;
  auto it = prim.attributes.find(name);
  if (it == prim.attributes.end()) return Error(what + ": the primitive has no such attribute");
  Result<int> ai = accessorIndex(model, it->second, what);
  if (!ai) return Error(ai.error());
  const tinygltf::Accessor original = model.accessors[*ai];
  const draco::PointAttribute* att = id <= UINT32_MAX ? mesh.GetAttributeByUniqueId(uint32_t(id)) : nullptr;
  if (att == nullptr) return Error(what + ": the Draco data has no attribute with id " + std::to_string(id));
  const int nc = tinygltf::GetNumComponentsInType(uint32_t(original.type));
  if (nc <= 0 || att->num_components() != nc)
    return Error(what + ": the Draco attribute has " + std::to_string(att->num_components()) +
                 " components but the accessor's type needs " + std::to_string(nc));
  const size_t n = mesh.num_points();
  if (original.count != n)
    return Error(what + ": accessor count " + std::to_string(original.count) + " differs from the " +
                 std::to_string(n) + " decoded points");
  std::vector<unsigned char> bytes(n * nc * sizeof(float));
  for (size_t i = 0; i < n; ++i) {
    float v[4] = {0, 0, 0, 0};
    draco::AttributeValueIndex avi = att->mapped_index(draco::PointIndex(uint32_t(i)));
    if (avi.value() >= att->size() || !att->ConvertValue<float>(avi, int8_t(nc), v))
      return Error(what + ": the Draco attribute's value for point " + std::to_string(i) + " cannot be read");
    for (int c = 0; c < nc; ++c)
      if (!std::isfinite(v[c])) return Error(what + ": decoded value of point " + std::to_string(i) + " is not finite");
    std::memcpy(bytes.data() + i * nc * sizeof(float), v, nc * sizeof(float));
  }
  it->second = appendAccessor(model, bufferIndex, original, bytes, TINYGLTF_COMPONENT_TYPE_FLOAT, n);
  return {};
}

// The decoded triangles as a uint32 index accessor replacing prim.indices.
Result<void> replaceIndices(tinygltf::Model& model, tinygltf::Primitive& prim, const draco::Mesh& mesh, int bufferIndex,
                            const std::string& where) {
  tinygltf::Accessor original;
  original.type = TINYGLTF_TYPE_SCALAR;
  if (prim.indices >= 0) {
    Result<int> ai = accessorIndex(model, prim.indices, where + " indices");
    if (!ai) return Error(ai.error());
    original = model.accessors[*ai];
    if (original.count != uint64_t(mesh.num_faces()) * 3)
      return Error(where + " indices: accessor count " + std::to_string(original.count) + " differs from the " +
                   std::to_string(uint64_t(mesh.num_faces()) * 3) + " decoded indices");
  }
  std::vector<unsigned char> bytes(size_t(mesh.num_faces()) * 3 * sizeof(uint32_t));
  for (uint32_t f = 0; f < mesh.num_faces(); ++f) {
    const draco::Mesh::Face& face = mesh.face(draco::FaceIndex(f));
    for (int k = 0; k < 3; ++k) {
      uint32_t v = face[k].value();
      if (v >= mesh.num_points())
        return Error(where + ": decoded face " + std::to_string(f) + " names point " + std::to_string(v) + " of " +
                     std::to_string(mesh.num_points()));
      std::memcpy(bytes.data() + (size_t(f) * 3 + k) * sizeof(uint32_t), &v, sizeof v);
    }
  }
  prim.indices = appendAccessor(model, bufferIndex, original, bytes, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                                size_t(mesh.num_faces()) * 3);
  return {};
}

// The Draco mesh stored in the extension's bufferView.
Result<std::unique_ptr<draco::Mesh>> decodeDracoMesh(const tinygltf::Model& model, const tinygltf::Value& ext,
                                                     uint64_t maxTriangles, const std::string& where) {
  Result<uint64_t> view = indexOr(ext, "bufferView", -1, where);
  if (!view) return Error(view.error());
  if (*view >= model.bufferViews.size())
    return Error(where + ": bufferView " + std::to_string(*view) + " does not exist");
  const tinygltf::BufferView& bv = model.bufferViews[*view];
  if (bv.buffer < 0 || size_t(bv.buffer) >= model.buffers.size())
    return Error(where + ": buffer " + std::to_string(bv.buffer) + " does not exist");
  const std::vector<unsigned char>& data = model.buffers[bv.buffer].data;
  if (!rangeInside(bv.byteOffset, bv.byteLength, data.size()))
    return Error(where + ": bufferView " + std::to_string(*view) + " runs past the end of buffer " +
                 std::to_string(bv.buffer) + " (" + std::to_string(data.size()) + " bytes)");
  draco::DecoderBuffer in;
  in.Init(reinterpret_cast<const char*>(data.data() + bv.byteOffset), bv.byteLength);
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&in);
  if (!decoded.ok())
    return Error(where +
                 ": the compressed data is corrupt or truncated (Draco: " + decoded.status().error_msg_string() + ")");
  std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
  if (mesh->num_faces() > maxTriangles)
    return Error(where + ": " + std::to_string(mesh->num_faces()) + " triangles are more than the limit of " +
                 std::to_string(maxTriangles));
  return Result<std::unique_ptr<draco::Mesh>>(std::move(mesh));
}

// Decodes one primitive's Draco data (triangle lists only: the loader skips
// points and lines) and drops the extension from it.
Result<void> decodeDracoPrimitive(tinygltf::Model& model, tinygltf::Primitive& prim, int& bufferIndex,
                                  uint64_t maxTriangles, const std::string& where) {
  const tinygltf::Value ext = prim.extensions.at(kDracoExtension);
  const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
    return {};  // points and lines: skipped by the loader with a warning
  if (mode != TINYGLTF_MODE_TRIANGLES) return Error(where + ": Draco data decodes to triangle lists (mode 4) only");
  if (!ext.IsObject() || !ext.Has("attributes") || !ext.Get("attributes").IsObject())
    return Error(where + ": the extension needs an attributes object");
  Result<std::unique_ptr<draco::Mesh>> mesh = decodeDracoMesh(model, ext, maxTriangles, where);
  if (!mesh) return Error(mesh.error());
  if (bufferIndex < 0) {
    model.buffers.emplace_back();
    bufferIndex = int(model.buffers.size()) - 1;
  }
  const tinygltf::Value& attributes = ext.Get("attributes");
  for (const std::string& name : attributes.Keys()) {
    Result<uint64_t> id = indexOr(attributes, name.c_str(), -1, where + " attributes");
    if (!id) return Error(id.error());
    if (Result<void> ok = replaceAttribute(model, prim, **mesh, name, *id, bufferIndex, where); !ok) return ok;
  }
  if (Result<void> ok = replaceIndices(model, prim, **mesh, bufferIndex, where); !ok) return ok;
  prim.extensions.erase(kDracoExtension);
  return {};
}
#endif

}  // namespace

namespace {

// The buffers without a uri that EXT_meshopt_compression bufferViews decode
// into (not a GLB's first buffer: that is its binary chunk), stubbed.
std::vector<FallbackBuffer> stubFallbackBuffers(nlohmann::json& doc, bool isBinary) {
  std::vector<FallbackBuffer> out;
  if (!doc.contains("buffers") || !doc["buffers"].is_array() || !doc.contains("bufferViews") ||
      !doc["bufferViews"].is_array())
    return out;
  nlohmann::json& buffers = doc["buffers"];
  std::set<size_t> targets;
  for (const nlohmann::json& bv : doc["bufferViews"])
    if (bv.is_object() && bv.contains("extensions") && bv["extensions"].is_object() &&
        bv["extensions"].contains(kMeshoptExtension) && bv.contains("buffer") && bv["buffer"].is_number_unsigned())
      targets.insert(bv["buffer"].get<size_t>());
  for (size_t i : targets) {
    if (i >= buffers.size() || !buffers[i].is_object() || buffers[i].contains("uri")) continue;
    if (isBinary && i == 0) continue;
    nlohmann::json& b = buffers[i];
    if (!b.contains("byteLength") || !b["byteLength"].is_number_unsigned()) continue;  // tinygltf says why
    out.push_back({int(i), b["byteLength"].get<uint64_t>()});
    b["uri"] = "data:application/octet-stream;base64,AAAA";  // 3 zero bytes
    b["byteLength"] = 3;
  }
  return out;
}

// Whether accessor index of doc exists and has no bufferView.
bool withoutBufferView(const nlohmann::json& doc, const nlohmann::json& index) {
  if (!index.is_number_unsigned() || !doc.contains("accessors") || !doc["accessors"].is_array()) return false;
  const size_t i = index.get<size_t>();
  return i < doc["accessors"].size() && doc["accessors"][i].is_object() && !doc["accessors"][i].contains("bufferView");
}

// The Draco primitives' indices accessors without a bufferView, taken out.
std::vector<DracoIndices> stubDracoIndices(nlohmann::json& doc) {
  std::vector<DracoIndices> out;
  if (!dracoAvailable() || !doc.contains("meshes") || !doc["meshes"].is_array()) return out;
  for (size_t m = 0; m < doc["meshes"].size(); ++m) {
    nlohmann::json& mesh = doc["meshes"][m];
    if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) continue;
    for (size_t p = 0; p < mesh["primitives"].size(); ++p) {
      nlohmann::json& prim = mesh["primitives"][p];
      if (!prim.is_object() || !prim.contains("extensions") || !prim["extensions"].is_object() ||
          !prim["extensions"].contains(kDracoExtension) || !prim.contains("indices") ||
          !withoutBufferView(doc, prim["indices"]))
        continue;
      out.push_back({int(m), int(p), prim["indices"].get<int>()});
      prim.erase("indices");
    }
  }
  return out;
}

}  // namespace

TinygltfStubs stubForTinygltf(nlohmann::json& doc, bool isBinary) {
  TinygltfStubs stubs;
  if (!doc.is_object()) return stubs;
  stubs.fallbackBuffers = stubFallbackBuffers(doc, isBinary);
  stubs.dracoIndices = stubDracoIndices(doc);
  return stubs;
}

Result<void> decodeMeshopt(tinygltf::Model& model, const std::vector<FallbackBuffer>& fallbacks, uint64_t inputBytes) {
  std::set<int> fallbackIndices;
  for (const FallbackBuffer& f : fallbacks) {
    if (f.index < 0 || size_t(f.index) >= model.buffers.size()) continue;
    const std::string where = "buffer " + std::to_string(f.index) + " (" + kMeshoptExtension + " fallback)";
    if (f.byteLength / 64 > inputBytes)
      return Error(where + ": byteLength " + std::to_string(f.byteLength) + " is more than the " +
                   std::to_string(inputBytes) + " bytes of this file and its buffers can decode to");
    model.buffers[f.index].data.assign(size_t(f.byteLength), 0);
    model.buffers[f.index].uri.clear();
    fallbackIndices.insert(f.index);
  }
  for (size_t i = 0; i < model.bufferViews.size(); ++i)
    if (model.bufferViews[i].extensions.count(kMeshoptExtension))
      if (Result<void> ok = decodeMeshoptView(model, i, fallbackIndices); !ok) return ok;
  return {};
}

Result<void> decodeDraco(tinygltf::Model& model, const std::vector<DracoIndices>& dracoIndices, uint64_t maxTriangles) {
#if VSL_HAVE_DRACO
  for (const DracoIndices& d : dracoIndices)  // restore what tinygltf could not parse
    if (size_t(d.mesh) < model.meshes.size() && size_t(d.primitive) < model.meshes[d.mesh].primitives.size())
      model.meshes[d.mesh].primitives[d.primitive].indices = d.accessor;
  int bufferIndex = -1;  // created on the first decoded primitive
  for (size_t m = 0; m < model.meshes.size(); ++m)
    for (size_t p = 0; p < model.meshes[m].primitives.size(); ++p) {
      tinygltf::Primitive& prim = model.meshes[m].primitives[p];
      if (!prim.extensions.count(kDracoExtension)) continue;
      const std::string where = "mesh " + std::to_string(m) + " primitive " + std::to_string(p) + " " + kDracoExtension;
      if (Result<void> ok = decodeDracoPrimitive(model, prim, bufferIndex, maxTriangles, where); !ok) return ok;
    }
  return {};
#else
  // Without Draco a file that only uses the extension falls back to the
  // primitives' plain accessors (one that requires it is refused earlier).
  (void)model;
  (void)dracoIndices;
  (void)maxTriangles;
  return {};
#endif
}

}  // namespace vsl
