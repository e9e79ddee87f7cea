#include "krr_core/experiments/new_circumstances.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <set>

#include "experiment_yaml.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/parallel.h"
#include "krr_core/common/random.h"
#include "krr_core/kb/free_time_learner.h"
#include "krr_core/mdp/reach_probability.h"
#include "krr_core/mdp/solvers.h"
#include "krr_core/nav/blocking_rate.h"

namespace krr {
namespace experiments {

using kb::FixedTaskSelector;
using kb::FreeTimeLearner;
using kb::FreeTimeOptions;
using kb::extractionFromString;
using kb::LeastKnownSelector;
using kb::NavDomain;
using kb::NavigationKnowledge;
using kb::NavModel;
using kb::NavStateSpace;
using kb::NavTask;
using kb::SimulatedNavigation;
using kb::TaskSelector;

void NewCircumstancesOptions::validate() const {
  auto bad = [](const std::string& f, const std::string& v) {
    throw ConfigError("new circumstances: field '" + f + "' has invalid value " + v);
  };
  if (start.empty()) bad("start", "'' (no place: name one of the map's places)");
  if (goal.empty()) bad("goal", "'' (no place: name one of the map's places)");
  if (start == goal) bad("goal", goal + " (same as start)");
  if (learn_times.size() < 2)
    bad("learn_times", "of " + std::to_string(learn_times.size()) +
                           " setting(s) (at least two are needed: the robot must not know which)");
  std::set<std::string> seen;
  for (const std::string& t : learn_times) {
    if (t.empty() || t.find_first_of(",+\" \t\n") != std::string::npos)
      bad("learn_times", "'" + t + "' (a time of day: no empty names, commas, '+' or spaces)");
    if (!seen.insert(t).second) bad("learn_times", t + " (listed twice)");
  }
  if (unknown_count < 2 || unknown_count > learn_times.size())
    bad("unknown_count", std::to_string(unknown_count) + " (expected 2.." +
                             std::to_string(learn_times.size()) +
                             ": the robot is in one of that many learned settings)");
  nav::checkBlockingRate(blocking_rate, "new circumstances", "blocking_rate",
                         nav::RateUnset::kAllowed);
  if (selector != "fixed" && selector != "least_known")
    bad("selector", "'" + selector + "' (expected fixed or least_known)");
  if (extraction != "pairs" && extraction != "areas")
    bad("extraction", "'" + extraction + "' (expected pairs or areas)");
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
  const YAML::Node root = parseYaml(readFile(path), path);
  if (root.IsMap() && root["new_circumstances"] && root["new_circumstances"].IsMap() &&
      root["new_circumstances"]["unknown_times"])
    throw ConfigError(path + ": field 'new_circumstances.unknown_times' is no longer read: the settings the robot "
                             "may be in are drawn per trial (use unknown_count)");
  // Base settings (navigation.yaml: reward and planning discount of the controllers, R-Max,
  // blocking rate), then the file's overrides of them, then the experiment's own section.
  YamlSection top(root, path, "", {"new_circumstances", "planning", "rmax_learning", "simulator"});
  detail::ExperimentBase b = detail::experimentBase(path);
  if (!b.found) b = detail::experimentBaseOf(defaults.rmax, defaults.blocking_rate, defaults.plan_discount);
  if (!b.found) b.planning.rmax = defaults.plan_rmax;
  detail::readBaseOverrides(top, b, nav::RateUnset::kAllowed);
  NewCircumstancesOptions o = defaults;
  detail::applyRMax(b, o.rmax);
  o.blocking_rate = b.blocking_rate;
  o.plan_discount = b.planning.discount;
  o.plan_rmax = b.planning.rmax;
  YamlSection s(top.has("new_circumstances") ? top.get("new_circumstances") : YAML::Node(), path, "new_circumstances",
                {"domain", "start", "goal", "learn_times", "unknown_count", "learning_runs",
                 "selector", "places", "extraction", "learn_tasks", "learn_episodes",
                 "convergence_episodes", "controller_step_cost"});
  o.domain = s.string("domain", o.domain);
  o.start = s.string("start", o.start);
  o.goal = s.string("goal", o.goal);
  o.learn_times = s.strings("learn_times", o.learn_times);
  o.unknown_count = s.count("unknown_count", o.unknown_count, 2, 1000);
  o.learning_runs = s.count("learning_runs", o.learning_runs, 0, 1000000);
  o.selector = s.string("selector", o.selector);
  o.places = s.strings("places", o.places);
  o.extraction = s.string("extraction", o.extraction);
  o.learn_tasks = s.count("learn_tasks", o.learn_tasks, 1, 1000000);
  o.learn_episodes = s.count("learn_episodes", o.learn_episodes, 1, 100000000);
  o.convergence_episodes = s.count("convergence_episodes", o.convergence_episodes, 1, 100000000);
  o.plan_step_cost = s.number("controller_step_cost", o.plan_step_cost, 0.0, 1e12);
  try {
    o.validate();
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
  return o;
}

std::vector<std::vector<std::size_t>> possibleSettingSets(const NewCircumstancesOptions& o) {
  o.validate();
  const std::size_t n = o.learn_times.size(), k = o.unknown_count;
  std::vector<std::vector<std::size_t>> out;
  std::vector<std::size_t> c(k);
  for (std::size_t i = 0; i < k; ++i) c[i] = i;
  while (true) {
    out.push_back(c);
    // Next combination in lexicographic order.
    std::size_t i = k;
    while (i > 0 && c[i - 1] == n - k + (i - 1)) --i;
    if (i == 0) break;
    ++c[i - 1];
    for (std::size_t j = i; j < k; ++j) c[j] = c[j - 1] + 1;
  }
  return out;
}

std::size_t learningRunOf(const NewCircumstancesOptions& o, std::size_t index) {
  return o.learning_runs == 0 ? index : index % o.learning_runs;
}

namespace {

std::size_t uniformIndex(Rng& g, std::size_t n) {
  return std::min(n - 1, static_cast<std::size_t>(uniform01(g) * static_cast<double>(n)));
}

}  // namespace

SettingDraw drawSettings(const NewCircumstancesOptions& o, std::uint64_t seed, std::size_t index) {
  const auto sets = possibleSettingSets(o);
  Rng g = makeRng(seed, "new_circumstances/setting", index);
  SettingDraw d;
  d.set = uniformIndex(g, sets.size());
  const std::vector<std::size_t>& s = sets[d.set];
  d.truth = s[uniformIndex(g, s.size())];
  d.pick = s[uniformIndex(g, s.size())];
  return d;
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
  return nav::Context::withRate(dom.simulator->timeOfDayIndex(time), br);
}

struct Endpoints {
  int start_cell, goal_cell;
  mdp::StateId start, goal;
};

Endpoints endpointsOf(const NavDomain& dom, const NewCircumstancesOptions& o) {
  Endpoints e;
  e.start_cell = dom.grid->placeCell(o.start);
  e.goal_cell = dom.grid->placeCell(o.goal);
  e.start = dom.space->stateOf(e.start_cell);
  e.goal = dom.space->stateOf(e.goal_cell);
  return e;
}

}  // namespace

LearnedControllers learnControllers(const NavDomain& dom, NavigationKnowledge& kb,
                                    const NewCircumstancesOptions& o, std::uint64_t seed,
                                    std::size_t run) {
  o.validate();
  const NavStateSpace& sp = *dom.space;
  const Endpoints ep = endpointsOf(dom, o);
  const std::size_t limit = static_cast<std::size_t>(dom.domain.step_limit);
  const std::size_t T = o.learn_times.size();
  for (const std::string& time : o.learn_times) dom.simulator->timeOfDayIndex(time);  // checks
  LearnedControllers lc;
  lc.run = run;

  // Procedure 1 in every setting; the KB collects what was learned, per time of day. A time's
  // knowledge is conditioned on curr_time = time, so it never enters another time's model.
  kb.clearLearned();
  for (const std::string& time : o.learn_times) {
    FreeTimeOptions fo;
    fo.extraction = extractionFromString(o.extraction);
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
      if (places.empty())  // every place of the site's map but the start
        for (const nav::Place& p : dom.grid->places())
          if (p.name != o.start) places.push_back(p.name);
      places.push_back(o.start);
      selector = std::make_unique<LeastKnownSelector>(places, o.start);
    }
    FreeTimeLearner learner(dom, kb, *selector, fo);
    Rng rng = makeRng(seed, "new_circumstances/learn/" + time, run);
    lc.learned_pairs.push_back(learner.run(rng, {}).pairs_extracted);
  }

