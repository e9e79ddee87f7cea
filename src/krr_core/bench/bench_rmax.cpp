/**
 * @file bench_rmax.cpp
 * @brief R-Max on a 50x50 navigation grid (the paper's large domain, step limit 300):
 * 200 episodes, replanning on newly known pairs and every E = 10 steps, warm-started.
 * Target: < 0.2 s for the 200 episodes. Also prints the full-sweep (non-local) warm replanning
 * variant and the "with extraction" variant (all pairs pre-loaded as known priors).
 *
 * Usage: bench_rmax [EPISODES=200] [SEED=1] [M=5]
 */
#include <cstdio>
#include <string>

#include "krr_core/common/cli.h"
#include "krr_core/common/random.h"
#include "krr_core/common/resources.h"
#include "krr_core/examples/grid_world.h"
#include "krr_core/mdp/environment.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/rmax_agent.h"

using namespace krr;
using namespace krr::mdp;
using krr::examples::GridWorldEnvironment;

namespace {

void run(const char* name, const GridDynamics& dyn, StateId start, StateId goal,
         const RMaxParams& p, std::size_t episodes, std::uint64_t seed, bool priors) {
  GridWorldEnvironment env(dyn, start, {goal}, p.navigationReward());
  const StateId fail = env.failureState();
  RMaxAgent agent(makeNavigationRMaxTask(env.numStates(), 4, {goal}, {fail},
                                         p.navigationReward()),
                  p);
  if (priors) {  // knowledge extracted from a previous task: the true distributions
    for (StateId c = 0; c < dyn.numCells(); ++c) {
      if (dyn.blocked[c] || c == goal) continue;
      for (ActionId a = 0; a < 4; ++a) {
        Distribution d;
        for (unsigned k = 0; k < 6; ++k) {
          if (dyn.p(c, a, k) > 0.0) d.push_back(Outcome{dyn.target(c, k), dyn.p(c, a, k)});
        }
        agent.setPrior(c, a, d);
      }
    }
  }
  Rng rng = makeRng(seed, "bench_rmax");
  const double c0 = threadCpuSeconds();
  Stopwatch sw;
  std::vector<EpisodeResult> res = runEpisodes(env, agent, episodes, p.step_limit, p.rmax, rng);
  const double t = sw.seconds(), cpu = threadCpuSeconds() - c0;
  std::size_t steps = 0, late_success = 0, late = 0;
  double late_reward = 0.0;
  for (std::size_t e = 0; e < res.size(); ++e) {
    steps += res[e].steps;
    if (e + 50 >= res.size()) {
      ++late;
      late_success += res[e].success;
      late_reward += res[e].total_reward;
    }
  }
  const RMaxStats& st = agent.stats();
  std::printf("%-22s episodes %zu  steps %zu  replans %zu  backups %zu (%.1f sweeps-equiv)  "
              "known %zu  wall %.3f s  cpu %.3f s  last-50: success %.2f mean reward %.1f\n",
              name, res.size(), steps, st.replans, st.backups,
              static_cast<double>(st.backups) / static_cast<double>(agent.model().getS()),
              agent.model().numKnown(), t, cpu, late ? double(late_success) / late : 0.0,
              late ? late_reward / late : 0.0);
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t episodes = 200;
  std::uint64_t seed = 1;
  std::uint32_t m = 5;
  OptionParser cli("bench_rmax", "R-Max on a 50x50 navigation grid (step limit 300), with and\n"
                                 "without extraction; target: < 0.2 s for 200 episodes.");
  cli.positional("EPISODES", "episodes (default 200)",
                 [&](const std::string& v) { episodes = parseCountOption("EPISODES", v); });
  cli.positional("SEED", "seed (default 1)",
                 [&](const std::string& v) { seed = parseCountOption("SEED", v); });
  cli.positional("M", "known threshold (default 5)", [&](const std::string& v) {
    m = static_cast<std::uint32_t>(parseCountOption("M", v));
  });
  if (const auto status = cli.parse(argc, argv)) return *status;
  const std::uint32_t side = 50;
  const StateId start = 2 * side + 2, goal = (side - 3) * side + side - 3;
  RandomGridOptions o;
  o.obstacle_density = 0.1;
  GridDynamics dyn;
  for (std::uint64_t attempt = 0;; ++attempt) {  // first seeded grid where the goal is reachable
    Rng rng = makeRng(seed, "bench_rmax_grid", attempt);
    dyn = makeRandomGridDynamics(side, side, o, {start, goal}, rng);
    if (reachable(dyn, start)[goal]) break;
  }
  RMaxParams p;
  p.known_threshold = m;
  p.replan_every = 10;
  p.step_limit = 300;
  std::printf("# R-Max, %ux%u grid, M=%u, E=%u, gamma=%.2f, epsilon=%g, step limit %u\n", side,
              side, p.known_threshold, p.replan_every, p.discount, p.epsilon, p.step_limit);
  run("local warm replans", dyn, start, goal, p, episodes, seed, false);
  RMaxParams full = p;
  full.local_replanning = false;
  run("full warm replans", dyn, start, goal, full, episodes, seed, false);
  RMaxParams refine = p;
  refine.refine_known = true;
  run("local, refine_known", dyn, start, goal, refine, episodes, seed, false);
  run("with extraction", dyn, start, goal, p, episodes, seed, true);
  return 0;
}
