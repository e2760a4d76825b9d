// The parameter registry (docs/ARCHITECTURE.md, "Adding a parameter"): each
// parameter of the many-light methods is declared once, as a ParamSpec bound
// to the settings field that holds it. Everything else is generated from the
// declaration: the options of `vsl render`, `vsl sweep` and `vsl-studio`
// (app/param_options.h), the studio's widgets (ui/param_widgets.h), the
// last-session file and metrics.json (paramsToJson, paramsFromJson),
// describe() and the replay commands (describeParams), the sweep's grid
// axes (--vary NAME=V1,V2), the parameter table in docs/REFERENCE.md
// (paramTableMarkdown, `vsl params --markdown`), and the checks
// (checkParams). Models: pbrt-v4's ParameterDictionary, Mitsuba 3's plug-in
// parameter tables.
//
// A value is held as a double while it passes through the registry: every
// parameter is an integer below 2^53, a float, a flag or a choice, so the
// round trip to the field is exact.
#pragma once

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/result.h"

namespace vsl {

// Method: a parameter of the published methods (Hasan et al. 2009, Keller
// 1997) or of how long they run. Experimental: a heuristic of this project,
// measured in docs/REFERENCE.md "Parameters"; `--preset paper` turns
// every one off.
enum class ParamTier { Method, Experimental };
enum class ParamKind { Int, Real, Flag, Choice };

// A named value ("auto" = 0, "off" = infinity). For a Choice the words are
// the only values.
struct ParamWord {
  const char* word;
  double value;
};

struct ParamSpec {
  const char* name;  // "lobe-floor": --lobe-floor, the sweep's axis, the error messages
  const char* key;   // "lobeFloor": the JSON key in the last session and metrics.json
  ParamKind kind = ParamKind::Real;
  ParamTier tier = ParamTier::Method;
  const char* appliesTo = "VSL";  // "VSL", "VPL", "VSL, VPL"
  // Valid numbers (words are valid too). minOpen excludes min itself.
  double min = 0, max = 0;
  bool minOpen = false;
  const char* unit = "";
  const char* help = "";  // one line
  const char* why = "";   // one line on the default, with a link to the evidence
  std::vector<ParamWord> words = {};
  // describe() leaves the parameter out at this value (NaN: never), and
  // whenever the parameter `needs` names is off: at needsValue's other
  // values where needsValue is set, else at its own quiet value.
  double quiet = std::numeric_limits<double>::quiet_NaN();
  const char* needs = nullptr;
  double needsValue = std::numeric_limits<double>::quiet_NaN();
  // The studio's slider: its range (0, 0: min to max) and scale, and the
  // value it starts at when switched on from a word outside that range
  // ("radius" from off; NaN: the middle of the range).
  double uiMin = 0, uiMax = 0;
  bool uiLog = false;
  double uiStart = std::numeric_limits<double>::quiet_NaN();
  // An older option name a command still accepts ("sets" for light-sets).
  const char* alias = nullptr;
  // A preset sets it (core/presets.h): it defines the method's variant. The
  // light set's scale, the batches and VPL's clamp stay the user's.
  bool preset = false;
};

// The text of a value: its word if it has one, else the number in its
// shortest form that reads back the same ("0.05", "1", "10000").
std::string formatParamValue(const ParamSpec& p, double v);
// Reads a value from text: a word, or a number of the parameter's kind
// ("1.5" is not an Int; a Flag takes true/false/1/0). Errors name the
// parameter and say what it takes.
Result<double> parseParamValue(const ParamSpec& p, std::string_view text);
// Success, or "name: must be in [min,max] (got v)" with the words allowed.
Result<void> checkParamValue(const ParamSpec& p, double v);
// What the parameter takes, as help and errors say it: "[0,100] or off".
std::string paramRangeText(const ParamSpec& p);

// Edit distance between two names (insertions, deletions, substitutions).
size_t editDistance(std::string_view a, std::string_view b);
// Of names, the nearest to name (at most a third of its length away, and at
// most 3 edits); empty when none is that near.
std::string nearestName(std::string_view name, const std::vector<std::string>& names);

// A parameter bound to a field of the settings type S.
template <class S>
struct Param {
  ParamSpec spec;
  std::function<double(const S&)> get;
  std::function<void(S&, double)> set;
};

// The binding for a field of arithmetic or enum type.
template <class S, class T>
Param<S> bindField(ParamSpec spec, T S::*field) {
  return {std::move(spec), [field](const S& s) { return double(s.*field); },
          [field](S& s, double v) {
            if constexpr (std::is_same_v<T, bool>)
              s.*field = v != 0;
            else if constexpr (std::is_enum_v<T>)
              s.*field = T(int(v));
            else
              s.*field = T(v);
          }};
}

// The parameters of one settings type, in the order describe() and the docs
// list them. Lookup by name gives the nearest name on a miss.
template <class S>
class ParamTable {
 public:
  explicit ParamTable(std::vector<Param<S>> params) : params_(std::move(params)) {}
  const std::vector<Param<S>>& all() const { return params_; }
  const Param<S>* find(std::string_view name) const {
    for (const Param<S>& p : params_)
      if (name == p.spec.name) return &p;
    return nullptr;
  }
  // The parameter, or "unknown parameter 'x' (did you mean 'y'?)".
  Result<const Param<S>*> lookup(std::string_view name) const {
    if (const Param<S>* p = find(name)) return p;
    std::vector<std::string> names;
    for (const Param<S>& q : params_) names.push_back(q.spec.name);
    std::string near = nearestName(name, names);
    return Error("unknown parameter '" + std::string(name) + "'" +
                 (near.empty() ? std::string(" (see `vsl params`)") : " (did you mean '" + near + "'?)"));
  }
  // Sets the parameter from text: the name and the value are both checked.
  Result<void> setText(S& s, std::string_view name, std::string_view text) const {
    Result<const Param<S>*> p = lookup(name);
    if (!p) return Error(p.error());
    Result<double> v = parseParamValue((*p)->spec, text);
    if (!v) return Error(v.error());
    (*p)->set(s, *v);
    return {};
  }
  // The first parameter out of range, as checkParamValue says it.
  Result<void> check(const S& s) const {
    for (const Param<S>& p : params_)
      if (Result<void> r = checkParamValue(p.spec, p.get(s)); !r) return r;
    return {};
  }
  // " --name value" for every parameter, in order, except those left out:
  // quiet ones (ParamSpec::quiet, needs) and those named in skip. Flags
  // appear as " --name" when set.
  std::string describe(const S& s, const std::vector<std::string>& skip = {}) const;
  // Whether describe() would leave p out for s (quiet, or its requirement is).
  bool quiet(const Param<S>& p, const S& s) const;
  // Is the parameter p's `needs` off in s (ParamSpec::needs, needsValue)?
  // False where p needs none.
  bool needUnmet(const Param<S>& p, const S& s) const;
  // pbrt's ReportUnused: of the parameters given (by name), the first that
  // s does not use, as "name: for VSL, but only VPL is rendered" or
  // "name: has no effect while lobe-gather is off". vsl and vpl say which
  // methods are rendered.
  Result<void> checkUsed(const S& s, const std::vector<std::string>& given, bool vsl, bool vpl) const {
    for (const std::string& name : given) {
      const Param<S>* p = find(name);
      if (!p) continue;
      const std::string_view applies = p->spec.appliesTo;
      const bool forVsl = applies.find("VSL") != applies.npos, forVpl = applies.find("VPL") != applies.npos;
      if (!(forVsl && vsl) && !(forVpl && vpl))
        return Error(name + ": for " + std::string(applies) + ", but only " + (vsl ? "VSL" : "VPL") + " is rendered");
      if (needUnmet(*p, s)) {
        const Param<S>& need = *find(p->spec.needs);
        return Error(name + ": has no effect while " + need.spec.name +
                     (std::isnan(p->spec.needsValue) ? std::string(" is off")
                                                     : " is not " + formatParamValue(need.spec, p->spec.needsValue)));
      }
    }
    return {};
  }
  // Copies every parameter of the given tier from `from` to `to`.
  void copyTier(const S& from, S& to, ParamTier tier) const {
    for (const Param<S>& p : params_)
      if (p.spec.tier == tier) p.set(to, p.get(from));
  }

