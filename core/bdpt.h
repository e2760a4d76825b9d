// Bidirectional path tracing with multiple importance sampling.
//
// Method: Veach, "Robust Monte Carlo Methods for Light Transport
// Simulation", PhD thesis, Stanford 1997, chapter 10 (every strategy (s, t):
// s vertices of a light subpath joined to t vertices of a camera subpath),
// with the per-vertex density bookkeeping of pbrt-v3 (Pharr, Jakob and
// Humphreys, 3rd ed., section 16.3): each vertex keeps the area density of
// being generated from its own side (pdfFwd) and from the other side
// (pdfRev), and a strategy's MIS weight walks the joined path, recomputing
// only the four densities the connection changes.
// Strategies: s = 0 (a camera subpath reaching an emitter), s = 1 (the
// emitter sampled afresh from the camera vertex, as next-event estimation),
// t = 1 (a light subpath vertex joined to the pinhole camera and splatted to
// the pixel it lands in), and every other (s, t).
// Parameters: maxDepth (64) and rrDepth (3) as the path tracer
// (RenderSettings), seed; the heuristic (power, or balance).
// The environment light (core/environment.h) is a light at infinity, as in
// pbrt-v3 (section 16.3.1): a camera subpath that leaves the scene ends in an
// escaped vertex on it (strategy s = 0); its light subpaths start on the disk
// of the bounding sphere like a directional light's beam. An infinite
// vertex's own density is the solid-angle pdf of its direction
// (LightSampler::pdfEnvironment), the density of the vertex it lights is
// per area across the beam (1 / (pi R^2) times the cosine there), and a
// direction sampled toward it is not converted to area. It cannot be joined
// to the pinhole (s = 1, t = 1).
// Known bias: none up to maxDepth scattering events, the path tracer's
// truncation. Punctual lights seen directly by the camera (s = 1, t = 1) are
// left out, as the path tracer cannot see them either (zero area).
// Components: as the path tracer's (core/pathtracer.h): "direct" = paths of
// at most one scattering event (s + t <= 3), "indirect" the rest.
// Determinism: sample k of pixel p draws both subpaths from
// Rng::forItem(p, k, kBdptStream, seed); light-traced splats are summed per
// tile and then in tile order, so the image depends only on the settings.
// Memory: two subpaths of at most maxDepth + 2 vertices per worker thread.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "core/accel.h"
#include "core/film.h"
#include "core/lights.h"
#include "core/material.h"
#include "core/pathtracer.h"
#include "core/rng.h"
#include "core/settings.h"

namespace vsl {

enum class MisHeuristic { Balance, Power };

// One vertex of a subpath. Densities are with respect to area at the
// vertex (for the vertex after a directional light: area on the plane
// perpendicular to the beam, i.e. the beam's density times the cosine).
struct BdptVertex {
  enum class Kind : uint8_t { Camera, Light, Surface };
  Kind kind = Kind::Surface;
  Vec3 p;
  // Surface: geometric normal on the side the subpath arrived from. Area
  // light: the emitting side's normal. Zero for the camera and punctual lights.
  Vec3 ng;
  Vec3 beta;  // subpath throughput up to and including this vertex
  double pdfFwd = 0, pdfRev = 0;
  SurfaceHit hit;    // Surface only
  BrdfAt f;          // Surface only: the BRDF with w() toward the previous vertex (local)
  size_t light = 0;  // Light only: the light's index in sampler order
  // Light only: the environment, at infinity; ng is then the direction its
  // light travels (toward the scene).
  bool infinite = false;
};

// Settings of a BdptRenderer beyond RenderSettings. onlyS/onlyT (>= 0)
// restrict it to one strategy; unweighted drops the MIS weights (each
// strategy alone is then an unbiased estimate of its own path space): tests.
struct BdptOptions {
  MisHeuristic heuristic = MisHeuristic::Power;
  int onlyS = -1, onlyT = -1;
  bool unweighted = false;
};

class BdptRenderer {
 public:
  static constexpr uint64_t kBdptStream = 0xbd;

  BdptRenderer(const Scene& scene, const Accel& accel, const LightSampler& lights, const RenderSettings& settings,
               const BdptOptions& options = {});

  int width() const { return width_; }
  int height() const { return height_; }

