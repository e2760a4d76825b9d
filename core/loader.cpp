// The glTF 2.0 loader (core/loader.h): tinygltf parses, and everything here
// checks and flattens. Sections:
//   [1] accessor reading with bounds checks
//   [2] materials, textures and extensions
//   [3] the Loader: node traversal, meshes, cameras, lights
//   [4] files: the scene file, and URIs only inside the scene's folder
//   [5] JSON checks before tinygltf: nesting depth, value types
//   [6] whole-scene checks: instanced size, emitted power
//   [7] loadScene()
#include "core/loader.h"

#include <fcntl.h>
#include <stb_image.h>
#include <sys/stat.h>
#include <tiny_gltf.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string_view>
#include <utility>

#include "core/mesh_compression.h"
#include "core/scene.h"
#include "core/tangents.h"

namespace vsl {

namespace {

// Thrown inside the loader only; loadScene() turns it into an Error.
struct LoadError {
  std::string message;
};

// What the JSON says that tinygltf's model cannot: tinygltf stores 0 both
// for an absent aspectRatio or zfar and for an explicit 0 (which is invalid).
struct JsonFacts {
  struct Camera {
    bool aspectRatio = false, zfar = false;  // given in the file
  };
  std::vector<Camera> cameras;  // by glTF camera index

  Camera camera(int index) const { return index >= 0 && size_t(index) < cameras.size() ? cameras[index] : Camera{}; }
};

std::string formatNumber(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Error text quotes at most this much of a URI: a data: URI can be megabytes.
constexpr size_t kMaxQuotedUri = 60;

std::string abbreviated(const std::string& s) {
  return s.size() <= kMaxQuotedUri ? s : s.substr(0, kMaxQuotedUri) + "...";
}

// text with every data: URI in it cut to its first kMaxQuotedUri characters
// (tinygltf quotes whole a data: URI that does not decode).
std::string withDataUrisAbbreviated(const std::string& text) {
  std::string out;
  size_t i = 0;
  while (i < text.size()) {
    size_t at = text.find("data:", i);
    if (at == std::string::npos) {
      out.append(text, i, std::string::npos);
      break;
    }
    size_t end = text.find_first_of(" \t\r\n'\"", at);
    if (end == std::string::npos) end = text.size();
    out.append(text, i, at - i);
    out += abbreviated(text.substr(at, end - at));
    i = end;
  }
  return out;
}

// A JSON number that is an index into a glTF array (tinygltf keeps indices
// in an int: larger values would wrap around).
bool isIndexNumber(double v) { return v >= 0 && v <= double(INT32_MAX) && v == std::floor(v); }

std::string quoted(const std::string& kind, int index, const std::string& name) {
  std::ostringstream s;
  s << kind << " " << index;
  if (!name.empty()) s << " '" << name << "'";
  return s.str();
}

// ---- [1] Accessors -------------------------------------------------------------

int componentCount(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR:
      return 1;
    case TINYGLTF_TYPE_VEC2:
      return 2;
    case TINYGLTF_TYPE_VEC3:
      return 3;
    case TINYGLTF_TYPE_VEC4:
      return 4;
    case TINYGLTF_TYPE_MAT2:
      return 4;
    case TINYGLTF_TYPE_MAT3:
      return 9;
    case TINYGLTF_TYPE_MAT4:
      return 16;
  }
  return 0;
}

int componentSize(int ct) {
  switch (ct) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return 2;
    case TINYGLTF_COMPONENT_TYPE_INT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return 4;
    case TINYGLTF_COMPONENT_TYPE_DOUBLE:
      return 8;
  }
  return 0;
}

const char* typeName(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR:
      return "SCALAR";
    case TINYGLTF_TYPE_VEC2:
      return "VEC2";
    case TINYGLTF_TYPE_VEC3:
      return "VEC3";
    case TINYGLTF_TYPE_VEC4:
      return "VEC4";
    case TINYGLTF_TYPE_MAT2:
      return "MAT2";
    case TINYGLTF_TYPE_MAT3:
      return "MAT3";
    case TINYGLTF_TYPE_MAT4:
      return "MAT4";
  }
  return "unknown type";
}

const char* componentTypeName(int ct) {
  switch (ct) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
      return "BYTE";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return "UNSIGNED_BYTE";
    case TINYGLTF_COMPONENT_TYPE_SHORT:
      return "SHORT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return "UNSIGNED_SHORT";
    case TINYGLTF_COMPONENT_TYPE_INT:
      return "INT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
      return "UNSIGNED_INT";
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return "FLOAT";
    case TINYGLTF_COMPONENT_TYPE_DOUBLE:
      return "DOUBLE";
  }
  return "unknown componentType";
}

// What the loader reads from an accessor, and the formats (componentType,
// normalized) glTF 2.0 allows for it. KHR_mesh_quantization, which allows
// integer positions, normals, tangents and texture coordinates, is not
// supported: such data would be misread, so it is refused.
struct Semantic {
  const char* name;  // "POSITION", "indices"
  int type;          // TINYGLTF_TYPE_*
  std::vector<std::pair<int, bool>> formats;
  bool quantizable;  // KHR_mesh_quantization would allow more
};

const Semantic kPosition{"POSITION", TINYGLTF_TYPE_VEC3, {{TINYGLTF_COMPONENT_TYPE_FLOAT, false}}, true};
const Semantic kNormal{"NORMAL", TINYGLTF_TYPE_VEC3, {{TINYGLTF_COMPONENT_TYPE_FLOAT, false}}, true};
const Semantic kTangent{"TANGENT", TINYGLTF_TYPE_VEC4, {{TINYGLTF_COMPONENT_TYPE_FLOAT, false}}, true};
const Semantic kTexCoord0{"TEXCOORD_0",
                          TINYGLTF_TYPE_VEC2,
                          {{TINYGLTF_COMPONENT_TYPE_FLOAT, false},
                           {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, true},
                           {TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, true}},
                          true};
const Semantic kTexCoord1{"TEXCOORD_1", kTexCoord0.type, kTexCoord0.formats, true};
const Semantic kIndices{"indices",
                        TINYGLTF_TYPE_SCALAR,
                        {{TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, false},
                         {TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, false},
                         {TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, false}},
                        false};

std::string formatName(int type, int componentType, bool normalized) {
  return std::string(typeName(type)) + " " + componentTypeName(componentType) + (normalized ? " normalized" : "");
}

// Throws unless the accessor's format is one glTF 2.0 allows for sem.
void checkFormat(const tinygltf::Accessor& acc, const Semantic& sem, const std::string& where) {
  if (acc.type == sem.type)
    for (auto [ct, normalized] : sem.formats)
      if (acc.componentType == ct && acc.normalized == normalized) return;
  std::string allowed;
  for (auto [ct, normalized] : sem.formats)
    allowed += (allowed.empty() ? "" : ", ") + formatName(sem.type, ct, normalized);
  throw LoadError{where + ": " + formatName(acc.type, acc.componentType, acc.normalized) +
                  " is not a glTF 2.0 format for " + sem.name + " (allowed: " + allowed +
                  (sem.quantizable ? "; KHR_mesh_quantization is not supported)" : ")")};
}

// One component at p, of a glTF componentType; normalized integers map to
// [0,1] (unsigned) or [-1,1] (signed), per the specification.
double readComponent(const unsigned char* p, int componentType, bool normalized) {
  double v = 0;
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      int8_t x;
      std::memcpy(&x, p, 1);
      v = normalized ? std::max(x / 127.0, -1.0) : x;
      break;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
      uint8_t x;
      std::memcpy(&x, p, 1);
      v = normalized ? x / 255.0 : x;
      break;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      int16_t x;
      std::memcpy(&x, p, 2);
      v = normalized ? std::max(x / 32767.0, -1.0) : x;
      break;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t x;
      std::memcpy(&x, p, 2);
      v = normalized ? x / 65535.0 : x;
      break;
    }
    case TINYGLTF_COMPONENT_TYPE_INT: {
      int32_t x;
      std::memcpy(&x, p, 4);
      v = x;
      break;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
      uint32_t x;
      std::memcpy(&x, p, 4);
      v = x;
      break;
    }
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
      float x;
      std::memcpy(&x, p, 4);
      v = x;
      break;
    }
    case TINYGLTF_COMPONENT_TYPE_DOUBLE: {
      double x;
      std::memcpy(&x, p, 8);
      v = x;
      break;
    }
  }
  return v;
}

// Reads an accessor of a format glTF 2.0 allows for sem as doubles, count x
// components, with every offset checked against its buffer view and buffer
// (in an order that cannot overflow: offsets may be near 2^64).
// zeroBudget bounds accessors without a bufferView (all zeros): a file must
// hold at least one byte per element it declares, so a 220-byte file cannot
// make us zero-fill 100 GB.
std::vector<double> readAccessor(const tinygltf::Model& model, int index, const std::string& what, const Semantic& sem,
                                 size_t* countOut, uint64_t zeroBudget) {
  if (index < 0 || size_t(index) >= model.accessors.size())
    throw LoadError{what + ": accessor " + std::to_string(index) + " does not exist"};
  const tinygltf::Accessor& acc = model.accessors[index];
  std::string where = what + " (accessor " + std::to_string(index) + ")";
  int nc = componentCount(acc.type), cs = componentSize(acc.componentType);
  if (nc == 0 || cs == 0) throw LoadError{where + ": unknown type or componentType"};
  checkFormat(acc, sem, where);
  if (acc.sparse.isSparse) throw LoadError{where + ": sparse accessors are not supported"};
  size_t count = acc.count;
  *countOut = count;
  std::vector<double> out;
  if (count == 0) return out;
  if (acc.bufferView < 0) {  // all zeros, per the specification
    if (count > zeroBudget)
      throw LoadError{where + ": count " + std::to_string(count) +
                      " without a bufferView (all zeros) is more than this file of " + std::to_string(zeroBudget) +
                      " bytes can describe"};
    out.assign(count * nc, 0.0);
    return out;
  }
  if (size_t(acc.bufferView) >= model.bufferViews.size())
    throw LoadError{where + ": bufferView " + std::to_string(acc.bufferView) + " does not exist"};
  const tinygltf::BufferView& bv = model.bufferViews[acc.bufferView];
  if (bv.buffer < 0 || size_t(bv.buffer) >= model.buffers.size())
    throw LoadError{where + ": buffer " + std::to_string(bv.buffer) + " does not exist"};
  const tinygltf::Buffer& buf = model.buffers[bv.buffer];
  uint64_t elem = uint64_t(nc) * cs;
  uint64_t stride = bv.byteStride ? bv.byteStride : elem;
  if (stride < elem) throw LoadError{where + ": byteStride smaller than the element size"};
  if (bv.byteOffset > buf.data.size() || bv.byteLength > buf.data.size() - bv.byteOffset)
    throw LoadError{where + ": bufferView " + std::to_string(acc.bufferView) + " runs past the end of buffer " +
                    std::to_string(bv.buffer) + " (" + std::to_string(buf.data.size()) + " bytes)"};
  if (count > (uint64_t(1) << 32)) throw LoadError{where + ": count " + std::to_string(count) + " is absurd"};
  if (acc.byteOffset > bv.byteLength)
    throw LoadError{where + ": byteOffset " + std::to_string(acc.byteOffset) + " lies past the end of bufferView " +
                    std::to_string(acc.bufferView) + " (" + std::to_string(bv.byteLength) + " bytes)"};
  // No overflow: byteOffset <= byteLength < 2^32, stride <= 252, count <= 2^32.
  uint64_t need = uint64_t(acc.byteOffset) + stride * (count - 1) + elem;
  if (need > bv.byteLength)
    throw LoadError{where + ": needs " + std::to_string(need) + " bytes but its bufferView has " +
                    std::to_string(bv.byteLength)};
  const unsigned char* base = buf.data.data() + bv.byteOffset + acc.byteOffset;
  out.resize(count * nc);
  for (size_t i = 0; i < count; ++i) {
    const unsigned char* e = base + i * stride;
    for (int c = 0; c < nc; ++c) out[i * nc + c] = readComponent(e + c * cs, acc.componentType, acc.normalized);
  }
  return out;
}

