// An estimator's parameters and statistics as JSON, the same in render's
// --json and the studio's metrics.json (header-only: core itself writes no
// JSON through it; its users link nlohmann_json).
#pragma once

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "core/estimator_registry.h"
#include "core/params_json.h"

namespace vsl {

// The chosen estimator's parameters by their JSON keys ({"mrcsRows": 300, ...}).
inline nlohmann::json estimatorValuesJson(const EstimatorSettings& e) {
  nlohmann::json j = nlohmann::json::object();
  if (const EstimatorInfo* info = findEstimator(e.name))
    for (const EstimatorParam& p : info->params) j[p.spec.key] = paramJsonValue(p.spec, e.value(p.spec.name));
  return j;
}

// Statistics by key; whole numbers as integers.
inline nlohmann::json estimatorStatsJson(const std::vector<std::pair<std::string, double>>& stats) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [key, v] : stats)
    j[key] = v == std::floor(v) && std::fabs(v) < 9e15 ? nlohmann::json((long long)v) : nlohmann::json(v);
  return j;
}

}  // namespace vsl
