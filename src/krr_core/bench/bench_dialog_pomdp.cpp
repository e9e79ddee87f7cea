// Benchmark: the certified dialog solver (CertifiedDialogSolver) on the dialog models the
// experiments use (Table I: br 0.1 / 0.5 / 0.7 x learned / outdated knowledge, built from the
// knowledge base exactly as delivery_trials builds them).
//
// Usage: bench_dialog_pomdp [--timeout 60] [--trials 4000] [--seed 1] [--root DIR]
//                           [--learned-cache DIR|none] [--models 0.1:learned,0.7:outdated,node]
//                           [--export DIR] [--sarsop PATH]
// Per model (and dialog_node's: the knowledge base's navigation model, no learned knowledge),
// single-threaded and cold:
//  - the configured policy (config/dialog.yaml's solver budget, the robot's and the
//    experiments': to the certified precision): its certified bounds at the prior, solve time
//    and size;
//  - a fresh solve up to --timeout: bounds at checkpoints of solver time, the first time the
//    certified gap fell to <= 4, 2 and 1 reward, and the search's memory;
//  - the configured policy in --trials delivery trials: reward, expected reward,
//    identification and forced-serve rate (serves forced by the 20-turn limit);
//  - the robot's decision latency on the configured policy, on a plan and scanning (--trials
//    simulated dialogs, and a scan at up to 500 random beliefs: a turn's worst case);
//  - with --sarsop PATH: SARSOP (pomdpsol) on the same model with the turn counter in the state,
//    exported as Cassandra .pomdp, for the same --timeout; its last bounds line is printed.
// --export writes each model as Cassandra .pomdp, plain and with the turn counter.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/format.h"
#include "krr_core/common/resource_locator.h"
#include "krr_core/common/resources.h"
#include "krr_core/common/subprocess.h"
#include "krr_core/dialog/delivery_navigation.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/dialog/dialog_knowledge.h"
#include "krr_core/experiments/delivery_experiment.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/experiments/experiment_cli.h"
#include "krr_core/experiments/experiment_paths.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/turn_counter_model.h"
#include "krr_core/dialog/certified_dialog_solver.h"
#include "krr_core/dialog/dialog_policy.h"
#include "krr_core/dialog/dialog_session.h"
#include "krr_core/experiments/belief_entropy_survey.h"
#include "krr_core/common/random.h"

using namespace krr;
using namespace krr::dialog;
using namespace krr::experiments;

