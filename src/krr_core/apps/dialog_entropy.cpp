// dialog_entropy: the paper's Table II experiment, headless. Random beliefs over all requests,
// the dialog policy's suggested action at each, and the belief entropy (nats) of those where
// it suggests a delivery, with the delivered request's room. Sample i depends only on (seed, i).
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <sstream>
#include <string>

#include "krr_core/common/cli.h"
#include "krr_core/common/files.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/resources.h"
#include "krr_core/experiments/belief_entropy_survey.h"
#include "krr_core/experiments/delivery_experiment.h"
#include "krr_core/experiments/experiment_cli.h"

namespace {

const char* kSummary =
    "The paper's Table II experiment, headless: one CSV row per sample: trial, action, room\n"
    "(of the delivery, empty otherwise), entropy (nats), entropy_bits, max_probability,\n"
    "served, policy_lower, policy_upper (the dialog policy's certified bounds at the prior).\n"
    "Beliefs: Dirichlet(alpha) over the requests, alpha log-uniform in [alpha-min,\n"
    "alpha-max]; the action is the policy's at the start of a dialog.";

}  // namespace

/// @brief The program; main() runs it under guardedMain so that no exception aborts it.
static int mainBody(int argc, char** argv) {
  krr::experiments::ExperimentCli cli;
  std::size_t count = 0;
  krr::experiments::BeliefSamplerOptions sampler;
  krr::OptionParser parser("dialog_entropy", kSummary);
  parser.add("--samples", "N", "beliefs to sample", &count).required().alias("--trials");
  cli.declare(parser);
  parser.add("--alpha-min", "A", "smallest Dirichlet concentration", &sampler.alpha_min);
  parser.add("--alpha-max", "A", "largest Dirichlet concentration", &sampler.alpha_max);
  const auto check = [&] {
    cli.finish();
    sampler.validate();
  };
  if (const auto status = parser.parse(argc, argv, check)) return *status;
  using namespace krr::dialog;
  using namespace krr::experiments;
  const ExperimentPaths paths = cli.paths();
  const DialogConfig config = cli.config(paths);
  const krr::kb::NavDomain domain = krr::kb::NavDomain::load(
      paths.navigationConfig(), cli.experiment.domain_name, paths.geometry, paths.navigation_plog);
  DeliveryExperiment ex(domain, config, cli.experiment);
  BeliefEntropySurvey survey(ex.dialog(), ex.policy(), sampler, cli.experiment.seed);
  krr::Stopwatch clock;
  const auto samples = survey.run(cli.begin, count, cli.threads);
  if (!cli.out.empty()) {
    std::ostringstream csv;
    // The policy's certified bounds at the prior on every row (the evaluation checks them).
    char bounds[64];
    std::snprintf(bounds, sizeof(bounds), ",%.10g,%.10g", ex.preparation().policy.bounds.lower,
                  ex.preparation().policy.bounds.upper);
    csv << BeliefEntropySurvey::csvHeader() << ",policy_lower,policy_upper\n";
    for (const auto& s : samples) csv << survey.csvRow(s) << bounds << "\n";
    krr::writeFileAtomic(cli.out, csv.str());
  }
  const PreparationReport& p = ex.preparation();
  std::printf("dialog_entropy: br %.3g, condition %s (knowledge learned at br %.3g), seed %llu, "
              "policy %s, bounds at the prior [%.2f, %.2f]%s\n",
              cli.experiment.blocking_rate, toString(cli.experiment.condition).c_str(),
              p.knowledge_br, static_cast<unsigned long long>(cli.experiment.seed),
              p.policy.from_cache ? "cached" : "solved", p.policy.bounds.lower,
              p.policy.bounds.upper,
              p.policy.reproducible ? "" : " (stopped by the timeout: NOT reproducible)");
  std::map<std::string, std::vector<double>> byRoom;
  std::size_t serves = 0;
  for (const auto& s : samples)
    if (s.serve) {
      ++serves;
      byRoom[ex.dialog().spec().rooms[ex.dialog().requestParts(s.request)[1]]].push_back(s.entropy);
    }
  std::printf("  %zu samples, %zu with a delivery action (%.3f ms per sample)\n", samples.size(),
              serves, samples.empty() ? 0.0 : 1000.0 * clock.seconds() / samples.size());
  for (const auto& [room, v] : byRoom) {
    double m = 0, sq = 0, mx = 0;
    for (double e : v) m += e, sq += e * e, mx = std::max(mx, e);
    m /= static_cast<double>(v.size());
    const double sd = std::sqrt(std::max(0.0, sq / static_cast<double>(v.size()) - m * m));
    std::printf("  entropy (nats) %s: mean %.3f (std %.3f), max %.3f, n %zu\n", room.c_str(), m,
                sd, mx, v.size());
  }
  return 0;
}

int main(int argc, char** argv) {
  return krr::guardedMain("dialog_entropy", mainBody, argc, argv);
}