  // Controllers from models the reasoner builds out of the KB (Procedure 2).
  for (const std::string& time : o.learn_times)
    lc.own.push_back(controllerOf(kb.buildModel({time}, o.plan_discount), sp, ep.goal, o));
  for (const auto& set : possibleSettingSets(o)) {
    std::vector<std::string> times;
    for (std::size_t k : set) times.push_back(o.learn_times[k]);
    lc.merged.push_back(controllerOf(kb.buildModel(times, o.plan_discount), sp, ep.goal, o));
  }

  // Exact success probability of every controller in every setting (true dynamics).
  const mdp::NavigationReward sim_reward{o.plan_step_cost, o.plan_rmax};
  lc.p_own.assign(T, std::vector<double>(T, 0.0));
  lc.p_merged.assign(lc.merged.size(), std::vector<double>(T, 0.0));
  for (std::size_t u = 0; u < T; ++u) {
    SimulatedNavigation env(*dom.simulator, sp, ep.start_cell, {ep.goal_cell},
                            contextOf(dom, o.learn_times[u], o.blocking_rate), sim_reward);
    const mdp::SparseModel truth = env.trueModel(1.0);
    for (std::size_t k = 0; k < T; ++k)
      lc.p_own[k][u] = mdp::reachProbability(truth, lc.own[k], {ep.goal}, limit)[ep.start];
    for (std::size_t m = 0; m < lc.merged.size(); ++m)
      lc.p_merged[m][u] = mdp::reachProbability(truth, lc.merged[m], {ep.goal}, limit)[ep.start];
  }
  return lc;
}

EpisodeOutcome runControllerEpisode(const NavDomain& dom, const NewCircumstancesOptions& o,
                                    const std::vector<mdp::ActionId>& policy, std::size_t setting,
                                    std::uint64_t seed, std::size_t index) {
  if (setting >= o.learn_times.size())
    throw ConfigError("new circumstances: setting index " + std::to_string(setting) +
                      " out of range (" + std::to_string(o.learn_times.size()) + " settings)");
  if (policy.size() != dom.space->numStates())
    throw ConfigError("new circumstances: controller has " + std::to_string(policy.size()) +
                      " states, the domain " + std::to_string(dom.space->numStates()));
  const Endpoints ep = endpointsOf(dom, o);
  const mdp::NavigationReward reward{o.plan_step_cost, o.plan_rmax};
  SimulatedNavigation env(*dom.simulator, *dom.space, ep.start_cell, {ep.goal_cell},
                          contextOf(dom, o.learn_times[setting], o.blocking_rate), reward);
  mdp::FixedPolicyAgent agent(policy);
  // Common random numbers: every controller of trial `index` meets the same walkers and slips.
  Rng rng = makeRng(seed, "new_circumstances/episode", index);
  const mdp::EpisodeResult r =
      mdp::runEpisode(env, agent, static_cast<std::size_t>(dom.domain.step_limit), o.plan_rmax, rng);
  return {r.success, r.steps};
}

NewCircumstancesTrial evaluateNewCircumstancesTrial(const NavDomain& dom,
                                                    const NewCircumstancesOptions& o,
                                                    const LearnedControllers& lc,
                                                    std::uint64_t seed, std::size_t index) {
  o.validate();
  const std::size_t T = o.learn_times.size();
  const auto sets = possibleSettingSets(o);
  if (lc.run != learningRunOf(o, index))
    throw ConfigError("new circumstances: trial " + std::to_string(index) + " uses learning run " +
                      std::to_string(learningRunOf(o, index)) + ", given run " +
                      std::to_string(lc.run));
  if (lc.own.size() != T || lc.merged.size() != sets.size() || lc.p_own.size() != T ||
      lc.p_merged.size() != sets.size() || lc.learned_pairs.size() != T)
    throw ConfigError("new circumstances: the learned controllers do not match the options (" +
                      std::to_string(lc.own.size()) + " settings, " +
                      std::to_string(lc.merged.size()) + " merged controllers; expected " +
                      std::to_string(T) + " and " + std::to_string(sets.size()) + ")");
  const SettingDraw d = drawSettings(o, seed, index);
  NewCircumstancesTrial t;
  t.index = index;
  t.learning_run = lc.run;
  for (std::size_t k : sets[d.set]) t.possible.push_back(o.learn_times[k]);
  t.setting = o.learn_times[d.truth];
  t.baseline_choice = o.learn_times[d.pick];

  // One episode per distinct controller, all from the trial's episode stream. The baseline and
  // the oracle *are* own controllers, so their episodes are those of the own controllers.
  const EpisodeOutcome merged = runControllerEpisode(dom, o, lc.merged[d.set], d.truth, seed, index);
  std::vector<EpisodeOutcome> own;
  for (std::size_t k = 0; k < T; ++k)
    own.push_back(runControllerEpisode(dom, o, lc.own[k], d.truth, seed, index));
  t.success_merged = merged.success;
  t.steps_merged = merged.steps;
  t.success_baseline = own[d.pick].success;
  t.steps_baseline = own[d.pick].steps;
  t.success_oracle = own[d.truth].success;
  t.steps_oracle = own[d.truth].steps;
  for (const EpisodeOutcome& e : own) t.success_own.push_back(e.success ? 1 : 0);

  t.p_merged = lc.p_merged[d.set][d.truth];
  t.p_baseline = lc.p_own[d.pick][d.truth];
  t.p_oracle = lc.p_own[d.truth][d.truth];
  for (std::size_t k = 0; k < T; ++k) {
    t.p_own.push_back(lc.p_own[k][d.truth]);
    t.p_self.push_back(lc.p_own[k][k]);
  }
  t.learned_pairs = lc.learned_pairs;
  return t;
}

NewCircumstancesTrial runNewCircumstancesTrial(const NavDomain& dom, NavigationKnowledge& kb,
                                               const NewCircumstancesOptions& o,
                                               std::uint64_t seed, std::size_t index) {
  const LearnedControllers lc = learnControllers(dom, kb, o, seed, learningRunOf(o, index));
  return evaluateNewCircumstancesTrial(dom, o, lc, seed, index);
}

namespace {

/// @brief Learning runs shared by the worker threads: each run is learned once, by the first
/// worker that needs it (the others wait for it), and never depends on which worker it was.
class RunCache {
 public:
  template <class Make>
  std::shared_ptr<const LearnedControllers> get(std::size_t run, Make make) {
    std::shared_ptr<Slot> slot;
    {
      std::lock_guard<std::mutex> lock(mu_);
      std::shared_ptr<Slot>& s = slots_[run];
      if (!s) s = std::make_shared<Slot>();
      slot = s;
    }
    std::lock_guard<std::mutex> lock(slot->mu);
    if (!slot->value) slot->value = std::make_shared<const LearnedControllers>(make());
    return slot->value;
  }

