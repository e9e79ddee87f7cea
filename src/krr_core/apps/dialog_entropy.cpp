// dialog_entropy: the paper's Table II experiment, headless. Random beliefs over all requests,
// the dialog policy's suggested action at each, and the belief entropy (nats) of those where
// it suggests a delivery, with the delivered request's room. Sample i depends only on (seed, i).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <sstream>
#include <string>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/resources.h"
#include "krr_core/experiments/belief_entropy_survey.h"
#include "krr_core/experiments/delivery_experiment.h"
#include "krr_core/experiments/experiment_cli.h"

namespace {

const char* kUsage =
    "usage: dialog_entropy --samples N [--alpha-min 0.005] [--alpha-max 0.5]\n"
    "                      (shared options below; --trials is a synonym of --samples)\n";
const char* kHelp =
    "  One CSV row per sample: trial, action, room (of the delivery, empty otherwise), entropy\n"
    "  (nats), entropy_bits, max_probability, served, policy_lower, policy_upper (the dialog\n"
    "  policy's certified bounds at the prior). Beliefs: Dirichlet(alpha) over the\n"
    "  requests, alpha log-uniform in [alpha-min, alpha-max]; the action is the policy's at\n"
    "  the start of a dialog.\n";

}  // namespace

/// @brief The program; main() runs it under guardedMain so that no exception aborts it.
static int mainBody(int argc, char** argv) {
  krr::dialog::ExperimentCli cli;
  long count = -1;
  krr::dialog::BeliefSamplerOptions sampler;
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
      if (f == "--samples" || f == "--trials") count = static_cast<long>(krr::parseCountOption(f, v));
      else if (f == "--alpha-min") sampler.alpha_min = krr::parseNumberOption(f, v);
      else if (f == "--alpha-max") sampler.alpha_max = krr::parseNumberOption(f, v);
      else throw krr::ConfigError("unknown option " + f);
    }
    if (count < 0) throw krr::ConfigError("--samples is required");
    cli.finish();
    sampler.validate();
  } catch (const krr::Error& e) {
    std::cerr << "dialog_entropy: error: " << e.what() << "\n" << kUsage << krr::dialog::kExperimentCliUsage;
    return 2;
  }
  try {
    using namespace krr::dialog;
    const ExperimentPaths paths = cli.paths();
    const DialogConfig config = cli.config(paths);
    const krr::kb::NavDomain domain = krr::kb::NavDomain::load(
        paths.navigation_yaml, cli.experiment.domain_name, paths.geometry, paths.navigation_plog);
    DeliveryExperiment ex(domain, config, cli.experiment);
    BeliefEntropySurvey survey(ex.dialog(), ex.policy(), sampler, cli.experiment.seed);
    krr::Stopwatch clock;
    const auto samples = survey.run(cli.begin, static_cast<std::size_t>(count), cli.threads);
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
  } catch (const std::exception& e) {
    std::cerr << "dialog_entropy: error: " << e.what() << "\n";
    return 1;
  }
}

int main(int argc, char** argv) {
  return krr::guardedMain("dialog_entropy", mainBody, argc, argv);
}
