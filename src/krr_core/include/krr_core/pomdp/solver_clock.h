/**
 * @file solver_clock.h
 * @brief Solver time across repeated runUntil() calls, and the anytime trial loop that both
 * point-based solvers run (one copy, so that their deadline and trial-budget rules agree).
 */
#pragma once

#include <cstddef>

#include "krr_core/common/resources.h"

namespace krr {
namespace pomdp {

/// @brief Solver seconds: the time of all runs so far plus the current run's.
class SolverClock {
 public:
  /// @brief Begin a run that may last until `deadline` seconds of solver time.
  void start(double deadline) {
    offset_ = elapsed_;
    clock_.reset();
    deadline_ = deadline;
  }
  /// @brief End the current run (its time counts from now on in elapsed()).
  void stop() { elapsed_ = now(); }
  double now() const { return offset_ + clock_.seconds(); }
  bool expired() const { return now() >= deadline_; }
  double deadline() const { return deadline_; }
  void setDeadline(double deadline) { deadline_ = deadline; }
  /// @brief Solver seconds at the end of the last run.
  double elapsed() const { return elapsed_; }
  /// @brief Count `seconds` already spent (the set-up in the constructor).
  void setElapsed(double seconds) { elapsed_ = seconds; }

 private:
  Stopwatch clock_;
  double offset_ = 0.0, elapsed_ = 0.0, deadline_ = 0.0;
};

/// @brief The anytime loop: trial() until done(), the deadline or maxTrials trials in total
/// (0: no limit). `trials` is the solver's trial counter, which trial() increments.
template <class Done, class Trial>
void runTrials(SolverClock& clock, double deadline, std::size_t maxTrials,
               const std::size_t& trials, Done done, Trial trial) {
  clock.start(deadline);
  while (!done() && !clock.expired() && (maxTrials == 0 || trials < maxTrials)) trial();
  clock.stop();
}

}  // namespace pomdp
}  // namespace krr
