// Benchmark: the turn-limited point-based solver on the dialog models the experiments use
// (Table I: br 0.1 / 0.5 / 0.7 x learned / outdated knowledge, built from the knowledge base
// exactly as delivery_trials builds them).
//
// Usage: bench_dialog_pomdp [--timeout 8] [--trials 2000] [--seed 1] [--root DIR]
//                           [--learned-cache DIR|none] [--models 0.1:learned,0.7:outdated]
//                           [--export DIR]
// Per model: bounds at the prior at checkpoints of solver time, the first time the certified
// gap fell to <= 4, 2 and 1 reward, the bounds at config/dialog.yaml's trial budget (the policy
// the experiments and dialog_node use) and that policy in --trials delivery trials: mean
// reward, identification rate and forced-serve rate (serves forced by the 20-turn limit).
// --export writes each model as Cassandra .pomdp, plain and with the turn counter in the
// state (pomdp::withTurnCounter), for comparisons with SARSOP.
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
#include "krr_core/experiments/delivery_experiment.h"
#include "krr_core/experiments/experiment_cli.h"
#include "krr_core/experiments/experiment_paths.h"
#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/turn_counter_model.h"
#include "krr_core/pomdp/turn_limited_solver.h"

using namespace krr;
using namespace krr::dialog;
using namespace krr::experiments;

int main(int argc, char** argv) {
  double timeout = 8.0;
  std::size_t trials = 2000;
  std::uint64_t seed = 1;
  std::string root, cache, exportDir;
  bool haveCache = false;
  std::vector<std::pair<double, KnowledgeCondition>> models;
  OptionParser cli("bench_dialog_pomdp",
                   "The turn-limited point-based solver on the dialog models of Table I: bounds\n"
                   "at the prior over solver time, the configured policy in delivery trials.");
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
              const auto colon = item.find(':');
              if (colon == std::string::npos)
                throw ConfigError("option --models: '" + item + "' is not br:condition");
              models.push_back({parseNumberOption("--models", item.substr(0, colon)),
                                conditionFromString(item.substr(colon + 1))});
            }
          },
          "0.1,0.5,0.7 x learned,outdated");
  cli.add("--export", "DIR", "write each model as Cassandra .pomdp (plain and with turns)",
          &exportDir);
  if (const auto status = cli.parse(argc, argv)) return *status;
  if (models.empty())
    for (double br : {0.1, 0.5, 0.7})
      for (auto c : {KnowledgeCondition::kLearned, KnowledgeCondition::kOutdated}) models.push_back({br, c});
  try {
    const ExperimentPaths paths = ExperimentPaths::find(root, "office_30x30");
    const DialogConfig cfg = loadDeliveryExperimentConfig(paths);
    const kb::NavDomain dom = kb::NavDomain::load(paths.navigation_yaml, "office_30x30",
                                                  paths.geometry, paths.navigation_plog);
    std::printf("# turn limit %d, precision %g, trial budget %zu (config/dialog.yaml); "
                "solver timeout %g s per model; %zu delivery trials per model\n",
                cfg.turn_limit, cfg.solver_precision, cfg.solver_max_trials, timeout, trials);
    const double checkpoints[] = {0.25, 0.5, 1, 2, 4, 8, 16, 32, 64, 128, 256};
    const double marks[] = {4.0, 2.0, 1.0};
    for (const auto& [br, condition] : models) {
      DeliveryExperimentOptions o;
      o.blocking_rate = br;
      o.condition = condition;
      o.seed = seed;
      o.cache_dir = haveCache ? (cache == "none" ? "" : cache) : defaultCacheDir();
      DeliveryExperiment ex(dom, cfg, o, false);
      const DialogPomdp& d = ex.dialog();
      const std::string name = "br" + formatNumber(br, 3) + "_" + toString(condition);
      std::printf("\n## %s: %zu states, %zu actions, P^N(shop, room):", name.c_str(),
                  d.model().getS(), d.model().getA());
      for (std::size_t r = 0; r < ex.navigation().numRooms(); ++r)
        std::printf(" %.3f", ex.navigation().toRoom(r).reach);
      std::printf("\n");
      if (!exportDir.empty()) {
        makeDirectories(exportDir);
        pomdp::saveCassandra(exportDir + "/dialog_" + name + ".pomdp", d.model());
        pomdp::saveCassandra(exportDir + "/dialog_" + name + "_turns.pomdp",
                             pomdp::withTurnCounter(d.model(), d.model().initialBelief(), cfg.turn_limit));
      }
      // The configured solve (what solveDialogPolicy runs), then on to the timeout.
      pomdp::TurnLimitedSolverOptions so = dialogSolverOptions(cfg);
      so.timeout = 1e9;
      pomdp::TurnLimitedSolver solver(d.model(), d.model().initialBelief(), cfg.turn_limit, so);
      solver.solve();
      const pomdp::BoundsReport budget = solver.report();
      ex.setPolicy(solver.policy());
      solver.setMaxTrials(0);
      double reached[3] = {-1, -1, -1};
      auto mark = [&](const pomdp::BoundsReport& r) {
        for (int k = 0; k < 3; ++k)
          if (reached[k] < 0 && r.gap() <= marks[k]) reached[k] = r.time;
      };
      mark(budget);
      std::printf("%9s %10s %10s %8s %8s %8s\n", "time_s", "lower", "upper", "gap", "trials", "vectors");
      std::printf("%9.3f %10.3f %10.3f %8.3f %8zu %8zu   <- configured budget\n", budget.time,
                  budget.lower, budget.upper, budget.gap(), budget.trials, budget.alphas);
      for (double ck : checkpoints) {
        if (ck > timeout) break;
        if (ck <= solver.report().time) continue;
        while (solver.report().time < ck && !solver.converged()) {
          solver.runUntil(std::min(ck, solver.report().time + 0.05));
          mark(solver.report());
        }
        const auto r = solver.report();
        std::printf("%9.3f %10.3f %10.3f %8.3f %8zu %8zu\n", r.time, r.lower, r.upper, r.gap(),
                    r.trials, r.alphas);
        std::fflush(stdout);
        if (solver.converged()) break;
      }
      for (int k = 0; k < 3; ++k) {
        if (reached[k] >= 0) std::printf("# %s: gap <= %g after %.3f s\n", name.c_str(), marks[k], reached[k]);
        else std::printf("# %s: gap <= %g not reached in %.1f s (gap %.3f)\n", name.c_str(), marks[k],
                         solver.report().time, solver.report().gap());
      }
      const auto res = ex.runTrials(0, trials, 1);
      double reward = 0, sq = 0, forced = 0, correct = 0;
      for (const auto& r : res) {
        reward += r.reward.total();
        sq += r.reward.total() * r.reward.total();
        forced += r.delivery.forced;
        correct += r.correct;
      }
      const double n = static_cast<double>(res.size());
      const double mean = reward / n;
      const double ci = 1.96 * std::sqrt(std::max(0.0, sq / n - mean * mean) / n);
      std::printf("# %s: configured policy in %zu trials: reward %.2f +- %.2f, identified %.3f, "
                  "forced serves %.4f%s\n", name.c_str(), res.size(), mean, ci, correct / n,
                  forced / n, forced / n < 0.01 ? "" : "  (ABOVE 1%)");
    }
    std::printf("\n# peak RSS %.1f MiB\n", peakRssMiB());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_dialog_pomdp: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
