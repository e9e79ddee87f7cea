/**
 * @file types.h
 * @brief The index and outcome types of the MDP model contract, in their own header so that
 * the contract (model_concept.h) and every model implementation depend on them and not on one
 * another (AI-Toolbox keeps such types in Types.hpp for the same reason).
 */
#pragma once

#include <cstdint>
#include <vector>

namespace krr {
namespace mdp {

/// @brief Index of a state (dense, 0..S-1).
using StateId = std::uint32_t;
/// @brief Index of an action (dense, 0..A-1).
using ActionId = std::uint32_t;

/// @brief One outcome of an action: a next state and its probability.
struct Outcome {
  StateId state = 0;
  double probability = 0.0;
};

/// @brief A discrete distribution over next states, as written to / read from the knowledge base.
using Distribution = std::vector<Outcome>;

}  // namespace mdp
}  // namespace krr
