// delivery_trials: the paper's delivery experiment (Sec. IV, Table I), headless. The robot's
// DeliveryManager with a simulated person and the blockage simulator; knowledge learned at the
// trial's br ("learned") or at 0.3 ("outdated"). One CSV row per trial; trial i depends only
// on (seed, i), never on --threads or --trial-begin.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>

#include "krr_core/common/cli.h"
#include "krr_core/common/files.h"
#include "krr_core/common/json.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/resources.h"
#include "krr_core/experiments/delivery_experiment.h"
#include "krr_core/experiments/experiment_cli.h"

namespace {

const char* kSummary =
    "The paper's delivery experiment (Table I), headless: one CSV row per trial (trial index\n"
    "first). reward = +80 fulfilled / -80, minus the questions' costs, the navigation cost\n"
    "driven and the wrong-delivery penalty (config/dialog.yaml, serve_cost). policy_lower /\n"
    "policy_upper: the certified bounds of the dialog policy at the prior.";
const char* kModelReportHelp =
    "print (only) a JSON report on stdout: per room the believed P^N (the knowledge base's "
    "model) and the true P^N (the simulator's exact dynamics, driven with the robot's "
    "policies), the policy's certified bounds and, after the trials, the forced-serve rate; "
    "the usual summary goes to stderr";

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

/// @brief The program; main() runs it under guardedMain so that no exception aborts it.
static int mainBody(int argc, char** argv) {
  krr::experiments::ExperimentCli cli;
  std::size_t trials = 0;
  std::string exportPomdp;
  bool modelReport = false;
  krr::OptionParser parser("delivery_trials", kSummary);
  parser.add("--trials", "N", "trials to run", &trials).required();
  cli.declare(parser);
  parser.add("--export-pomdp", "FILE", "write the dialog POMDP (Cassandra format)", &exportPomdp);
  parser.flag("--model-report", kModelReportHelp, &modelReport);
  if (const auto status = parser.parse(argc, argv, [&] { cli.finish(); })) return *status;
  using namespace krr::dialog;
  using namespace krr::experiments;
  const ExperimentPaths paths = cli.paths();
  const DialogConfig config = cli.config(paths);
  krr::Stopwatch clock;
  const krr::kb::NavDomain domain = krr::kb::NavDomain::load(
      paths.navigationConfig(), cli.experiment.domain_name, paths.geometry, paths.navigation_plog);
  DeliveryExperiment ex(domain, config, cli.experiment);
  const PreparationReport& p = ex.preparation();
  const double prepSeconds = clock.seconds();
  if (!exportPomdp.empty()) krr::writeFileAtomic(exportPomdp, ex.dialog().exportCassandra());

  clock.reset();
  const auto results = ex.runTrials(cli.begin, trials, cli.threads);
  const double trialSeconds = clock.seconds();
  if (!cli.out.empty()) {
    std::ostringstream csv;
    csv << deliveryCsvHeader() << "\n";
    const double rewardError = ex.rewardError();
    for (const auto& r : results) csv << deliveryCsvRow(ex.dialog(), rewardError, r, p.policy.bounds) << "\n";
    krr::writeFileAtomic(cli.out, csv.str());
  }
  std::FILE* say = modelReport ? stderr : stdout;
  std::fprintf(say, "delivery_trials: br %.3g, condition %s (knowledge learned at br %.3g: %zu pairs, %zu areas, "
              "%s %.1f s), seed %llu, serve cost %s x %g, wrong delivery %g\n",
              cli.experiment.blocking_rate, toString(cli.experiment.condition).c_str(),
              p.knowledge_br, p.learning.pairs, p.learning.areas, p.learning.from_cache ? "cached" : "learned in",
              p.learning.seconds, static_cast<unsigned long long>(cli.experiment.seed),
              toString(config.serve_cost_mode).c_str(), config.serve_cost_weight,
              config.wrong_delivery_penalty);
  std::fprintf(say, "  P^N(shop, room) / P^N(room, shop), believed (true):");
  for (std::size_t r = 0; r < ex.navigation().numRooms(); ++r)
    std::fprintf(say, " %s %.3f/%.3f (%.3f/%.3f)", ex.navigation().options().rooms[r].c_str(),
                 ex.navigation().toRoom(r).reach, ex.navigation().toShop(r).reach,
                 ex.trueTrips().to_room[r].reach, ex.trueTrips().to_shop[r].reach);
  const PolicyReport& pol = p.policy;
  std::fprintf(say, "\n  models: navigation %.3f s, dialog %.3f s; policy: %s in %.2f s, bounds at the "
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
    std::fprintf(say, "  %zu trials [%zu, %zu): reward %.2f +- %.2f, fulfilled %.3f +- %.3f, "
                "QA cost %.2f +- %.2f, turns %.2f, identified %.3f, entropy at serve %.3f, "
                "forced serves %.4f (95%% CI)\n",
                results.size(), cli.begin, cli.begin + results.size(), reward.mean(), reward.ci(),
                fulfilled.mean(), fulfilled.ci(), qa.mean(), qa.ci(), turns.mean(),
                correct.mean(), entropy.mean(), forced.mean());
    std::fprintf(say, "  %.3f ms per trial (%zu threads)\n",
                1000.0 * trialSeconds / static_cast<double>(results.size()), cli.threads);
  }
  if (modelReport) {
    using krr::jsonNumber;
    using krr::jsonString;
    const TripTable believed = ex.navigation().trips();
    const TripTable& truth = ex.trueTrips();
    std::string rooms;
    double worst = 0.0;
    for (std::size_t r = 0; r < believed.rooms.size(); ++r) {
      const double e1 = believed.to_room[r].reach - truth.to_room[r].reach;
      const double e2 = believed.to_shop[r].reach - truth.to_shop[r].reach;
      worst = std::max({worst, std::fabs(e1), std::fabs(e2)});
      rooms += std::string(r ? ", " : "") + "{\"room\": " + jsonString(believed.rooms[r]) +
               ", \"believed\": {\"shop_to_room\": " + jsonNumber(believed.to_room[r].reach) +
               ", \"room_to_shop\": " + jsonNumber(believed.to_shop[r].reach) +
               "}, \"true\": {\"shop_to_room\": " + jsonNumber(truth.to_room[r].reach) +
               ", \"room_to_shop\": " + jsonNumber(truth.to_shop[r].reach) +
               "}, \"error\": {\"shop_to_room\": " + jsonNumber(e1) +
               ", \"room_to_shop\": " + jsonNumber(e2) + "}}";
    }
    double forced = 0.0;
    for (const auto& r : results) forced += r.delivery.forced ? 1.0 : 0.0;
    const PolicyReport& pr = p.policy;
    std::printf("{\"br\": %s, \"condition\": %s, \"knowledge_br\": %s, \"seed\": %llu, "
                "\"learning\": %s, \"learned_pairs\": %zu, \"learned_areas\": %zu, \"rooms\": [%s], "
                "\"max_abs_error\": %s, \"policy\": {\"lower\": %s, \"upper\": %s, "
                "\"gap\": %s, \"trials\": %zu, \"certified\": %s}, \"trials\": %zu, "
                "\"forced_serve_rate\": %s}\n",
                jsonNumber(cli.experiment.blocking_rate).c_str(),
                jsonString(toString(cli.experiment.condition)).c_str(),
                jsonNumber(p.knowledge_br).c_str(),
                static_cast<unsigned long long>(cli.experiment.seed),
                jsonString(config.learning_mode).c_str(), p.learning.pairs, p.learning.areas,
                rooms.c_str(),
                jsonNumber(worst).c_str(), jsonNumber(pr.bounds.lower).c_str(),
                jsonNumber(pr.bounds.upper).c_str(), jsonNumber(pr.bounds.gap()).c_str(),
                pr.bounds.trials, pr.converged ? "true" : "false", results.size(),
                results.empty() ? "null"
                                : jsonNumber(forced / static_cast<double>(results.size())).c_str());
  }
  return 0;
}

int main(int argc, char** argv) {
  return krr::guardedMain("delivery_trials", mainBody, argc, argv);
}
