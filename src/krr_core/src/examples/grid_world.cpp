#include "krr_core/examples/grid_world.h"

#include <string>

#include "krr_core/common/errors.h"

namespace krr {
namespace examples {

using mdp::ActionId;
using mdp::GridDynamics;
using mdp::kFail;
using mdp::kStay;
using mdp::NavigationReward;
using mdp::StateId;
using mdp::StepResult;

GridWorldEnvironment::GridWorldEnvironment(GridDynamics dynamics, StateId start,
                                           std::vector<StateId> goals,
                                           const NavigationReward& reward)
    : dyn_(std::move(dynamics)), start_(start), goals_(std::move(goals)), reward_(reward) {
  dyn_.validate();
  reward_.validate();
  goal_.assign(dyn_.numCells() + 1, 0);
  for (StateId g : goals_) {
    if (g >= dyn_.numCells() || dyn_.blocked[g]) {
      throw ConfigError("GridWorldEnvironment: goal " + std::to_string(g) +
                        " is out of range or an obstacle");
    }
    goal_[g] = 1;
  }
  if (start_ >= dyn_.numCells() || dyn_.blocked[start_] || goal_[start_]) {
    throw ConfigError("GridWorldEnvironment: start " + std::to_string(start_) +
                      " is out of range, an obstacle or a goal");
  }
  state_ = start_;
}

StateId GridWorldEnvironment::reset() {
  state_ = start_;
  return state_;
}

StepResult GridWorldEnvironment::step(ActionId a, Rng& rng) {
  if (a >= 4) throw ConfigError("GridWorldEnvironment::step: action " + std::to_string(a) +
                                " out of range [0, 4)");
  StepResult r;
  if (state_ >= dyn_.numCells() || goal_[state_]) {  // already over: stay
    r.next = state_;
    r.done = true;
    r.failed = state_ == failureState();
    return r;
  }
  double u = uniform01(rng);
  unsigned slot = kStay;
  for (unsigned k = 0; k < 6; ++k) {
    const double p = dyn_.p(state_, a, k);
    if (p <= 0.0) continue;
    slot = k;
    u -= p;
    if (u < 0.0) break;
  }
  state_ = dyn_.target(state_, slot);
  r.next = state_;
  r.failed = slot == kFail;
  const bool goal = !r.failed && goal_[state_];
  r.done = r.failed || goal;
  r.reward = reward_.arrival(goal, r.failed);
  return r;
}

}  // namespace examples
}  // namespace krr
