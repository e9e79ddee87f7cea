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
#include "krr_core/common/resources.h"
#include "krr_core/dialog/belief_entropy_survey.h"
#include "krr_core/dialog/delivery_experiment.h"
#include "krr_core/dialog/experiment_paths.h"

namespace {

const char* kUsage =
    "usage: dialog_entropy --br B --condition learned|outdated --samples N [--trial-begin K]\n"
    "         --seed S [--threads T] [--domain office_30x30] [--learned-cache DIR|none]\n"
    "         [--out entropy.csv] [--root DIR] [--outdated-br 0.3] [--alpha-min 0.005]\n"
    "         [--alpha-max 0.5] [--serve-cost none|expected|tasks] [--serve-cost-weight W]\n"
    "         [--solver-trials N] [--solver-timeout S]\n"
    "  (--trials is a synonym of --samples.) One CSV row per sample: trial, action, room\n"
    "  (of the delivery, empty otherwise), entropy (nats), entropy_bits, max_probability.\n"
    "  Beliefs: Dirichlet(alpha) over the requests, alpha log-uniform in [alpha-min, alpha-max].\n";

struct Args {
  double br = -1;
  std::string condition;
  long samples = -1;
  std::size_t begin = 0, threads = 1;
  std::uint64_t seed = 0;
  bool have_seed = false;
  std::string domain = "office_30x30", cache, out, root, serve_cost;
  bool have_cache = false;
  double outdated_br = 0.3, weight = -1, solver_timeout = -1;
  long solver_trials = -1;
  krr::dialog::BeliefSamplerOptions sampler;
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
    else if (f == "--samples" || f == "--trials") a.samples = static_cast<long>(toCount(f, v));
    else if (f == "--trial-begin") a.begin = toCount(f, v);
    else if (f == "--seed") a.seed = toCount(f, v), a.have_seed = true;
    else if (f == "--threads") a.threads = toCount(f, v);
    else if (f == "--domain") a.domain = v;
    else if (f == "--learned-cache") a.cache = v, a.have_cache = true;
    else if (f == "--out") a.out = v;
    else if (f == "--root") a.root = v;
    else if (f == "--outdated-br") a.outdated_br = toNumber(f, v);
    else if (f == "--alpha-min") a.sampler.alpha_min = toNumber(f, v);
    else if (f == "--alpha-max") a.sampler.alpha_max = toNumber(f, v);
    else if (f == "--serve-cost") a.serve_cost = v;
    else if (f == "--serve-cost-weight") a.weight = toNumber(f, v);
    else if (f == "--solver-trials") a.solver_trials = static_cast<long>(toCount(f, v));
    else if (f == "--solver-timeout") a.solver_timeout = toNumber(f, v);
    else throw krr::ConfigError("unknown option " + f);
  }
  if (a.br < 0) throw krr::ConfigError("--br is required");
  if (a.condition.empty()) throw krr::ConfigError("--condition is required");
  if (a.samples < 0) throw krr::ConfigError("--samples is required");
  if (!a.have_seed) throw krr::ConfigError("--seed is required");
  if (a.threads == 0) throw krr::ConfigError("option --threads: must be at least 1");
  a.sampler.validate();
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  try {
    a = parse(argc, argv);
  } catch (const krr::Error& e) {
    std::cerr << "dialog_entropy: error: " << e.what() << "\n" << kUsage;
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

    const krr::kb::NavDomain domain = krr::kb::NavDomain::load(
        paths.navigation_yaml, a.domain, paths.geometry, paths.navigation_plog);
    DeliveryExperiment ex(domain, config, o);
    BeliefEntropySurvey survey(ex.dialog(), ex.policy(), a.sampler, a.seed);
    krr::Stopwatch clock;
    const auto samples = survey.run(a.begin, static_cast<std::size_t>(a.samples), a.threads);
    if (!a.out.empty()) {
      std::ostringstream csv;
      csv << BeliefEntropySurvey::csvHeader() << "\n";
      for (const auto& s : samples) csv << survey.csvRow(s) << "\n";
      krr::writeFileAtomic(a.out, csv.str());
    }
    const PreparationReport& p = ex.preparation();
    std::printf("dialog_entropy: br %.3g, condition %s (knowledge learned at br %.3g), seed %llu, "
                "policy %s%s\n",
                a.br, a.condition.c_str(), p.knowledge_br, static_cast<unsigned long long>(a.seed),
                p.policy_from_cache ? "cached" : "solved",
                p.reproducible ? "" : " (stopped by the timeout: NOT reproducible)");
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
