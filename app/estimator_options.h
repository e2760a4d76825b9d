// Command-line options generated from the estimator registry
// (core/estimator_registry.h): --estimator NAME, an option per registered
// estimator parameter (--mrcs-rows ..., app/param_options.h), and each
// estimator's shorthand (--mrcs ROWS,CLUSTERS[,MIX]). Shared by vsl render,
// vsl sweep and vsl-studio; nothing here names an estimator.
#pragma once

#include <CLI/CLI.hpp>
#include <map>
#include <set>
#include <string>

#include "app/param_options.h"
#include "core/estimator_registry.h"

namespace vsl {

// What the options wrote; resolveEstimatorOptions makes settings of it.
struct EstimatorOptions {
  std::string name;                          // --estimator ("": not given)
  EstimatorSettings values;                  // the parameters given one by one
  std::set<std::string> given;               // their names
  std::map<std::string, std::string> texts;  // the shorthands given, by shorthand name
};

// Adds the options (--estimator only when chooser: the sweep's methods name
// their estimator). Parameters go in their tiers' groups, as the many-light
// methods' do.
inline void addEstimatorOptions(CLI::App* cmd, EstimatorOptions& o, bool chooser = true) {
  if (chooser) {
    std::string names;
    for (const EstimatorInfo& e : estimators()) names += (names.empty() ? "" : ", ") + e.name + ": " + e.help;
    cmd->add_option("--estimator", o.name, "How the many-light gather is estimated: " + names)
        ->default_str(EstimatorSettings::kDefaultName);
  }
  for (const EstimatorInfo& e : estimators())
    if (!e.shorthand.empty())
      cmd->add_option_function<std::string>(
          "--" + e.shorthand, [&o, name = e.shorthand](const std::string& text) { o.texts[name] = text; },
          e.shorthandHelp);
  addParamOptions(cmd, estimatorParams(), o.values, &o.given);
}

namespace detail {
// The one estimator whose options were given (nullptr: none), or an error
// naming two options of two estimators.
inline Result<const EstimatorInfo*> estimatorOfOptions(const EstimatorOptions& o, std::string* by) {
  const EstimatorInfo* owner = nullptr;
  std::set<std::string> names = o.given;
  for (const auto& [shorthand, text] : o.texts) names.insert(shorthand);
  for (const std::string& n : names) {
    const EstimatorInfo* e = estimatorOwning(n);
    if (owner && e != owner)
      return Error("--" + *by + " and --" + n + ": options of two estimators (" + owner->name + ", " + e->name + ")");
    if (!owner) *by = n;
    owner = e;
  }
  return owner;
}
}  // namespace detail

// The estimator the options choose, in `base` (whose seed and progressive
// radius are kept): --estimator, else the estimator whose options were
// given, else base's. An option of another estimator than --estimator's is
// an error naming both; a shorthand's text is parsed, and the parameters
// given one by one override it. The result is validated.
inline Result<EstimatorSettings> resolveEstimatorOptions(const EstimatorOptions& o, EstimatorSettings base = {}) {
  std::string by;
  Result<const EstimatorInfo*> implied = detail::estimatorOfOptions(o, &by);
  if (!implied) return Error(implied.error());
  const EstimatorInfo* chosen = *implied ? *implied : findEstimator(base.name);
  if (!o.name.empty()) {
    Result<const EstimatorInfo*> named = lookupEstimator(o.name);
    if (!named) return Error("--estimator: " + named.error());
    if (*implied && *implied != *named)
      return Error("--" + by + ": an option of estimator " + (*implied)->name + ", but --estimator is " +
                   (*named)->name);
    chosen = *named;
  }
  if (!chosen) return Error("--estimator: " + lookupEstimator(base.name).error());
  EstimatorSettings e = base;
  e.name = chosen->name;
  if (auto t = o.texts.find(chosen->shorthand); t != o.texts.end() && chosen->parseShorthand)
    if (Result<void> r = chosen->parseShorthand(t->second, e); !r) return Error(r.error());
  for (const Param<EstimatorSettings>& p : estimatorParams().all())
    if (o.given.count(p.spec.name)) p.set(e, p.get(o.values));
  if (Result<void> v = e.validate(); !v) return Error(v.error());
  return e;
}

}  // namespace vsl
