// new_circumstances: the paper's "generate controllers for new circumstances" experiment,
// headless. Learns navigation in three settings (times of day); per trial draws the two
// settings the robot may be in and the true one, and drives, from the same random numbers, the
// controller the reasoner merges for "one of these two" (P-log, time exogenous), a random pick
// of the two settings' own controllers, the oracle (the true setting's own controller) and
// every setting's own controller. Learning runs are shared by the trials (config:
// learning_runs). Writes one CSV row per trial (trial i depends only on (seed, i), so ranges
// can be run in separate processes and concatenated) and prints a summary.
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/resources.h"
#include "krr_core/experiments/experiment_cli.h"
#include "krr_core/experiments/new_circumstances.h"

namespace {

const char* kSummary =
    "The paper's \"controllers for new circumstances\" experiment: one CSV row per trial and a\n"
    "summary. Flags override the options file; default paths are under ROOT (see --root).";

}  // namespace

/// @brief The options file's settings, laid under the site's places and then the command
/// line's overrides (in order), validated; the input files resolved for the domain.
static krr::experiments::NewCircumstancesOptions experimentOptions(
    krr::experiments::NavExperimentFiles& files,
    const std::vector<std::pair<std::string, std::string>>& overrides, const std::string& domain) {
  // The start is the site's shop unless the options file names another.
  krr::experiments::NewCircumstancesOptions defaults;
  defaults.start = files.siteShop();
  krr::experiments::NewCircumstancesOptions o =
      krr::experiments::loadNewCircumstancesOptions(files.options, defaults);
  if (files.site) {
    // A site's places, not the options file's (the office's): its shop, every place of its
    // map for the least-known selector, site.yaml's experiments.new_circumstances.goal.
    o.start = files.siteShop();
    if (!files.sitePlace("new_circumstances", "goal").empty())
      o.goal = files.sitePlace("new_circumstances", "goal");
    o.places.clear();
  }
  for (const auto& [f, v] : overrides) {
    if (f == "--goal") o.goal = v;
    else if (f == "--br") o.blocking_rate = krr::parseNumberOption(f, v);
    else if (f == "--learn-episodes") o.learn_episodes = krr::parseCountOption(f, v);
    else if (f == "--selector") o.selector = v;
    else if (f == "--learning-runs") o.learning_runs = krr::parseCountOption(f, v);
    else if (f == "--extraction") o.extraction = v;
  }
  if (!domain.empty()) o.domain = domain;
  if (o.domain.empty()) o.domain = files.defaultDomain();
  o.validate();
  files.resolveInputs(o.domain);
  return o;
}

/// @brief The summary on stdout: each strategy's success and exact P(success), mean +- 95 % CI.
static void printSummary(const krr::experiments::NewCircumstancesOptions& o,
                         const std::vector<krr::experiments::NewCircumstancesTrial>& res,
                         double seconds) {
  const std::size_t T = o.learn_times.size();
  std::vector<double> sm, sb, so, pm, pb, po, pick_mean, diff;
  std::vector<std::vector<double>> sown(T), pown(T), self(T);
  std::set<std::size_t> runs;
  for (const auto& t : res) {
    sm.push_back(t.success_merged);
    sb.push_back(t.success_baseline);
    so.push_back(t.success_oracle);
    pm.push_back(t.p_merged);
    pb.push_back(t.p_baseline);
    po.push_back(t.p_oracle);
    // The random pick's expected success in this trial: the mean of the possible settings'
    // own controllers in the true setting.
    double e = 0;
    for (const std::string& s : t.possible) {
      const std::size_t k = static_cast<std::size_t>(
          std::find(o.learn_times.begin(), o.learn_times.end(), s) - o.learn_times.begin());
      e += t.p_own[k] / static_cast<double>(t.possible.size());
    }
    pick_mean.push_back(e);
    diff.push_back(t.p_merged - e);
    for (std::size_t k = 0; k < T; ++k) {
      sown[k].push_back(t.success_own[k]);
      pown[k].push_back(t.p_own[k]);
    }
    if (runs.insert(t.learning_run).second)
      for (std::size_t k = 0; k < T; ++k) self[k].push_back(t.p_self[k]);
  }
  auto line = [](const std::string& name, const std::vector<double>& x) {
    const krr::experiments::MeanCi m = krr::experiments::meanCi(x);
    std::printf("  %-44s %.3f +- %.3f\n", name.c_str(), m.mean, m.ci95);
  };
  std::printf("new circumstances (%s, %s -> %s, br %g): %zu trials, %zu learning run(s); the robot "
              "is in one of %zu settings drawn from {",
              o.domain.c_str(), o.start.c_str(), o.goal.c_str(), o.blocking_rate, res.size(),
              runs.size(), o.unknown_count);
  for (std::size_t k = 0; k < T; ++k) std::printf("%s%s", k ? ", " : "", o.learn_times[k].c_str());
  std::printf("}\n");
  // One line per statistic, then one per setting's own controller.
  const auto perSetting = [&](const std::string& prefix, const std::string& suffix,
                              const std::vector<std::vector<double>>& x) {
    for (std::size_t k = 0; k < T; ++k) line(prefix + o.learn_times[k] + suffix, x[k]);
  };
  line("success, merged (KRR-RL)", sm);
  line("success, random pick (baseline)", sb);
  line("success, oracle (knows the setting)", so);
  perSetting("success, own controller of ", "", sown);
  line("exact P(success), merged", pm);
  line("exact P(success), random pick", pb);
  line("exact P(success), random pick, mean over the pick", pick_mean);
  line("exact P(success), oracle", po);
  perSetting("exact P(success), own controller of ", "", pown);
  line("exact merged - random pick (mean over pick)", diff);
  perSetting("own controller in ", " (per learning run)", self);
  std::printf("  (%.1f s)\n", seconds);
}