// ---- [2] Materials and textures -------------------------------------------------

double numberOr(const tinygltf::Value& obj, const char* key, double fallback, const std::string& where) {
  if (!obj.IsObject() || !obj.Has(key)) return fallback;
  const tinygltf::Value& v = obj.Get(key);
  if (!v.IsNumber()) throw LoadError{where + ": '" + key + "' must be a number"};
  return v.GetNumberAsDouble();
}

int textureIndexOf(const tinygltf::Value& obj, const char* key, const std::string& where) {
  if (!obj.IsObject() || !obj.Has(key)) return -1;
  const tinygltf::Value& t = obj.Get(key);
  if (!t.IsObject() || !t.Has("index") || !t.Get("index").IsNumber() ||
      !isIndexNumber(t.Get("index").GetNumberAsDouble()))
    throw LoadError{where + ": '" + key + "' must be an object with an integer 'index' in [0, 2147483647]"};
  return int(t.Get("index").GetNumberAsDouble());
}

void checkRange(double v, double lo, double hi, const std::string& where, const char* what) {
  if (!(v >= lo && v <= hi)) {
    std::ostringstream s;
    s << where << ": " << what << " must be in [" << lo << "," << hi << "] (got " << v << ")";
    throw LoadError{s.str()};
  }
}

// Coordinates the ray tracer can take: Embree asserts on ray origins beyond
// about 1.8e18, and squared distances must stay finite in float. 1e9 m keeps
// every product of two coordinates far inside float range.
constexpr double kMaxWorldCoordinate = 1e9;
// Entries of an accumulated node transform (translation or scale).
constexpr double kMaxTransformEntry = 1e12;
// Hierarchy limits: real files nest a few dozen levels.
constexpr size_t kMaxNodeDepth = 1024;
constexpr size_t kMaxNodeVisits = 1'000'000;

std::string formatPoint(double x, double y, double z) {
  std::ostringstream s;
  s << "(" << x << " " << y << " " << z << ")";
  return s.str();
}

// Whether the ray tracer can take a world-space point.
bool worldPointOk(const double p[3]) {
  return std::abs(p[0]) <= kMaxWorldCoordinate && std::abs(p[1]) <= kMaxWorldCoordinate &&
         std::abs(p[2]) <= kMaxWorldCoordinate;
}

// Throws unless a world-space point is one the ray tracer can take (the
// message is built only on failure: this runs for every vertex).
void checkWorldPoint(const double p[3], const std::string& what) {
  if (worldPointOk(p)) return;
  std::ostringstream s;
  s << what << " lies at " << formatPoint(p[0], p[1], p[2]) << " in world space, outside +-" << kMaxWorldCoordinate
    << " (the ray tracer cannot represent it)";
  throw LoadError{s.str()};
}

// xf applied to a point, in double (no float overflow before the range check).
void transformPoint(const Mat4& xf, double x, double y, double z, double out[3]) {
  for (int r = 0; r < 3; ++r) out[r] = xf.at(r, 0) * x + xf.at(r, 1) * y + xf.at(r, 2) * z + xf.at(r, 3);
}

// A direction from the file made unit length in double; zero when it has none.
Vec3 unitOrZero(double x, double y, double z) {
  double len = std::sqrt(x * x + y * y + z * z);
  if (!(len > 0) || !std::isfinite(len)) return Vec3(0.0f);
  return Vec3(float(x / len), float(y / len), float(z / len));
}

// Two numbers under key in a KHR_texture_transform object, finite in float.
Vec2 transformPair(const tinygltf::Value& ext, const char* key, Vec2 fallback, const std::string& where) {
  if (!ext.Has(key)) return fallback;
  const tinygltf::Value& a = ext.Get(key);
  Vec2 v;
  bool ok = a.IsArray() && a.ArrayLen() == 2 && a.Get(0).IsNumber() && a.Get(1).IsNumber();
  if (ok) v = {float(a.Get(0).GetNumberAsDouble()), float(a.Get(1).GetNumberAsDouble())};
  if (!ok || !std::isfinite(v.x) || !std::isfinite(v.y))
    throw LoadError{where + ": '" + key + "' must be an array of 2 finite numbers"};
  return v;
}

// A texCoord value (a set index) as an int; -1 when absent.
int texCoordOf(const tinygltf::Value& obj, const std::string& where) {
  if (!obj.IsObject() || !obj.Has("texCoord")) return -1;
  const tinygltf::Value& v = obj.Get("texCoord");
  if (!v.IsNumber() || !isIndexNumber(v.GetNumberAsDouble()))
    throw LoadError{where + ": 'texCoord' must be an integer in [0, 2147483647]"};
  return int(v.GetNumberAsDouble());
}

struct Loader {
  const tinygltf::Model& model;
  Scene& scene;
  std::string file;
  std::vector<int> textureSlot;  // glTF texture index -> Scene::textures index
  std::set<std::string> warned;
  uint64_t inputBytes = 0;  // the file and its buffers: bounds zero-filled accessors
  uint64_t texels = 0;      // texels of all textures so far
  uint64_t maxTexels = LoadOptions{}.maxTexels;
  size_t maxTriangles = LoadOptions{}.maxTriangles;
  JsonFacts facts{};  // what tinygltf's model does not say

  void warn(const std::string& m) {
    if (warned.insert(m).second) scene.warnings.push_back(m);
  }

