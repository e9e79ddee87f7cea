// bench_delivery: timings of the delivery pipeline on the office domain. Prints the time to
// reason out the dialog knowledge (prior + speech model: 30 requests x 13 queries), to build
// the navigation model from the knowledge base (Procedure 2) with the robot's policies and P^N,
// to build the dialog POMDP (T^D + serve costs), to solve it, and per delivery trial.
// usage: bench_delivery [--root DIR] [--br 0.3] [--trials 2000] [--solver-trials N]
#include <cstdio>
#include <string>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/resource_locator.h"
#include "krr_core/common/resources.h"
#include "krr_core/experiments/delivery_experiment.h"
#include "krr_core/experiments/experiment_cli.h"
#include "krr_core/experiments/experiment_paths.h"

int main(int argc, char** argv) {
  using namespace krr;
  using namespace krr::dialog;
  using namespace krr::experiments;
  std::string root;
  double br = 0.3;
  std::size_t trials = 2000, solverTrials = 0;  // 0: the config's budget
  OptionParser cli("bench_delivery",
                   "Timings of the delivery pipeline on the office domain: dialog knowledge by\n"
                   "reasoning, the navigation model (Procedure 2), the dialog POMDP, its solution\n"
                   "and one delivery trial.");
  cli.add("--root", "DIR", kRepositoryRootHelp, &root);
  cli.add("--br", "B", "blocking rate of the trials", &br);
  cli.add("--trials", "N", "delivery trials timed", &trials);
  cli.add("--solver-trials", "N", "solver trial budget", &solverTrials)
      .defaultText("config/dialog.yaml's");
  if (const auto status = cli.parse(argc, argv)) return *status;
  try {
    const ExperimentPaths paths = ExperimentPaths::find(root);
    DialogConfig cfg = loadDeliveryExperimentConfig(paths);
    if (solverTrials > 0) cfg.solver_max_trials = solverTrials;
    const kb::NavDomain dom = kb::NavDomain::load(paths.navigation_yaml, paths.domain,
                                                  paths.geometry, paths.navigation_plog);
    const int reps = 5;
    double tKnowledge = 0, tNav = 0, tSpec = 0;
    std::unique_ptr<DialogKnowledge> k;
    std::unique_ptr<DeliveryNavigation> nav;
    std::unique_ptr<DialogPomdp> d;
    kb::NavigationKnowledge nk(*dom.grid, dom.knowledge_files);
    for (int r = 0; r < reps; ++r) {
      Stopwatch c;
      k = std::make_unique<DialogKnowledge>(cfg.office_plog, cfg.speech_plog);
      tKnowledge += c.seconds() / reps;
      c.reset();
      nav = deliveryNavigationFromKnowledge(dom, nk, cfg, k->base().rooms);
      tNav += c.seconds() / reps;
      c.reset();
      d = std::make_unique<DialogPomdp>(k->buildSpec(nav->trips(), cfg));
      tSpec += c.seconds() / reps;
    }
    std::printf("dialog knowledge by reasoning (prior + speech model): %8.2f ms\n", 1e3 * tKnowledge);
    std::printf("navigation model (Procedure 2) + 6 policies + P^N:     %8.2f ms\n", 1e3 * tNav);
    std::printf("dialog POMDP (T^D, serve costs, %zu states):          %8.2f ms\n",
                d->model().getS(), 1e3 * tSpec);
    std::printf("dialog model from the KB, total:                       %8.2f ms\n",
                1e3 * (tKnowledge + tNav + tSpec));
    PolicyReport rep;
    Stopwatch c;
    solveDialogPolicy(*d, cfg, "", &rep);
    std::printf("solve (%zu trials): %.2f s, bounds at b0 [%.2f, %.2f]\n", rep.bounds.trials,
                c.seconds(), rep.bounds.lower, rep.bounds.upper);
    DeliveryExperimentOptions eo;
    eo.blocking_rate = br;
    eo.cache_dir = "";
    eo.domain_name = paths.domain;
    DeliveryExperiment ex(dom, cfg, eo);
    c.reset();
    const auto res = ex.runTrials(0, trials, 1);
    const double per = c.seconds() / static_cast<double>(trials);
    double turns = 0;
    for (const auto& r : res) turns += r.delivery.turns;
    std::printf("delivery trial (br %.2f, 1 thread): %.3f ms per trial (%.1f questions, %zu trials)\n",
                br, 1e3 * per, turns / static_cast<double>(trials), trials);
    std::printf("experiment preparation: learning %.2f s, navigation %.3f s, dialog %.3f s, solve %.2f s\n",
                ex.preparation().learning.seconds, ex.preparation().nav_model_seconds,
                ex.preparation().dialog_model_seconds, ex.preparation().policy.seconds);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_delivery: error: %s\n", e.what());
    return 1;
  }
}
