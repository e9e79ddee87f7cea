/**
 * @file area_knowledge.h
 * @brief Learning what the knowledge base says is shared: one estimate per blocking area.
 *
 * config/navigation.plog says why moves fail: walkers in a blocking area A (walkers(A)) block
 * every move into a cell of A, and a blocked robot is sometimes trapped; elsewhere a move slips
 * in the same way everywhere. So the robot need not learn each (cell, move) pair on its own
 * (a few dozen samples each, and a planner that prefers the pairs that happened to see no trap
 * biases what it believes): it pools the samples of all cells of an area into one estimate of
 * that area's walker rate and trap rate, and all free moves into one estimate of the move
 * noise, and writes them back as P-log knowledge about the area (areaKnowledgeText).
 *
 * Estimation, per time of day, from R-Max's visit counts (every own sample, known or not):
 *  - free moves (target cell outside every blocking area): success s = n(target) / n,
 *    slip to each existing lateral neighbour l = n(lateral) / (sum over moves of the number of
 *    lateral neighbours), the rest stays; moves into a wall: stay rate w;
 *  - moves into area A: outcomes target / lateral / stay / trapped. A blocked move stays (or is
 *    trapped), an unblocked one moves with the free noise, so a "stay" is ambiguous: walker rate
 *    b and trap rate t (P(trapped | blocked)) are the maximum-likelihood estimates given s, l,
 *    by EM over the latent "blocked" of the stays (exact complete-data M-step).
 * These are consistent for any way of collecting the samples (the outcome of a move does not
 * depend on why the robot tried it), which per-pair estimates read through a planner are not.
 */
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/mdp/visit_counts.h"

namespace krr {
namespace kb {

/// @brief Move noise outside blocking areas.
struct MoveNoiseEstimate {
  double success = 0.0;      ///< reach the intended neighbour
  double lateral = 0.0;      ///< slip to one given lateral neighbour (when it exists)
  double wall_stay = 1.0;    ///< stay when moving into a wall
  std::uint64_t moves = 0;   ///< free moves seen
  std::uint64_t wall_moves = 0;
};

/// @brief The walkers of one blocking area.
struct AreaEstimate {
  std::string area;
  double blocking = 0.0;     ///< P(walkers(A) = true): a move into A is blocked
  double trap = 0.0;         ///< P(trapped | blocked)
  std::uint64_t moves = 0;   ///< moves into A seen
  std::uint64_t trapped = 0;
};

/// @brief Pooled knowledge for one time of day.
struct AreaKnowledge {
  std::string time;
  MoveNoiseEstimate noise;
  std::vector<AreaEstimate> areas;  ///< areas with at least one move seen
};

/**
 * @brief The pooled estimates (file comment) from the visit counts of navigation MDPs over
 * `space`, learned at time `time`.
 * @throws ConfigError when the counts are not over the space's states and 4 moves, or when no
 * free move was seen (the noise cannot be estimated).
 */
AreaKnowledge estimateAreaKnowledge(const mdp::VisitCounts& counts, const NavStateSpace& space,
                                    const std::string& time);

/**
 * @brief The estimates as P-log statements for config/navigation.plog: per area
 * pr(walkers(A)=true | curr_time=T), the trap and stay rates of a blocked move into A and the
 * fact learned_area(A, T); the free-move noise (target, each lateral neighbour, nothing
 * backwards, stay into a wall) and learned_noise(T). Probabilities as exact fractions over
 * 10^6. They switch off the human defaults of the same time, and per-pair learned knowledge
 * (learned(C, M, T)) still wins over them.
 */
std::string areaKnowledgeText(const AreaKnowledge& k);

}  // namespace kb
}  // namespace krr