  int texture(int gltfIndex, const std::string& where) {
    if (gltfIndex < 0) return -1;
    if (size_t(gltfIndex) >= model.textures.size())
      throw LoadError{where + ": texture " + std::to_string(gltfIndex) + " does not exist"};
    if (textureSlot[gltfIndex] >= 0) return textureSlot[gltfIndex];
    const tinygltf::Texture& t = model.textures[gltfIndex];
    if (t.source < 0 || size_t(t.source) >= model.images.size())
      throw LoadError{where + ": texture " + std::to_string(gltfIndex) + " has no valid image source"};
    const tinygltf::Image& img = model.images[t.source];
    if (img.width <= 0 || img.height <= 0 || img.component < 1 || img.component > 4 ||
        (img.bits != 8 && img.bits != 16) ||
        img.image.size() < size_t(img.width) * img.height * img.component * (img.bits / 8))
      throw LoadError{where + ": image " + std::to_string(t.source) + " could not be decoded"};
    if (!t.extensions.empty())
      for (auto& [k, v] : t.extensions)
        warn(quoted("texture", gltfIndex, t.name) + ": extension " + k + " is not supported (ignored)");
    // Every texture is expanded to float RGBA (16 bytes a texel), also when
    // many textures share one image: bound the total before allocating.
    texels += uint64_t(img.width) * uint64_t(img.height);
    if (texels > maxTexels)
      throw LoadError{where + ": textures would hold more than " + std::to_string(maxTexels) +
                      " texels in total (16 bytes each as float RGBA)"};
    Texture tex;
    tex.name = img.name.empty() ? img.uri : img.name;
    tex.width = img.width;
    tex.height = img.height;
    tex.rgba.assign(size_t(img.width) * img.height * 4, 1.0f);
    size_t n = size_t(img.width) * img.height;
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < img.component; ++c) {
        float v;
        if (img.bits == 8) {
          v = img.image[i * img.component + c] / 255.0f;
        } else {
          uint16_t x;
          std::memcpy(&x, &img.image[(i * img.component + c) * 2], 2);
          v = x / 65535.0f;
        }
        // Grey images replicate into RGB.
        if (img.component <= 2 && c == 0)
          tex.rgba[i * 4] = tex.rgba[i * 4 + 1] = tex.rgba[i * 4 + 2] = v;
        else if (img.component == 2 && c == 1)
          tex.rgba[i * 4 + 3] = v;
        else
          tex.rgba[i * 4 + c] = v;
      }
    textureSlot[gltfIndex] = int(scene.textures.size());
    scene.textures.push_back(std::move(tex));
    return textureSlot[gltfIndex];
  }

  // A texture slot's UV set and KHR_texture_transform (ext: the extension's
  // object, or null): the extension's texCoord overrides the textureInfo's.
  // Sets beyond TEXCOORD_1 are not read: TEXCOORD_0 is used, with a warning.
  TextureTransform slotTransform(int texCoord, const tinygltf::Value* ext, const std::string& where,
                                 const std::string& slot) {
    Vec2 offset{0, 0}, scale{1, 1};
    float rotation = 0;
    if (ext) {
      std::string ew = where + " " + slot + " KHR_texture_transform";
      if (!ext->IsObject()) throw LoadError{ew + ": must be an object"};
      offset = transformPair(*ext, "offset", offset, ew);
      scale = transformPair(*ext, "scale", scale, ew);
      rotation = float(numberOr(*ext, "rotation", 0.0, ew));
      if (!std::isfinite(rotation)) throw LoadError{ew + ": 'rotation' must be finite"};
      if (int t = texCoordOf(*ext, ew); t >= 0) texCoord = t;
    }
    if (texCoord > 1) {
      warn(where + ": " + slot + " uses TEXCOORD_" + std::to_string(texCoord) +
           "; only TEXCOORD_0 and TEXCOORD_1 are read (TEXCOORD_0 used)");
      texCoord = 0;
    }
    return TextureTransform::make(offset, rotation, scale, texCoord);
  }

  // slotTransform for a textureInfo; warns about its other extensions.
  TextureTransform textureInfo(const tinygltf::TextureInfo& ti, const std::string& where, const char* slot) {
    if (ti.index < 0) return {};
    const tinygltf::Value* ext = nullptr;
    for (auto& [k, v] : ti.extensions) {
      if (k == "KHR_texture_transform")
        ext = &v;
      else
        warn(where + ": " + slot + " extension " + k + " is not supported (ignored)");
    }
    return slotTransform(ti.texCoord, ext, where, slot);
  }

  // slotTransform for a textureInfo inside an extension's JSON (key in obj).
  TextureTransform textureInfo(const tinygltf::Value& obj, const char* key, const std::string& where) {
    if (!obj.IsObject() || !obj.Has(key)) return {};
    const tinygltf::Value& ti = obj.Get(key);
    const tinygltf::Value* ext = nullptr;
    if (ti.Has("extensions") && ti.Get("extensions").IsObject())
      for (const std::string& k : ti.Get("extensions").Keys()) {
        if (k == "KHR_texture_transform")
          ext = &ti.Get("extensions").Get(k);
        else
          warn(where + ": " + key + " extension " + k + " is not supported (ignored)");
      }
    return slotTransform(std::max(0, texCoordOf(ti, where + " " + key)), ext, where, key);
  }

  // alphaMode, alphaCutoff and baseColorFactor's alpha (glTF 2.0, 3.9.4).
  void alphaOf(const tinygltf::Material& gm, const std::string& where, Material& m) {
    m.alpha = float(gm.pbrMetallicRoughness.baseColorFactor[3]);
    if (gm.alphaMode == "MASK")
      m.alphaMode = AlphaMode::Mask;
    else if (gm.alphaMode == "BLEND")
      m.alphaMode = AlphaMode::Blend;
    else if (gm.alphaMode != "OPAQUE" && !gm.alphaMode.empty())
      throw LoadError{where + ": alphaMode must be OPAQUE, MASK or BLEND (got '" + abbreviated(gm.alphaMode) + "')"};
    checkRange(gm.alphaCutoff, 0, std::numeric_limits<double>::max(), where, "alphaCutoff");
    m.alphaCutoff = float(gm.alphaCutoff);
  }

  Material material(int index) {
    const tinygltf::Material& gm = model.materials[index];
    std::string where = file + ": " + quoted("material", index, gm.name);
    Material m;
    m.name = gm.name.empty() ? "material " + std::to_string(index) : gm.name;
    const auto& pbr = gm.pbrMetallicRoughness;
    if (pbr.baseColorFactor.size() != 4) throw LoadError{where + ": baseColorFactor must have 4 components"};
    for (int c = 0; c < 4; ++c) checkRange(pbr.baseColorFactor[c], 0, 1, where, "baseColorFactor");
    m.baseColor = Vec3(float(pbr.baseColorFactor[0]), float(pbr.baseColorFactor[1]), float(pbr.baseColorFactor[2]));
    checkRange(pbr.metallicFactor, 0, 1, where, "metallicFactor");
    checkRange(pbr.roughnessFactor, 0, 1, where, "roughnessFactor");
    m.metallic = float(pbr.metallicFactor);
    m.roughness = float(pbr.roughnessFactor);
    m.doubleSided = gm.doubleSided;
    m.baseColorTexture = texture(pbr.baseColorTexture.index, where + " baseColorTexture");
    m.metallicRoughnessTexture = texture(pbr.metallicRoughnessTexture.index, where + " metallicRoughnessTexture");
    m.emissiveTexture = texture(gm.emissiveTexture.index, where + " emissiveTexture");
    m.baseColorTransform = textureInfo(pbr.baseColorTexture, where, "baseColorTexture");
    m.metallicRoughnessTransform = textureInfo(pbr.metallicRoughnessTexture, where, "metallicRoughnessTexture");
    m.emissiveTransform = textureInfo(gm.emissiveTexture, where, "emissiveTexture");
    alphaOf(gm, where, m);

    Vec3 emissive(0.0f);
    if (!gm.emissiveFactor.empty()) {
      if (gm.emissiveFactor.size() != 3) throw LoadError{where + ": emissiveFactor must have 3 components"};
      for (int c = 0; c < 3; ++c) checkRange(gm.emissiveFactor[c], 0, 1, where, "emissiveFactor");
      emissive = Vec3(float(gm.emissiveFactor[0]), float(gm.emissiveFactor[1]), float(gm.emissiveFactor[2]));
    }
    float strength = 1;
    for (const auto& [name, ext] : gm.extensions) {
      std::string ew = where + " " + name;
      if (name == "KHR_materials_emissive_strength") {
        strength = float(numberOr(ext, "emissiveStrength", 1.0, ew));
        checkRange(strength, 0, 1e9, ew, "emissiveStrength");
      } else if (name == "KHR_materials_anisotropy") {
        m.anisotropyStrength = float(numberOr(ext, "anisotropyStrength", 0.0, ew));
        checkRange(m.anisotropyStrength, 0, 1, ew, "anisotropyStrength");
        m.anisotropyRotation = float(numberOr(ext, "anisotropyRotation", 0.0, ew));
        if (!std::isfinite(m.anisotropyRotation)) throw LoadError{ew + ": anisotropyRotation must be finite"};
        m.anisotropyTexture = texture(textureIndexOf(ext, "anisotropyTexture", ew), ew + " anisotropyTexture");
        if (m.anisotropyTexture >= 0) m.anisotropyTransform = textureInfo(ext, "anisotropyTexture", ew);
      } else if (name == "KHR_materials_specular") {
        m.specularWeight = float(numberOr(ext, "specularFactor", 1.0, ew));
        checkRange(m.specularWeight, 0, 1, ew, "specularFactor");
        if (ext.IsObject() &&
            (ext.Has("specularColorFactor") || ext.Has("specularTexture") || ext.Has("specularColorTexture")))
          warn(ew + ": only specularFactor is modelled (specular colour and textures ignored)");
      } else if (name == "KHR_materials_clearcoat") {
        clearcoat(ext, ew, m);
      } else {
        warn(where + ": extension " + name + " is not modelled (ignored)");
      }
    }
    m.emission = emissive * strength;
    normalMap(gm, m, where);
    if (gm.occlusionTexture.index >= 0)
      warn(where + ": occlusionTexture is not used (a path tracer computes occlusion itself)");
    return m;
  }

  // KHR_materials_clearcoat (its README, "Properties"): factors in [0,1],
  // the coat's weight in clearcoatTexture's R channel, its roughness in
  // clearcoatRoughnessTexture's G channel, and its own normal map with a
  // scale, each texture with its UV set and KHR_texture_transform.
  void clearcoat(const tinygltf::Value& ext, const std::string& ew, Material& m) {
    m.clearcoat = float(numberOr(ext, "clearcoatFactor", 0.0, ew));
    checkRange(m.clearcoat, 0, 1, ew, "clearcoatFactor");
    m.clearcoatRoughness = float(numberOr(ext, "clearcoatRoughnessFactor", 0.0, ew));
    checkRange(m.clearcoatRoughness, 0, 1, ew, "clearcoatRoughnessFactor");
    m.clearcoatTexture = texture(textureIndexOf(ext, "clearcoatTexture", ew), ew + " clearcoatTexture");
    if (m.clearcoatTexture >= 0) m.clearcoatTransform = textureInfo(ext, "clearcoatTexture", ew);
    m.clearcoatRoughnessTexture =
        texture(textureIndexOf(ext, "clearcoatRoughnessTexture", ew), ew + " clearcoatRoughnessTexture");
    if (m.clearcoatRoughnessTexture >= 0)
      m.clearcoatRoughnessTransform = textureInfo(ext, "clearcoatRoughnessTexture", ew);
    m.clearcoatNormalTexture =
        texture(textureIndexOf(ext, "clearcoatNormalTexture", ew), ew + " clearcoatNormalTexture");
    if (m.clearcoatNormalTexture < 0) return;
    const std::string nw = ew + " clearcoatNormalTexture";
    const double scale = numberOr(ext.Get("clearcoatNormalTexture"), "scale", 1.0, nw);
    if (!std::isfinite(scale) || std::abs(scale) > 1e6)
      throw LoadError{nw + ": scale must be finite, at most 1e6 in magnitude (got " + formatNumber(scale) + ")"};
    m.clearcoatNormalScale = float(scale);
    m.clearcoatNormalTransform = textureInfo(ext, "clearcoatNormalTexture", ew);
  }

  // The material's normalTexture and its scale (glTF 2.0, 3.9.3). A scale
  // of any finite sign is allowed: negative flips the map's x and y.
  void normalMap(const tinygltf::Material& gm, Material& m, const std::string& where) {
    const tinygltf::NormalTextureInfo& nt = gm.normalTexture;
    if (nt.index < 0) return;
    if (!std::isfinite(nt.scale) || std::abs(nt.scale) > 1e6)
      throw LoadError{where + ": normalTexture scale must be finite, at most 1e6 in magnitude (got " +
                      formatNumber(nt.scale) + ")"};
    m.normalTexture = texture(nt.index, where + " normalTexture");
    m.normalScale = float(nt.scale);
    const tinygltf::Value* ext = nullptr;
    for (auto& [k, v] : nt.extensions) {
      if (k == "KHR_texture_transform")
        ext = &v;
      else
        warn(where + ": normalTexture extension " + k + " is not supported (ignored)");
    }
    m.normalTransform = slotTransform(nt.texCoord, ext, where, "normalTexture");
  }

  // ---- [3] Nodes, meshes, cameras, lights ---------------------------------------

  static Mat4 localTransform(const tinygltf::Node& n, const std::string& where) {
    Mat4 m;
    if (n.matrix.size() == 16) {
      for (int i = 0; i < 16; ++i) m.m[i] = n.matrix[i];
    } else if (!n.matrix.empty()) {
      throw LoadError{where + ": matrix must have 16 numbers"};
    } else {
      Mat4 t, r, s;
      if (n.translation.size() == 3)
        for (int i = 0; i < 3; ++i) t.at(i, 3) = n.translation[i];
      else if (!n.translation.empty())
        throw LoadError{where + ": translation must have 3 numbers"};
      if (n.rotation.size() == 4) {
        double x = n.rotation[0], y = n.rotation[1], z = n.rotation[2], w = n.rotation[3];
        double len = std::sqrt(x * x + y * y + z * z + w * w);
        if (!(len > 0)) throw LoadError{where + ": rotation quaternion has zero length"};
        x /= len;
        y /= len;
        z /= len;
        w /= len;
        r.at(0, 0) = 1 - 2 * (y * y + z * z);
        r.at(0, 1) = 2 * (x * y - z * w);
        r.at(0, 2) = 2 * (x * z + y * w);
        r.at(1, 0) = 2 * (x * y + z * w);
        r.at(1, 1) = 1 - 2 * (x * x + z * z);
        r.at(1, 2) = 2 * (y * z - x * w);
        r.at(2, 0) = 2 * (x * z - y * w);
        r.at(2, 1) = 2 * (y * z + x * w);
        r.at(2, 2) = 1 - 2 * (x * x + y * y);
      } else if (!n.rotation.empty())
        throw LoadError{where + ": rotation must have 4 numbers"};
      if (n.scale.size() == 3)
        for (int i = 0; i < 3; ++i) s.at(i, i) = n.scale[i];
      else if (!n.scale.empty())
        throw LoadError{where + ": scale must have 3 numbers"};
      m = t * r * s;
    }
    for (double v : m.m)
      if (!std::isfinite(v)) throw LoadError{where + ": transform is not finite"};
    return m;
  }

  // A primitive's vertex attributes, as read from the file (object space).
  struct Attributes {
    size_t count = 0;  // vertices
    std::vector<double> pos, nrm, tan, uv, uv1;
    bool hasN = false, hasT = false, hasUV = false, hasUV1 = false;
  };

  // One mesh primitive under world transform xf: its triangles, with their
  // vertices in world space, appended to the scene.
  void primitive(const tinygltf::Mesh& mesh, int meshIndex, int primIndex, const Mat4& xf,
                 const std::string& nodeWhere) {
    const tinygltf::Primitive& prim = mesh.primitives[primIndex];
    std::string where =
        nodeWhere + " " + quoted("mesh", meshIndex, mesh.name) + " primitive " + std::to_string(primIndex);
    int mode = triangleMode(prim, where);
    if (mode < 0) return;
    Attributes at = attributes(prim, where);
    if (at.count == 0) return;
    std::vector<uint32_t> tris = triangulate(mode, indices(prim, at.count, where), at.count, where);
    uint32_t matIndex = primitiveMaterial(prim, at, where);
    bool flip = xf.det3() < 0;  // mirrored transforms reverse the winding
    uint32_t base = appendVertices(at, xf, flip, where);
    // Generate tangents from UV derivatives where the file has none.
    const Material& mat = scene.materials[matIndex];
    if (!at.hasT && at.hasUV && (mat.normalTexture >= 0 || mat.clearcoatNormalTexture >= 0))
      generateMikkTangents(scene.positions, scene.normals, scene.uvs, absoluteIndices(base, tris, flip), base,
                           scene.tangents, scene.tangentSigns);
    else if (!at.hasT && at.hasUV && mat.anisotropyStrength > 0)
      generateTangents(base, tris);
    appendTriangles(base, tris, flip, matIndex, where);
  }

  // The primitive's mode if it holds triangles, or -1 (with a warning) for
  // points and lines; warns about what it carries that is not modelled.
  int triangleMode(const tinygltf::Primitive& prim, const std::string& where) {
    int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE || mode == TINYGLTF_MODE_LINE_LOOP ||
        mode == TINYGLTF_MODE_LINE_STRIP) {
      warn(where + ": points and lines are not modelled (skipped)");
      return -1;
    }
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
      throw LoadError{where + ": unknown primitive mode " + std::to_string(mode)};
    if (!prim.targets.empty()) warn(where + ": morph targets are not modelled (base shape used)");
    for (auto& [k, v] : prim.extensions) warn(where + ": extension " + k + " is not supported (ignored)");
    for (auto& [name, acc] : prim.attributes)
      if (name != "POSITION" && name != "NORMAL" && name != "TANGENT" && name != "TEXCOORD_0" &&
          name.rfind("TEXCOORD_", 0) != 0 && name.rfind("COLOR_", 0) != 0 && name.rfind("JOINTS_", 0) != 0 &&
          name.rfind("WEIGHTS_", 0) != 0 && name.rfind("_", 0) != 0)
        warn(where + ": attribute " + name + " is not used");
    if (prim.attributes.count("COLOR_0")) warn(where + ": vertex colours (COLOR_0) are not modelled (ignored)");
    return mode;
  }

  // POSITION (finite), and NORMAL, TANGENT and TEXCOORD_0 where present, each
  // with POSITION's count. count is 0 for an empty primitive.
  Attributes attributes(const tinygltf::Primitive& prim, const std::string& where) {
    Attributes at;
    auto it = prim.attributes.find("POSITION");
    if (it == prim.attributes.end()) throw LoadError{where + ": has no POSITION attribute"};
    at.pos = readAccessor(model, it->second, where + " POSITION", kPosition, &at.count, inputBytes);
    if (at.count == 0) return at;
    for (size_t i = 0; i < at.pos.size(); ++i)
      if (!std::isfinite(at.pos[i])) throw LoadError{where + ": POSITION[" + std::to_string(i / 3) + "] is not finite"};
    auto optional = [&](const Semantic& sem, std::vector<double>& out) {
      auto a = prim.attributes.find(sem.name);
      if (a == prim.attributes.end()) return false;
      size_t n = 0;
      out = readAccessor(model, a->second, where + " " + sem.name, sem, &n, inputBytes);
      if (n != at.count)
        throw LoadError{where + ": " + sem.name + " has " + std::to_string(n) + " entries but POSITION has " +
                        std::to_string(at.count)};
      return true;
    };
    at.hasN = optional(kNormal, at.nrm);
    at.hasT = optional(kTangent, at.tan);
    at.hasUV = optional(kTexCoord0, at.uv);
    at.hasUV1 = optional(kTexCoord1, at.uv1);
    return at;
  }

  // The primitive's vertex indices (unsigned, each below nv), or 0..nv-1
  // when it has none.
  std::vector<uint32_t> indices(const tinygltf::Primitive& prim, size_t nv, const std::string& where) {
    std::vector<uint32_t> idx;
    if (prim.indices < 0) {
      idx.resize(nv);
      for (size_t i = 0; i < nv; ++i) idx[i] = uint32_t(i);
      return idx;
    }
    size_t ni = 0;
    std::vector<double> raw = readAccessor(model, prim.indices, where + " indices", kIndices, &ni, inputBytes);
    idx.resize(ni);
    for (size_t i = 0; i < ni; ++i) {
      if (raw[i] >= double(nv))
        throw LoadError{where + ": index " + std::to_string(uint64_t(raw[i])) + " at position " + std::to_string(i) +
                        " is out of range (" + std::to_string(nv) + " vertices)"};
      idx[i] = uint32_t(raw[i]);
    }
    return idx;
  }

  // Triangle lists, strips and fans as a list of index triples, after
  // bounding the size of the whole scene.
  std::vector<uint32_t> triangulate(int mode, const std::vector<uint32_t>& idx, size_t nv, const std::string& where) {
    // Bound the whole scene, not only this file's bytes: shared meshes under
    // a DAG of nodes multiply (20 levels of 882 triangles are billions).
    size_t newTris = mode == TINYGLTF_MODE_TRIANGLES ? idx.size() / 3 : idx.size() >= 3 ? idx.size() - 2 : 0;
    if (scene.triangleCount() + newTris > maxTriangles || scene.positions.size() + nv > 3 * maxTriangles)
      throw LoadError{where + ": the scene expands to more than " + std::to_string(maxTriangles) +
                      " triangles (meshes instanced through the node hierarchy multiply); refusing to load it"};
    std::vector<uint32_t> tris;
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      if (idx.size() % 3 != 0) warn(where + ": index count is not a multiple of 3 (trailing indices ignored)");
      tris.assign(idx.begin(), idx.begin() + (idx.size() / 3) * 3);
      return tris;
    }
    for (size_t i = 2; i < idx.size(); ++i) {
      if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
        if (i % 2 == 0)
          tris.insert(tris.end(), {idx[i - 2], idx[i - 1], idx[i]});
        else
          tris.insert(tris.end(), {idx[i - 1], idx[i - 2], idx[i]});
      } else {
        tris.insert(tris.end(), {idx[0], idx[i - 1], idx[i]});
      }
    }
    return tris;
  }

  // The scene material of the primitive (glTF's default material when it
  // names none).
  uint32_t primitiveMaterial(const tinygltf::Primitive& prim, const Attributes& at, const std::string& where) {
    uint32_t matIndex;
    if (prim.material < 0) {
      matIndex = uint32_t(model.materials.size());  // the default material slot
    } else if (size_t(prim.material) >= model.materials.size()) {
      throw LoadError{where + ": material " + std::to_string(prim.material) + " does not exist"};
    } else {
      matIndex = uint32_t(prim.material);
    }
    const Material& mat = scene.materials[matIndex];
    for (const TextureTransform* t :
         {&mat.baseColorTransform, &mat.metallicRoughnessTransform, &mat.emissiveTransform, &mat.anisotropyTransform,
          &mat.clearcoatTransform, &mat.clearcoatRoughnessTransform, &mat.clearcoatNormalTransform})
      if (t->texCoord() == 1 && !at.hasUV1)
        warn(where + ": material '" + mat.name + "' reads TEXCOORD_1, which the primitive lacks (TEXCOORD_0 used)");
    if (mat.anisotropyStrength > 0 && !at.hasT && !at.hasUV)
      warn(where + ": anisotropic material '" + mat.name +
           "' on a mesh with neither TANGENT nor TEXCOORD_0; the anisotropy direction is arbitrary");
    if ((mat.normalTexture >= 0 || mat.clearcoatNormalTexture >= 0) && !at.hasT && !at.hasUV)
      warn(where + ": normal-mapped material '" + mat.name +
           "' on a mesh with neither TANGENT nor TEXCOORD_0; its normal map is not applied");
    return matIndex;
  }

  // Appends the vertices transformed to world space; returns the index of
  // the first.
  uint32_t appendVertices(const Attributes& at, const Mat4& xf, bool flip, const std::string& where) {
    uint32_t base = uint32_t(scene.positions.size());
    for (size_t i = 0; i < at.count; ++i) {
      double world[3];
      transformPoint(xf, at.pos[3 * i], at.pos[3 * i + 1], at.pos[3 * i + 2], world);
      if (!worldPointOk(world)) checkWorldPoint(world, where + ": POSITION[" + std::to_string(i) + "]");
      Vec3 p{float(world[0]), float(world[1]), float(world[2])};
      scene.positions.push_back(p);
      scene.boundsMin = min(scene.boundsMin, p);
      scene.boundsMax = max(scene.boundsMax, p);
      Vec3 n(0.0f);
      if (at.hasN) {
        n = xf.normal(unitOrZero(at.nrm[3 * i], at.nrm[3 * i + 1], at.nrm[3 * i + 2]));
        if (!isFinite(n)) n = Vec3(0.0f);
      }
      scene.normals.push_back(n);
      Vec3 t(0.0f);
      float s = 1;
      if (at.hasT) {
        t = normalize(xf.vector(unitOrZero(at.tan[4 * i], at.tan[4 * i + 1], at.tan[4 * i + 2])));
        if (!isFinite(t)) t = Vec3(0.0f);
        s = at.tan[4 * i + 3] < 0 ? -1.0f : 1.0f;
        if (flip) s = -s;
      }
      scene.tangents.push_back(t);
      scene.tangentSigns.push_back(s);
      scene.uvs.push_back(at.hasUV ? Vec2{float(at.uv[2 * i]), float(at.uv[2 * i + 1])} : Vec2{0, 0});
    }
    appendTexCoord1(at, base);
    return base;
  }

  // The triangles' vertex indices in the scene, wound as appendTriangles
  // will wind them (reversed under a mirroring transform).
  static std::vector<uint32_t> absoluteIndices(uint32_t base, std::vector<uint32_t> tris, bool flip) {
    for (uint32_t& i : tris) i += base;
    if (flip)
      for (size_t k = 0; k + 2 < tris.size(); k += 3) std::swap(tris[k + 1], tris[k + 2]);
    return tris;
  }

  // TEXCOORD_1 (Scene::uvs1), kept only once a primitive has it: then every
  // vertex has one, TEXCOORD_0's where its primitive has no TEXCOORD_1.
  void appendTexCoord1(const Attributes& at, uint32_t base) {
    if (!at.hasUV1 && scene.uvs1.empty()) return;
    if (scene.uvs1.empty()) scene.uvs1.assign(scene.uvs.begin(), scene.uvs.begin() + base);
    for (size_t i = 0; i < at.count; ++i)
      scene.uvs1.push_back(at.hasUV1 ? Vec2{float(at.uv1[2 * i]), float(at.uv1[2 * i + 1])} : scene.uvs[base + i]);
  }

  // Tangents from UV derivatives, summed over the triangles at each vertex
  // from base on, for anisotropic materials on meshes without TANGENT.
  void generateTangents(uint32_t base, const std::vector<uint32_t>& tris) {
    for (size_t k = 0; k + 2 < tris.size(); k += 3) {
      uint32_t a = base + tris[k], b = base + tris[k + 1], c = base + tris[k + 2];
      Vec3 e1 = scene.positions[b] - scene.positions[a], e2 = scene.positions[c] - scene.positions[a];
      float du1 = scene.uvs[b].x - scene.uvs[a].x, dv1 = scene.uvs[b].y - scene.uvs[a].y;
      float du2 = scene.uvs[c].x - scene.uvs[a].x, dv2 = scene.uvs[c].y - scene.uvs[a].y;
      float det = du1 * dv2 - du2 * dv1;
      if (std::abs(det) < 1e-12f) continue;
      Vec3 t = (e1 * dv2 - e2 * dv1) / det;
      for (uint32_t v : {a, b, c}) scene.tangents[v] += t;
    }
    for (uint32_t v = base; v < scene.positions.size(); ++v) {
      Vec3 t = normalize(scene.tangents[v]);
      scene.tangents[v] = isFinite(t) ? t : Vec3(0.0f);
    }
  }

  // Appends the triangles (winding reversed under a mirroring transform),
  // skipping those of zero area with one warning.
  void appendTriangles(uint32_t base, const std::vector<uint32_t>& tris, bool flip, uint32_t matIndex,
                       const std::string& where) {
    size_t degenerate = 0;
    for (size_t k = 0; k + 2 < tris.size(); k += 3) {
      uint32_t a = base + tris[k], b = base + tris[k + 1], c = base + tris[k + 2];
      if (flip) std::swap(b, c);
      Vec3 cr = cross(scene.positions[b] - scene.positions[a], scene.positions[c] - scene.positions[a]);
      if (!(lengthSquared(cr) > 0)) {
        ++degenerate;
        continue;
      }
      scene.indices.insert(scene.indices.end(), {a, b, c});
      scene.triMaterial.push_back(matIndex);
    }
    if (degenerate > 0) warn(where + ": " + std::to_string(degenerate) + " zero-area triangle(s) skipped");
  }

  void light(int lightIndex, const Mat4& xf, const std::string& where) {
    if (lightIndex < 0 || size_t(lightIndex) >= model.lights.size())
      throw LoadError{where + ": KHR_lights_punctual light " + std::to_string(lightIndex) + " does not exist"};
    const tinygltf::Light& gl = model.lights[lightIndex];
    std::string lw = file + ": " + quoted("light", lightIndex, gl.name);
    PunctualLight L;
    L.name = gl.name.empty() ? "light " + std::to_string(lightIndex) : gl.name;
    Vec3 color(1.0f);
    if (!gl.color.empty()) {
      if (gl.color.size() != 3) throw LoadError{lw + ": color must have 3 components"};
      for (int c = 0; c < 3; ++c) checkRange(gl.color[c], 0, 1, lw, "color");
      color = Vec3(float(gl.color[0]), float(gl.color[1]), float(gl.color[2]));
    }
    checkRange(gl.intensity, 0, 1e12, lw, "intensity");
    L.intensity = color * float(gl.intensity);
    double world[3];
    transformPoint(xf, 0, 0, 0, world);
    checkWorldPoint(world, lw + ": position");
    L.position = Vec3(float(world[0]), float(world[1]), float(world[2]));
    L.direction = normalize(xf.vector(Vec3(0, 0, -1)));
    if (gl.range > 0) warn(lw + ": range is not modelled (inverse-square falloff without cut-off)");
    if (gl.type == "point") {
      L.type = PunctualLight::Type::Point;
    } else if (gl.type == "spot") {
      L.type = PunctualLight::Type::Spot;
      double inner = gl.spot.innerConeAngle, outer = gl.spot.outerConeAngle;
      if (!(inner >= 0 && inner < outer && outer <= kPi / 2 + 1e-6))
        throw LoadError{lw + ": spot cone angles must satisfy 0 <= inner < outer <= pi/2 (got " +
                        std::to_string(inner) + ", " + std::to_string(outer) + ")"};
      L.cosInner = float(std::cos(inner));
      L.cosOuter = float(std::cos(outer));
    } else if (gl.type == "directional") {
      L.type = PunctualLight::Type::Directional;  // intensity: lux, the irradiance it gives
    } else {
      throw LoadError{lw + ": unknown light type '" + gl.type + "'"};
    }
    if (!isFinite(L.position) || !isFinite(L.direction)) throw LoadError{lw + ": transform is not finite"};
    if (luminance(L.intensity) > 0) scene.punctualLights.push_back(L);
  }

  void camera(int camIndex, const Mat4& xf, const std::string& where, const std::string& wanted) {
    if (camIndex < 0 || size_t(camIndex) >= model.cameras.size())
      throw LoadError{where + ": camera " + std::to_string(camIndex) + " does not exist"};
    const tinygltf::Camera& gc = model.cameras[camIndex];
    if (scene.cameraFromFile) return;
    if (!wanted.empty() && gc.name != wanted) return;
    std::string cw = file + ": " + quoted("camera", camIndex, gc.name);
    if (gc.type != "perspective") {
      warn(cw + ": " + gc.type + " cameras are not modelled (skipped)");
      return;
    }
    checkRange(gc.perspective.yfov, 1e-4, kPi - 1e-4, cw, "yfov");
    // aspectRatio sets the default image height (512 / aspect): keep both
    // sides of the default image within [16, 16384] (when not given, the
    // image's own aspect is used; an explicit 0 is refused).
    if (facts.camera(camIndex).aspectRatio) checkRange(gc.perspective.aspectRatio, 1.0 / 32, 32, cw, "aspectRatio");
    Camera c;
    c.name = gc.name.empty() ? "camera " + std::to_string(camIndex) : gc.name;
    double world[3];
    transformPoint(xf, 0, 0, 0, world);
    checkWorldPoint(world, cw + ": position");
    c.position = Vec3(float(world[0]), float(world[1]), float(world[2]));
    c.forward = normalize(xf.vector(Vec3(0, 0, -1)));
    c.up = xf.vector(Vec3(0, 1, 0));
    c.right = normalize(cross(c.forward, c.up));
    c.up = cross(c.right, c.forward);
    if (!isFinite(c.position) || !isFinite(c.right) || lengthSquared(c.right) < 0.5f)
      throw LoadError{cw + ": camera transform is degenerate"};
    c.yfov = float(gc.perspective.yfov);
    c.aspect = float(gc.perspective.aspectRatio);
    scene.camera = c;
    scene.cameraFromFile = true;
  }

  // One node's own content: its meshes, camera and lights under world transform xf.
  void nodeContent(int index, const Mat4& xf, const std::string& where, const LoadOptions& opts) {
    const tinygltf::Node& n = model.nodes[index];
    if (n.skin >= 0) warn(where + ": skins are not modelled (rendered in bind pose)");
    if (n.mesh >= 0) {
      if (size_t(n.mesh) >= model.meshes.size())
        throw LoadError{where + ": mesh " + std::to_string(n.mesh) + " does not exist"};
      const tinygltf::Mesh& mesh = model.meshes[n.mesh];
      for (size_t p = 0; p < mesh.primitives.size(); ++p) primitive(mesh, n.mesh, int(p), xf, where);
    }
    if (n.camera >= 0) camera(n.camera, xf, where, opts.cameraName);
    for (auto& [name, ext] : n.extensions) {
      if (name == "KHR_lights_punctual") {
        if (!ext.IsObject() || !ext.Has("light") || !ext.Get("light").IsNumber() ||
            !isIndexNumber(ext.Get("light").GetNumberAsDouble()))
          throw LoadError{where + ": KHR_lights_punctual needs an integer 'light' in [0, 2147483647]"};
        light(int(ext.Get("light").GetNumberAsDouble()), xf, where);
      } else {
        warn(where + ": extension " + name + " is not supported (ignored)");
      }
    }
  }

  // Depth-first walk of the hierarchy below root, with an explicit stack (a
  // deep hierarchy must not overflow the call stack), a depth limit, cycle
  // detection and a bound on node visits (shared subtrees multiply).
  void walk(int root, std::vector<char>& onPath, size_t& visits, const LoadOptions& opts) {
    struct Frame {
      int node;
      Mat4 xf;
      size_t nextChild = 0;
    };
    std::vector<Frame> stack;
    auto enter = [&](int index, const Mat4& parent) {
      if (index < 0 || size_t(index) >= model.nodes.size())
        throw LoadError{file + ": node " + std::to_string(index) + " does not exist"};
      const tinygltf::Node& n = model.nodes[index];
      std::string where = file + ": " + quoted("node", index, n.name);
      if (onPath[index]) throw LoadError{where + ": the node hierarchy is recursive (a node is its own ancestor)"};
      if (stack.size() >= kMaxNodeDepth)
        throw LoadError{where + ": the node hierarchy is deeper than " + std::to_string(kMaxNodeDepth) + " levels"};
      if (++visits > kMaxNodeVisits)
        throw LoadError{file + ": the node hierarchy has more than " + std::to_string(kMaxNodeVisits) +
                        " node instances (shared subtrees multiply)"};
      Mat4 xf = parent * localTransform(n, where);
      for (double v : xf.m)
        if (!(std::abs(v) <= kMaxTransformEntry)) {
          std::ostringstream m;
          m << where << ": its world transform has an entry of " << v << ", outside +-" << kMaxTransformEntry
            << " (content there cannot be ray traced)";
          throw LoadError{m.str()};
        }
      onPath[index] = 1;
      nodeContent(index, xf, where, opts);
      stack.push_back({index, xf});
    };
    enter(root, Mat4());
    while (!stack.empty()) {
      Frame& top = stack.back();
      const std::vector<int>& children = model.nodes[top.node].children;
      if (top.nextChild < children.size()) {
        int child = children[top.nextChild++];
        Mat4 xf = top.xf;  // enter() may reallocate the stack
        enter(child, xf);
      } else {
        onPath[top.node] = 0;
        stack.pop_back();
      }
    }
  }
};

