// delivery_trials: the paper's delivery experiment (Sec. IV, Table I), headless. The robot's
// DeliveryManager with a simulated person and the blockage simulator; knowledge learned at the
// trial's br ("learned") or at 0.3 ("outdated"). One CSV row per trial; trial i depends only
// on (seed, i), never on --threads or --trial-begin.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resources.h"
#include "krr_core/dialog/delivery_experiment.h"
#include "krr_core/dialog/experiment_cli.h"

namespace {

const char* kUsage =
    "usage: delivery_trials --trials N [--export-pomdp FILE]\n"
    "                       (shared options below)\n";
const char* kHelp =
    "  One CSV row per trial (trial index first). reward = +80 fulfilled / -80, minus the\n"
    "  questions' costs, the navigation cost driven and the wrong-delivery penalty\n"
    "  (config/dialog.yaml, serve_cost). policy_lower / policy_upper: the certified bounds of\n"
    "  the dialog policy at the prior. --learned-cache: learned knowledge and solved policies\n"
    "  (default $KRR_CACHE_DIR or ~/.cache/krr_rl/delivery); 'none' learns and solves every run.\n";

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
  krr::dialog::ExperimentCli cli;
  long trials = -1;
  std::string exportPomdp;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string f = argv[i];
      if (f == "-h" || f == "--help") {
        std::cout << kUsage << krr::dialog::kExperimentCliUsage << kHelp;
        return 0;
      }
      if (i + 1 >= argc) throw krr::ConfigError("option " + f + " needs a value");
      const std::string v = argv[++i];
      if (cli.take(f, v)) continue;
      if (f == "--trials") trials = static_cast<long>(krr::parseCountOption(f, v));
      else if (f == "--export-pomdp") exportPomdp = v;
      else throw krr::ConfigError("unknown option " + f);
    }
    if (trials < 0) throw krr::ConfigError("--trials is required");
    cli.finish();
  } catch (const krr::Error& e) {
    std::cerr << "delivery_trials: error: " << e.what() << "\n" << kUsage << krr::dialog::kExperimentCliUsage;
    return 2;
  }
  try {
    using namespace krr::dialog;
    const ExperimentPaths paths = cli.paths();
    const DialogConfig config = cli.config(paths);
    krr::Stopwatch clock;
    const krr::kb::NavDomain domain = krr::kb::NavDomain::load(
        paths.navigation_yaml, cli.experiment.domain_name, paths.geometry, paths.navigation_plog);
    DeliveryExperiment ex(domain, config, cli.experiment);
    const PreparationReport& p = ex.preparation();
    const double prepSeconds = clock.seconds();
    if (!exportPomdp.empty()) krr::writeFileAtomic(exportPomdp, ex.dialog().exportCassandra());

    clock.reset();
    const auto results = ex.runTrials(cli.begin, static_cast<std::size_t>(trials), cli.threads);
    const double trialSeconds = clock.seconds();
    if (!cli.out.empty()) {
      std::ostringstream csv;
      csv << deliveryCsvHeader() << "\n";
      for (const auto& r : results) csv << deliveryCsvRow(ex.dialog(), r, p.policy.bounds) << "\n";
      krr::writeFileAtomic(cli.out, csv.str());
    }
    std::printf("delivery_trials: br %.3g, condition %s (knowledge learned at br %.3g: %zu pairs, "
                "%s %.1f s), seed %llu, serve cost %s x %g, wrong delivery %g\n",
                cli.experiment.blocking_rate, toString(cli.experiment.condition).c_str(),
                p.knowledge_br, p.learning.pairs, p.learning.from_cache ? "cached" : "learned in",
                p.learning.seconds, static_cast<unsigned long long>(cli.experiment.seed),
                toString(config.serve_cost_mode).c_str(), config.serve_cost_weight,
                config.wrong_delivery_penalty);
    std::printf("  P^N(shop, room) / P^N(room, shop):");
    for (std::size_t r = 0; r < ex.navigation().numRooms(); ++r)
      std::printf(" %s %.3f/%.3f", ex.navigation().options().rooms[r].c_str(),
                  ex.navigation().toRoom(r).reach, ex.navigation().toShop(r).reach);
    const PolicyReport& pol = p.policy;
    std::printf("\n  models: navigation %.3f s, dialog %.3f s; policy: %s in %.2f s, bounds at the "
                "prior [%.2f, %.2f] (gap %.2f, %zu trials%s), %zu vectors; preparation %.1f s\n",
                p.nav_model_seconds, p.dialog_model_seconds, pol.from_cache ? "cached" : "solved",
                pol.seconds, pol.bounds.lower, pol.bounds.upper, pol.bounds.gap(),
                pol.bounds.trials, pol.reproducible ? "" : ", stopped by the timeout: NOT reproducible",
                ex.policy().size(), prepSeconds);
    if (!results.empty()) {
      Mean reward, fulfilled, qa, turns, correct, entropy, forced;
      for (const auto& r : results) {
        reward.add(r.reward.total());
        fulfilled.add(r.fulfilled);
        qa.add(r.delivery.qa_cost);
        turns.add(r.delivery.turns);
        correct.add(r.correct);
        entropy.add(r.delivery.entropy);
        forced.add(r.delivery.forced);
      }
      std::printf("  %zu trials [%zu, %zu): reward %.2f +- %.2f, fulfilled %.3f +- %.3f, "
                  "QA cost %.2f +- %.2f, turns %.2f, identified %.3f, entropy at serve %.3f, "
                  "forced serves %.4f (95%% CI)\n",
                  results.size(), cli.begin, cli.begin + results.size(), reward.mean(), reward.ci(),
                  fulfilled.mean(), fulfilled.ci(), qa.mean(), qa.ci(), turns.mean(),
                  correct.mean(), entropy.mean(), forced.mean());
      std::printf("  %.3f ms per trial (%zu threads)\n",
                  1000.0 * trialSeconds / static_cast<double>(results.size()), cli.threads);
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "delivery_trials: error: " << e.what() << "\n";
    return 1;
  }
}