  // Adds one sample per pixel (sample index `pass`): one camera subpath and
  // one light subpath per pixel, every strategy between them; the light
  // subpaths' camera connections are splatted where they land. Films of
  // width() x height() (VSL_CHECK). Returns false if *stop became true
  // (checked between tiles); the films should then be discarded.
  bool renderPass(int pass, Film& direct, Film& indirect, PtCounters& counters,
                  const std::atomic<bool>* stop = nullptr) const;

  // ---- Pieces, public for the tests ----
  // The subpaths of sample k of pixel (x, y): their vertex counts.
  int cameraSubpath(int x, int y, Rng& rng, BdptVertex* path, uint64_t& rays) const;
  int lightSubpath(Rng& rng, BdptVertex* path, uint64_t& rays) const;
  // The MIS weight of strategy (s, t) for the path joining light[0..s-1]
  // (for s = 1: *sampled, the light sampled from camera[t-1]) and
  // camera[t-1..0]. The subpaths' own densities must be set as
  // cameraSubpath/lightSubpath set them.
  double misWeight(const BdptVertex* light, int s, const BdptVertex* camera, int t,
                   const BdptVertex* sampled = nullptr) const;
  // Area density at `to` of the direction vertex v samples, v having come
  // from `prev` (ignored for the camera and lights, which start subpaths).
  double density(const BdptVertex& v, const BdptVertex* prev, const BdptVertex& to) const;
  // pL(x0): the density of choosing light vertex v's position (area measure;
  // the pmf alone for punctual lights). v may be a surface on an emitter.
  double originDensity(const BdptVertex& v) const;
  // Max vertices of a camera subpath (maxDepth + 2) and a light one (maxDepth + 1).
  int maxCameraVertices() const { return settings_.maxDepth + 2; }
  int maxLightVertices() const { return settings_.maxDepth + 1; }

 private:
  struct Splat {
    uint32_t pixel;
    bool direct;
    Vec3 value;
  };
  struct Work;  // per-tile scratch: subpaths, splats

  void samplePixel(int x, int y, int pass, Work& w, Vec3& Ld, Vec3& Lind) const;
  int walk(Ray ray, Vec3 beta, bool fromLight, Rng& rng, BdptVertex* path, int count, int maxCount,
           uint64_t& rays) const;
  // Strategies of one camera vertex count t against the light subpath.
  void connectAll(const BdptVertex* light, int nL, const BdptVertex* camera, int t, Work& w, Vec3& Ld,
                  Vec3& Lind) const;
  Vec3 connectEmitterHit(const BdptVertex* camera, int t) const;
  Vec3 connectSampledLight(const BdptVertex& c, Rng& rng, BdptVertex& sampled, uint64_t& rays) const;
  Vec3 connectCamera(const BdptVertex& q, bool origin, float& px, float& py, uint64_t& rays) const;
  Vec3 connectInner(const BdptVertex& q, const BdptVertex& c, uint64_t& rays) const;
  // f cos at a subpath's surface vertex toward w (world): the camera side's
  // f |cos_s|, the light side's with the adjoint shading-normal correction
  // (Veach 1997, section 5.3).
  Vec3 scatter(const BdptVertex& v, const Vec3& w, bool lightSide) const;
  double emissionDensity(const BdptVertex& v, const BdptVertex& to) const;
  bool isEnvironment(size_t light) const {
    return lights_.environment() != nullptr && light + 1 == lights_.lightCount();
  }
  bool isPunctual(size_t light) const { return light >= lights_.emissiveTriangleCount() && !isEnvironment(light); }
  // The escaped vertex ending a camera subpath that left the scene along ray.
  void escape(const Ray& ray, const Vec3& beta, BdptVertex* path, int count) const;
  const PunctualLight& punctual(size_t light) const {
    return scene_.punctualLights[light - lights_.emissiveTriangleCount()];
  }
  // The pinhole camera: raster position of a direction, importance and pdf.
  bool raster(const Vec3& w, float& px, float& py) const;
  double cameraPdfDir(const Vec3& w) const;

  const Scene& scene_;
  const Accel& accel_;
  const LightSampler& lights_;
  RenderSettings settings_;
  BdptOptions options_;
  int width_, height_;
  float tanHalf_, aspect_, filmArea_;  // the image plane at distance 1
  float sceneRadius_;
};

}  // namespace vsl
