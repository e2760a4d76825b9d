// The comparison's verdict: which of VSL and clamped VPL has the lower error
// at equal time, and whether that can be told yet (docs/REFERENCE.md,
// "The verdict").
//
// Both errors are relMSE less the reference's own noise, read from the
// error history at the equal-time budget (each method's own clock,
// session.h). A difference counts only when it exceeds the margin: the
// reference's own noise plus the larger of the noises still left in the two
// methods' images at the budget (one light set's variance, as last measured,
// over the sets averaged then; ErrorSample::vslSetVariance). Until two light
// sets are complete that variance is unknown and no winner is named. The
// margin shrinks as light sets accumulate and the reference converges, so a
// stated winner is one whose lead exceeded every noise the numbers carry.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "core/session.h"

namespace vsl {

enum class VerdictOutcome { NoData, NotYetSeparable, VslWins, VplWins };

struct Verdict {
  VerdictOutcome outcome = VerdictOutcome::NoData;
  double budget = 0;                      // seconds of each method's own time
  double vsl = NAN, vpl = NAN, pt = NAN;  // relMSE less the reference's noise at the budget
  double margin = NAN;                    // what |vsl - vpl| must exceed; NaN: unknown yet
};

// The verdict on the history's first `count` points (all of them by default).
Verdict judge(const std::vector<ErrorSample>& history, size_t count = size_t(-1));

// The verdict's last line: "VSL wins: ...", "clamped VPL wins: ..." or
// "not yet separable: ...", with the numbers it rests on.
std::string verdictLine(const Verdict& v);

// The verdict on s in three lines: VSL's and clamped VPL's error at equal
// time with each one's mean against the reference's (of the component
// compared, session.h comparedComponent), then verdictLine.
std::vector<std::string> verdictReport(const Snapshot& s);

}  // namespace vsl
