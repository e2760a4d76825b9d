// The environment light's options, shared by `vsl render`, `vsl reference`
// and `vsl-studio` (core/environment.h; docs/REFERENCE.md, "Environment
// light"): --env FILE.exr, --env-scale, --sky R,G,B, --sun X,Y,Z,
// --sun-diameter, --sun-irradiance. The numbers are declared once in
// environmentParams() (core/params.cpp); the file and the two vectors are
// options of their own, as the registry holds numbers only.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdlib>
#include <string>
#include <vector>

#include "app/param_options.h"
#include "core/environment.h"
#include "core/params.h"

namespace vsl {

struct EnvironmentOptions {
  EnvironmentSettings settings;  // the numbers and the map, as parsed
  std::string sky, sun;          // "R,G,B" (or one value), "X,Y,Z"
};

// "1,0.5,0.2" or "0.7" (all three the same) as a Vec3; an error names the
// option and what it takes.
inline Result<Vec3> parseTriple(const std::string& option, const std::string& text, bool allowSingle) {
  std::vector<float> v;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string part = text.substr(start, comma - start);
    char* end = nullptr;
    const float x = std::strtof(part.c_str(), &end);
    if (part.empty() || end != part.c_str() + part.size() || !std::isfinite(x))
      return Error(option + ": '" + text + "' is not " + (allowSingle ? "R,G,B or one number" : "X,Y,Z"));
    v.push_back(x);
    start = comma + 1;
  }
  if (v.size() == 1 && allowSingle) return Vec3(v[0]);
  if (v.size() != 3)
    return Error(option + ": '" + text + "' is not " + (allowSingle ? "R,G,B or one number" : "X,Y,Z"));
  return Vec3(v[0], v[1], v[2]);
}

inline void addEnvironmentOptions(CLI::App* cmd, EnvironmentOptions& o) {
  const char* group = "Environment light (for scenes that bring none)";
  cmd->add_option("--env", o.settings.map, "Lat-long (equirectangular) EXR map lighting the scene from far away")
      ->group(group);
  cmd->add_option("--sky", o.sky, "Constant sky radiance R,G,B (or one value for grey)")->group(group);
  cmd->add_option("--sun", o.sun, "A sun in direction X,Y,Z (toward the sun, +Y up)")->group(group);
  addParamOptions(cmd, environmentParams(), o.settings);
  for (const Param<EnvironmentSettings>& p : environmentParams().all())
    cmd->get_option(std::string("--") + p.spec.name)->group(group);
}

// The settings from the parsed options: --sky and --sun read, every value
// checked (EnvironmentSettings::validate); an error is a bad argument.
inline Result<EnvironmentSettings> resolveEnvironmentOptions(const EnvironmentOptions& o) {
  EnvironmentSettings s = o.settings;
  if (!o.sky.empty()) {
    Result<Vec3> sky = parseTriple("--sky", o.sky, true);
    if (!sky) return Error(sky.error());
    s.sky = *sky;
  }
  if (!o.sun.empty()) {
    Result<Vec3> sun = parseTriple("--sun", o.sun, false);
    if (!sun) return Error(sun.error());
    if (!(lengthSquared(*sun) > 0)) return Error("--sun: the direction must not be zero");
    s.sunDirection = *sun;
  }
  if (Result<void> v = s.validate(); !v) return Error("--" + v.error());
  return s;
}

}  // namespace vsl
