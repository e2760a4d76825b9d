// `vsl render`, shared between its two halves: app/render.cpp (options,
// validation, loading, the path tracer) and app/render_many_lights.cpp (VSL,
// VPL and MRCS from one virtual light set).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/accel.h"
#include "core/many_light.h"
#include "core/mrcs.h"
#include "core/settings.h"

namespace vsl {

struct RenderArgs {
  std::string scene, out, png, jsonPath, camera, component = "full";
  RenderSettings settings;
  ManyLightSettings many;
  std::string clamp = "auto", vslSamples = "auto", mrcsSpec;
  bool mrcsSpread = false;
  MrcsSettings mrcs{0, 0, 0};  // rows 0: no MRCS
  float exposure = 0;
};

// The per-channel mean of an image as a JSON array [r, g, b] (for --json).
nlohmann::json imageMeanJson(const Image& img);

// Renders a.settings.method (vsl, vpl or all) into a.out, a.png and
// a.jsonPath; returns the exit code. loadSeconds: scene loading and BVH.
int renderManyLights(RenderArgs& a, const Scene& scene, const Accel& accel, double loadSeconds);

}  // namespace vsl
