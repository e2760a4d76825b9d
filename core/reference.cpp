#include "core/reference.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <vector>

#include "core/compare.h"
#include "core/image_io.h"
#include "core/stopwatch.h"

namespace vsl {

namespace {

double noiseOf(const Image& a, const Image& b) {
  if (a.rgb.empty() || b.rgb.empty() || a.width != b.width || a.height != b.height) return -1;
  return compareImages(a, b).average.relMse / 4;
}

// 64-bit FNV-1a.
struct Fnv {
  uint64_t h = 0xcbf29ce484222325ull;
  void bytes(const void* data, size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
  }
  template <typename T>
  void vec(const std::vector<T>& v) {
    uint64_t n = v.size();
    bytes(&n, sizeof n);
    if (!v.empty()) bytes(v.data(), v.size() * sizeof(T));
  }
  void str(const std::string& s) { vec(std::vector<char>(s.begin(), s.end())); }
  void f(float x) { bytes(&x, sizeof x); }
  void v3(const Vec3& v) {
    f(v.x);
    f(v.y);
    f(v.z);
  }
};

// A file name made safe for a cache key: letters, digits, '-', '_' and '.'.
std::string safeName(const std::string& path) {
  std::string base = std::filesystem::path(path).stem().string(), out;
  for (char c : base) out += (std::isalnum((unsigned char)c) || c == '-' || c == '_') ? c : '_';
  return out.empty() ? "scene" : out.substr(0, 48);
}

const Layer* layerNamed(const std::vector<Layer>& layers, const std::string& name) {
  for (const Layer& l : layers)
    if (l.name == name) return &l;
  return nullptr;
}

}  // namespace

double Reference::indirectNoise() const { return hasHalves() ? noiseOf(indirectA, indirectB) : -1; }
double Reference::fullNoise() const { return noiseOf(fullA, fullB); }

// ---- Rendering ------------------------------------------------------------------------

const char* referenceMethodName(ReferenceMethod m) { return m == ReferenceMethod::Bdpt ? "bdpt" : "pt"; }

ReferenceRenderer::ReferenceRenderer(const Scene& scene, const Accel& accel, const LightSampler& lights,
                                     const RenderSettings& settings, ReferenceMethod method)
    : pt_(scene, accel, lights, settings) {
  if (method == ReferenceMethod::Bdpt) bdpt_ = std::make_unique<BdptRenderer>(scene, accel, lights, settings);
  for (int h = 0; h < 2; ++h) {
    direct_[h] = Film(pt_.width(), pt_.height());
    indirect_[h] = Film(pt_.width(), pt_.height());
  }
}

// Renders passes nextPass_ .. nextPass_ + count - 1 (count <= 2, so each
// half gets at most one) into the scratch copies of their halves, then swaps
// them in; on a stop the halves are untouched.
bool ReferenceRenderer::renderPasses(int count, const std::atomic<bool>* stop) {
  Stopwatch clock;
  const int first = nextPass_;
  nextPass_ += count;  // whatever happens, these indices are used
  for (int p = first; p < first + count; ++p) {
    const int h = p % 2;
    scratchDirect_[h] = direct_[h];  // copy-assignment reuses the scratch's storage
    scratchIndirect_[h] = indirect_[h];
    const bool done = bdpt_ ? bdpt_->renderPass(p, scratchDirect_[h], scratchIndirect_[h], counters_, stop)
                            : pt_.renderPass(p, scratchDirect_[h], scratchIndirect_[h], counters_, stop);
    if (!done) return false;
  }
  for (int p = first; p < first + count; ++p) {
    direct_[p % 2].swap(scratchDirect_[p % 2]);
    indirect_[p % 2].swap(scratchIndirect_[p % 2]);
  }
  passes_ += count;
  seconds_ += clock.seconds();
  return true;
}

bool ReferenceRenderer::step(const std::atomic<bool>* stop) { return renderPasses(2, stop); }

bool ReferenceRenderer::stepPass(const std::atomic<bool>* stop) { return renderPasses(1, stop); }

double ReferenceRenderer::indirectNoise() const {
  if (passes_ < 2) return -1;
  return noiseOf(indirect_[0].image(), indirect_[1].image());
}

uint64_t ReferenceRenderer::rejected() const {
  return counters_.nonFinite + direct_[0].rejected() + direct_[1].rejected() + indirect_[0].rejected() +
         indirect_[1].rejected();
}

Reference ReferenceRenderer::result() const {
  Reference r;
  r.width = width();
  r.height = height();
  r.directA = direct_[0].image();
  r.directB = direct_[1].image();
  r.indirectA = indirect_[0].image();
  r.indirectB = indirect_[1].image();
  r.fullA = sum(r.directA, r.indirectA);
  r.fullB = sum(r.directB, r.indirectB);
  r.direct = average(r.directA, r.directB);
  r.indirect = average(r.indirectA, r.indirectB);
  r.full = average(r.fullA, r.fullB);
  r.spp = spp();
  r.seconds = seconds_;
  r.method = referenceMethodName(method());
  return r;
}

// ---- Keys and the cache ---------------------------------------------------------------

std::string referenceKey(const Scene& scene, int width, int height, int maxDepth, const EnvironmentSettings& env,
                         ReferenceMethod method) {
  Fnv h;
  auto fileBytes = [&h](const std::string& path) {
    if (std::ifstream in(path, std::ios::binary); in) {
      std::vector<char> buf(1 << 16);
      while (in.read(buf.data(), std::streamsize(buf.size())) || in.gcount() > 0)
        h.bytes(buf.data(), size_t(in.gcount()));
    }
  };
  // The scene file's bytes (materials, lights and cameras live there) ...
  fileBytes(scene.path);
  // ... the environment light, if any ...
  if (env.any()) {
    h.str(env.describe());
    if (env.hasMap()) fileBytes(env.map);
  }
  // ... and what it loaded from other files (buffers, images).
  h.vec(scene.positions);
  h.vec(scene.normals);
  h.vec(scene.uvs);
  h.vec(scene.indices);
  h.vec(scene.triMaterial);
  for (const Texture& t : scene.textures) h.vec(t.rgba);
  const Camera& c = scene.camera;
  h.str(c.name);
  h.v3(c.position);
  h.v3(c.forward);
  h.v3(c.up);
  h.f(c.yfov);
  char key[160];
  std::snprintf(key, sizeof key, "%s-%016llx-%dx%d-d%d%s", safeName(scene.path).c_str(), (unsigned long long)h.h, width,
                height, maxDepth, method == ReferenceMethod::Bdpt ? "-bdpt" : "");
  return key;
}

std::string referenceCacheDir() {
  if (const char* d = std::getenv("VSL_REFERENCE_CACHE"); d && *d) return d;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return std::string(x) + "/vsl-studio/references";
  if (const char* home = std::getenv("HOME"); home && *home) return std::string(home) + "/.cache/vsl-studio/references";
  return ".vsl-cache/references";
}

namespace {

// The scene hash of a key "NAME-HASH-WxH-dD" or "NAME-HASH-WxH-dD-bdpt"
// (NAME may hold '-'); "" when the key has no such form.
std::string keySceneHash(std::string key) {
  if (key.size() > 5 && key.compare(key.size() - 5, 5, "-bdpt") == 0) key.resize(key.size() - 5);
  size_t depth = key.rfind('-');
  if (depth == std::string::npos || depth == 0) return {};
  size_t size = key.rfind('-', depth - 1);
  if (size == std::string::npos || size == 0) return {};
  size_t hash = key.rfind('-', size - 1);
  if (hash == std::string::npos) return {};
  return key.substr(hash + 1, size - hash - 1);
}

}  // namespace

Result<void> checkReferenceScene(const Reference& ref, const Scene& scene, const std::string& path,
                                 const EnvironmentSettings& env) {
  if (ref.key.empty()) return {};
  const std::string want = referenceKey(scene, ref.width, ref.height, RenderSettings().maxDepth, env);
  if (keySceneHash(ref.key) == keySceneHash(want)) return {};
  return Error(path + ": rendered from another scene or camera than " + scene.path + " (its key " + ref.key +
               ", this scene's " + want + "); render one of this scene with `vsl reference " + scene.path + "`");
}

std::string referenceCachePath(const std::string& key) { return referenceCacheDir() + "/" + key + ".exr"; }

// ---- Files ----------------------------------------------------------------------------

Result<void> writeReference(const std::string& path, const Reference& ref, const std::string& scenePath, bool half) {
  std::vector<Layer> layers = {{"", ref.full}, {"full", ref.full}, {"direct", ref.direct}, {"indirect", ref.indirect}};
  if (ref.hasHalves()) {
    layers.insert(layers.end(), {{"A.full", ref.fullA},
                                 {"A.direct", ref.directA},
                                 {"A.indirect", ref.indirectA},
                                 {"B.full", ref.fullB},
                                 {"B.direct", ref.directB},
                                 {"B.indirect", ref.indirectB}});
  }
  char noise[64];
  std::snprintf(noise, sizeof noise, "%.6g", ref.indirectNoise());
  std::map<std::string, std::string> attrs = {{"vsl.version", VSL_VERSION},
                                              {"vsl.scene", scenePath},
                                              {"vsl.method", ref.method},
                                              {"vsl.reference.spp", std::to_string(ref.spp)},
                                              {"vsl.reference.seconds", std::to_string(ref.seconds)},
                                              {"vsl.reference.key", ref.key},
                                              {"vsl.reference.indirectNoise", noise}};
  return writeExr(path, layers, attrs, half);
}

namespace {

// The layer a reference is compared on: indirectLayer, else (for the default
// "indirect" only) a full image, as other renderers write one: the layer
// "full", else the file's unnamed one. Null when neither exists.
const Layer* comparedLayer(const std::vector<Layer>& layers, const std::string& indirectLayer, bool* fullOnly) {
  *fullOnly = false;
  if (const Layer* l = layerNamed(layers, indirectLayer)) return l;
  if (indirectLayer != "indirect") return nullptr;
  *fullOnly = true;
  if (const Layer* l = layerNamed(layers, "full")) return l;
  return layerNamed(layers, "");
}

// The halves A.* and B.* of the layers, when every one has the size of I.
void readHalves(const std::vector<Layer>& layers, const Image& I, Reference& r) {
  const char* names[6] = {"A.full", "A.direct", "A.indirect", "B.full", "B.direct", "B.indirect"};
  Image* into[6] = {&r.fullA, &r.directA, &r.indirectA, &r.fullB, &r.directB, &r.indirectB};
  const Layer* halves[6];
  for (int k = 0; k < 6; ++k) {
    halves[k] = layerNamed(layers, names[k]);
    if (!halves[k] || halves[k]->image.width != I.width || halves[k]->image.height != I.height) return;
  }
  for (int k = 0; k < 6; ++k) *into[k] = halves[k]->image;
}

}  // namespace

Result<Reference> readReference(const std::string& path, int width, int height, const std::string& indirectLayer) {
  std::map<std::string, std::string> attrs;
  Result<std::vector<Layer>> read = readExr(path, &attrs);
  if (!read) return Error(read.error());
  const std::vector<Layer>& layers = *read;
  bool fullOnly = false;
  const Layer* ind = comparedLayer(layers, indirectLayer, &fullOnly);
  if (!ind) {
    std::string have;
    for (const Layer& l : layers) have += (have.empty() ? "" : ", ") + (l.name.empty() ? "(default)" : l.name);
    return Error(path + ": no '" + indirectLayer + "' layer (it has: " + have +
                 "); name the layer that holds the component to compare, or render one with `vsl reference`");
  }
  const Image& I = ind->image;
  const std::string layerName = ind->name.empty() ? "(default)" : ind->name;
  if ((width > 0 && I.width != width) || (height > 0 && I.height != height)) {
    return Error(path + ": " + std::to_string(I.width) + "x" + std::to_string(I.height) + ", but the render is " +
                 std::to_string(width) + "x" + std::to_string(height));
  }
  // Every method is measured against it: one NaN would turn a metric into NaN
  // or drop the pixel from it, and an all-NaN reference would score zero error.
  size_t nonFinite = 0;
  for (float v : I.rgb) nonFinite += !std::isfinite(v);
  if (nonFinite > 0)
    return Error(path + ": " + std::to_string(nonFinite) + " of " + std::to_string(I.rgb.size()) + " values of the '" +
                 layerName + "' layer are not finite numbers; a reference must be finite everywhere");
  Reference r;
  r.width = I.width;
  r.height = I.height;
  r.source = path;
  auto sameSize = [&](const Layer* l) { return l && l->image.width == I.width && l->image.height == I.height; };
  if (fullOnly) {
    // Another renderer's full image: the component compared is the full one
    // (Reference::fullOnly), and only the full halves can measure its noise.
    r.full = I;
    const Layer* a = layerNamed(layers, "A.full");
    const Layer* b = layerNamed(layers, "B.full");
    if (sameSize(a) && sameSize(b)) {
      r.fullA = a->image;
      r.fullB = b->image;
    }
  } else {
    r.indirect = I;
    const Layer* d = layerNamed(layers, "direct");
    const Layer* f = layerNamed(layers, "full");
    if (sameSize(d)) r.direct = d->image;
    if (sameSize(f))
      r.full = f->image;
    else if (!r.direct.rgb.empty())
      r.full = sum(r.direct, r.indirect);
    if (indirectLayer == "indirect") readHalves(layers, I, r);
  }
  if (auto it = attrs.find("vsl.reference.spp"); it != attrs.end()) r.spp = std::atoi(it->second.c_str());
  if (auto it = attrs.find("vsl.reference.seconds"); it != attrs.end()) r.seconds = std::atof(it->second.c_str());
  if (auto it = attrs.find("vsl.reference.key"); it != attrs.end()) r.key = it->second;
  if (auto it = attrs.find("vsl.method"); it != attrs.end()) r.method = it->second;
  return r;
}

std::string shippedReferenceDir() {
  if (const char* d = std::getenv("VSL_SHIPPED_REFERENCES")) return d;
  return VSL_SHIPPED_REFERENCES_DIR;
}

namespace {
std::unique_ptr<Reference> readCandidate(const std::string& path, const std::string& key, int width, int height) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return nullptr;
  Result<Reference> read = readReference(path, width, height);
  if (!read) return nullptr;
  auto r = std::make_unique<Reference>(std::move(read).value());
  r->key = key;
  r->source = path;
  return r;
}
}  // namespace

