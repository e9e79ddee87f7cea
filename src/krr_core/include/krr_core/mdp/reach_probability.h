/**
 * @file reach_probability.h
 * @brief P^N(s, goal): probability that a policy reaches a target set before any other
 * absorbing state, from every start state at once (the paper's delivery equation, Sec. III-B).
 *
 * Under a fixed policy the MDP is a Markov chain. Target states are treated as absorbing
 * successes, the model's other terminal states as absorbing failures. With an infinite horizon
 * the answer solves the absorbing-chain system (I - Q) x = b restricted to the states that can
 * reach a target (the others are 0, which also makes the system non-singular); with a step
 * limit N (episodes have one) it is N steps of x_{k+1} = P_pi x_k from x_0 = 1[target].
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "krr_core/common/random.h"
#include "krr_core/mdp/sparse_model.h"

namespace krr {
namespace mdp {

/// @brief Horizon value meaning "no step limit".
constexpr std::size_t kInfiniteHorizon = static_cast<std::size_t>(-1);

/**
 * @brief Exact P(reach target within horizon steps | start = s) for every state s.
 * @param target states counted as success (they need not be terminal in the model).
 * @throws ConfigError when the policy or a target index is out of range.
 */
std::vector<double> reachProbability(const SparseModel& model, const std::vector<ActionId>& policy,
                                     const std::vector<StateId>& target,
                                     std::size_t horizon = kInfiniteHorizon);

/**
 * @brief Monte-Carlo estimate of the same quantity from one start state: the fraction of
 * `episodes` simulated runs that enter the target within `horizon` steps (an infinite horizon
 * is capped at max_steps steps, counted as not reaching).
 */
double monteCarloReachProbability(const SparseModel& model, const std::vector<ActionId>& policy,
                                  const std::vector<StateId>& target, StateId start,
                                  std::size_t horizon, std::size_t episodes, Rng& rng,
                                  std::size_t max_steps = 100000);

}  // namespace mdp
}  // namespace krr