 private:
  struct Slot {
    std::mutex mu;
    std::shared_ptr<const LearnedControllers> value;
  };
  std::mutex mu_;
  std::map<std::size_t, std::shared_ptr<Slot>> slots_;
};

}  // namespace

std::vector<NewCircumstancesTrial> runNewCircumstances(const NavDomain& dom,
                                                       const NewCircumstancesOptions& o,
                                                       std::uint64_t seed, std::size_t begin,
                                                       std::size_t count, std::size_t threads) {
  o.validate();
  if (count == 0) throw ConfigError("new circumstances: trials must be at least 1");
  auto cache = std::make_shared<RunCache>();
  return runParallelTrials<NewCircumstancesTrial>(count, threads, [&, cache]() {
    auto kb = std::make_shared<NavigationKnowledge>(*dom.grid, dom.knowledge_files);
    return [&, kb, cache](std::size_t i) {
      const std::size_t index = begin + i, run = learningRunOf(o, index);
      if (o.learning_runs == 0) return runNewCircumstancesTrial(dom, *kb, o, seed, index);
      const auto lc = cache->get(run, [&] { return learnControllers(dom, *kb, o, seed, run); });
      return evaluateNewCircumstancesTrial(dom, o, *lc, seed, index);
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
      "trial,learning_run,possible_settings,true_setting,baseline_pick,success_merged,"
      "success_baseline,success_oracle";
  for (const std::string& t : o.learn_times) h += ",success_own_" + t;
  h += ",steps_merged,steps_baseline,steps_oracle,p_merged,p_baseline,p_oracle";
  for (const std::string& t : o.learn_times) h += ",p_own_" + t;
  for (const std::string& t : o.learn_times) h += ",p_self_" + t;
  for (const std::string& t : o.learn_times) h += ",learned_pairs_" + t;
  return h;
}

std::string newCircumstancesCsvRow(const NewCircumstancesTrial& t) {
  std::string possible;
  for (const std::string& s : t.possible) possible += (possible.empty() ? "" : "+") + s;
  std::string row = std::to_string(t.index) + "," + std::to_string(t.learning_run) + "," +
                    possible + "," + t.setting + "," + t.baseline_choice + "," +
                    (t.success_merged ? "1" : "0") + "," + (t.success_baseline ? "1" : "0") + "," +
                    (t.success_oracle ? "1" : "0");
  for (std::uint8_t s : t.success_own) row += s ? ",1" : ",0";
  row += "," + std::to_string(t.steps_merged) + "," + std::to_string(t.steps_baseline) + "," +
         std::to_string(t.steps_oracle);
  char buf[64];
  auto num = [&](double p) {
    std::snprintf(buf, sizeof(buf), ",%.6f", p);
    row += buf;
  };
  num(t.p_merged);
  num(t.p_baseline);
  num(t.p_oracle);
  for (double p : t.p_own) num(p);
  for (double p : t.p_self) num(p);
  for (std::size_t n : t.learned_pairs) row += "," + std::to_string(n);
  return row;
}

}  // namespace experiments
}  // namespace krr
