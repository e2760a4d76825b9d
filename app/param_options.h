// Command-line options generated from the parameter registry
// (core/params.h): one option per registered parameter, with its help, its
// range check and its default, grouped in --help by tier ("Method
// parameters", "Experimental heuristics"). Nothing algorithmic is declared
// by hand in app/ (docs/ARCHITECTURE.md, "Adding a parameter").
#pragma once

#include <CLI/CLI.hpp>
#include <algorithm>
#include <functional>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include "core/params.h"

namespace vsl {

inline const char* paramGroup(const ParamSpec& p) {
  return p.tier == ParamTier::Method ? "Method parameters" : "Experimental heuristics (docs/REFERENCE.md)";
}

// The option's help: the parameter's line, its range and unit, and what it
// applies to.
inline std::string paramOptionHelp(const ParamSpec& p) {
  std::string h = std::string(p.help) + " [" + p.appliesTo + "]";
  if (p.kind != ParamKind::Flag) h += "; " + paramRangeText(p) + (*p.unit ? std::string(" ") + p.unit : "");
  return h;
}

// The check of a parameter's option: its value read as the parameter's.
// CLI11 names the option, so the message drops the parameter's name.
inline CLI::Validator paramValidator(const ParamSpec& p, const std::string& what) {
  return CLI::Validator(
      [&p](std::string& text) -> std::string {
        Result<double> v = parseParamValue(p, text);
        if (v) return {};
        const std::string prefix = std::string(p.name) + ": ";
        return v.error().rfind(prefix, 0) == 0 ? v.error().substr(prefix.size()) : v.error();
      },
      what);
}

inline const char* paramTypeName(const ParamSpec& p) {
  return p.kind == ParamKind::Choice ? "WORD" : (p.kind == ParamKind::Int ? "INT" : "NUMBER");
}

// Adds --NAME (and --ALIAS) for the parameter p, whose value is checked and
// handed to set; its name is added to *given. Shows the default text given.
inline CLI::Option* addParamOption(CLI::App* cmd, const ParamSpec& p, std::function<void(double)> set,
                                   const std::string& defaultText, std::set<std::string>* given = nullptr) {
  const std::string option = std::string("--") + p.name + (p.alias ? std::string(",--") + p.alias : "");
  if (p.kind == ParamKind::Flag)
    return cmd
        ->add_flag_function(
            option,
            [set, given, &p](int64_t n) {
              set(n > 0 ? 1.0 : 0.0);
              if (given) given->insert(p.name);
            },
            paramOptionHelp(p))
        ->group(paramGroup(p));
  return cmd
      ->add_option_function<std::string>(
          option,
          [set, given, &p](const std::string& text) {
            if (Result<double> v = parseParamValue(p, text)) set(*v);
            if (given) given->insert(p.name);
          },
          paramOptionHelp(p))
      ->check(paramValidator(p, paramTypeName(p)))
      ->default_str(defaultText)
      ->group(paramGroup(p));
}

// The same, bound to a field of arithmetic type (which must outlive the
// parse); the default shown is its value when called.
template <class T>
CLI::Option* addParamOption(CLI::App* cmd, const ParamSpec& p, T& field, std::set<std::string>* given = nullptr) {
  static_assert(std::is_arithmetic_v<T>);
  return addParamOption(
      cmd, p, [&field](double v) { field = T(v); }, formatParamValue(p, double(field)), given);
}

// Adds --NAME for every parameter of table but those in skip; a value given
// is checked and written into target (which must outlive the parse), and its
// name added to *given. The default shown is target's value when called.
template <class S>
void addParamOptions(CLI::App* cmd, const ParamTable<S>& table, S& target, std::set<std::string>* given = nullptr,
                     const std::vector<std::string>& skip = {}) {
  for (const Param<S>& param : table.all()) {
    if (std::find(skip.begin(), skip.end(), param.spec.name) != skip.end()) continue;
    const Param<S>* bound = &param;
    addParamOption(
        cmd, param.spec, [bound, &target](double v) { bound->set(target, v); },
        formatParamValue(param.spec, param.get(target)), given);
  }
}

// A grid axis of `vsl sweep`: --NAME V1,V2,... for a registered parameter,
// its help and each value checked as the parameter's.
template <class T>
void addParamAxisOption(CLI::App* cmd, const ParamSpec& p, std::vector<T>& values) {
  std::string defaults;
  for (const T& v : values) defaults += (defaults.empty() ? "" : ",") + formatParamValue(p, double(v));
  cmd->add_option(std::string("--") + p.name, values, paramOptionHelp(p) + "; a grid axis: comma-separated values")
      ->delimiter(',')
      ->check(paramValidator(p, p.kind == ParamKind::Int ? "INT,..." : "NUMBER,..."))
      ->default_str(defaults)
      ->group("Grid axes");
}

// For a parse error that names options the command does not have ("The
// following argument was not expected: --lobe-flor"), the nearest option of
// cmd to each (" (did you mean --lobe-floor?)"); empty otherwise.
inline std::string nearestOptionHint(const CLI::App& cmd, const std::string& message) {
  std::vector<std::string> names;
  for (const CLI::Option* o : cmd.get_options())
    for (const std::string& l : o->get_lnames()) names.push_back("--" + l);
  std::string hint;
  for (size_t at = message.find("--"); at != std::string::npos; at = message.find("--", at + 2)) {
    const size_t end = message.find_first_of(" ,=:'", at);
    const std::string given = message.substr(at, end == std::string::npos ? std::string::npos : end - at);
    if (std::find(names.begin(), names.end(), given) != names.end()) continue;
    if (std::string near = nearestName(given, names); !near.empty()) hint += " (did you mean " + near + "?)";
  }
  return hint;
}

}  // namespace vsl
