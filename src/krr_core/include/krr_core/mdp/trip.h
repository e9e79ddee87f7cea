/**
 * @file trip.h
 * @brief How a trip ends: the one rule of the robot (navigation_node), the delivery
 * experiments (dialog::DeliveryNavigation) and R-Max's episodes (mdp::runEpisode).
 *
 * A trip makes moves until one of them reaches the goal (reached) or ends it as a failure
 * (trapped), or it is stopped from outside before a move (preempted, the executor gone), or
 * `stepLimit` moves were made without either (step limit). A trip that starts at its goal is
 * reached with no move. Every caller keeps its own notion of a move (a simulator step, an
 * external move_base goal, an MDP step with its reward); this file decides only when to stop,
 * so the robot and the experiments cannot disagree on it.
 */
#pragma once

#include <cstddef>

namespace krr {
namespace mdp {

/// @brief Why a trip ended.
enum class TripEnd {
  kReached,    ///< a move arrived at the goal (or the trip started there)
  kFailed,     ///< a move ended the trip as a failure (trapped, aborted)
  kStepLimit,  ///< stepLimit moves made without reaching or failing
  kStopped,    ///< stopped from outside before a move, or by the move itself
};

/// @brief "reached", "failed", "step_limit", "stopped".
inline const char* toString(TripEnd e) {
  switch (e) {
    case TripEnd::kReached: return "reached";
    case TripEnd::kFailed: return "failed";
    case TripEnd::kStepLimit: return "step_limit";
    case TripEnd::kStopped: return "stopped";
  }
  return "?";
}

/// @brief What one move did.
struct TripMove {
  bool reached = false;  ///< at the goal after the move
  bool failed = false;   ///< the move ended the trip as a failure
  bool stopped = false;  ///< the move could not be made (no sample, the trip ends)
};

/// @brief How a trip ended and after how many moves (a stopped move is not counted).
struct TripSummary {
  TripEnd end = TripEnd::kStopped;
  std::size_t moves = 0;
};

/**
 * @brief Run a trip (see the file comment).
 * @param atGoal   the trip starts at its goal (then no move is made)
 * @param stepLimit the most moves a trip may make
 * @param stop     `bool()`: asked before every move; true ends the trip (kStopped)
 * @param move     `TripMove(std::size_t k)`: make move k (1-based)
 */
template <class Stop, class Move>
TripSummary runTrip(bool atGoal, std::size_t stepLimit, Stop&& stop, Move&& move) {
  TripSummary t;
  if (atGoal) {
    t.end = TripEnd::kReached;
    return t;
  }
  for (;;) {
    if (stop()) {
      t.end = TripEnd::kStopped;
      return t;
    }
    if (t.moves >= stepLimit) {
      t.end = TripEnd::kStepLimit;
      return t;
    }
    const TripMove m = move(t.moves + 1);
    if (m.stopped) {
      t.end = TripEnd::kStopped;
      return t;
    }
    ++t.moves;
    if (m.failed) {
      t.end = TripEnd::kFailed;
      return t;
    }
    if (m.reached) {
      t.end = TripEnd::kReached;
      return t;
    }
  }
}

/// @brief runTrip without an outside stop.
template <class Move>
TripSummary runTrip(bool atGoal, std::size_t stepLimit, Move&& move) {
  return runTrip(atGoal, stepLimit, [] { return false; }, move);
}

}  // namespace mdp
}  // namespace krr
