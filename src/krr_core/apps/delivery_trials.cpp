// delivery_trials: the paper's delivery experiment (Sec. IV, Table I), headless. Dialog with a
// simulated person, navigation in the blockage simulator, the redelivery rule; knowledge
// learned at the trial's br ("learned") or at 0.3 ("outdated"). One CSV row per trial; trial i
// depends only on (seed, i), never on --threads or --trial-begin.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resources.h"
#include "krr_core/dialog/delivery_experiment.h"
#include "krr_core/dialog/experiment_paths.h"

namespace {

const char* kUsage =
    "usage: delivery_trials --br B --condition learned|outdated --trials N [--trial-begin K]\n"
    "         --seed S [--threads T] [--domain office_30x30] [--learned-cache DIR|none]\n"
    "         [--out trials.csv] [--export-pomdp FILE] [--root DIR] [--outdated-br 0.3]\n"
    "         [--serve-cost none|expected|tasks] [--serve-cost-weight W]\n"
    "         [--solver-trials N] [--solver-timeout S]\n"
    "  One CSV row per trial (trial index first). reward = delivery (+80 fulfilled / -80)\n"
    "  - qa_cost - nav_cost (step cost x moves driven + failure penalty if a trip failed).\n"
    "  --learned-cache: learned knowledge and solved policies (default $KRR_CACHE_DIR or\n"
    "  ~/.cache/krr_rl/delivery); 'none' learns and solves in-process every run.\n";

struct Args {
  double br = -1;
  std::string condition;
  long trials = -1;
  std::size_t begin = 0, threads = 1;
  std::uint64_t seed = 0;
  bool have_seed = false;
  std::string domain = "office_30x30", cache, out, export_pomdp, root, serve_cost;
  bool have_cache = false;
  double outdated_br = 0.3, weight = -1, solver_timeout = -1;
  long solver_trials = -1;
};

double toNumber(const std::string& flag, const std::string& v) {
  return krr::parseNumberOption(flag, v);
}

std::size_t toCount(const std::string& flag, const std::string& v) {
  return krr::parseCountOption(flag, v);
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string f = argv[i];
    if (f == "-h" || f == "--help") {
      std::cout << kUsage;
      std::exit(0);
    }
    if (i + 1 >= argc) throw krr::ConfigError("option " + f + " needs a value");
    const std::string v = argv[++i];
    if (f == "--br") a.br = toNumber(f, v);
    else if (f == "--condition") a.condition = v;
    else if (f == "--trials") a.trials = static_cast<long>(toCount(f, v));
    else if (f == "--trial-begin") a.begin = toCount(f, v);
    else if (f == "--seed") a.seed = toCount(f, v), a.have_seed = true;
    else if (f == "--threads") a.threads = toCount(f, v);
    else if (f == "--domain") a.domain = v;
    else if (f == "--learned-cache") a.cache = v, a.have_cache = true;
    else if (f == "--out") a.out = v;
    else if (f == "--export-pomdp") a.export_pomdp = v;
    else if (f == "--root") a.root = v;
    else if (f == "--outdated-br") a.outdated_br = toNumber(f, v);
    else if (f == "--serve-cost") a.serve_cost = v;
    else if (f == "--serve-cost-weight") a.weight = toNumber(f, v);
    else if (f == "--solver-trials") a.solver_trials = static_cast<long>(toCount(f, v));
    else if (f == "--solver-timeout") a.solver_timeout = toNumber(f, v);
    else throw krr::ConfigError("unknown option " + f);
  }
  if (a.br < 0) throw krr::ConfigError("--br is required");
  if (a.condition.empty()) throw krr::ConfigError("--condition is required");
  if (a.trials < 0) throw krr::ConfigError("--trials is required");
  if (!a.have_seed) throw krr::ConfigError("--seed is required");
  if (a.threads == 0) throw krr::ConfigError("option --threads: must be at least 1");
  return a;
}

struct Mean {
  double sum = 0, sq = 0;
  std::size_t n = 0;
  void add(double v) { sum += v, sq += v * v, ++n; }
  double mean() const { return n ? sum / n : 0.0; }
  double ci() const {
    if (n < 2) return 0.0;
    const double m = mean();
    return 1.959963984540054 * std::sqrt(std::max(0.0, (sq - n * m * m) / (n - 1.0)) / n);
  }
};

}  // namespace

