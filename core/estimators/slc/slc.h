// The stochastic lightcuts plug-in (slc.cpp) as its tests see it: its
// settings from the EstimatorSettings that name them.
#pragma once

#include "core/estimator.h"

namespace vsl {

struct SlcSettings {
  int samples = kDefaultSamples;  // lights per gather point per step
  int steps = kDefaultSteps;      // steps per light set
  float floor = kDefaultFloor;    // share of descents by flux alone
  bool independent = false;       // each draw its own descent (else split)
  // The lobe strategy (slc.cpp): BRDF directions per gather point per step
  // at receivers whose specular lobe is narrower than lobeAlpha (0: off).
  int lobeRays = kDefaultLobeRays;
  float lobeAlpha = kDefaultLobeAlpha;
  static constexpr int kDefaultSamples = 4;
  static constexpr int kDefaultLobeRays = 1;
  static constexpr float kDefaultLobeAlpha = 0.05f;
  static constexpr int kDefaultSteps = 16;
  static constexpr float kDefaultFloor = 0.05f;
};

// From est's "slc-..." values (their defaults where absent).
SlcSettings slcSettings(const EstimatorSettings& est);
// The estimator "slc" with s's values.
EstimatorSettings slcEstimatorSettings(const SlcSettings& s);

}  // namespace vsl
