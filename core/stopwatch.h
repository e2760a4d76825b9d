// Stopwatch: wall-clock seconds since construction or the last reset, on the
// monotonic clock (it never jumps with the system time). Nori's Timer is the
// model. Reading is const and safe from any thread; reset() and lap() are not
// safe against concurrent use of the same stopwatch.
#pragma once

#include <chrono>

namespace vsl {

class Stopwatch {
 public:
  using Clock = std::chrono::steady_clock;

  Stopwatch() : start_(Clock::now()) {}
  // Restarts from zero.
  void reset() { start_ = Clock::now(); }
  // Seconds since construction or the last reset (or lap).
  double seconds() const { return secondsBetween(start_, Clock::now()); }
  // Seconds since the start, and restarts: the duration of one lap.
  double lap() {
    Clock::time_point now = Clock::now();
    double s = secondsBetween(start_, now);
    start_ = now;
    return s;
  }

 private:
  static double secondsBetween(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
  }
  Clock::time_point start_;
};

}  // namespace vsl