 private:
  std::vector<Param<S>> params_;
};

template <class S>
bool ParamTable<S>::quiet(const Param<S>& p, const S& s) const {
  if (!std::isnan(p.spec.quiet) && p.get(s) == p.spec.quiet) return true;
  return needUnmet(p, s);
}

template <class S>
bool ParamTable<S>::needUnmet(const Param<S>& p, const S& s) const {
  const Param<S>* r = p.spec.needs ? find(p.spec.needs) : nullptr;
  if (!r) return false;
  return std::isnan(p.spec.needsValue) ? quiet(*r, s) : r->get(s) != p.spec.needsValue;
}

template <class S>
std::string ParamTable<S>::describe(const S& s, const std::vector<std::string>& skip) const {
  std::string out;
  for (const Param<S>& p : params_) {
    bool skipped = false;
    for (const std::string& n : skip) skipped |= n == p.spec.name;
    if (skipped || quiet(p, s)) continue;
    const double v = p.get(s);
    if (p.spec.kind == ParamKind::Flag) {
      if (v != 0) out += std::string(" --") + p.spec.name;
      continue;
    }
    out += std::string(" --") + p.spec.name + " " + formatParamValue(p.spec, v);
  }
  return out;
}

struct ManyLightSettings;
// The many-light methods' parameters (ManyLightSettings), declared in
// core/params.cpp.
const ParamTable<ManyLightSettings>& manyLightParams();

struct RenderSettings;
// The path tracer's parameters (RenderSettings: --spp, --max-depth), for
// `vsl render` and `vsl reference`.
const ParamTable<RenderSettings>& pathTracerParams();

struct EnvironmentSettings;
// The environment light's numbers (core/environment.h: --env-scale,
// --sun-diameter, --sun-irradiance); its map, sky and sun direction are a
// file and vectors, options of their own (app/environment_options.h).
const ParamTable<EnvironmentSettings>& environmentParams();

// How long and how often the methods run, declared once and bound by each
// command to its own field (app/param_options.h, addParamOption): the light
// sets averaged, the progressive radius, the reference's stopping rule and
// the studio's background reference. Each command shows its own default.
const std::vector<ParamSpec>& runParams();
// The run parameter of that name; a name not declared is a programming
// error (it aborts).
const ParamSpec& runParam(std::string_view name);

// The registry's parameter table as Markdown: name, default, range and unit,
// tier, methods, meaning and why (docs/REFERENCE.md, "Parameter table").
std::string paramTableMarkdown(const std::vector<ParamSpec>& specs, const std::vector<std::string>& defaults);
std::string paramTableMarkdown(const std::vector<ParamSpec>& specs, const std::vector<double>& defaults);
template <class S>
std::string paramTableMarkdown(const ParamTable<S>& table, const S& defaults) {
  std::vector<ParamSpec> specs;
  std::vector<double> values;
  for (const Param<S>& p : table.all()) {
    specs.push_back(p.spec);
    values.push_back(p.get(defaults));
  }
  return paramTableMarkdown(specs, values);
}

}  // namespace vsl
