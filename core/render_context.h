// RenderContext: what every renderer of one scene shares, built once. The
// scene, its acceleration structure (BVH) and its light sampler, in the order
// they depend on each other (pbrt-v4's Integrator owns the aggregate and the
// lights; Nori's Scene holds the same three). Every front end (the CLI's
// subcommands, the sweep, the studio's Session) builds one of these instead of
// repeating the load-build-sampler sequence.
//
// Lifetime: the context owns all three; renderers built on it hold references
// into it and must not outlive it. Immutable after creation, so queries from
// any thread are safe; the lobe gather's kept map (lobeGatherMaps) has its own
// lock.
#pragma once

#include <memory>
#include <string>

#include "core/accel.h"
#include "core/environment.h"
#include "core/lights.h"
#include "core/loader.h"
#include "core/lobe_gather.h"
#include "core/result.h"

namespace vsl {

class RenderContext {
 public:
  // Loads the scene file, then builds the BVH and the light sampler (with
  // the environment env describes, if any: core/environment.h). Fails with
  // the loader's message (file, element, valid range), the BVH's, or the
  // environment's ("FILE: reason").
  static Result<std::unique_ptr<RenderContext>> load(const std::string& path, const LoadOptions& options = {},
                                                     const EnvironmentSettings& env = {});
  // Builds the BVH and the light sampler over a scene already loaded (its
  // load time, if known, goes into loadSeconds()).
  static Result<std::unique_ptr<RenderContext>> create(std::shared_ptr<const Scene> scene, double loadSeconds = 0,
                                                       const EnvironmentSettings& env = {});

  RenderContext(const RenderContext&) = delete;
  RenderContext& operator=(const RenderContext&) = delete;

  const Scene& scene() const { return *scene_; }
  const std::shared_ptr<const Scene>& sharedScene() const { return scene_; }
  const Accel& accel() const { return *accel_; }
  const LightSampler& lights() const { return *lights_; }
  // The environment light, or null.
  const Environment* environment() const { return lights_->environment(); }
  // False for a scene with no emissive triangle, no punctual light and no
  // environment: every
  // method renders black, and light tracing has nothing to start from.
  bool hasEmitters() const { return !lights_->empty(); }

  // The lobe gather's map of this scene's last brute-force render, kept for
  // the next (LobeGatherCache).
  LobeGatherCache& lobeGatherMaps() const { return lobeMaps_; }

  // Wall time of parsing the scene file (0 when created from a scene) and
  // of building the BVH, in seconds.
  double loadSeconds() const { return loadSeconds_; }
  double bvhSeconds() const { return bvhSeconds_; }

 private:
  RenderContext() = default;
  std::shared_ptr<const Scene> scene_;
  std::unique_ptr<Accel> accel_;
  std::unique_ptr<LightSampler> lights_;
  mutable LobeGatherCache lobeMaps_;
  double loadSeconds_ = 0, bvhSeconds_ = 0;
};

}  // namespace vsl