int main(int argc, char** argv) {
  Args a;
  try {
    a = parse(argc, argv);
  } catch (const krr::Error& e) {
    std::cerr << "delivery_trials: error: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    using namespace krr::dialog;
    DeliveryExperimentOptions o;
    o.blocking_rate = a.br;
    o.condition = conditionFromString(a.condition);
    o.outdated_rate = a.outdated_br;
    o.seed = a.seed;
    o.domain_name = a.domain;
    o.cache_dir = a.have_cache ? (a.cache == "none" ? "" : a.cache) : defaultCacheDir();
    o.validate();
    const ServeCostMode mode = a.serve_cost.empty() ? ServeCostMode::kTasks
                                                    : serveCostModeFromString(a.serve_cost);
    const ExperimentPaths paths = ExperimentPaths::find(a.root, a.domain);
    DialogConfig config = loadDialogConfig(paths.dialog_yaml);
    if (!a.serve_cost.empty()) config.serve_cost_mode = mode;
    if (a.weight >= 0) config.serve_cost_weight = a.weight;
    if (a.solver_trials >= 0) config.solver_max_trials = static_cast<std::size_t>(a.solver_trials);
    if (a.solver_timeout >= 0) config.solver_timeout = a.solver_timeout;
    config.validate();

    krr::Stopwatch clock;
    const krr::kb::NavDomain domain = krr::kb::NavDomain::load(
        paths.navigation_yaml, a.domain, paths.geometry, paths.navigation_plog);
    DeliveryExperiment ex(domain, config, o);
    const PreparationReport& p = ex.preparation();
    const double prepSeconds = clock.seconds();
    if (!a.export_pomdp.empty()) krr::writeFileAtomic(a.export_pomdp, ex.dialog().exportCassandra());

    clock.reset();
    const auto results = ex.runTrials(a.begin, static_cast<std::size_t>(a.trials), a.threads);
    const double trialSeconds = clock.seconds();
    if (!a.out.empty()) {
      std::ostringstream csv;
      csv << deliveryCsvHeader() << "\n";
      for (const auto& r : results) csv << deliveryCsvRow(ex.dialog(), r) << "\n";
      krr::writeFileAtomic(a.out, csv.str());
    }

    std::printf("delivery_trials: br %.3g, condition %s (knowledge learned at br %.3g: %zu pairs, "
                "%s %.1f s), seed %llu, serve cost %s x %g\n",
                a.br, a.condition.c_str(), p.knowledge_br, p.learning.pairs,
                p.learning.from_cache ? "cached" : "learned in", p.learning.seconds,
                static_cast<unsigned long long>(a.seed), toString(config.serve_cost_mode).c_str(),
                config.serve_cost_weight);
    std::printf("  P^N(shop, room) / P^N(room, shop):");
    for (std::size_t r = 0; r < ex.navigation().numRooms(); ++r)
      std::printf(" %s %.3f/%.3f", ex.navigation().options().rooms[r].c_str(),
                  ex.navigation().toRoom(r).reach, ex.navigation().toShop(r).reach);
    std::printf("\n  models: navigation %.3f s, dialog %.3f s; policy: %s", p.nav_model_seconds,
                p.dialog_model_seconds, p.policy_from_cache ? "cached" : "solved");
    if (!p.policy_from_cache)
      std::printf(" in %.1f s, %zu trials, bounds at b0 [%.2f, %.2f]%s", p.solve_seconds,
                  p.bounds.trials, p.bounds.lower, p.bounds.upper,
                  p.reproducible ? "" : " (stopped by the timeout: NOT reproducible)");
    std::printf(", %zu alpha vectors; preparation %.1f s\n", ex.policy().size(), prepSeconds);
    if (!results.empty()) {
      Mean reward, fulfilled, qa, turns, correct, entropy, nav;
      for (const auto& r : results) {
        reward.add(r.reward);
        fulfilled.add(r.fulfilled);
        qa.add(r.qa_cost);
        turns.add(r.turns);
        correct.add(r.correct);
        entropy.add(r.entropy);
        nav.add(r.nav_cost);
      }
      std::printf("  %zu trials [%zu, %zu): reward %.2f +- %.2f, fulfilled %.3f +- %.3f, "
                  "QA cost %.2f +- %.2f, turns %.2f, correct %.3f, entropy at serve %.3f, "
                  "nav cost %.1f (95%% CI)\n",
                  results.size(), a.begin, a.begin + results.size(), reward.mean(), reward.ci(),
                  fulfilled.mean(), fulfilled.ci(), qa.mean(), qa.ci(), turns.mean(),
                  correct.mean(), entropy.mean(), nav.mean());
      std::printf("  %.3f ms per trial (%zu threads)\n",
                  1000.0 * trialSeconds / static_cast<double>(results.size()), a.threads);
    }
    return 0;
  } catch (const krr::Error& e) {
    std::cerr << "delivery_trials: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "delivery_trials: error: " << e.what() << "\n";
    return 1;
  }
}