// ---- [4] Files: the scene file, and URIs only inside the scene's folder ---------

constexpr uint64_t kMaxFileBytes = uint64_t(2) << 30;  // tinygltf takes sizes as unsigned int
constexpr uint64_t kMaxTexturePixels = uint64_t(1) << 26;

// A regular file of at most kMaxFileBytes, open for reading. A FIFO, device,
// socket or directory is refused before any read (a FIFO would block,
// /dev/zero never ends). Errors are the bare reason, without the path.
class RegularFile {
 public:
  static Result<RegularFile> open(const std::string& path) {
    RegularFile f(::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY));
    if (f.fd_ < 0) return Error(errno == ENOENT ? "no such file" : std::strerror(errno));
    struct stat st;
    if (::fstat(f.fd_, &st) != 0) return Error(std::strerror(errno));
    if (S_ISDIR(st.st_mode)) return Error("it is a directory");
    if (!S_ISREG(st.st_mode)) return Error("not a regular file (a FIFO, device or socket)");
    if (uint64_t(st.st_size) > kMaxFileBytes) return Error("larger than 2 GiB");
    f.size_ = uint64_t(st.st_size);
    return Result<RegularFile>(std::move(f));
  }
  RegularFile(RegularFile&& o) noexcept : fd_(std::exchange(o.fd_, -1)), size_(o.size_) {}
  RegularFile& operator=(RegularFile&&) = delete;
  ~RegularFile() {
    if (fd_ >= 0) ::close(fd_);
  }
  uint64_t size() const { return size_; }
  // Up to n bytes from offset (fewer where the file ends first: it shrank).
  Result<std::vector<unsigned char>> read(uint64_t offset, uint64_t n) const {
    std::vector<unsigned char> out(static_cast<size_t>(n));
    size_t got = 0;
    while (got < out.size()) {
      ssize_t k = ::pread(fd_, out.data() + got, out.size() - got, off_t(offset + got));
      if (k < 0 && errno == EINTR) continue;
      if (k < 0) return Error(std::strerror(errno));
      if (k == 0) break;
      got += size_t(k);
    }
    out.resize(got);
    return out;
  }

 private:
  explicit RegularFile(int fd) : fd_(fd) {}
  int fd_ = -1;
  uint64_t size_ = 0;
};

