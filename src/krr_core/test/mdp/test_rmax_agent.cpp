#include <gtest/gtest.h>

#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/examples/grid_world.h"
#include "krr_core/mdp/environment.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/rmax_agent.h"
#include "krr_core/mdp/solvers.h"

namespace krr {
namespace mdp {
using examples::GridWorldEnvironment;
namespace {

constexpr std::uint32_t kW = 6, kH = 6;
constexpr StateId kStart = 0, kGoal = kW * kH - 1;

/// A small stochastic grid with one blocking area (trap probability 0.1) and its true model.
struct World {
  GridDynamics dyn;
  SparseModel truth;
  World() {
    Rng rng = makeRng(21, "rmax_world");
    RandomGridOptions o;
    o.obstacle_density = 0.1;
    o.trap_areas = 1;
    o.trap_size = 2;
    dyn = makeRandomGridDynamics(kW, kH, o, {kStart, kGoal}, rng);
    truth = makeNavigationGridModel(dyn, {kGoal}, NavigationReward(), 0.95).toSparse();
  }
  RMaxTask task() const {
    return makeNavigationRMaxTask(dyn.numCells() + 1, 4, {kGoal}, {kGoal + 1},
                                  NavigationReward());
  }
};

std::vector<ActionId> realPolicy(RMaxAgent& agent, std::size_t n) {
  std::vector<ActionId> pi = agent.policy();
  pi.resize(n);  // drop the optimistic state
  return pi;
}

TEST(RMaxAgent, ConvergesToTheOptimalPolicyOfTheTrueModel) {
  World w;
  ASSERT_TRUE(reachable(w.dyn, kStart)[kGoal]);
  RMaxParams p;
  p.known_threshold = 10;
  p.step_limit = 100;
  p.epsilon = 1e-3;
  RMaxAgent agent(w.task(), p);
  GridWorldEnvironment env(w.dyn, kStart, {kGoal}, NavigationReward());
  Rng rng = makeRng(21, "rmax_run");
  std::vector<EpisodeResult> res = runEpisodes(env, agent, 300, p.step_limit, p.rmax, rng);
  Solution opt = valueIteration(w.truth, SolverOptions());
  std::vector<double> v = evaluatePolicy(w.truth, realPolicy(agent, w.truth.getS()));
  // The learned policy's true value at the start is within 2% of Rmax of the optimum (the
  // model is estimated from M = 10 samples per pair, so near-ties can be broken wrongly).
  EXPECT_NEAR(v[kStart], opt.values[kStart], 0.02 * p.rmax);
  EXPECT_GT(v[kStart], 0.0);
  // Late episodes mostly succeed (success probability of the optimal policy is high here).
  int late_success = 0;
  for (std::size_t e = 200; e < res.size(); ++e) late_success += res[e].success;
  EXPECT_GT(late_success, 80);
  EXPECT_GT(agent.model().numKnown(), 20u);
}

TEST(RMaxAgent, LearnedProbabilitiesMatchTheTruthWithinSamplingError) {
  World w;
  RMaxParams p;
  p.known_threshold = 5;
  p.step_limit = 100;
  p.refine_known = true;  // keep estimating from every sample
  RMaxAgent agent(w.task(), p);
  GridWorldEnvironment env(w.dyn, kStart, {kGoal}, NavigationReward());
  Rng rng = makeRng(22, "rmax_run");
  runEpisodes(env, agent, 300, p.step_limit, p.rmax, rng);
  std::size_t checked = 0;
  for (const KnownPair& k : agent.model().knownPairs()) {
    if (k.samples < 50) continue;
    const double n = k.samples;
    for (StateId s1 = 0; s1 < w.truth.getS(); ++s1) {
      const double truth = w.truth.getTransitionProbability(k.state, k.action, s1);
      const double est = agent.model().getTransitionProbability(k.state, k.action, s1);
      // 4.5 standard errors (Bonferroni over a few thousand comparisons) plus one count.
      EXPECT_NEAR(est, truth, 4.5 * std::sqrt(truth * (1 - truth) / n) + 1.0 / n)
          << "pair (" << k.state << ", " << k.action << ") -> " << s1 << ", n=" << n;
    }
    ++checked;
  }
  EXPECT_GT(checked, 10u);
}

TEST(RMaxAgent, WarmStartedReplansTakeFewerIterationsThanColdOnes) {
  World w;
  RMaxParams p;
  p.known_threshold = 5;
  p.step_limit = 100;
  p.local_replanning = false;  // full warm-started sweeps
  RMaxAgent agent(w.task(), p);
  GridWorldEnvironment env(w.dyn, kStart, {kGoal}, NavigationReward());
  Rng rng = makeRng(23, "rmax_run");
  std::size_t warm_sweeps = 0, cold_sweeps = 0, replans = 0;
  for (int e = 0; e < 30; ++e) {
    StateId s = env.reset();
    for (std::uint32_t t = 0; t < p.step_limit; ++t) {
      const std::size_t before = agent.stats().sweeps, plans = agent.stats().replans;
      const ActionId a = agent.act(s);
      if (agent.stats().replans > plans && plans > 0) {  // a warm replan just happened
        warm_sweeps += agent.stats().sweeps - before;
        cold_sweeps += agent.solveCold().iterations;
        ++replans;
      }
      const StepResult r = env.step(a, rng);
      agent.observe(s, a, r.reward, r.next, r.done);
      s = r.next;
      if (r.done) break;
    }
  }
  ASSERT_GT(replans, 20u);
  EXPECT_LT(warm_sweeps * 2, cold_sweeps);  // at least twice cheaper on average
  // The warm-started plan is as accurate as a cold one.
  Solution cold = agent.solveCold();
  const std::vector<double>& v = agent.values();
  for (std::size_t s = 0; s < v.size(); ++s) EXPECT_NEAR(v[s], cold.values[s], p.epsilon);
}

TEST(RMaxAgent, LocalReplanningStaysEpsilonAccurateAndCostsLessThanASweep) {
  World w;
  RMaxParams p;
  p.known_threshold = 5;
  p.step_limit = 100;
  RMaxAgent agent(w.task(), p);
  GridWorldEnvironment env(w.dyn, kStart, {kGoal}, NavigationReward());
  Rng rng = makeRng(24, "rmax_run");
  runEpisodes(env, agent, 40, p.step_limit, p.rmax, rng);
  const RMaxStats st = agent.stats();
  ASSERT_GT(st.replans, 50u);
  const std::size_t s = agent.model().getS();
  // After the first (cold) plan, replans average fewer backups than one full sweep.
  const std::size_t first = agent.solveCold().iterations * s;
  EXPECT_LT(st.backups - std::min(st.backups, first), (st.replans - 1) * s);
  Solution cold = agent.solveCold();
  const std::vector<double>& v = agent.values();
  for (std::size_t i = 0; i < v.size(); ++i) EXPECT_NEAR(v[i], cold.values[i], 10 * p.epsilon);
}

TEST(RMaxAgent, PriorsFromTheKnowledgeBaseMakePairsKnownFromTheStart) {
  World w;
  RMaxParams p;
  p.epsilon = 1e-4;
  RMaxAgent agent(w.task(), p);
  // "With extraction": every pair's true distribution is pre-loaded as known.
  for (StateId s = 0; s + 1 < w.truth.getS(); ++s) {
    if (w.truth.isTerminal(s)) continue;
    for (ActionId a = 0; a < 4; ++a) {
      Distribution d;
      for (Outcome o : w.truth.successors(s, a)) d.push_back(o);
      agent.setPrior(s, a, d);
      EXPECT_TRUE(agent.model().isKnown(s, a));
    }
  }
  // Before any experience the plan is already the true optimal plan.
  Solution opt = valueIteration(w.truth, SolverOptions());
  std::vector<double> v = evaluatePolicy(w.truth, realPolicy(agent, w.truth.getS()));
  EXPECT_NEAR(v[kStart], opt.values[kStart], 1e-3);
  EXPECT_EQ(agent.stats().steps, 0u);
}

TEST(RMaxAgent, InvalidParametersThrowConfigErrorNamingTheField) {
  World w;
  auto expectField = [&](RMaxParams p, const std::string& field) {
    try {
      RMaxAgent a(w.task(), p);
      ADD_FAILURE() << "expected ConfigError for " << field;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  RMaxParams p;
  p.known_threshold = 0;
  expectField(p, "known_threshold");
  p = RMaxParams();
  p.rmax = -1;
  expectField(p, "rmax");
  p = RMaxParams();
  p.discount = 0.0;
  expectField(p, "discount");
  p = RMaxParams();
  p.discount = 1.5;
  expectField(p, "discount");
  p = RMaxParams();
  p.step_cost = 50.0;  // not below rmax
  expectField(p, "step_cost");
  p = RMaxParams();
  p.step_limit = 0;
  expectField(p, "step_limit");
  p = RMaxParams();
  p.epsilon = 0.0;
  expectField(p, "epsilon");
  p = RMaxParams();
  p.max_sweeps = 0;
  expectField(p, "max_sweeps");
  RMaxAgent ok(w.task(), RMaxParams());
  EXPECT_THROW(ok.act(9999), ConfigError);
}

}  // namespace
}  // namespace mdp
}  // namespace krr
