/**
 * @file observed_navigation.h
 * @brief Learning from the moves a real executor made (navigation_node's external move_base
 * executor, issue 26): every observed move becomes the same (cell, move, next) sample the
 * simulator gives R-Max, pooled per time of day in the visit counts that area extraction reads
 * (kb/area_knowledge.h). So the knowledge base learns from the robot's own trips exactly as it
 * learns from free-time practice, and the two can share one pool.
 *
 * A move has one of four outcomes: it reached the intended neighbour, stayed in its cell, ended
 * in another cell, or was aborted (the executor gave up on it). An abort is the trapped outcome
 * of the knowledge base (the trip fails there), so the learned rate of walkers(A) converges to the
 * rate at which moves into A are aborted or stay (area_knowledge.h's EM splits the stays).
 */
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "krr_core/kb/area_knowledge.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/mdp/visit_counts.h"

namespace krr {
namespace kb {

/// @brief What became of one executed move.
enum class MoveOutcome {
  kReached,    ///< the robot is in the intended neighbour
  kStayed,     ///< the robot is still in its cell
  kElsewhere,  ///< the robot is in another cell
  kAborted,    ///< the executor gave up on the move (the trapped outcome)
};

/// @brief "reached", "stayed", "elsewhere", "aborted".
std::string toString(MoveOutcome o);
/// @throws ConfigError for another name.
MoveOutcome moveOutcomeFromString(const std::string& name);

/// @brief One observed move: from `cell` by `move` (nav::Move) to `next_cell` (-1: aborted).
struct ObservedMove {
  int cell = -1;
  int move = 0;
  int next_cell = -1;
  std::string time;  ///< time of day the move was made in (the knowledge base's context)
};

/**
 * @brief The outcome of a move from `cell` by `move` after which the robot is in `observed`
 * (aborted: the executor gave up, wherever the robot is).
 */
MoveOutcome classifyMove(const nav::NavGrid& grid, int cell, int move, int observed, bool aborted);

/**
 * @brief The observed moves of a robot, pooled per time of day, and the area knowledge they
 * teach. Not thread-safe: one owner adds and extracts.
 */
class ObservedNavigation {
 public:
  /// @param space the navigation states the counts are over (must outlive this object).
  explicit ObservedNavigation(const NavStateSpace& space);

  /// @brief Pool the moves of `time` in `pool` (e.g. a free-time learner's samples, so area
  /// extraction sees both). @throws ConfigError when the pool is not over the space's states.
  void share(const std::string& time, std::shared_ptr<mdp::VisitCounts> pool);
  /// @brief The pool of `time` (created empty on first use).
  std::shared_ptr<mdp::VisitCounts> pool(const std::string& time);

  /// @brief Count one move. @throws UnknownSymbolError for a cell or next cell that is not a
  /// free cell of the grid, a move outside nav::Move, or an empty time.
  void add(const ObservedMove& m);
  /// @brief Moves added for `time` (through add(), not the shared pool's other samples).
  std::uint64_t moves(const std::string& time) const;

  /**
   * @brief The pooled estimates of `time` (area_knowledge.h), or nothing while no move outside
   * the blocking areas was seen at that time (the move noise, which the areas' rates are
   * separated from, is unknown until then).
   */
  std::optional<AreaKnowledge> estimate(const std::string& time) const;
  /// @brief estimate() written into `knowledge` (setLearnedAreas) when there is one.
  std::optional<AreaKnowledge> extract(NavigationKnowledge& knowledge,
                                       const std::string& time) const;

 private:
  const NavStateSpace& space_;
  std::map<std::string, std::shared_ptr<mdp::VisitCounts>> pools_;
  std::map<std::string, std::uint64_t> moves_;
};

/**
 * @brief The largest change of a learned probability (move noise, each area's walker and trap
 * rates) from `before` to `after`; 1 for what `after` knows and `before` does not (no free move
 * seen, or an area without moves). How much a round of learning taught.
 */
double largestChange(const std::optional<AreaKnowledge>& before, const AreaKnowledge& after);

}  // namespace kb
}  // namespace krr
