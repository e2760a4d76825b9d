// `vsl sweep`: a grid of methods x light counts x radius scales against a
// reference, with CSV, JSON and error-vs-time / Pareto plots.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/mrcs.h"

namespace vsl {

struct SweepArgs {
  std::string scene, reference, outDir;
  std::string referenceB;  // optional second, independent reference: measures the first one's noise
  // Also vsl-progressive, vsl-mrcs, vsl-mrcs-progressive and vpl-mrcs (see sweep.cpp).
  std::vector<std::string> methods = {"pt", "vpl", "vsl"};
  float alpha = 0.7f;  // for vsl-progressive
  std::vector<uint32_t> lights = {1000, 10000};
  std::vector<float> radiusScales = {1.0f};
  double time = 30;  // seconds: the path tracer's budget, and a cap per many-light run
  int batches = 8;
  MrcsSettings mrcs;  // for the -mrcs methods (seed: per pass)
  uint64_t seed = 1;  // differ from the reference's seed, or the path tracer replays it
};

int runSweep(const SweepArgs& args);

}  // namespace vsl
