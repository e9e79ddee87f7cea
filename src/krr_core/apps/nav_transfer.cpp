// nav_transfer: the paper's navigation experiment (learn shop-room1, apply to shop-room2),
// headless. Prints a summary and writes per-episode means as CSV (--out) and, optionally, one
// row per (trial, episode, condition) (--trials-out) for an evaluator that splits trial ranges
// over processes (--trial-begin) and concatenates them: trial i depends only on (seed, i).
#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <fstream>
#include <string>
#include <thread>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/resources.h"
#include "krr_core/experiments/nav_transfer.h"

namespace {

const char* kUsage =
    "usage: nav_transfer [--domain office_30x30] [--trials 1000] [--trial-begin 0] [--threads N]\n"
    "         [--seed 1] [--out means.csv] [--trials-out trials.csv]\n"
    "         [--options config/nav_transfer.yaml] [--config config/navigation.yaml]\n"
    "         [--geometry maps/<domain>_geometry.plog] [--knowledge config/navigation.plog]\n"
    "         [--target-episodes N] [--source-episodes N] [--convergence-episodes N] [--br 0.3]\n"
    "         [--time morning] [--source room1] [--target room2] [--rmax 40] [--step-cost 1]\n"
    "         [--known M] [--replan E] [--discount 0.95] [--repo DIR]\n"
    "Experiment defaults come from the options file (default DIR/config/nav_transfer.yaml when\n"
    "it exists); flags override them. Relative default paths are under DIR (the\n"
    "checkout found from $KRR_ROOT, the working directory or this program).\n"
    "--out: episode, mean and 95% CI of the reward with/without extraction, success rates.\n"
    "--trials-out: trial, episode, condition (with/without), reward, success.\n";

double toNumber(const std::string& flag, const std::string& v) {
  return krr::parseNumberOption(flag, v);
}

std::size_t toCount(const std::string& flag, const std::string& v) {
  return krr::parseCountOption(flag, v);
}

struct Args {
  std::string repo, options, config, domain = "office_30x30", geometry, knowledge, out, trials_out;
  std::size_t trials = 1000, begin = 0, threads = std::max(1u, std::thread::hardware_concurrency());
  std::uint64_t seed = 1;
  std::vector<std::pair<std::string, std::string>> overrides;  // applied after the options file
};

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
    if (f == "--repo") a.repo = v;
    else if (f == "--options") a.options = v;
    else if (f == "--config") a.config = v;
    else if (f == "--domain") a.domain = v;
    else if (f == "--geometry") a.geometry = v;
    else if (f == "--knowledge") a.knowledge = v;
    else if (f == "--out") a.out = v;
    else if (f == "--trials-out") a.trials_out = v;
    else if (f == "--trials") a.trials = toCount(f, v);
    else if (f == "--trial-begin") a.begin = toCount(f, v);
    else if (f == "--threads") a.threads = std::max<std::size_t>(1, toCount(f, v));
    else if (f == "--seed") a.seed = toCount(f, v);
    else if (f == "--target-episodes" || f == "--source-episodes" ||
             f == "--convergence-episodes" || f == "--br" || f == "--time" || f == "--source" ||
             f == "--target" || f == "--rmax" || f == "--step-cost" || f == "--known" ||
             f == "--replan" || f == "--discount")
      a.overrides.emplace_back(f, v);
    else throw krr::ConfigError("unknown option " + f);
  }
  if (a.trials == 0) throw krr::ConfigError("--trials must be at least 1");
  return a;
}

void applyOverride(krr::kb::NavTransferOptions& o, const std::string& f, const std::string& v) {
  if (f == "--target-episodes") o.target_episodes = toCount(f, v);
  else if (f == "--source-episodes") o.source_episodes = toCount(f, v);
  else if (f == "--convergence-episodes") o.convergence_episodes = toCount(f, v);
  else if (f == "--br") o.blocking_rate = toNumber(f, v);
  else if (f == "--time") o.time = v;
  else if (f == "--source") o.source = v;
  else if (f == "--target") o.target = v;
  else if (f == "--rmax") o.rmax.rmax = toNumber(f, v);
  else if (f == "--step-cost") o.rmax.step_cost = toNumber(f, v);
  else if (f == "--known") o.rmax.known_threshold = static_cast<std::uint32_t>(toCount(f, v));
  else if (f == "--replan") o.rmax.replan_every = static_cast<std::uint32_t>(toCount(f, v));
  else if (f == "--discount") o.rmax.discount = toNumber(f, v);
}

}  // namespace

