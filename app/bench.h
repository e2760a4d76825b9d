// `vsl bench`: throughput of the path tracer against raw Embree occlusion
// rays on the same scene, measured in one run.
#pragma once

#include <string>

namespace vsl {
int runBench(const std::string& scenePath, double seconds, int size, const std::string& jsonPath);
}
