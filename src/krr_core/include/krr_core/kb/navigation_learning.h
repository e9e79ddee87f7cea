/**
 * @file navigation_learning.h
 * @brief Procedure 1's building blocks, shared by the robot's learner (FreeTimeLearner) and the
 * experiments: an R-Max agent for a navigation task seeded from the knowledge base, and
 * learning until R-Max has converged.
 */
#pragma once

#include <cstddef>
#include <functional>

#include "krr_core/common/random.h"
#include "krr_core/kb/nav_domain.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/kb/simulated_navigation.h"
#include "krr_core/mdp/rmax_agent.h"

namespace krr {
namespace kb {

/**
 * @brief An R-Max agent for a navigation task in `env`. With `kb_model` (Procedure 2's model),
 * every pair the knowledge base knows from learning starts known with the KB's distribution
 * (goal states excepted: they are terminal in this task); everything else is optimistic.
 * @param prior_pairs if given, receives the number of pairs that started known.
 */
mdp::RMaxAgent makeNavigationAgent(const NavDomain& domain, const SimulatedNavigation& env,
                                   const mdp::RMaxParams& params, const NavModel* kb_model,
                                   std::size_t* prior_pairs = nullptr);

/**
 * @brief Run R-Max episodes until it converged (no newly known pair for `quiet_episodes`
 * episodes), `max_episodes` ran, or `interrupted()` (checked before each episode) is true.
 * @return episodes run; *converged tells whether convergence ended it.
 */
std::size_t learnUntilConverged(SimulatedNavigation& env, mdp::RMaxAgent& agent,
                                std::size_t max_episodes, std::size_t quiet_episodes, Rng& rng,
                                const std::function<bool()>& interrupted, bool* converged);

}  // namespace kb
}  // namespace krr