// Reads a whole regular file (RegularFile's limits and errors).
Result<std::vector<unsigned char>> readRegularFile(const std::string& path) {
  Result<RegularFile> f = RegularFile::open(path);
  if (!f) return Error(f.error());
  return f->read(0, f->size());
}

// tinygltf's file callbacks. tinygltf tries basedir/uri and then ./uri; we
// accept only the first candidate, so nothing falls back to the current
// directory, and resolve it lexically and through symlinks inside the
// scene's folder. Errors about refused URIs say nothing about the file they
// name (whether it exists, its size).
struct UriPolicy {
  std::filesystem::path root;  // the scene's folder, canonical
  std::string rootPrefix;      // root + "/"
};

std::string uriExpandPath(const std::string& path, void*) { return path; }  // no ~ or $VAR expansion

bool uriFileExists(const std::string& path, void* user) {
  const auto* policy = static_cast<const UriPolicy*>(user);
  return path.rfind(policy->rootPrefix, 0) == 0;
}

bool insideRoot(const std::filesystem::path& p, const std::filesystem::path& root) {
  std::filesystem::path rel = p.lexically_relative(root);
  // The folder itself ("." or "") is not inside it.
  return !rel.empty() && rel != "." && *rel.begin() != ".." && !rel.is_absolute();
}

// A URI (already percent-decoded) as the file it names inside root (the
// scene's folder, canonical), or why it is refused.
Result<std::filesystem::path> resolveUri(const std::filesystem::path& root, const std::string& uri) {
  if (uri.empty()) return Error("empty");
  if (uri[0] == '/' || uri[0] == '\\')
    return Error("absolute paths are refused; URIs are resolved inside the scene's folder only");
  std::filesystem::path candidate = (root / uri).lexically_normal();
  if (candidate.lexically_relative(root) == ".") return Error("names the scene's folder, not a file");
  if (!insideRoot(candidate, root)) return Error("points outside the scene's folder (refused)");
  std::error_code ec;
  std::filesystem::path resolved = std::filesystem::weakly_canonical(candidate, ec);
  if (ec || !insideRoot(resolved, root)) return Error("points outside the scene's folder (refused)");
  return resolved;
}

