#include "krr_core/kb/simulated_navigation.h"

#include "krr_core/common/errors.h"

namespace krr {
namespace kb {

SimulatedNavigation::SimulatedNavigation(const nav::BlockageSimulator& sim,
                                         const NavStateSpace& space, int start_cell,
                                         const std::vector<int>& goal_cells,
                                         const nav::Context& context,
                                         const mdp::NavigationReward& reward)
    : sim_(sim), space_(space), start_(space.stateOf(start_cell)),
      is_goal_(space.numStates(), 0), context_(context), reward_(reward) {
  reward_.validate();
  if (goal_cells.empty()) throw ConfigError("navigation task: no goal cell");
  for (int c : goal_cells) {
    goals_.push_back(space.stateOf(c));
    is_goal_[goals_.back()] = 1;
  }
  if (is_goal_[start_]) throw ConfigError("navigation task: the start cell " +
                                          std::to_string(start_cell) + " is a goal");
}

mdp::StateId SimulatedNavigation::reset() {
  cell_ = space_.cellOf(start_);
  return start_;
}

mdp::StepResult SimulatedNavigation::step(mdp::ActionId a, Rng& rng) {
  if (a >= 4) throw ConfigError("navigation: action " + std::to_string(a) + " is not a move");
  const nav::Outcome o = sim_.step(cell_, static_cast<int>(a), context_, rng);
  mdp::StepResult r;
  if (o.trapped) {
    r.next = space_.trappedState();
    r.done = r.failed = true;
    r.reward = reward_.arrival(false, true);
    return r;
  }
  cell_ = o.cell;
  r.next = space_.stateOf(o.cell);
  r.done = is_goal_[r.next] != 0;
  r.reward = reward_.arrival(r.done, false);
  return r;
}

mdp::SparseModel SimulatedNavigation::trueModel(double discount) const {
  return trueDynamics(sim_, space_, context_, discount);
}

mdp::SparseModel trueDynamics(const nav::BlockageSimulator& sim, const NavStateSpace& space,
                              const nav::Context& context, double discount) {
  mdp::SparseModelBuilder b(space.numStates(), 4, discount);
  for (mdp::StateId s = 0; s < space.trappedState(); ++s) {
    for (int a = 0; a < 4; ++a) {
      for (const auto& [c, p] : sim.trueDistribution(space.cellOf(s), a, context)) {
        const mdp::StateId s1 = c == sim.trappedState() ? space.trappedState() : space.stateOf(c);
        b.addTransition(s, static_cast<mdp::ActionId>(a), s1, p);
      }
    }
  }
  b.setTerminal(space.trappedState());
  return b.build();
}

}  // namespace kb
}  // namespace krr