/// @brief The program; main() runs it under guardedMain so that no exception aborts it.
static int mainBody(int argc, char** argv) {
  krr::experiments::NavExperimentFiles files;
  std::string domain, out;
  std::size_t trials = 0, threads = std::max(1u, std::thread::hardware_concurrency()), begin = 0;
  std::uint64_t seed = 1;
  bool no_header = false;
  std::vector<std::pair<std::string, std::string>> overrides;
  krr::OptionParser parser("new_circumstances", kSummary);
  parser.add("--trials", "N", "trials to run (at least 1)", &trials).required();
  parser.add("--seed", "S", "root seed", &seed).required();
  parser.add("--threads", "T", "worker threads", &threads).defaultText("the number of cores");
  parser.add("--trial-begin", "K", "index of the first trial (trial i depends only on seed and i)",
             &begin);
  parser.add("--out", "FILE", "trials as CSV", &out);
  parser.flag("--no-header", "write the CSV without its header line", &no_header);
  files.declare(parser, "config/experiments/new_circumstances.yaml");
  parser.add("--domain", "NAME", "navigation domain (default: the options file's, else the first of the navigation "
                 "config's)", &domain);
  // Overrides of the options file, applied after it is read.
  const std::pair<const char*, const char*> experiment[] = {
      {"--goal", "PLACE"}, {"--br", "B"}, {"--learn-episodes", "N"},
      {"--selector", "fixed|least_known"}, {"--extraction", "pairs|areas"},
      {"--learning-runs", "K"}};
  for (const auto& [flag, value] : experiment) {
    const std::string f = flag;
    parser.add(f, value, "override of the options file",
               [&overrides, f](const std::string& v) {
                 if (f == "--br") krr::parseNumberOption(f, v);  // a bad number fails now
                 if (f == "--learn-episodes" || f == "--learning-runs") krr::parseCountOption(f, v);
                 overrides.emplace_back(f, v);
               });
  }
  parser.epilog(
      "--learning-runs K: trial i uses learning run i mod K (0: a fresh run per trial; the CSV\n"
      "does not depend on it for i < K).");
  const auto check = [&] {
    if (trials == 0) throw krr::ConfigError("--trials N (N >= 1) is required");
    threads = std::max<std::size_t>(1, threads);
  };
  if (const auto status = parser.parse(argc, argv, check)) return *status;
  files.resolveRoot();
  const krr::experiments::NewCircumstancesOptions o = experimentOptions(files, overrides, domain);

  std::cerr << "new_circumstances: seed " << seed << ", trials [" << begin << ", "
            << begin + trials << "), " << threads << " threads, domain " << o.domain << ", "
            << o.start << " -> " << o.goal << "\n";
  krr::Stopwatch clock;
  const auto dom =
      krr::kb::NavDomain::load(files.navigationConfig(), o.domain, files.geometry, files.knowledge);
  const auto res = krr::experiments::runNewCircumstances(dom, o, seed, begin, trials, threads);
  std::ostringstream csv;
  if (!no_header) csv << krr::experiments::newCircumstancesCsvHeader(o) << "\n";
  for (const auto& t : res) csv << krr::experiments::newCircumstancesCsvRow(t) << "\n";
  if (!out.empty()) krr::writeFileAtomic(out, csv.str());

  printSummary(o, res, clock.seconds());
  return 0;
}

int main(int argc, char** argv) {
  return krr::guardedMain("new_circumstances", mainBody, argc, argv);
}