// The scene's folder, canonical (where its URIs resolve).
std::filesystem::path sceneRoot(const std::string& scenePath) {
  std::error_code ec;
  std::filesystem::path parent = std::filesystem::absolute(scenePath, ec).parent_path();
  std::filesystem::path root = std::filesystem::weakly_canonical(parent, ec);
  return ec ? parent.lexically_normal() : root;
}

bool uriReadFile(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
  const auto* policy = static_cast<const UriPolicy*>(user);
  std::string uri = path.rfind(policy->rootPrefix, 0) == 0 ? path.substr(policy->rootPrefix.size()) : path;
  auto fail = [&](const std::string& why) {
    if (err) *err += "URI '" + abbreviated(uri) + "': " + why + "\n";
    return false;
  };
  Result<std::filesystem::path> resolved = resolveUri(policy->root, uri);
  if (!resolved) return fail(resolved.error());
  Result<std::vector<unsigned char>> bytes = readRegularFile(resolved->string());
  if (!bytes) return fail("cannot be read (" + bytes.error() + ")");
  *out = std::move(bytes).value();
  return true;
}

bool uriWriteFile(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "the loader never writes files\n";
  return false;
}

// Checks the decoded size of an image before tinygltf decodes it.
bool loadImageBounded(tinygltf::Image* image, const int index, std::string* err, std::string* warn, int reqWidth,
                      int reqHeight, const unsigned char* bytes, int size, void*) {
  int w = 0, h = 0, comp = 0;
  if (stbi_info_from_memory(bytes, size, &w, &h, &comp) && uint64_t(w) * uint64_t(h) > kMaxTexturePixels) {
    if (err)
      *err += "image " + std::to_string(index) + ": " + std::to_string(w) + "x" + std::to_string(h) +
              " pixels is more than the texture limit of " + std::to_string(kMaxTexturePixels) + " pixels\n";
    return false;
  }
  return tinygltf::LoadImageData(image, index, err, warn, reqWidth, reqHeight, bytes, size, nullptr);
}

// ---- [5] JSON checks before tinygltf: nesting depth, value types -----------------

constexpr size_t kMaxJsonDepth = 64;

// The JSON text of a .gltf, or the JSON chunk of a .glb (empty if malformed:
// tinygltf then reports the problem).
std::string_view jsonText(const std::vector<unsigned char>& bytes, bool isBinary) {
  const char* p = reinterpret_cast<const char*>(bytes.data());
  if (!isBinary) return {p, bytes.size()};
  if (bytes.size() < 20) return {};
  uint32_t len;
  std::memcpy(&len, p + 12, 4);
  if (uint64_t(len) + 20 > bytes.size()) return {};
  return {p + 20, len};
}

// tinygltf converts JSON to its Value type recursively, one stack frame per
// level of extras/extensions: refuse absurd nesting first. Counts brackets
// outside strings; returns the byte offset where the limit is passed, or npos.
size_t jsonDepthExceeded(std::string_view text, size_t limit) {
  size_t depth = 0;
  bool inString = false;
  for (size_t i = 0; i < text.size(); ++i) {
    char c = text[i];
    if (inString) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        inString = false;
    } else if (c == '"') {
      inString = true;
    } else if (c == '[' || c == '{') {
      if (++depth > limit) return i;
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return std::string_view::npos;
}

// tinygltf silently keeps the default when a known property has the wrong
// type ("roughnessFactor": "0.5"), reads an index of -1 as "absent" and
// 2^32 as 0, and a negative byteOffset as 0. Name such values instead, and
// refuse what is not glTF 2.0. Records in facts what tinygltf loses.
struct JsonChecker {
  using json = nlohmann::json;
  std::string file;
  JsonFacts& facts;

  static std::string got(const json& v) {
    std::string d = v.dump();
    if (d.size() > 40) d = d.substr(0, 37) + "...";
    return d;
  }
  std::string element(const char* kind, size_t i, const json& obj) const {
    std::string name = obj.is_object() && obj.contains("name") && obj["name"].is_string() ? obj["name"] : "";
    return file + ": " + quoted(kind, int(i), name);
  }
  void number(const json& obj, const char* key, const std::string& where) const {
    if (obj.contains(key) && !obj[key].is_number())
      throw LoadError{where + ": '" + key + "' must be a number (got " + got(obj[key]) + ")"};
  }
  void integer(const json& obj, const char* key, const std::string& where) const {
    if (obj.contains(key) && !obj[key].is_number_integer())
      throw LoadError{where + ": '" + key + "' must be an integer (got " + got(obj[key]) + ")"};
  }
  void boolean(const json& obj, const char* key, const std::string& where) const {
    if (obj.contains(key) && !obj[key].is_boolean())
      throw LoadError{where + ": '" + key + "' must be true or false (got " + got(obj[key]) + ")"};
  }
  void numbers(const json& obj, const char* key, size_t n, const std::string& where) const {
    if (!obj.contains(key)) return;
    const json& a = obj[key];
    bool ok = a.is_array() && a.size() == n;
    for (size_t i = 0; ok && i < n; ++i) ok = a[i].is_number();
    if (!ok)
      throw LoadError{where + ": '" + key + "' must be an array of " + std::to_string(n) + " numbers (got " + got(a) +
                      ")"};
  }
  static bool isIndex(const json& v) {
    if (v.is_number_unsigned()) return v.get<uint64_t>() <= uint64_t(INT32_MAX);
    return v.is_number_integer() && v.get<int64_t>() >= 0 && v.get<int64_t>() <= INT32_MAX;
  }
  // An index into one of the file's arrays.
  void index(const json& obj, const char* key, const std::string& where) const {
    if (obj.contains(key) && !isIndex(obj[key]))
      throw LoadError{where + ": '" + key + "' must be an index in [0, 2147483647] (got " + got(obj[key]) + ")"};
  }
  void indices(const json& obj, const char* key, const std::string& where) const {
    if (!obj.contains(key)) return;
    const json& a = obj[key];
    bool ok = a.is_array();
    for (size_t i = 0; ok && i < a.size(); ++i) ok = isIndex(a[i]);
    if (!ok)
      throw LoadError{where + ": '" + key + "' must be an array of indices in [0, 2147483647] (got " + got(a) + ")"};
  }
  void nonNegative(const json& obj, const char* key, const std::string& where) const {
    if (obj.contains(key) && !obj[key].is_number_unsigned() &&
        !(obj[key].is_number_integer() && obj[key].get<int64_t>() >= 0))
      throw LoadError{where + ": '" + key + "' must be an integer >= 0 (got " + got(obj[key]) + ")"};
  }
  const json& object(const json& obj, const char* key, const std::string& where) const {
    static const json empty = json::object();
    if (!obj.contains(key)) return empty;
    if (!obj[key].is_object()) throw LoadError{where + ": '" + key + "' must be an object (got " + got(obj[key]) + ")"};
    return obj[key];
  }
  // Calls f(element, where) for each object in the array doc[key].
  template <typename F>
  void each(const json& doc, const char* key, const char* kind, F f) const {
    if (!doc.contains(key)) return;
    if (!doc[key].is_array()) throw LoadError{file + ": '" + key + "' must be an array (got " + got(doc[key]) + ")"};
    for (size_t i = 0; i < doc[key].size(); ++i) {
      const json& e = doc[key][i];
      std::string where = element(kind, i, e);
      if (!e.is_object()) throw LoadError{where + ": must be an object (got " + got(e) + ")"};
      f(e, where);
    }
  }

  // "major.minor", as the schema's pattern ^[0-9]+\.[0-9]+$ says.
  static bool parseVersion(const json& v, int& major, int& minor) {
    if (!v.is_string()) return false;
    const std::string& t = v.get_ref<const std::string&>();
    size_t dot = t.find('.');
    auto digits = [](const std::string& d) {
      return !d.empty() && d.size() <= 9 && d.find_first_not_of("0123456789") == std::string::npos;
    };
    if (dot == std::string::npos || !digits(t.substr(0, dot)) || !digits(t.substr(dot + 1))) return false;
    major = std::stoi(t.substr(0, dot));
    minor = std::stoi(t.substr(dot + 1));
    return true;
  }

  // glTF 2.0 only: asset.version "2.x" (minor versions are forward
  // compatible) and asset.minVersion at most "2.0". A glTF 1.0 file says
  // "1.0", or has no version and keeps its objects in dictionaries: say so,
  // instead of naming its first dictionary.
  void asset(const json& doc) const {
    const json& a = object(doc, "asset", file);
    int major = 0, minor = 0;
    bool given = a.contains("version"), parsed = given && parseVersion(a["version"], major, minor);
    const char* dictionary = nullptr;
    for (const char* k : {"meshes", "nodes", "accessors", "bufferViews", "buffers", "materials", "scenes"})
      if (!dictionary && doc.contains(k) && doc[k].is_object()) dictionary = k;
    if (major == 1 || (!parsed && dictionary)) {
      std::string why = given ? "asset.version is " + got(a["version"]) : "it has no asset.version";
      if (dictionary) why += std::string(", and '") + dictionary + "' is a dictionary as in glTF 1.0";
      throw LoadError{file + ": glTF 1.0 is not supported; convert it to glTF 2.0 (" + why + ")"};
    }
    if (!given)
      throw LoadError{file + ": asset.version is missing (a glTF 2.0 file has \"asset\": {\"version\": \"2.0\"})"};
    if (!parsed)
      throw LoadError{file + ": asset.version must be \"major.minor\", such as \"2.0\" (got " + got(a["version"]) +
                      ")"};
    if (major != 2)
      throw LoadError{file + ": asset.version is " + got(a["version"]) + "; only glTF 2.0 (version 2.x) is supported"};
    if (a.contains("minVersion")) {
      int minMajor = 0, minMinor = 0;
      if (!parseVersion(a["minVersion"], minMajor, minMinor))
        throw LoadError{file + ": asset.minVersion must be \"major.minor\", such as \"2.0\" (got " +
                        got(a["minVersion"]) + ")"};
      if (minMajor > 2 || (minMajor == 2 && minMinor > 0))
        throw LoadError{file + ": asset.minVersion is " + got(a["minVersion"]) +
                        ": the file needs a loader for a later glTF than 2.0"};
    }
  }

  void check(const json& doc) const {
    if (!doc.is_object()) return;  // tinygltf reports it
    asset(doc);
    index(doc, "scene", file);
    each(doc, "scenes", "scene", [&](const json& sc, const std::string& w) { indices(sc, "nodes", w); });
    each(doc, "materials", "material", [&](const json& m, const std::string& w) {
      const json& pbr = object(m, "pbrMetallicRoughness", w);
      numbers(pbr, "baseColorFactor", 4, w);
      number(pbr, "metallicFactor", w);
      number(pbr, "roughnessFactor", w);
      numbers(m, "emissiveFactor", 3, w);
      number(m, "alphaCutoff", w);
      boolean(m, "doubleSided", w);
    });
    each(doc, "nodes", "node", [&](const json& n, const std::string& w) {
      numbers(n, "translation", 3, w);
      numbers(n, "rotation", 4, w);
      numbers(n, "scale", 3, w);
      numbers(n, "matrix", 16, w);
      for (const char* k : {"mesh", "camera", "skin"}) index(n, k, w);
      indices(n, "children", w);
    });
    each(doc, "cameras", "camera", [&](const json& c, const std::string& w) {
      const json& p = object(c, "perspective", w);
      for (const char* k : {"yfov", "aspectRatio", "znear", "zfar"}) number(p, k, w);
      facts.cameras.push_back({p.contains("aspectRatio"), p.contains("zfar")});
    });
    each(doc, "accessors", "accessor", [&](const json& a, const std::string& w) {
      index(a, "bufferView", w);
      nonNegative(a, "byteOffset", w);
      for (const char* k : {"componentType", "count"}) integer(a, k, w);
      boolean(a, "normalized", w);
    });
    each(doc, "bufferViews", "bufferView", [&](const json& v, const std::string& w) {
      index(v, "buffer", w);
      nonNegative(v, "byteOffset", w);
      for (const char* k : {"byteLength", "byteStride"}) integer(v, k, w);
    });
    each(doc, "textures", "texture", [&](const json& t, const std::string& w) {
      for (const char* k : {"source", "sampler"}) index(t, k, w);
    });
    each(doc, "images", "image", [&](const json& im, const std::string& w) { index(im, "bufferView", w); });
    each(doc, "meshes", "mesh", [&](const json& mesh, const std::string& w) {
      each(mesh, "primitives", "primitive", [&](const json& prim, const std::string& pw) {
        std::string where = w + " " + pw.substr(file.size() + 2);
        for (const char* k : {"indices", "material"}) index(prim, k, where);
        integer(prim, "mode", where);
        for (const auto& [name, acc] : object(prim, "attributes", where).items())
          if (!isIndex(acc))
            throw LoadError{where + ": attribute '" + name + "' must be an index in [0, 2147483647] (got " + got(acc) +
                            ")"};
      });
    });
    lights(doc);
  }

  void lights(const json& doc) const {
    const json& ext = object(doc, "extensions", file);
    const json& punctual = object(ext, "KHR_lights_punctual", file + ": KHR_lights_punctual");
    each(punctual, "lights", "light", [&](const json& l, const std::string& w) {
      number(l, "intensity", w);
      number(l, "range", w);
      numbers(l, "color", 3, w);
      const json& spot = object(l, "spot", w);
      number(spot, "innerConeAngle", w);
      number(spot, "outerConeAngle", w);
    });
  }
};

// ---- [6] Whole-scene checks: instanced size, emitted power -------------------------

// Triangles a mesh declares, from accessor counts alone (0 where invalid:
// the walk reports those).
uint64_t declaredTriangles(const tinygltf::Model& model, int meshIndex) {
  if (meshIndex < 0 || size_t(meshIndex) >= model.meshes.size()) return 0;
  uint64_t n = 0;
  for (const auto& prim : model.meshes[meshIndex].primitives) {
    int acc = prim.indices;
    if (acc < 0) {
      auto it = prim.attributes.find("POSITION");
      acc = it == prim.attributes.end() ? -1 : it->second;
    }
    if (acc < 0 || size_t(acc) >= model.accessors.size()) continue;
    uint64_t count = model.accessors[acc].count;
    int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode == TINYGLTF_MODE_TRIANGLES)
      n += count / 3;
    else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP || mode == TINYGLTF_MODE_TRIANGLE_FAN)
      n += count >= 3 ? count - 2 : 0;
  }
  return n;
}

