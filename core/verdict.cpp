#include "core/verdict.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/compare.h"

namespace vsl {

namespace {

// The noise left in a method's image at own time t: one light set's
// variance, as last measured (the best estimate: the most sets), over the
// sets complete at the first point at or after t (the one whose error the
// interpolation ends at; at least one, the set in progress). Negative when
// unknown.
double noiseAtOwnTime(const std::vector<ErrorSample>& history, StudioMethod m, double t) {
  const double variance = m == StudioMethod::Vsl ? history.back().vslSetVariance : history.back().vplSetVariance;
  if (variance < 0) return -1;
  for (const ErrorSample& e : history)
    if (ownSeconds(e, m) >= t) return variance / std::max(e.lightSetsDone, 1);
  return -1;
}

}  // namespace

Verdict judge(const std::vector<ErrorSample>& all, size_t count) {
  const std::vector<ErrorSample> history(all.begin(), all.begin() + std::min(count, all.size()));
  Verdict v;
  if (history.empty()) return v;
  v.budget = equalTimeBudget(history);
  v.vsl = errorAtOwnTime(history, StudioMethod::Vsl, v.budget);
  v.vpl = errorAtOwnTime(history, StudioMethod::Vpl, v.budget);
  v.pt = errorAtOwnTime(history, StudioMethod::Pt, v.budget);
  if (!std::isfinite(v.vsl) || !std::isfinite(v.vpl)) return v;
  v.outcome = VerdictOutcome::NotYetSeparable;
  const double vslNoise = noiseAtOwnTime(history, StudioMethod::Vsl, v.budget);
  const double vplNoise = noiseAtOwnTime(history, StudioMethod::Vpl, v.budget);
  if (vslNoise < 0 || vplNoise < 0) return v;
  v.margin = std::max(history.back().referenceNoise, 0.0) + std::max(vslNoise, vplNoise);
  // An error at or below zero is within the reference's own noise: it has no
  // size to compare (the table's "< noise").
  if (v.vsl <= 0 || v.vpl <= 0) return v;
  if (std::abs(v.vsl - v.vpl) > v.margin) v.outcome = v.vsl < v.vpl ? VerdictOutcome::VslWins : VerdictOutcome::VplWins;
  return v;
}

std::string verdictLine(const Verdict& v) {
  char line[320];
  switch (v.outcome) {
    case VerdictOutcome::NoData:
      return "no verdict yet: both methods need a picture";
    case VerdictOutcome::NotYetSeparable:
      if (!std::isfinite(v.margin))
        std::snprintf(line, sizeof line,
                      "not yet separable: the noise left in each method's image is measured from two light sets");
      else if (v.vsl <= 0 || v.vpl <= 0)
        std::snprintf(line, sizeof line,
                      "not yet separable: %s error is within the reference's own noise (a more converged reference "
                      "tells)",
                      v.vsl <= 0 && v.vpl <= 0 ? "each method's"
                      : v.vsl <= 0             ? "VSL's"
                                               : "clamped VPL's");
      else
        std::snprintf(line, sizeof line,
                      "not yet separable: the difference %.3g is within the noise %.3g (the reference's and the "
                      "spread between light sets)",
                      std::abs(v.vsl - v.vpl), v.margin);
      return line;
    case VerdictOutcome::VslWins:
    case VerdictOutcome::VplWins: {
      const bool vsl = v.outcome == VerdictOutcome::VslWins;
      const double ratio = vsl ? v.vsl / v.vpl : v.vpl / v.vsl;
      std::snprintf(line, sizeof line,
                    "%s wins at equal time (%.3g s each): its error is %.3gx %s's, and the difference %.3g exceeds "
                    "the noise %.3g",
                    vsl ? "VSL" : "clamped VPL", v.budget, ratio, vsl ? "clamped VPL" : "VSL", std::abs(v.vsl - v.vpl),
                    v.margin);
      return line;
    }
  }
  return {};
}

std::vector<std::string> verdictReport(const Snapshot& s) {
  const Verdict v = judge(s.history);
  const Image ref = comparedImage(s, s.refDirect, s.refIndirect);
  std::vector<std::string> lines;
  const std::pair<const char*, const Image*> rows[] = {{"VSL", &s.many.vsl}, {"clamped VPL", &s.many.vpl}};
  for (const auto& [name, img] : rows) {
    const double error = img == &s.many.vsl ? v.vsl : v.vpl;
    char line[256];
    if (img->rgb.size() != ref.rgb.size() || ref.rgb.empty()) {
      std::snprintf(line, sizeof line, "%-12s no picture yet", name);
    } else {
      const CompareResult c = compareImages(comparedImage(s, s.many.direct, *img), ref);
      const double rel = c.average.meanRef != 0 ? c.average.meanTest / c.average.meanRef - 1 : NAN;
      std::snprintf(line, sizeof line,
                    "%-12s %s relMSE at equal time %.4g, mean %.4g against the reference's %.4g (%+.1f%%)", name,
                    componentName(comparedComponent(s)), error, c.average.meanTest, c.average.meanRef, 100 * rel);
    }
    lines.push_back(line);
  }
  lines.push_back(verdictLine(v));
  return lines;
}

}  // namespace vsl
