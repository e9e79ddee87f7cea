#include "krr_core/experiments/nav_transfer.h"

#include <cmath>
#include <exception>
#include <utility>

#include "experiment_yaml.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/parallel.h"
#include "krr_core/common/random.h"
#include "krr_core/kb/simulated_navigation.h"
#include "krr_core/nav/blocking_rate.h"

namespace krr {
namespace experiments {

using kb::NavDomain;
using kb::NavigationKnowledge;
using kb::NavModel;
using kb::NavStateSpace;
using kb::SimulatedNavigation;

void NavTransferOptions::validate() const {
  auto bad = [](const std::string& f, const std::string& v) {
    throw ConfigError("nav transfer: field '" + f + "' has invalid value " + v);
  };
  nav::checkBlockingRate(blocking_rate, "nav transfer");
  const std::pair<const char*, const std::string*> places[] = {
      {"start", &start}, {"source", &source}, {"target", &target}};
  for (const auto& [field, value] : places)
    if (value->empty()) bad(field, "'' (no place: name one of the map's places)");
  if (source_episodes == 0) bad("source_episodes", "0");
  if (target_episodes == 0) bad("target_episodes", "0");
  if (convergence_episodes == 0) bad("convergence_episodes", "0");
  if (source == target) bad("target", target + " (same as source)");
  rmax.validate();
}

NavTransferOptions loadNavTransferOptions(const std::string& path,
                                          const NavTransferOptions& defaults) {
  const YAML::Node root = parseYaml(readFile(path), path);
  // Base settings (navigation.yaml: reward, R-Max, blocking rate), then the file's overrides
  // of them, then the experiment's own section.
  YamlSection top(root, path, "",
                  {"nav_transfer", "planning", "rmax_learning", "simulator", "context"});
  detail::ExperimentBase b = detail::experimentBase(path);
  if (!b.found) {
    b = detail::experimentBaseOf(defaults.rmax, defaults.blocking_rate, 0.99);
    b.time = defaults.time;
  }
  detail::readBaseOverrides(top, b, nav::RateUnset::kRefused);
  NavTransferOptions o = defaults;
  detail::applyRMax(b, o.rmax);
  o.blocking_rate = b.blocking_rate;
  o.time = b.time;
  YamlSection s(top.has("nav_transfer") ? top.get("nav_transfer") : YAML::Node(), path, "nav_transfer",
                {"start", "source", "target", "source_episodes", "convergence_episodes",
                 "target_episodes"});
  o.start = s.string("start", o.start);
  o.source = s.string("source", o.source);
  o.target = s.string("target", o.target);
  o.source_episodes = s.count("source_episodes", o.source_episodes, 1, 100000000);
  o.convergence_episodes = s.count("convergence_episodes", o.convergence_episodes, 1, 100000000);
  o.target_episodes = s.count("target_episodes", o.target_episodes, 1, 100000000);
  try {
    o.validate();
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
  return o;
}

NavTransferTrial runNavTransferTrial(const NavDomain& dom, NavigationKnowledge& knowledge,
                                     const NavTransferOptions& o, std::uint64_t seed,
                                     std::size_t index) {
  mdp::RMaxParams p = o.rmax;
  p.step_limit = static_cast<std::uint32_t>(dom.domain.step_limit);
  const nav::Context ctx = nav::Context::withRate(dom.simulator->timeOfDayIndex(o.time),
                                                  o.blocking_rate);
  const NavStateSpace& sp = *dom.space;
  const int start = dom.grid->placeCell(o.start);
  NavTransferTrial t;
  t.index = index;

  // 1. Procedure 1 on the source task (from scratch: the agent does not read the KB), then
  // extraction into the KB, replacing what an earlier trial of this thread wrote (anything
  // else learned is forgotten first).
  if (!knowledge.learnedAreas().empty() ||
      knowledge.learnedPairCount() != knowledge.learnedPairCount(o.time))
    knowledge.clearLearned();
  {
    SimulatedNavigation env(*dom.simulator, sp, start, {dom.grid->placeCell(o.source)}, ctx,
                            p.navigationReward());
    mdp::RMaxAgent agent = kb::makeNavigationAgent(dom, env, p, nullptr);
    Rng rng = makeRng(seed, "nav_transfer/source", index);
    t.source_episodes_run = kb::learnUntilConverged(env, agent, o.source_episodes,
                                                    o.convergence_episodes, rng, {}, nullptr);
    t.learned_pairs = knowledge.replaceLearned(agent.model().knownPairs(), o.time);
  }

  // 2. Procedure 2: the target task's model, computed by reasoning.
  const NavModel model = knowledge.buildModel({o.time}, p.discount);

  // 3. The target task with and without the extracted knowledge (same random stream).
  SimulatedNavigation env(*dom.simulator, sp, start, {dom.grid->placeCell(o.target)}, ctx,
                          p.navigationReward());
  for (int with = 1; with >= 0; --with) {
    mdp::RMaxAgent agent =
        kb::makeNavigationAgent(dom, env, p, with ? &model : nullptr,
                                with ? &t.prior_pairs : nullptr);
    Rng rng = makeRng(seed, "nav_transfer/target", index);
    auto& rewards = with ? t.reward_with : t.reward_without;
    auto& success = with ? t.success_with : t.success_without;
    for (const mdp::EpisodeResult& e :
         mdp::runEpisodes(env, agent, o.target_episodes, p.step_limit, p.rmax, rng)) {
      rewards.push_back(e.total_reward);
      success.push_back(e.success ? 1 : 0);
    }
  }
  return t;
}

std::vector<NavTransferTrial> runNavTransferTrials(const NavDomain& dom,
                                                   const NavTransferOptions& o,
                                                   std::uint64_t seed, std::size_t begin,
                                                   std::size_t count, std::size_t threads) {
  o.validate();
  if (count == 0) throw ConfigError("nav transfer: trials must be at least 1");
  return runParallelTrials<NavTransferTrial>(count, threads, [&]() {
    auto kb = std::make_shared<NavigationKnowledge>(*dom.grid, dom.knowledge_files);
    return [&, kb](std::size_t i) { return runNavTransferTrial(dom, *kb, o, seed, begin + i); };
  });
}

NavTransferSummary summarizeNavTransfer(const std::vector<NavTransferTrial>& results) {
  NavTransferSummary s;
  const std::size_t trials = results.size();
  s.trials = trials;
  if (trials == 0) return s;
  const std::size_t E = results.front().reward_with.size();
  for (const auto& r : results)
    if (r.reward_with.size() != E || r.reward_without.size() != E)
      throw ConfigError("nav transfer: trials with different numbers of episodes");
  auto meanCi = [&](auto get, std::vector<double>& mean, std::vector<double>& ci) {
    mean.assign(E, 0.0);
    ci.assign(E, 0.0);
    for (std::size_t e = 0; e < E; ++e) {
      double sum = 0, sq = 0;
      for (const auto& r : results) {
        const double v = get(r, e);
        sum += v;
        sq += v * v;
      }
      const double n = static_cast<double>(trials);
      mean[e] = sum / n;
      const double var = trials > 1 ? std::max(0.0, (sq - n * mean[e] * mean[e]) / (n - 1)) : 0.0;
      ci[e] = 1.959963984540054 * std::sqrt(var / n);
    }
  };
  std::vector<double> unused;
  meanCi([](const NavTransferTrial& r, std::size_t e) { return r.reward_with[e]; }, s.mean_with, s.ci_with);
  meanCi([](const NavTransferTrial& r, std::size_t e) { return r.reward_without[e]; }, s.mean_without, s.ci_without);
  meanCi([](const NavTransferTrial& r, std::size_t e) { return double(r.success_with[e]); }, s.success_with, unused);
  meanCi([](const NavTransferTrial& r, std::size_t e) { return double(r.success_without[e]); }, s.success_without, unused);
  for (const auto& r : results) {
    s.mean_learned_pairs += static_cast<double>(r.learned_pairs) / static_cast<double>(trials);
    s.mean_prior_pairs += static_cast<double>(r.prior_pairs) / static_cast<double>(trials);
    s.mean_source_episodes += static_cast<double>(r.source_episodes_run) / static_cast<double>(trials);
  }
  return s;
}

NavTransferSummary runNavTransfer(const NavDomain& dom, const NavTransferOptions& o,
                                  std::uint64_t seed, std::size_t trials, std::size_t threads) {
  return summarizeNavTransfer(runNavTransferTrials(dom, o, seed, 0, trials, threads));
}

}  // namespace experiments
}  // namespace krr
