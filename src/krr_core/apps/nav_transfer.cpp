// nav_transfer: the paper's navigation experiment (learn shop-room1, apply to shop-room2),
// headless. Prints a summary and writes per-episode means as CSV for tools/plot_nav_transfer.py.
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resources.h"
#include "krr_core/kb/nav_transfer.h"

namespace {

const char* kUsage =
    "usage: nav_transfer --config config/navigation.yaml --domain office_30x30\n"
    "         --geometry maps/office_30x30_geometry.plog --knowledge config/navigation.plog\n"
    "         [--trials 1000] [--threads N] [--seed 1] [--target-episodes 100]\n"
    "         [--source-episodes 300] [--br 0.3] [--time morning] [--source room1]\n"
    "         [--target room2] [--rmax 40] [--step-cost 1] [--known 5] [--replan 10]\n"
    "         [--discount 0.95] [--out results.csv]\n";

struct Args {
  std::string config, domain, geometry, knowledge, out;
  std::size_t trials = 1000, threads = std::thread::hardware_concurrency();
  std::uint64_t seed = 1;
  krr::kb::NavTransferOptions options;
};

double toNumber(const std::string& flag, const std::string& v) {
  char* end = nullptr;
  const double d = std::strtod(v.c_str(), &end);
  if (v.empty() || *end) throw krr::ConfigError("option " + flag + ": '" + v + "' is not a number");
  return d;
}

std::size_t toCount(const std::string& flag, const std::string& v) {
  const double d = toNumber(flag, v);
  if (d < 0 || d != static_cast<double>(static_cast<std::size_t>(d)))
    throw krr::ConfigError("option " + flag + ": '" + v + "' is not a non-negative integer");
  return static_cast<std::size_t>(d);
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
    auto& o = a.options;
    if (f == "--config") a.config = v;
    else if (f == "--domain") a.domain = v;
    else if (f == "--geometry") a.geometry = v;
    else if (f == "--knowledge") a.knowledge = v;
    else if (f == "--out") a.out = v;
    else if (f == "--trials") a.trials = toCount(f, v);
    else if (f == "--threads") a.threads = toCount(f, v);
    else if (f == "--seed") a.seed = toCount(f, v);
    else if (f == "--target-episodes") o.target_episodes = toCount(f, v);
    else if (f == "--source-episodes") o.source_episodes = toCount(f, v);
    else if (f == "--br") o.blocking_rate = toNumber(f, v);
    else if (f == "--time") o.time = v;
    else if (f == "--source") o.source = v;
    else if (f == "--target") o.target = v;
    else if (f == "--rmax") o.rmax.rmax = toNumber(f, v);
    else if (f == "--step-cost") o.rmax.step_cost = toNumber(f, v);
    else if (f == "--known") o.rmax.known_threshold = static_cast<std::uint32_t>(toCount(f, v));
    else if (f == "--replan") o.rmax.replan_every = static_cast<std::uint32_t>(toCount(f, v));
    else if (f == "--discount") o.rmax.discount = toNumber(f, v);
    else throw krr::ConfigError("unknown option " + f);
  }
  if (a.config.empty() || a.domain.empty() || a.geometry.empty() || a.knowledge.empty())
    throw krr::ConfigError("--config, --domain, --geometry and --knowledge are required");
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  try {
    a = parse(argc, argv);
  } catch (const krr::Error& e) {
    std::cerr << "nav_transfer: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    std::cerr << "nav_transfer: seed " << a.seed << ", " << a.trials << " trials, " << a.threads
              << " threads, domain " << a.domain << "\n";
    krr::Stopwatch clock;
    auto dom = krr::kb::NavDomain::load(a.config, a.domain, a.geometry, a.knowledge);
    auto s = krr::kb::runNavTransfer(dom, a.options, a.seed, a.trials, a.threads);
    std::ostringstream csv;
    csv << "episode,mean_with,ci95_with,mean_without,ci95_without,success_with,success_without\n";
    for (std::size_t e = 0; e < s.mean_with.size(); ++e)
      csv << e + 1 << "," << s.mean_with[e] << "," << s.ci_with[e] << "," << s.mean_without[e]
          << "," << s.ci_without[e] << "," << s.success_with[e] << "," << s.success_without[e]
          << "\n";
    if (!a.out.empty()) krr::writeFileAtomic(a.out, csv.str());
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
