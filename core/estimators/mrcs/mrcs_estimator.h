// The MRCS plug-in (mrcs_estimator.cpp) as its tests and the benchmark see
// it: the MrcsSettings (core/mrcs.h) that EstimatorSettings name, and back.
#pragma once

#include "core/estimator.h"
#include "core/mrcs.h"

namespace vsl {

// Rows, clusters, mix and spread from est's "mrcs-..." values (their
// defaults where absent), and est.seed.
MrcsSettings mrcsSettings(const EstimatorSettings& est);
// The estimator "mrcs" with m's values and seed.
EstimatorSettings mrcsEstimatorSettings(const MrcsSettings& m);

}  // namespace vsl