namespace {

/// @brief The model's header line (with P^N from the shop to each room) and, with --export,
/// its Cassandra files, plain and with the turn counter.
void modelHeader(const std::string& name, const DialogPomdp& d, const Eigen::VectorXd& reach,
                 int turnLimit, const std::string& exportDir) {
  std::printf("\n## %s: %zu states, %zu actions, P^N(shop, room):", name.c_str(),
              d.model().getS(), d.model().getA());
  for (Eigen::Index r = 0; r < reach.size(); ++r) std::printf(" %.3f", reach(r));
  std::printf("\n");
  if (exportDir.empty()) return;
  makeDirectories(exportDir);
  pomdp::saveCassandra(exportDir + "/dialog_" + name + ".pomdp", d.model());
  pomdp::saveCassandra(exportDir + "/dialog_" + name + "_turns.pomdp",
                       pomdp::withTurnCounter(d.model(), d.model().initialBelief(), turnLimit));
}

/// @brief The configured policy (solveDialogPolicy with `cfg`'s budget, uncached): its
/// certified bounds at the prior, time and size.
pomdp::TurnLimitedPolicy configuredPolicy(const std::string& name, const std::string& what,
                                          const DialogPomdp& d, const DialogConfig& cfg) {
  PolicyReport conf;
  pomdp::TurnLimitedPolicy policy = solveDialogPolicy(d, cfg, "", &conf);
  std::printf("# %s: configured policy (%s, %zu trials): lower %.3f upper %.3f gap %.3f in "
              "%.2f s, %zu vectors, stopped by %s\n", name.c_str(), what.c_str(),
              conf.bounds.trials, conf.bounds.lower, conf.bounds.upper, conf.bounds.gap(),
              conf.seconds, policy.size(),
              conf.reproducible ? (conf.converged ? "precision" : "trial budget") : "timeout");
  return policy;
}

/// @brief A fresh solve, cold, single-threaded: bounds at checkpoints of solver time, the
/// first times the gap fell to 4, 2 and 1, and the search's memory.
void freshSolve(const std::string& name, const DialogPomdp& d, double timeout) {
  const double checkpoints[] = {0.25, 0.5, 1, 2, 4, 8, 16, 32, 64, 128, 256};
  const double marks[] = {4.0, 2.0, 1.0};
  CertifiedSolverOptions so;
  so.precision = 1.0;  // the target gap at the prior
  so.timeout = timeout;
  so.maxTrials = 0;
  CertifiedDialogSolver solver(d, Eigen::VectorXd(), 0, so);
  double reached[3] = {-1, -1, -1};
  auto mark = [&](const CertifiedReport& r) {
    for (int k = 0; k < 3; ++k)
      if (reached[k] < 0 && r.gap() <= marks[k]) reached[k] = r.seconds;
  };
  std::printf("%9s %10s %10s %8s %9s %10s %10s %10s %9s\n", "time_s", "lower", "upper",
              "gap", "trials", "nodes", "expanded", "sub_nodes", "MiB");
  auto row = [&](const CertifiedReport& r) {
    std::printf("%9.3f %10.3f %10.3f %8.3f %9zu %10zu %10zu %10zu %9.1f\n", r.seconds, r.lower,
                r.upper, r.gap(), r.trials, r.nodes, r.expanded, r.subNodes, r.bytes / 1048576.0);
    std::fflush(stdout);
  };
  row(solver.report());
  mark(solver.report());
  std::size_t ck = 0;
  for (;;) {
    const bool done = solver.runTrials(100);
    const CertifiedReport r = solver.report();
    mark(r);
    if (done || r.stop != SolveStop::kRunning) {
      row(r);
      std::printf("# %s: stopped by %s; bounds crossed: %zu (0 unless a bound is wrong)\n",
                  name.c_str(), toString(r.stop), r.crossings);
      break;
    }
    while (ck < sizeof(checkpoints) / sizeof(checkpoints[0]) && r.seconds >= checkpoints[ck]) {
      if (ck + 1 == sizeof(checkpoints) / sizeof(checkpoints[0]) ||
          r.seconds < checkpoints[ck + 1])
        row(r);
      ++ck;
    }
  }
  for (int k = 0; k < 3; ++k) {
    if (reached[k] >= 0) std::printf("# %s: gap <= %g after %.3f s\n", name.c_str(), marks[k], reached[k]);
    else std::printf("# %s: gap <= %g not reached in %.1f s (gap %.3f)\n", name.c_str(), marks[k],
                     solver.report().seconds, solver.report().gap());
  }
  std::printf("# %s: search memory %.1f MiB (%zu nodes, %zu sub-dialog nodes), peak RSS so "
              "far %.1f MiB\n", name.c_str(), solver.report().bytes / 1048576.0,
              solver.report().nodes, solver.report().subNodes, peakRssMiB());
}

/// @brief SARSOP's pomdpsol on the model with the turn counter, for the same timeout: its last
/// bounds line.
void runSarsop(const std::string& name, const DialogPomdp& d, int turnLimit, double timeout,
               const std::string& sarsop, const std::string& exportDir) {
  const std::string dir = exportDir.empty() ? "/tmp/krr_bench_dialog" : exportDir;
  makeDirectories(dir);
  const std::string file = dir + "/dialog_" + name + "_turns.pomdp";
  pomdp::saveCassandra(file, pomdp::withTurnCounter(d.model(), d.model().initialBelief(),
                                                    turnLimit));
  // pomdpsol asserts a discount below 1. The model with the turn counter ends within
  // turn_limit + 1 steps, so 0.99999 moves no value by more than 2e-4 of its size.
  std::string sarsopNote;
  if (d.model().getDiscount() >= 1.0) {
    std::string text = readFile(file);
    const std::size_t at = text.find("discount:");
    if (at != std::string::npos) {
      const std::size_t eol = text.find('\n', at);
      text.replace(at, eol - at, "discount: 0.99999");
      writeFileAtomic(file, text);
      sarsopNote = " (its file with discount 0.99999: pomdpsol needs < 1)";
    }
  }
  // Its own time limit, with a minute's slack for its set-up and the end of its last backup.
  Subprocess sol({sarsop, "--timeout", formatNumber(timeout, 6), "--output", "/dev/null", file});
  sol.setStdout(Subprocess::Stream::pipe()).setStderr(Subprocess::Stream::pipe());
  std::string out, last;
  try {
    sol.start();
    const SubprocessResult r = sol.wait(timeout + 60.0);
    out = r.out + r.err;
  } catch (const SubprocessError& e) {
    out = std::string("cannot run it: ") + e.what();
  }
  // The last progress row of pomdpsol's table: time #Trial #Backup LBound UBound ...
  std::size_t pos = 0;
  while (pos < out.size()) {
    const std::size_t end = out.find('\n', pos);
    const std::string line = out.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
    double t, lb, ub;
    long tr, bk;
    if (std::sscanf(line.c_str(), " %lf %ld %ld %lf %lf", &t, &tr, &bk, &lb, &ub) == 5) last = line;
    if (end == std::string::npos) break;
    pos = end + 1;
  }
  if (last.empty()) last = "no bounds line in its output" + (out.empty() ? "" : ": " + out.substr(0, 200));
  std::printf("# %s: SARSOP %s, %.0f s%s: %s\n", name.c_str(), sarsop.c_str(), timeout,
              sarsopNote.c_str(), last.c_str());
}

/// @brief The policy in delivery trials: reward, expected reward, identification, forced serves.
void deliveryTrials(const std::string& name, DeliveryExperiment& ex, std::size_t trials) {
  const auto res = ex.runTrials(0, trials, 1);
  double reward = 0, sq = 0, exp = 0, esq = 0, forced = 0, correct = 0;
  for (const auto& r : res) {
    reward += r.reward.total();
    sq += r.reward.total() * r.reward.total();
    exp += r.expected_reward;
    esq += r.expected_reward * r.expected_reward;
    forced += r.delivery.forced;
    correct += r.correct;
  }
  const double n = static_cast<double>(res.size());
  const double mean = reward / n, emean = exp / n;
  const double ci = 1.96 * std::sqrt(std::max(0.0, sq / n - mean * mean) / n);
  const double eci = 1.96 * std::sqrt(std::max(0.0, esq / n - emean * emean) / n);
  std::printf("# %s: policy in %zu delivery trials: reward %.2f +- %.2f, expected reward "
              "%.2f +- %.2f, identified %.3f, forced serves %.4f%s\n", name.c_str(),
              res.size(), mean, ci, emean, eci, correct / n, forced / n,
              forced / n < 0.01 ? "" : "  (ABOVE 1%)");
}

/// @brief Quantiles of a sample (sorted in place): "median M ms, max X ms".
std::string latency(std::vector<double>& ms) {
  if (ms.empty()) return "none";
  std::sort(ms.begin(), ms.end());
  char buf[96];
  std::snprintf(buf, sizeof(buf), "%zu, median %.4f ms, max %.3f ms", ms.size(),
                ms[ms.size() / 2], ms.back());
  return buf;
}

/// @brief The robot's decision latency on the configured policy: each nextAction() of
/// `dialogs` simulated dialogs (answers drawn from the model), on a plan (no scan) or scanning
/// the policy; and a scan at random beliefs (Table II's sampler), which is what a belief the
/// search never reached costs the robot (the worst case of a turn).
void decisionLatency(const std::string& name, const DialogPomdp& d,
                     const pomdp::TurnLimitedPolicy& policy, std::size_t dialogs,
                     std::uint64_t seed) {
  std::vector<double> onPlan, scans, random;
  const pomdp::Model& m = d.model();
  DialogSession s(d, nullptr, &policy);
  for (std::size_t k = 0; k < dialogs; ++k) {
    Rng rng = makeRng(seed, "bench/latency", k);
    std::size_t truth = 0;
    for (double u = uniform01(rng); truth + 1 < d.numRequests(); ++truth)
      if ((u -= d.spec().prior(static_cast<Eigen::Index>(truth))) < 0) break;
    s.reset();
    for (;;) {
      const bool planned = s.plan() >= 0;
      const Stopwatch clock;
      const std::size_t a = s.nextAction();
      (planned ? onPlan : scans).push_back(1e3 * clock.seconds());
      if (d.isServe(a)) break;
      s.act(a);
      s.observe(a, std::get<1>(m.sampleSOR(truth, a, rng)));
    }
  }
  const BeliefEntropySurvey survey(d, policy, BeliefSamplerOptions{}, seed);
  for (std::size_t k = 0; k < std::min<std::size_t>(dialogs, 500); ++k) {
    const pomdp::Belief b = survey.belief(k);
    const Stopwatch clock;
    decideAction(d, policy, b, 0);
    random.push_back(1e3 * clock.seconds());
  }
  std::printf("# %s: decision latency (%zu vectors): on a plan %s; scans %s; scans at random "
              "beliefs %s\n", name.c_str(), policy.size(), latency(onPlan).c_str(),
              latency(scans).c_str(), latency(random).c_str());
}

}  // namespace