/// @brief The program; main() runs it under guardedMain so that no exception aborts it.
static int mainBody(int argc, char** argv) {
  Args a;
  try {
    a = parse(argc, argv);
  } catch (const krr::Error& e) {
    std::cerr << "nav_transfer: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    a.repo = krr::findRepositoryRoot(a.repo);
    krr::kb::NavTransferOptions o;
    const std::string default_options = a.repo + "/config/nav_transfer.yaml";
    if (!a.options.empty()) o = krr::kb::loadNavTransferOptions(a.options);
    else if (std::ifstream(default_options).good()) o = krr::kb::loadNavTransferOptions(default_options);
    for (const auto& [f, v] : a.overrides) applyOverride(o, f, v);
    o.validate();
    if (a.config.empty()) a.config = a.repo + "/config/navigation.yaml";
    if (a.geometry.empty()) a.geometry = a.repo + "/maps/" + a.domain + "_geometry.plog";
    if (a.knowledge.empty()) a.knowledge = a.repo + "/config/navigation.plog";

    std::cerr << "nav_transfer: seed " << a.seed << ", trials [" << a.begin << ", "
              << a.begin + a.trials << "), " << a.threads << " threads, domain " << a.domain
              << ", M " << o.rmax.known_threshold << ", Rmax " << o.rmax.rmax << ", step cost "
              << o.rmax.step_cost << ", " << o.target_episodes << " target episodes\n";
    krr::Stopwatch clock;
    auto dom = krr::kb::NavDomain::load(a.config, a.domain, a.geometry, a.knowledge);
    const auto trials = krr::kb::runNavTransferTrials(dom, o, a.seed, a.begin, a.trials, a.threads);
    const auto s = krr::kb::summarizeNavTransfer(trials);
    if (!a.out.empty()) {
      std::ostringstream csv;
      csv << "episode,mean_with,ci95_with,mean_without,ci95_without,success_with,success_without\n";
      for (std::size_t e = 0; e < s.mean_with.size(); ++e)
        csv << e + 1 << "," << s.mean_with[e] << "," << s.ci_with[e] << "," << s.mean_without[e]
            << "," << s.ci_without[e] << "," << s.success_with[e] << "," << s.success_without[e]
            << "\n";
      krr::writeFileAtomic(a.out, csv.str());
    }
    if (!a.trials_out.empty()) {
      std::string csv = "trial,episode,condition,reward,success\n";
      char buf[96];
      for (const auto& t : trials) {
        for (std::size_t e = 0; e < t.reward_with.size(); ++e) {
          std::snprintf(buf, sizeof(buf), "%zu,%zu,with,%.10g,%d\n", t.index, e + 1,
                        t.reward_with[e], t.success_with[e] ? 1 : 0);
          csv += buf;
          std::snprintf(buf, sizeof(buf), "%zu,%zu,without,%.10g,%d\n", t.index, e + 1,
                        t.reward_without[e], t.success_without[e] ? 1 : 0);
          csv += buf;
        }
      }
      krr::writeFileAtomic(a.trials_out, csv);
    }
    double w = 0, wo = 0;
    for (std::size_t e = 0; e < s.mean_with.size(); ++e) {
      w += s.mean_with[e];
      wo += s.mean_without[e];
    }
    const double n = static_cast<double>(s.mean_with.size());
    std::printf("domain %s: %zu trials, %zu target episodes, source task learned in %.1f episodes, "
                "%.0f pairs extracted, %.0f target pairs known from the KB\n",
                a.domain.c_str(), s.trials, s.mean_with.size(), s.mean_source_episodes,
                s.mean_learned_pairs, s.mean_prior_pairs);
    std::printf("mean reward per episode: with extraction %.2f, without %.2f (%.1f s)\n", w / n,
                wo / n, clock.seconds());
    return 0;
  } catch (const krr::Error& e) {
    std::cerr << "nav_transfer: " << e.what() << "\n";
    return 1;
  }
}

int main(int argc, char** argv) {
  return krr::guardedMain("nav_transfer", mainBody, argc, argv);
}
