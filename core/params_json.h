// The parameter registry (core/params.h) as JSON: what the studio's last
// session and metrics.json write, and what the last session reads back. A
// parameter's key is its ParamSpec::key; flags are booleans, choices and
// values outside the numbers ("auto", "off") their words, other values
// numbers (floats in their shortest form: 0.02, not 0.0199999995).
// Header-only: it needs nlohmann/json, which its users (app/, ui/) link.
#pragma once

#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/params.h"

namespace vsl {

inline nlohmann::json paramJsonValue(const ParamSpec& p, double v) {
  const std::string text = formatParamValue(p, v);
  if (p.kind == ParamKind::Flag) return v != 0;
  for (const ParamWord& w : p.words)
    if (text == w.word) return text;
  if (p.kind == ParamKind::Int) return (long long)v;
  return std::stod(text);
}

// Every parameter of s under its key.
template <class S>
nlohmann::json paramsToJson(const ParamTable<S>& table, const S& s) {
  nlohmann::json j = nlohmann::json::object();
  for (const Param<S>& p : table.all()) j[p.spec.key] = paramJsonValue(p.spec, p.get(s));
  return j;
}

// The parameters j holds (by key) into s; the first value of the wrong type
// or out of range is an error naming the key ("lobeFloor: must be in
// [0,100] (got 200)"), and s is then unchanged. Keys of j that are neither
// parameters nor in `others` are named in *unknown, each with the nearest
// known key.
template <class S>
Result<void> paramsFromJson(const ParamTable<S>& table, const nlohmann::json& j, S& s,
                            const std::vector<std::string>& others = {}, std::vector<std::string>* unknown = nullptr) {
  S out = s;
  std::vector<std::string> keys = others;
  for (const Param<S>& p : table.all()) {
    keys.push_back(p.spec.key);
    if (!j.contains(p.spec.key)) continue;
    const nlohmann::json& v = j.at(p.spec.key);
    Result<double> value = Error(std::string(p.spec.key) + ": must be a number, a word or a boolean");
    if (v.is_boolean())
      value = v.get<bool>() ? 1.0 : 0.0;
    else if (v.is_number())
      value = v.get<double>();
    else if (v.is_string())
      value = parseParamValue(p.spec, v.get<std::string>());
    if (value)
      if (Result<void> ok = checkParamValue(p.spec, *value); !ok) value = Error(ok.error());
    if (!value) return Error(std::string(p.spec.key) + " (" + value.error() + ")");
    p.set(out, *value);
  }
  if (unknown)
    for (const auto& item : j.items())
      if (std::find(keys.begin(), keys.end(), item.key()) == keys.end()) {
        const std::string near = nearestName(item.key(), keys);
        unknown->push_back(item.key() + (near.empty() ? "" : " (did you mean " + near + "?)"));
      }
  s = out;
  return {};
}

}  // namespace vsl
