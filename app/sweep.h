// `vsl sweep`: a grid of methods x light counts x radius scales against a
// reference, each configuration run with several independent light sets (or
// seeds), with CSV, JSON and error-vs-time / Pareto / FLIP plots; shards of
// the grid run separately and merge into the same outputs.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/estimator.h"

namespace vsl {

struct SweepArgs {
  std::string scene, reference, outDir;
  std::string referenceB;  // optional second, independent reference: measures the first one's noise
  int width = 256;         // without a reference: the width whose cached reference is used
  // Also vsl-progressive, vsl-mrcs, vsl-mrcs-progressive and vpl-mrcs (see sweep.cpp).
  std::vector<std::string> methods = {"pt", "vpl", "vsl"};
  float alpha = 0.7f;  // for vsl-progressive
  std::vector<uint32_t> lights = {1000, 10000};
  std::vector<float> radiusScales = {1.0f};
  double time = 30;  // seconds per run: the budget its final point keeps (sweep.cpp)
  int batches = 8;
  // The estimators' parameters for the methods that use them (-mrcs: the
  // "mrcs-..." values); name and seed are set per method and pass.
  EstimatorSettings estimator;
  uint64_t seed = 1;  // differ from the reference's seed, or the path tracer replays it
  // Independent runs per configuration (light sets, or path-tracer seeds): a
  // many-light method's error is heavy-tailed and one light set decides
  // nothing. Finals are summarised by the median and interquartile range.
  int sets = 5;
  // Template for the many-light runs: k, VSL samples, clipped disk, where eye
  // paths continue (lights, seed, radius scale, batches are set per run).
  ManyLightSettings many;
  // Fan-out: "I/N" runs the configurations whose grid index is I mod N (the
  // same rows an unsharded run writes for them); merge joins such shard
  // output directories into outDir (scene and reference are not needed then).
  std::string shard;
  std::vector<std::string> merge;
  // Another grid axis, "NAME=V1,V2,...": any registered method parameter
  // (core/params.h). Each value's sweep is written to outDir/NAME=V, and
  // outDir/vary.csv joins their summaries with a column for the value.
  std::string vary;
};

// Runs the sweep (or merges shards) and writes its outputs to args.outDir;
// returns the exit code (cli.h), having reported any error. The command line
// reaches it through addSweepCommand (cli.h).
int runSweep(const SweepArgs& args);

}  // namespace vsl
