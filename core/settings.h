// RenderSettings: the one value that flows from the UI or CLI to a renderer.
// Named defaults, validate() at construction sites, and it can print itself.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "core/result.h"

namespace vsl {

// Reads the decimal integer (optional '-', then digits) that starts at
// text[pos] into out and moves pos past it; false, with pos unchanged, when
// there is none or it does not fit in an int (no silent wrap-around).
bool readInt(std::string_view text, size_t& pos, int& out);

enum class Component { Full, Direct, Indirect };
const char* componentName(Component c);
bool parseComponent(const std::string& s, Component* out);

struct RenderSettings {
  static constexpr int kDefaultResolution = 512;
  static constexpr int kMaxResolution = 16384;

  std::string method = "pt";
  int width = 0, height = 0;  // 0 = from the scene's camera aspect, or 512x512
  int spp = 64;               // samples per pixel (passes)
  double timeLimit = 0;       // seconds; > 0 replaces spp as the stop criterion
  uint64_t seed = 0;
  int maxDepth = 64;  // maximum number of scattering events on a path
  int rrDepth = 3;    // Russian roulette starts after this many bounces
  Component component = Component::Full;

  // Success, or the first invalid setting: "setting: reason (got value)".
  Result<void> validate() const;
  // One-line, replayable description ("--spp 64 --seed 0 ...").
  std::string describe() const;
};

}  // namespace vsl
