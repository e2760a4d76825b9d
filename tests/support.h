// Helpers shared by the test suites: bundled scenes (alone, or with their
// acceleration structure and light sampler), hand-built geometry, files and
// scratch folders, means with their standard errors, and the path-traced
// indirect reference with its standard error.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "core/accel.h"
#include "core/lights.h"
#include "core/many_light.h"
#include "core/parallel.h"
#include "core/pathtracer.h"
#include "core/render_context.h"

namespace vsl::test {

// A scene with its BVH and light sampler (a RenderContext), and views of the
// three for the tests' calls.
struct Loaded {
  std::unique_ptr<RenderContext> context;
  std::shared_ptr<const Scene> scene;
  const Accel* accel = nullptr;
  const LightSampler* lights = nullptr;
  int width = 0, height = 0;  // the asked width, height from the camera's aspect ratio
};

// `built` as a Loaded (its views set), or an empty one and a test failure.
inline Loaded loadedFrom(Result<std::unique_ptr<RenderContext>> built, int width = 48) {
  Loaded l;
  EXPECT_TRUE(built) << built.error();
  if (!built) return l;
  l.context = std::move(built).value();
  l.scene = l.context->sharedScene();
  l.accel = &l.context->accel();
  l.lights = &l.context->lights();
  l.width = width;
  resolveResolution(*l.scene, l.width, l.height);
  return l;
}

// A hand-built scene with its BVH and light sampler.
inline Loaded loadedFrom(std::shared_ptr<const Scene> scene, int width = 48) {
  return loadedFrom(RenderContext::create(std::move(scene)), width);
}

// ---- Files --------------------------------------------------------------------------

// A file's bytes (empty if it cannot be read).
inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// Writes a glTF file of one grey triangle and no emitter (a scene that loads
// but cannot be rendered: "no emitters").
inline void writeNoEmitterTriangle(const std::string& path) {
  std::ofstream f(path);
  f << R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
    "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
    "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
    "bufferViews":[{"buffer":0,"byteLength":36}],
    "buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]})";
}

// An empty folder NAME under the system's temporary folder (emptied if it exists).
inline std::filesystem::path scratchDir(const std::string& name) {
  std::filesystem::path d = std::filesystem::temp_directory_path() / name;
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

// ---- Statistics -----------------------------------------------------------------------

// The mean of samples added one at a time, and its standard error (the
// samples' population variance over n), in double.
struct MeanAccumulator {
  double sum = 0, sum2 = 0;
  size_t n = 0;
  void add(double v) {
    sum += v;
    sum2 += v * v;
    ++n;
  }
  double mean() const { return n ? sum / double(n) : 0.0; }
  double variance() const { return n ? std::max(sum2 / double(n) - mean() * mean(), 0.0) : 0.0; }
  double standardError() const { return n ? std::sqrt(variance() / double(n)) : 0.0; }
};

// ---- Scenes ---------------------------------------------------------------------------

inline std::string assetPath(const std::string& name) {
  return std::string(VSL_SOURCE_DIR) + "/assets/scenes/" + name + ".gltf";
}

// The scene assets/scenes/NAME.gltf alone; null (and a test failure) if it
// does not load.
inline std::shared_ptr<const Scene> loadAssetScene(const std::string& name) {
  SceneResult r = loadScene(assetPath(name));
  EXPECT_TRUE(r) << r.error();
  return r.valueOr(nullptr);
}

// assets/scenes/NAME.gltf; failures are reported as test failures.
inline Loaded loadAsset(const std::string& name, int width = 48) {
  return loadedFrom(RenderContext::load(assetPath(name)), width);
}

// A material for hand-built test scenes (the other fields keep Material's
// defaults).
inline Material testMaterial(const char* name, Vec3 base, float metallic, float roughness = 1.0f,
                             float specularWeight = 1.0f) {
  Material m;
  m.name = name;
  m.baseColor = base;
  m.metallic = metallic;
  m.roughness = roughness;
  m.specularWeight = specularWeight;
  return m;
}
// A black, non-reflecting emitter of radiance Le.
inline Material emitterMaterial(Vec3 Le) {
  Material m = testMaterial("emitter", Vec3(0.0f), 0, 1, 0);
  m.emission = Le;
  return m;
}

// A quad o, o+eu, o+eu+ev, o+ev (two triangles) facing cross(eu, ev).
inline void addQuad(Scene& s, Vec3 o, Vec3 eu, Vec3 ev, uint32_t material) {
  uint32_t b = uint32_t(s.positions.size());
  for (Vec3 p : {o, o + eu, o + eu + ev, o + ev}) {
    s.positions.push_back(p);
    s.normals.push_back(Vec3(0.0f));
    s.tangents.push_back(Vec3(0.0f));
    s.tangentSigns.push_back(1);
    s.uvs.push_back({0, 0});
    s.boundsMin = min(s.boundsMin, p);
    s.boundsMax = max(s.boundsMax, p);
  }
  s.indices.insert(s.indices.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
  s.triMaterial.insert(s.triMaterial.end(), {material, material});
}

inline double channelMean(const Image& img) {
  double s = 0;
  for (float v : img.rgb) s += v;
  return s / double(img.rgb.size());
}

// The path tracer's indirect image, its grey mean and the standard error of
// that mean (from the per-pixel sample variances).
struct Reference {
  Image indirect;
  double mean = 0, se = 0;
};

inline Reference ptIndirect(const Loaded& l, int w, int h, int spp, uint64_t seed) {
  RenderSettings rs;
  rs.width = w;
  rs.height = h;
  rs.seed = seed;
  PathTracer pt(*l.scene, *l.accel, *l.lights, rs);
  Reference ref;
  ref.indirect = Image(w, h);
  const size_t n = size_t(w) * h;
  std::vector<double> pixelMean(n), pixelVar(n);  // of the grey value's pixel mean
  parallelFor(size_t(h), [&](size_t y) {
    uint64_t rays = 0, nf = 0;
    for (int x = 0; x < w; ++x) {
      double s = 0, s2 = 0;
      Vec3 acc(0.0f);
      for (int k = 0; k < spp; ++k) {
        Vec3 Ld, Li;
        pt.samplePixel(x, int(y), k, Ld, Li, rays, nf);
        double v = (double(Li.x) + Li.y + Li.z) / 3;
        s += v;
        s2 += v * v;
        acc += Li;
      }
      size_t i = y * w + x;
      ref.indirect.set(x, int(y), acc / float(spp));
      pixelMean[i] = s / spp;
      pixelVar[i] = std::max(s2 / spp - pixelMean[i] * pixelMean[i], 0.0) / spp;
    }
  });
  double varSum = 0;
  for (size_t i = 0; i < n; ++i) {
    ref.mean += pixelMean[i] / double(n);
    varSum += pixelVar[i];
  }
  ref.se = std::sqrt(varSum) / double(n);
  return ref;
}

// The z-score of the unclamped VPLs' indirect mean over 12 independent light
// sets (base's lights and direct samples; seeds firstSeed, firstSeed + 1,
// ...; VSL off) against the path tracer's indirect mean ref; prints both
// with the label. Each set renders without a non-finite value.
inline double unclampedVplZ(const Loaded& l, const Reference& ref, ManyLightSettings base, uint64_t firstSeed,
                            const char* label) {
  MeanAccumulator sets;
  for (int k = 0; k < 12; ++k) {
    ManyLightSettings s = base;
    s.width = l.width;
    s.height = l.height;
    s.batches = 1;
    s.seed = firstSeed + uint64_t(k);
    s.computeVsl = false;
    ManyLightRun run = prepareManyLights(*l.scene, *l.accel, *l.lights, s);
    ManyLightRenderer r(*l.scene, *l.accel, *l.lights, run.set, run.radii, s);
    for (int b = 0; b < r.batchCount(); ++b) EXPECT_TRUE(r.renderBatch(b));
    EXPECT_EQ(r.stats().nonFinite.load(), 0u);
    sets.add(channelMean(r.images().vplUnclamped));
  }
  const double se = sets.standardError() * std::sqrt(double(sets.n) / double(sets.n - 1));
  const double z = (sets.mean() - ref.mean) / std::hypot(se, ref.se);
  std::printf("%s, indirect: VPL %.5f +- %.5f, path tracer %.5f +- %.5f (z = %.2f)\n", label, sets.mean(), se, ref.mean,
              ref.se, z);
  return z;
}

}  // namespace vsl::test
