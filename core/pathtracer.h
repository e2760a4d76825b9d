// Reference path tracer.
//
// Method: unidirectional path tracing with next-event estimation (emitters
// chosen in proportion to power, uniform area sampling on triangles, the
// environment by its own importance sampling) and multiple importance
// sampling (power heuristic) against BRDF sampling, for emitters hit and for
// rays that leave the scene into the environment;
// Russian roulette after RenderSettings::rrDepth bounces. Unbiased up to
// maxDepth scattering events.
// Components: "direct" = emission seen by the camera plus light that reached
// an emitter after exactly one scattering event; "indirect" = everything else.
// Parameters: maxDepth (64), rrDepth (3), seed (0). Pixel filter: box.
// Determinism: sample s of pixel p uses Rng::forItem(p, s, 0, seed), so the
// image depends only on the settings, never on threads or timing.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "core/accel.h"
#include "core/film.h"
#include "core/lights.h"
#include "core/settings.h"

namespace vsl {

struct PtCounters {
  std::atomic<uint64_t> paths{0};
  std::atomic<uint64_t> rays{0};       // closest-hit plus shadow rays
  std::atomic<uint64_t> nonFinite{0};  // contributions rejected where they arose
};

class PathTracer {
 public:
  PathTracer(const Scene& scene, const Accel& accel, const LightSampler& lights, const RenderSettings& settings);

  int width() const { return width_; }
  int height() const { return height_; }
  const LightSampler& lightSampler() const { return lights_; }

  // Adds one sample per pixel (sample index `pass`) to the two films, which
  // must have the renderer's width() x height() (VSL_CHECK).
  // Returns false if *stop became true (checked between 16x16 tiles); the
  // pass is then incomplete and the films should be discarded.
  // indirectSquares (optional, width*height entries) accumulates the squared
  // grey value of each indirect sample, for variance estimates.
  bool renderPass(int pass, Film& direct, Film& indirect, PtCounters& counters, const std::atomic<bool>* stop = nullptr,
                  std::vector<double>* indirectSquares = nullptr) const;

  // One path for pixel (x, y), sample index s. Returns direct and indirect
  // radiance (both finite; rejected parts are counted in counters).
  void samplePixel(int x, int y, int s, Vec3& Ld, Vec3& Lind, uint64_t& rays, uint64_t& nonFinite) const;

 private:
  const Scene& scene_;
  const Accel& accel_;
  const LightSampler& lights_;
  RenderSettings settings_;
  int width_, height_;
};

// Resolution for a scene: explicit settings win; else the camera's aspect
// ratio at 512 pixels wide; else 512x512.
void resolveResolution(const Scene& scene, int& width, int& height);

}  // namespace vsl