// Before walking: node instances and triangles of the whole hierarchy,
// counted per node once (post-order over the DAG, saturating), so that a
// small file whose shared subtrees multiply into billions of triangles is
// refused at once instead of after millions of instances. A cycle stops the
// count; the walk then reports it with the node's name.
void checkInstancedSize(const tinygltf::Model& model, const std::vector<int>& roots, const std::string& file,
                        size_t maxTriangles) {
  static constexpr uint64_t kSaturated = uint64_t(1) << 62;
  auto add = [](uint64_t a, uint64_t b) { return std::min(a + b, kSaturated); };
  size_t n = model.nodes.size();
  std::vector<uint64_t> visits(n, 0), tris(n, 0);
  std::vector<char> state(n, 0);  // 0 new, 1 on the stack, 2 done
  std::vector<std::pair<int, size_t>> stack;
  uint64_t totalVisits = 0, totalTris = 0;
  for (int root : roots) {
    if (root < 0 || size_t(root) >= n) return;
    if (state[root] != 2) {
      stack.push_back({root, 0});
      state[root] = 1;
      while (!stack.empty()) {
        auto& [node, next] = stack.back();
        const std::vector<int>& children = model.nodes[node].children;
        if (next < children.size()) {
          int c = children[next++];
          if (c < 0 || size_t(c) >= n || state[c] == 1) return;  // invalid or a cycle: the walk reports it
          if (state[c] == 0) {
            state[c] = 1;
            stack.push_back({c, 0});
          }
          continue;
        }
        uint64_t v = 1, t = declaredTriangles(model, model.nodes[node].mesh);
        for (int c : children) {
          v = add(v, visits[c]);
          t = add(t, tris[c]);
        }
        visits[node] = v;
        tris[node] = t;
        state[node] = 2;
        stack.pop_back();
      }
    }
    totalVisits = add(totalVisits, visits[root]);
    totalTris = add(totalTris, tris[root]);
  }
  auto count = [&](uint64_t v) { return v >= kSaturated ? std::string("more than 4e18") : std::to_string(v); };
  if (totalVisits > kMaxNodeVisits)
    throw LoadError{file + ": the node hierarchy has " + count(totalVisits) + " node instances, more than " +
                    std::to_string(kMaxNodeVisits) + " (shared subtrees multiply)"};
  if (totalTris > maxTriangles)
    throw LoadError{file + ": the scene expands to " + count(totalTris) + " triangles, more than " +
                    std::to_string(maxTriangles) + " (meshes instanced through the node hierarchy multiply)"};
}

// An emitter whose power overflows would be dropped by the light sampler and
// the render would come out black: name it instead.
void checkEmittedPower(const Scene& scene, const std::string& file) {
  for (uint32_t t = 0; t < scene.triangleCount(); ++t) {
    const Material& m = scene.materials[scene.triMaterial[t]];
    if (!m.isEmissive()) continue;
    double power = double(luminance(m.emission)) * scene.triangleArea(t) * kPi * (m.doubleSided ? 2 : 1);
    if (!std::isfinite(power) || !std::isfinite(float(power)))
      throw LoadError{file + ": material '" + m.name +
                      "': emission times triangle area gives infinite power (triangle " + std::to_string(t) + ")"};
  }
  for (const PunctualLight& L : scene.punctualLights)
    if (!std::isfinite(L.power(scene.boundingRadius())))
      throw LoadError{file + ": light '" + L.name + "': power is not finite"};
}

}  // namespace

// ---- [7] loadScene ----------------------------------------------------------------

namespace {

// Whether the glTF JSON lists extension name in extensionsUsed (or in
// extensionsRequired, when required).
bool listsExtension(const nlohmann::json& doc, const char* name, bool required) {
  const char* key = required ? "extensionsRequired" : "extensionsUsed";
  if (!doc.contains(key) || !doc[key].is_array()) return false;
  for (const nlohmann::json& e : doc[key])
    if (e.is_string() && e.get<std::string>() == name) return true;
  return false;
}

// EXT_meshopt_compression before tinygltf parses (core/mesh_compression.h):
// refuses a file that requires it when this build has no decoder; gives
// tinygltf what it can parse in place of what it cannot (fallback buffers
// without data, Draco indices without a bufferView).
TinygltfStubs prepareCompressed(const std::string& path, nlohmann::json& doc, bool isBinary) {
  TinygltfStubs stubs = stubForTinygltf(doc, isBinary);
  if (!meshoptAvailable() && (!stubs.fallbackBuffers.empty() || listsExtension(doc, kMeshoptExtension, true)))
    throw LoadError{path + ": required extension " + kMeshoptExtension +
                    " cannot be decoded: this build has no meshoptimizer; install " + kMeshoptPackage +
                    " (scripts/setup.sh) and rebuild"};
  return stubs;
}

// The scene file's bytes with its JSON replaced by doc's (a .glb keeps its
// binary chunk).
std::vector<unsigned char> withJson(const std::vector<unsigned char>& bytes, bool isBinary, const nlohmann::json& doc) {
  std::string text = doc.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  if (!isBinary) return std::vector<unsigned char>(text.begin(), text.end());
  while (text.size() % 4 != 0) text += ' ';  // GLB chunks are 4-byte aligned
  const size_t oldEnd = 20 + jsonText(bytes, true).size();
  std::vector<unsigned char> out(bytes.begin(), bytes.begin() + 20);
  out.insert(out.end(), text.begin(), text.end());
  out.insert(out.end(), bytes.begin() + std::ptrdiff_t(oldEnd), bytes.end());
  const uint32_t total = uint32_t(out.size()), jsonLength = uint32_t(text.size());
  std::memcpy(out.data() + 8, &total, 4);
  std::memcpy(out.data() + 12, &jsonLength, 4);
  return out;
}

// The file's bytes (isBinary: a .glb), after the JSON checks that tinygltf
// does not make (or makes with unbounded recursion).
std::vector<unsigned char> readSceneFile(const std::string& path, bool& isBinary, JsonFacts& facts,
                                         TinygltfStubs& stubs) {
  Result<std::vector<unsigned char>> read = readRegularFile(path);
  if (!read) throw LoadError{path + ": cannot be read (" + read.error() + ")"};
  std::vector<unsigned char> bytes = std::move(read).value();
  if (bytes.empty()) throw LoadError{path + ": file is empty"};
  isBinary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
  if (isBinary && bytes.size() >= 8) {  // tinygltf ignores the container version
    uint32_t version;
    std::memcpy(&version, bytes.data() + 4, 4);
    if (version == 1)
      throw LoadError{path + ": GLB container version 1 (glTF 1.0 binary) is not supported; convert it to glTF 2.0"};
    if (version != 2)
      throw LoadError{path + ": GLB container version " + std::to_string(version) +
                      " is not supported (glTF 2.0 binary is version 2)"};
  }
  if (!isBinary) {
    // A .gltf file is a JSON object: anything else (an image, a binary file,
    // another format) is named as such rather than failing deep in the parse.
    size_t i = 0;
    if (bytes.size() >= 3 && bytes[0] == 0xef && bytes[1] == 0xbb && bytes[2] == 0xbf) i = 3;  // UTF-8 BOM
    while (i < bytes.size() && (bytes[i] == ' ' || bytes[i] == '\t' || bytes[i] == '\n' || bytes[i] == '\r')) ++i;
    if (i == bytes.size() || bytes[i] != '{') {
      const bool png = bytes.size() >= 4 && std::memcmp(bytes.data(), "\x89PNG", 4) == 0;
      const bool jpeg = bytes.size() >= 3 && bytes[0] == 0xff && bytes[1] == 0xd8 && bytes[2] == 0xff;
      throw LoadError{path + ": not a glTF file: it begins neither with a JSON object (glTF) nor with 'glTF' (GLB)" +
                      std::string(png    ? "; it is a PNG image"
                                  : jpeg ? "; it is a JPEG image"
                                         : "")};
    }
  }
  std::string_view text = jsonText(bytes, isBinary);
  if (size_t at = jsonDepthExceeded(text, kMaxJsonDepth); at != std::string_view::npos)
    throw LoadError{path + ": JSON nests deeper than " + std::to_string(kMaxJsonDepth) + " levels (at byte " +
                    std::to_string(at + (isBinary ? 20 : 0)) + "); refusing to parse it"};
  nlohmann::json doc = nlohmann::json::parse(text.begin(), text.end(), nullptr, false);
  if (doc.is_discarded()) return bytes;
  JsonChecker{path, facts}.check(doc);
  stubs = prepareCompressed(path, doc, isBinary);
  if (!stubs.empty()) bytes = withJson(bytes, isBinary, doc);
  return bytes;
}

// tinygltf's parse, with URIs resolved inside the scene's folder only.
// Returns tinygltf's warnings.
std::string parseGltf(const std::string& path, const std::vector<unsigned char>& bytes, bool isBinary,
                      tinygltf::Model& model) {
  UriPolicy policy;
  policy.root = sceneRoot(path);
  policy.rootPrefix = policy.root.string();
  if (policy.rootPrefix.empty() || policy.rootPrefix.back() != '/') policy.rootPrefix += '/';
  tinygltf::TinyGLTF gltf;
  gltf.SetFsCallbacks({&uriFileExists, &uriExpandPath, &uriReadFile, &uriWriteFile, &policy});
  gltf.SetImageLoader(&loadImageBounded, nullptr);
  std::string err, warn;
  std::string dir = policy.root.string();
  bool ok = isBinary ? gltf.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(), unsigned(bytes.size()), dir)
                     : gltf.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(bytes.data()),
                                                unsigned(bytes.size()), dir);
  if (!ok) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    throw LoadError{path +
                    ": not a valid glTF file: " + (err.empty() ? "unknown parse error" : withDataUrisAbbreviated(err))};
  }
  return withDataUrisAbbreviated(warn);
}