std::unique_ptr<Reference> findCachedReference(const std::string& key, int width, int height) {
  std::unique_ptr<Reference> cached = readCandidate(referenceCachePath(key), key, width, height);
  const std::string shippedDir = shippedReferenceDir();
  std::unique_ptr<Reference> shipped =
      shippedDir.empty() ? nullptr : readCandidate(shippedDir + "/" + key + ".exr", key, width, height);
  if (shipped && (!cached || shipped->spp > cached->spp)) return shipped;
  return cached;
}

std::unique_ptr<Reference> findCachedReferenceAnyMethod(const Scene& scene, int width, int height, int maxDepth,
                                                        const EnvironmentSettings& env, ReferenceMethod preferred) {
  const ReferenceMethod other =
      preferred == ReferenceMethod::Bdpt ? ReferenceMethod::PathTracer : ReferenceMethod::Bdpt;
  std::unique_ptr<Reference> mine =
      findCachedReference(referenceKey(scene, width, height, maxDepth, env, preferred), width, height);
  std::unique_ptr<Reference> theirs =
      findCachedReference(referenceKey(scene, width, height, maxDepth, env, other), width, height);
  if (!mine || !theirs) return mine ? std::move(mine) : std::move(theirs);
  const double a = mine->comparedNoise(), b = theirs->comparedNoise();
  return (b >= 0 && (a < 0 || b < a)) ? std::move(theirs) : std::move(mine);
}

Result<std::string> storeCachedReference(const Reference& ref, const std::string& scenePath, bool half) {
  if (ref.key.empty()) return Error("reference cache: the reference has no key");
  if (auto existing = findCachedReference(ref.key, ref.width, ref.height); existing && existing->spp >= ref.spp)
    return std::string();
  std::string dir = referenceCacheDir();
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Error(dir + ": cannot create the reference cache (" + ec.message() + ")");
  std::string path = referenceCachePath(ref.key);
  if (Result<void> w = writeReference(path, ref, scenePath, half); !w) return Error(w.error());
  return path;
}

}  // namespace vsl