int main(int argc, char** argv) {
  double timeout = 60.0;
  std::size_t trials = 4000;
  std::uint64_t seed = 1;
  std::string root, cache, exportDir, sarsop;
  bool haveCache = false;
  std::vector<std::pair<double, KnowledgeCondition>> models;
  bool nodeModel = false;
  OptionParser cli("bench_dialog_pomdp",
                   "The certified dialog solver on the dialog models of Table I: bounds at the\n"
                   "prior over solver time, the configured policy in delivery trials.");
  cli.add("--timeout", "S", "solver seconds per model", &timeout);
  cli.add("--trials", "N", "delivery trials per model", &trials);
  cli.add("--seed", "S", "seed of learning and trials", &seed);
  cli.add("--root", "DIR", kRepositoryRootHelp, &root);
  cli.add("--learned-cache", "DIR|none", "learned knowledge; none: learn every run",
          [&](const std::string& v) { cache = v, haveCache = true; },
          "$KRR_CACHE_DIR or ~/.cache/krr_rl/delivery");
  cli.add("--models", "br:condition,...", "models to solve",
          [&](const std::string& v) {
            for (const std::string& item : splitOption(v)) {
              if (item == "node") {
                nodeModel = true;
                continue;
              }
              const auto colon = item.find(':');
              if (colon == std::string::npos)
                throw ConfigError("option --models: '" + item + "' is not br:condition");
              models.push_back({parseNumberOption("--models", item.substr(0, colon)),
                                conditionFromString(item.substr(colon + 1))});
            }
          },
          "0.1,0.5,0.7 x learned,outdated, and node (dialog_node's model)");
  cli.add("--export", "DIR", "write each model as Cassandra .pomdp (plain and with turns)",
          &exportDir);
  cli.add("--sarsop", "PATH", "also run SARSOP's pomdpsol on the model with turns (same timeout)",
          &sarsop);
  if (const auto status = cli.parse(argc, argv)) return *status;
  if (models.empty() && !nodeModel) {
    nodeModel = true;
    for (double br : {0.1, 0.5, 0.7})
      for (auto c : {KnowledgeCondition::kLearned, KnowledgeCondition::kOutdated}) models.push_back({br, c});
  }
  try {
    const ExperimentPaths paths = ExperimentPaths::find(root);
    const DialogConfig cfg = loadDeliveryExperimentConfig(paths);
    const kb::NavDomain dom = kb::NavDomain::load(paths.navigation_yaml, paths.domain,
                                                  paths.geometry, paths.navigation_plog);
    std::printf("# turn limit %d, precision %g (config/dialog.yaml), the configured trial budget "
                "%zu (0: none; config/dialog.yaml, or config/experiments/delivery_trials.yaml's "
                "solver block); solver timeout %g s per model; %zu delivery trials per model\n",
                cfg.turn_limit, cfg.solver_precision, cfg.solver_max_trials, timeout, trials);
    for (const auto& [br, condition] : models) {
      DeliveryExperimentOptions o;
      o.blocking_rate = br;
      o.condition = condition;
      o.seed = seed;
      o.domain_name = paths.domain;
      o.cache_dir = haveCache ? (cache == "none" ? "" : cache) : defaultCacheDir();
      DeliveryExperiment ex(dom, cfg, o, false);
      const DialogPomdp& d = ex.dialog();
      const std::string name = "br" + formatNumber(br, 3) + "_" + toString(condition);
      Eigen::VectorXd reach(static_cast<Eigen::Index>(ex.navigation().numRooms()));
      for (std::size_t r = 0; r < ex.navigation().numRooms(); ++r)
        reach(static_cast<Eigen::Index>(r)) = ex.navigation().toRoom(r).reach;
      modelHeader(name, d, reach, cfg.turn_limit, exportDir);
      ex.setPolicy(configuredPolicy(name, "the experiments'", d, cfg));
      decisionLatency(name, d, ex.policy(), trials, seed);
      freshSolve(name, d, timeout);
      if (!sarsop.empty()) runSarsop(name, d, cfg.turn_limit, timeout, sarsop, exportDir);
      if (trials > 0) deliveryTrials(name, ex, trials);
    }
    if (nodeModel) {
      // dialog_node's model (~model_source local or reasoner): the knowledge base's navigation
      // model (no learned knowledge) and config/dialog.yaml, whose solver budget is the
      // robot's (its provisional start policy is not measured here).
      const DialogConfig nodeCfg = loadDialogConfig(paths.dialog_yaml);
      kb::NavDomain nd = kb::NavDomain::load(paths.navigation_yaml, paths.domain, paths.geometry,
                                             paths.navigation_plog);
      nd.knowledge_files = {paths.geometry, paths.navigation_plog};
      kb::NavigationKnowledge nk(*nd.grid, nd.knowledge_files);
      const DialogKnowledge know(nodeCfg.office_plog, nodeCfg.speech_plog);
      const TripTable t = deliveryNavigationFromKnowledge(nd, nk, nodeCfg, know.base().rooms)->trips();
      const DialogPomdp d(know.buildSpec(t, nodeCfg));
      modelHeader("dialog_node", d, t.reachFromShop(), nodeCfg.turn_limit, exportDir);
      const pomdp::TurnLimitedPolicy nodePolicy =
          configuredPolicy("dialog_node", "config/dialog.yaml's, the robot's", d, nodeCfg);
      decisionLatency("dialog_node", d, nodePolicy, trials, seed);
      freshSolve("dialog_node", d, timeout);
      if (!sarsop.empty()) runSarsop("dialog_node", d, nodeCfg.turn_limit, timeout, sarsop, exportDir);
    }
    std::printf("\n# peak RSS %.1f MiB\n", peakRssMiB());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_dialog_pomdp: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