// Refuses required extensions we do not model; warns about used ones,
// animations and skins.
void checkExtensions(const tinygltf::Model& model, Loader& L, const std::string& path) {
  std::set<std::string> kSupported = {
      "KHR_materials_emissive_strength", "KHR_materials_anisotropy", "KHR_materials_specular",
      "KHR_materials_clearcoat",         "KHR_lights_punctual",      "KHR_texture_transform"};
  // Compressed geometry: decoded when the decoder was built in; without it a
  // file that requires the extension is refused with the package to install.
  for (auto [name, available, library, package] :
       {std::tuple{kMeshoptExtension, meshoptAvailable(), "meshoptimizer", kMeshoptPackage},
        std::tuple{kDracoExtension, dracoAvailable(), "Draco", kDracoPackage}}) {
    if (available) {
      kSupported.insert(name);
      continue;
    }
    for (const auto& e : model.extensionsRequired)
      if (e == name)
        throw LoadError{path + ": required extension " + e + " cannot be decoded: this build has no " + library +
                        "; install " + package + " (scripts/setup.sh) and rebuild"};
  }
  // A required extension changes what the file means (Draco-compressed
  // geometry, quantised attributes): loading without it would render
  // something else, so it is refused.
  for (const auto& e : model.extensionsRequired)
    if (!kSupported.count(e))
      throw LoadError{path + ": required extension " + e +
                      " is not supported (supported: EXT_meshopt_compression, KHR_draco_mesh_compression, "
                      "KHR_lights_punctual, KHR_materials_anisotropy, KHR_materials_clearcoat, "
                      "KHR_materials_emissive_strength, KHR_materials_specular, KHR_texture_transform)"};
  for (const auto& e : model.extensionsUsed)
    if (!kSupported.count(e)) L.warn(path + ": extension " + e + " is used but not modelled");
  if (!model.animations.empty())
    L.warn(path + ": " + std::to_string(model.animations.size()) + " animation(s) ignored");
  if (!model.skins.empty()) L.warn(path + ": " + std::to_string(model.skins.size()) + " skin(s) not modelled");
}

// Decodes EXT_meshopt_compression bufferViews and KHR_draco_mesh_compression
// primitives in place (core/mesh_compression.h), before anything reads them.
void decodeCompressedGeometry(tinygltf::Model& model, const TinygltfStubs& stubs, uint64_t inputBytes,
                              const LoadOptions& options, const std::string& path) {
  if (meshoptAvailable())
    if (Result<void> ok = decodeMeshopt(model, stubs.fallbackBuffers, inputBytes); !ok)
      throw LoadError{path + ": " + ok.error()};
  if (Result<void> ok = decodeDraco(model, stubs.dracoIndices, options.maxTriangles); !ok)
    throw LoadError{path + ": " + ok.error()};
}

// The root nodes: the default scene's, or without scenes every node that is
// nobody's child.
std::vector<int> rootNodes(const tinygltf::Model& model, const std::string& path) {
  std::vector<int> roots;
  if (model.scenes.empty() && model.defaultScene >= 0)
    throw LoadError{path + ": default scene " + std::to_string(model.defaultScene) +
                    " does not exist (the file has no scenes)"};
  if (!model.scenes.empty()) {
    int si = model.defaultScene >= 0 ? model.defaultScene : 0;
    if (size_t(si) >= model.scenes.size())
      throw LoadError{path + ": default scene " + std::to_string(si) + " does not exist"};
    return model.scenes[si].nodes;
  }
  std::vector<char> isChild(model.nodes.size(), 0);
  for (const auto& n : model.nodes)
    for (int c : n.children)
      if (c >= 0 && size_t(c) < model.nodes.size()) isChild[c] = 1;
  for (size_t i = 0; i < model.nodes.size(); ++i)
    if (!isChild[i]) roots.push_back(int(i));
  return roots;
}

// Every perspective camera, used or not, against the specification's ranges
// (the camera a render uses also meets the renderer's limits, in
// Loader::camera). yfov >= pi is only a validator warning: not refused here.
void checkPerspectiveCameras(const tinygltf::Model& model, const JsonFacts& facts, const std::string& path) {
  for (size_t i = 0; i < model.cameras.size(); ++i) {
    const tinygltf::Camera& c = model.cameras[i];
    if (c.type != "perspective") continue;
    const tinygltf::PerspectiveCamera& p = c.perspective;
    std::string where = path + ": " + quoted("camera", int(i), c.name);
    auto positive = [&](double v, const char* what) {
      if (!(v > 0)) throw LoadError{where + ": " + what + " must be greater than 0 (got " + formatNumber(v) + ")"};
    };
    positive(p.yfov, "yfov");
    positive(p.znear, "znear");
    if (facts.camera(int(i)).aspectRatio) positive(p.aspectRatio, "aspectRatio");
    if (facts.camera(int(i)).zfar && !(p.zfar > p.znear))
      throw LoadError{where + ": zfar must be greater than znear (got zfar " + formatNumber(p.zfar) + ", znear " +
                      formatNumber(p.znear) + ")"};
  }
}

// After the walk: valid cameras, something to render, finite power, a camera.
void finishScene(Scene& scene, Loader& L, const std::string& path, const LoadOptions& options) {
  checkPerspectiveCameras(L.model, L.facts, path);
  if (scene.triangleCount() == 0) throw LoadError{path + ": the scene has no triangles to render"};
  checkEmittedPower(scene, path);
  bool anyEmitter = !scene.punctualLights.empty();
  for (uint32_t t = 0; t < scene.triangleCount() && !anyEmitter; ++t)
    anyEmitter = scene.materials[scene.triMaterial[t]].isEmissive();
  if (!anyEmitter)
    L.warn(path +
           ": the scene has no emissive triangles and no punctual lights; it renders black "
           "unless an environment light is given (--env, --sky, --sun)");
  if (!options.cameraName.empty() && !scene.cameraFromFile)
    throw LoadError{path + ": no perspective camera named '" + options.cameraName + "'"};
  if (!scene.cameraFromFile) {
    scene.camera = frameBounds(scene.boundsMin, scene.boundsMax);
    L.warn(path + ": no perspective camera; using a default camera that frames the scene");
  }
}

}  // namespace

SceneResult loadScene(const std::string& path, const LoadOptions& options) {
  try {
    bool isBinary = false;
    JsonFacts facts;
    TinygltfStubs stubs;
    std::vector<unsigned char> bytes = readSceneFile(path, isBinary, facts, stubs);
    tinygltf::Model model;
    std::string warn = parseGltf(path, bytes, isBinary, model);

    auto scene = std::make_shared<Scene>();
    scene->path = path;
    Loader L{model, *scene, path, std::vector<int>(model.textures.size(), -1), {}};
    L.inputBytes = bytes.size();
    for (const auto& b : model.buffers) L.inputBytes += b.data.size();
    L.maxTriangles = options.maxTriangles;
    L.maxTexels = options.maxTexels;
    L.facts = std::move(facts);
    bytes = {};
    if (!warn.empty()) {
      std::istringstream ws(warn);
      for (std::string line; std::getline(ws, line);)
        if (!line.empty()) L.warn(path + ": " + line);
    }
    checkExtensions(model, L, path);
    decodeCompressedGeometry(model, stubs, L.inputBytes, options, path);

    for (size_t i = 0; i < model.materials.size(); ++i) scene->materials.push_back(L.material(int(i)));
    // glTF's default material: white, metallic 1, roughness 1.
    Material def;
    def.name = "default";
    scene->materials.push_back(def);

    std::vector<int> roots = rootNodes(model, path);
    checkInstancedSize(model, roots, path, options.maxTriangles);
    std::vector<char> onPath(model.nodes.size(), 0);
    size_t visits = 0;
    for (int r : roots) L.walk(r, onPath, visits, options);

    finishScene(*scene, L, path, options);
    return std::shared_ptr<const Scene>(std::move(scene));
  } catch (const LoadError& e) {
    return Error(e.message);
  } catch (const std::bad_alloc&) {
    return Error(path + ": out of memory while loading (the file declares absurd sizes?)");
  } catch (const std::exception& e) {
    return Error(path + ": " + e.what());
  }
}

namespace {

// tinygltf's decoding of a URI before it looks the file up: '+' is a space,
// %XX a byte (a non-hex digit counts as 0).
std::string decodeUri(const std::string& uri) {
  auto hex = [](unsigned char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return 0;
  };
  std::string out;
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '+') {
      out += ' ';
    } else if (uri[i] == '%' && uri.size() > i + 2) {
      out += char((hex(uri[i + 1]) << 4) | hex(uri[i + 2]));
      i += 2;
    } else {
      out += uri[i];
    }
  }
  return out;
}

}  // namespace

std::vector<std::string> sceneReferencedFiles(const std::string& path) {
  std::vector<std::string> files;
  try {
    // The JSON only: a .glb's header and JSON chunk, not its binary chunk
    // (jsonText's layout).
    Result<RegularFile> file = RegularFile::open(path);
    if (!file) return files;
    auto readAt = [&file](uint64_t offset, uint64_t n) {
      Result<std::vector<unsigned char>> r = file->read(offset, n);
      return r ? std::string(r->begin(), r->end()) : std::string();
    };
    const std::string head = readAt(0, std::min<uint64_t>(file->size(), 20));
    std::string text;
    if (head.size() >= 4 && std::memcmp(head.data(), "glTF", 4) == 0) {
      uint32_t len = 0;
      if (head.size() < 20) return files;
      std::memcpy(&len, head.data() + 12, 4);
      if (len > file->size() - 20) return files;  // a declared length past the file's end
      text = readAt(20, len);
    } else {
      text = readAt(0, file->size());
    }
    if (jsonDepthExceeded(text, kMaxJsonDepth) != std::string::npos) return files;
    const nlohmann::json doc = nlohmann::json::parse(text, nullptr, false);
    if (!doc.is_object()) return files;
    const std::filesystem::path root = sceneRoot(path);
    for (const char* kind : {"buffers", "images"}) {
      if (!doc.contains(kind) || !doc[kind].is_array()) continue;
      for (const nlohmann::json& e : doc[kind]) {
        if (!e.is_object() || !e.contains("uri") || !e["uri"].is_string()) continue;
        const std::string uri = e["uri"];
        if (tinygltf::IsDataURI(uri)) continue;  // what tinygltf decodes instead of reading a file
        if (Result<std::filesystem::path> f = resolveUri(root, decodeUri(uri)); f) files.push_back(f->string());
      }
    }
  } catch (const std::exception&) {
    // An unreadable scene names no files: loading it reports why.
  }
  return files;
}

}  // namespace vsl
