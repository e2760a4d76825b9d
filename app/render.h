// `vsl render`, shared between its two halves: app/render.cpp (options,
// validation, loading, the path tracer) and app/render_many_lights.cpp (VSL,
// VPL from one virtual light set, by any registered estimator).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "app/environment_options.h"
#include "app/estimator_options.h"
#include "core/estimator.h"
#include "core/render_context.h"
#include "core/settings.h"

namespace vsl {

struct RenderArgs {
  std::string scene, out, png, jsonPath, camera, component = "full";
  RenderSettings settings;
  ManyLightSettings many;
  EstimatorOptions estimatorOptions;  // --estimator, its parameters, --mrcs
  EnvironmentOptions envOptions;      // --env, --sky, --sun and their numbers
  EnvironmentSettings env;            // resolved from envOptions
  Method method = Method::Pt;         // settings.method, parsed once
  EstimatorSettings estimator;        // resolved from estimatorOptions (its seed stays 0)
  float exposure = 0;
  // The many-light options given on the command line (their long names):
  // with --method pt they would do nothing, so they are refused.
  std::vector<std::string> manyLightOptionsGiven;
};

// The per-channel mean of an image as a JSON array [r, g, b] (for --json).
nlohmann::json imageMeanJson(const Image& img);

// Renders a.method (vsl, vpl or all) into a.out, a.png and a.jsonPath;
// returns the exit code.
int renderManyLights(RenderArgs& a, const RenderContext& ctx);

}  // namespace vsl
