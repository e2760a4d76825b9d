// The studio's widgets generated from the parameter registry (core/params.h):
// one control per parameter, its help, range, default and the reason for
// the default as a tooltip. A flag is a checkbox, a choice a combo; a number
// is a slider over the spec's studio range, with a combo in front where the
// parameter has words outside that range ("auto", "off"), and a word inside
// it ("off" at 0) shown on the slider.
#pragma once

#include <map>
#include <string>

#include "core/params.h"

namespace vsl::ui {

// The number each parameter returns to when switched from a word back to a
// value (kept while the word is chosen).
using ParamMemory = std::map<std::string, double>;

// The control for one parameter holding *value (with defaultValue its
// default, for the tooltip); returns whether *value changed.
bool paramWidget(const ParamSpec& p, double* value, double defaultValue, ParamMemory& memory);

// The same on a settings field.
template <class S>
bool paramWidget(const Param<S>& p, S& s, ParamMemory& memory) {
  double v = p.get(s);
  if (!paramWidget(p.spec, &v, p.get(S{}), memory)) return false;
  p.set(s, v);
  return true;
}

// The parameter's tooltip text: help, range and unit, default, why, option.
// An experimental heuristic's has the one-line help first, then "More: "
// and the measurement behind its default (naming its notebook entry), or
// docs/REFERENCE.md#parameters when it has none.
std::string paramTooltip(const ParamSpec& p, double defaultValue);

}  // namespace vsl::ui
