#include "krr_core/common/parallel.h"
#include "krr_core/kb/new_circumstances.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>
#include <set>

#include "experiment_yaml.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"
#include "krr_core/kb/free_time_learner.h"
#include "krr_core/mdp/reach_probability.h"
#include "krr_core/mdp/solvers.h"

namespace krr {
namespace kb {

void NewCircumstancesOptions::validate() const {
  auto bad = [](const std::string& f, const std::string& v) {
    throw ConfigError("new circumstances: field '" + f + "' has invalid value " + v);
  };
  if (start == goal) bad("goal", goal + " (same as start)");
  if (learn_times.empty()) bad("learn_times", "[] (no setting to learn in)");
  std::set<std::string> seen;
  for (const std::string& t : learn_times)
    if (!seen.insert(t).second) bad("learn_times", t + " (listed twice)");
  if (unknown_times.empty()) bad("unknown_times", "[] (no possible setting)");
  std::set<std::string> useen;
  for (const std::string& t : unknown_times) {
    if (!seen.count(t)) bad("unknown_times", t + " (not a learned setting)");
    if (!useen.insert(t).second) bad("unknown_times", t + " (listed twice)");
  }
  if (!(blocking_rate <= 1)) bad("blocking_rate", std::to_string(blocking_rate));
  if (selector != "fixed" && selector != "least_known")
    bad("selector", "'" + selector + "' (expected fixed or least_known)");
  if (selector == "least_known" && places.empty()) bad("places", "[]");
  if (learn_tasks == 0) bad("learn_tasks", "0");
  if (learn_episodes == 0) bad("learn_episodes", "0");
  if (convergence_episodes == 0) bad("convergence_episodes", "0");
  if (!(plan_discount > 0 && plan_discount <= 1)) bad("plan.discount", std::to_string(plan_discount));
  if (!(plan_step_cost >= 0)) bad("plan.step_cost", std::to_string(plan_step_cost));
  if (!(plan_rmax > 0)) bad("plan.rmax", std::to_string(plan_rmax));
  rmax.validate();
}

NewCircumstancesOptions loadNewCircumstancesOptions(const std::string& path,
                                                    const NewCircumstancesOptions& defaults) {
  using detail::YamlSection;
  const YAML::Node root = detail::loadYamlFile(path);
  YamlSection s(root, path, "",
                {"domain", "start", "goal", "learn_times", "unknown_times", "blocking_rate", "selector",
                 "places", "learn_tasks", "learn_episodes", "convergence_episodes", "rmax",
                 "plan"});
  NewCircumstancesOptions o = defaults;
  o.domain = s.string("domain", o.domain);
  o.start = s.string("start", o.start);
  o.goal = s.string("goal", o.goal);
  o.learn_times = s.strings("learn_times", o.learn_times);
  o.unknown_times = s.strings("unknown_times", o.unknown_times);
  o.blocking_rate = s.number("blocking_rate", o.blocking_rate, -1.0, 1.0);
  o.selector = s.string("selector", o.selector);
  o.places = s.strings("places", o.places);
  o.learn_tasks = s.count("learn_tasks", o.learn_tasks, 1, 1000000);
  o.learn_episodes = s.count("learn_episodes", o.learn_episodes, 1, 100000000);
  o.convergence_episodes = s.count("convergence_episodes", o.convergence_episodes, 1, 100000000);
  detail::readRMax(s, "rmax", o.rmax);
  if (s.has("plan")) {
    YamlSection p(s.get("plan"), path, "plan", {"discount", "step_cost", "rmax"});
    o.plan_discount = p.number("discount", o.plan_discount, 1e-9, 1.0);
    o.plan_step_cost = p.number("step_cost", o.plan_step_cost, 0.0, 1e12);
    o.plan_rmax = p.number("rmax", o.plan_rmax, 1e-9, 1e12);
  }
  try {
    o.validate();
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
  return o;
}

namespace {

/// @brief The controller of a KB model: value iteration on the navigation task (goal +Rmax,
/// trapped -Rmax, step cost) over the model's dynamics.
std::vector<mdp::ActionId> controllerOf(const NavModel& model, const NavStateSpace& space,
                                        mdp::StateId goal, const NewCircumstancesOptions& o) {
  const mdp::NavigationReward reward{o.plan_step_cost, o.plan_rmax};
  const mdp::SparseModel task =
      mdp::makeNavigationTask(model.dynamics, {goal}, {space.trappedState()}, reward);
  mdp::SolverOptions so;
  so.epsilon = 1e-6;
  return mdp::valueIteration(task, so).policy;
}

nav::Context contextOf(const NavDomain& dom, const std::string& time, double br) {
  nav::Context c;
  c.time_of_day = dom.simulator->timeOfDayIndex(time);
  c.blocking_rate = br;
  return c;
}

}  // namespace

NewCircumstancesTrial runNewCircumstancesTrial(const NavDomain& dom, NavigationKnowledge& kb,
                                               const NewCircumstancesOptions& o,
                                               std::uint64_t seed, std::size_t index) {
  o.validate();
  const NavStateSpace& sp = *dom.space;
  const int start_cell = dom.grid->placeCell(o.start);
  const int goal_cell = dom.grid->placeCell(o.goal);
  const mdp::StateId start = sp.stateOf(start_cell), goal = sp.stateOf(goal_cell);
  const std::size_t limit = static_cast<std::size_t>(dom.domain.step_limit);
  NewCircumstancesTrial t;
  t.index = index;

  // 1. Procedure 1 in every setting; the KB collects what was learned, per time of day.
  kb.clearLearned();
  for (const std::string& time : o.learn_times) {
    FreeTimeOptions fo;
    fo.time = time;
    fo.blocking_rate = o.blocking_rate;
    fo.max_episodes_per_task = o.learn_episodes;
    fo.convergence_episodes = o.convergence_episodes;
    fo.max_tasks = o.learn_tasks;
    fo.rmax = o.rmax;
    std::unique_ptr<TaskSelector> selector;
    if (o.selector == "fixed") {
      selector = std::make_unique<FixedTaskSelector>(NavTask{o.start, o.goal});
    } else {
      std::vector<std::string> places = o.places;
      places.push_back(o.start);
      selector = std::make_unique<LeastKnownSelector>(places, o.start);
    }
    FreeTimeLearner learner(dom, kb, *selector, fo);
    Rng rng = makeRng(seed, "new_circumstances/learn/" + time, index);
    t.learned_pairs.push_back(learner.run(rng, {}).pairs_extracted);
  }

  // 2. Controllers from models the reasoner builds out of the KB (Procedure 2).
  std::vector<std::vector<mdp::ActionId>> own;
  for (const std::string& time : o.learn_times)
    own.push_back(controllerOf(kb.buildModel({time}, o.plan_discount), sp, goal, o));
  const std::vector<mdp::ActionId> merged =
      controllerOf(kb.buildModel(o.unknown_times, o.plan_discount), sp, goal, o);
  auto ownOf = [&](const std::string& time) -> const std::vector<mdp::ActionId>& {
    return own[static_cast<std::size_t>(
        std::find(o.learn_times.begin(), o.learn_times.end(), time) - o.learn_times.begin())];
  };
  for (const auto& pol : own) t.differs_from.push_back(pol[start] != merged[start] ? 1 : 0);

  // Exact success probability of a controller in a setting (simulator's true dynamics).
  const mdp::NavigationReward sim_reward{o.plan_step_cost, o.plan_rmax};
  auto exact = [&](const std::vector<mdp::ActionId>& policy, const std::string& time) {
    SimulatedNavigation env(*dom.simulator, sp, start_cell, {goal_cell},
                            contextOf(dom, time, o.blocking_rate), sim_reward);
    return mdp::reachProbability(env.trueModel(1.0), policy, {goal}, limit)[start];
  };
  for (std::size_t k = 0; k < o.learn_times.size(); ++k)
    t.p_self.push_back(exact(own[k], o.learn_times[k]));

  // 3. Evaluation: the true setting and the baseline's pick, uniformly among unknown_times.
  Rng pick = makeRng(seed, "new_circumstances/setting", index);
  const std::size_t U = o.unknown_times.size();
  t.setting = o.unknown_times[std::min(U - 1, static_cast<std::size_t>(uniform01(pick) * U))];
  t.baseline_choice = o.unknown_times[std::min(U - 1, static_cast<std::size_t>(uniform01(pick) * U))];
  const std::vector<mdp::ActionId>& baseline = ownOf(t.baseline_choice);
  const std::vector<mdp::ActionId>& oracle = ownOf(t.setting);
  SimulatedNavigation env(*dom.simulator, sp, start_cell, {goal_cell},
                          contextOf(dom, t.setting, o.blocking_rate), sim_reward);
  auto episode = [&](const std::vector<mdp::ActionId>& policy, std::size_t* steps) {
    mdp::FixedPolicyAgent agent(policy);
    // Common random numbers: every controller meets the same walkers.
    Rng rng = makeRng(seed, "new_circumstances/episode", index);
    const mdp::EpisodeResult r = mdp::runEpisode(env, agent, limit, o.plan_rmax, rng);
    if (steps) *steps = r.steps;
    return r.success;
  };
  t.success_merged = episode(merged, &t.steps_merged);
  t.success_baseline = episode(baseline, &t.steps_baseline);
  t.success_oracle = episode(oracle, nullptr);
  for (const std::string& u : o.unknown_times) {
    t.expected_merged += exact(merged, u) / static_cast<double>(U);
    for (const std::string& v : o.unknown_times)
      t.expected_baseline += exact(ownOf(v), u) / static_cast<double>(U * U);
  }
  t.p_merged = exact(merged, t.setting);
  t.p_baseline = exact(baseline, t.setting);
  t.p_oracle = exact(oracle, t.setting);
  return t;
}

std::vector<NewCircumstancesTrial> runNewCircumstances(const NavDomain& dom,
                                                       const NewCircumstancesOptions& o,
                                                       std::uint64_t seed, std::size_t begin,
                                                       std::size_t count, std::size_t threads) {
  o.validate();
  if (count == 0) throw ConfigError("new circumstances: trials must be at least 1");
  return runParallelTrials<NewCircumstancesTrial>(count, threads, [&]() {
    auto kb = std::make_shared<NavigationKnowledge>(*dom.grid, dom.knowledge_files);
    return [&, kb](std::size_t i) {
      return runNewCircumstancesTrial(dom, *kb, o, seed, begin + i);
    };
  });
}

MeanCi meanCi(const std::vector<double>& x) {
  MeanCi r;
  if (x.empty()) return r;
  const double n = static_cast<double>(x.size());
  double sum = 0;
  for (double v : x) sum += v;
  r.mean = sum / n;
  double sq = 0;
  for (double v : x) sq += (v - r.mean) * (v - r.mean);
  r.ci95 = x.size() > 1 ? 1.959963984540054 * std::sqrt(sq / (n - 1) / n) : 0.0;
  return r;
}

std::string newCircumstancesCsvHeader(const NewCircumstancesOptions& o) {
  std::string h =
      "trial,setting,baseline_choice,success_merged,success_baseline,success_oracle,"
      "steps_merged,steps_baseline,p_merged,p_baseline,p_oracle,expected_merged,"
      "expected_baseline";
  for (const std::string& t : o.learn_times) h += ",p_self_" + t;
  for (const std::string& t : o.learn_times) h += ",learned_pairs_" + t;
  for (const std::string& t : o.learn_times) h += ",merged_differs_" + t;
  return h;
}

std::string newCircumstancesCsvRow(const NewCircumstancesTrial& t) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%zu,%s,%s,%d,%d,%d,%zu,%zu,%.6f,%.6f,%.6f,%.6f,%.6f",
                t.index, t.setting.c_str(), t.baseline_choice.c_str(), t.success_merged ? 1 : 0,
                t.success_baseline ? 1 : 0, t.success_oracle ? 1 : 0, t.steps_merged,
                t.steps_baseline, t.p_merged, t.p_baseline, t.p_oracle, t.expected_merged,
                t.expected_baseline);
  std::string row = buf;
  for (double p : t.p_self) {
    std::snprintf(buf, sizeof(buf), ",%.6f", p);
    row += buf;
  }
  for (std::size_t n : t.learned_pairs) row += "," + std::to_string(n);
  for (std::uint8_t d : t.differs_from) row += d ? ",1" : ",0";
  return row;
}

}  // namespace kb
}  // namespace krr
