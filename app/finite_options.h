// NaN and infinity pass CLI11's range checks (every comparison with NaN is
// false), so `--exposure nan` or `--after nan` would reach the settings. Both
// executables ask this after parsing and exit 2 with its message.
#pragma once

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>

namespace vsl {

// The first floating-point option of app (or of its parsed subcommands) given
// a value that is not a finite number, as "--name: must be a finite number
// (got 'nan')"; empty if there is none. Lists are checked item by item.
inline std::string nonFiniteOption(const CLI::App& app) {
  for (const CLI::Option* o : app.get_options()) {
    if (o->count() == 0 || o->get_type_name().find("FLOAT") == std::string::npos) continue;
    for (const std::string& given : o->results()) {
      std::istringstream items(given);
      for (std::string item; std::getline(items, item, ',');) {
        char* end = nullptr;
        const double v = std::strtod(item.c_str(), &end);
        if (end != item.c_str() && !std::isfinite(v))
          return o->get_name() + ": must be a finite number (got '" + item + "')";
      }
    }
  }
  for (const CLI::App* sub : app.get_subcommands())
    if (std::string m = nonFiniteOption(*sub); !m.empty()) return m;
  return {};
}

// A default value as --help prints it: the shortest form that reads back the
// same ("1", "0.05"), not std::to_string's "1.000000".
inline std::string defaultText(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// A check for time budgets: a number of seconds in (0, 1e7], with a message
// that says so (CLI::PositiveNumber prints the whole range of a double).
inline CLI::Validator positiveSeconds() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (end == text.c_str() || *end != 0 || !(v > 0 && v <= 1e7))
          return "must be a number of seconds in (0,1e7] (got '" + text + "')";
        return {};
      },
      "SECONDS");
}

// A check for seeds (unsigned 64-bit): digits only. The parse of an unsigned
// option takes "-1" as 2^64 - 1, a seed nobody meant.
inline CLI::Validator seedValue() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos)
          return "must be a whole number from 0 to 2^64 - 1 (got '" + text + "')";
        return {};
      },
      "UINT");
}

}  // namespace vsl
