#include "krr_core/kb/navigation_learning.h"

#include <cstdint>
#include <vector>

namespace krr {
namespace kb {

mdp::RMaxAgent makeNavigationAgent(const NavDomain& dom, const SimulatedNavigation& env,
                                   const mdp::RMaxParams& p, const NavModel* kb_model,
                                   std::size_t* prior_pairs) {
  const NavStateSpace& sp = *dom.space;
  auto task = mdp::makeNavigationRMaxTask(sp.numStates(), 4, env.goals(), {sp.trappedState()},
                                          p.navigationReward());
  mdp::RMaxAgent agent(task, p);
  std::size_t n = 0;
  if (kb_model) {
    std::vector<std::uint8_t> goal(sp.numStates(), 0);
    for (mdp::StateId g : env.goals()) goal[g] = 1;
    for (mdp::StateId s = 0; s < sp.trappedState(); ++s) {
      if (goal[s]) continue;  // terminal in this task: nothing to learn there
      for (mdp::ActionId a = 0; a < 4; ++a) {
        if (!kb_model->learned[s * 4 + a]) continue;
        mdp::Distribution d;
        for (mdp::Outcome out : kb_model->dynamics.successors(s, a)) d.push_back(out);
        agent.setPrior(s, a, d, true);
        ++n;
      }
    }
  }
  if (prior_pairs) *prior_pairs = n;
  return agent;
}

std::size_t learnUntilConverged(SimulatedNavigation& env, mdp::RMaxAgent& agent,
                                std::size_t max_episodes, std::size_t quiet_episodes, Rng& rng,
                                const std::function<bool()>& interrupted, bool* converged) {
  const std::uint32_t limit = agent.params().step_limit;
  std::size_t run = 0, quiet = 0;
  while (run < max_episodes && quiet < quiet_episodes && !(interrupted && interrupted())) {
    const std::size_t before = agent.model().numKnown();
    mdp::runEpisode(env, agent, limit, agent.params().rmax, rng);
    ++run;
    quiet = agent.model().numKnown() == before ? quiet + 1 : 0;
  }
  if (converged) *converged = quiet >= quiet_episodes;
  return run;
}

}  // namespace kb
}  // namespace krr
