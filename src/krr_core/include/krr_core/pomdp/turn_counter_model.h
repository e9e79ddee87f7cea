/**
 * @file turn_counter_model.h
 * @brief The turn-limited dialog problem (dialog::CertifiedDialogSolver) written as an ordinary discounted
 * POMDP with the turn count in the state, for comparisons with other solvers (our
 * PointBasedSolver, SARSOP through a Cassandra .pomdp file).
 *
 * States are (s, t) for t = 0..turnLimit ("name_t<t>"). A continuing action (one that does not
 * lead only to terminal states) moves (s, t) to (s', t + 1) with the model's probabilities;
 * at t = turnLimit it is not allowed: it ends the episode (in the first terminal state) with
 * a reward below every ending action's, so no optimal policy takes it. Terminal states stay
 * absorbing with zero reward. The value at the initial belief (turn 0) equals the
 * finite-horizon value V_0(b0) that the turn-limited solver bounds. Dense: (S (L + 1))^2 entries
 * per action, meant for exports and tests, not for the robot.
 */
#pragma once

#include "krr_core/pomdp/model.h"

namespace krr {
namespace pomdp {

/// @brief The model with a turn counter (see the file comment), initial belief b0 at turn 0.
/// @throws ConfigError for a negative limit, a model without an ending action, or a bad b0.
Model withTurnCounter(const Model& model, const Belief& b0, int turnLimit);

}  // namespace pomdp
}  // namespace krr
