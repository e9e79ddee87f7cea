// nav_transfer: the paper's navigation experiment (learn start -> source, apply the extracted
// knowledge to start -> target; the places: the options file, the start defaulting to the
// site's shop), headless. Prints a summary and writes per-episode means as CSV (--out) and,
// optionally, one row per (trial, episode, condition) (--trials-out) for an evaluator that
// splits trial ranges over processes (--trial-begin) and concatenates them: trial i depends
// only on (seed, i).
#include <cstdio>
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
#include "krr_core/experiments/experiment_cli.h"
#include "krr_core/experiments/nav_transfer.h"

namespace {

const char* kSummary =
    "The paper's navigation experiment: learn start -> source, extract the knowledge, apply it\n"
    "to start -> target. Experiment defaults come from the options file (the start: the site's\n"
    "shop, navigation.shop of the dialog.yaml beside the navigation config, unless the file\n"
    "names one); flags override them. Default paths are under ROOT (see --root).";
const char* kEpilog =
    "--out: episode, mean and 95% CI of the reward with/without extraction, success rates.\n"
    "--trials-out: trial, episode, condition (with/without), reward, success.\n";

double toNumber(const std::string& flag, const std::string& v) {
  return krr::parseNumberOption(flag, v);
}

std::size_t toCount(const std::string& flag, const std::string& v) {
  return krr::parseCountOption(flag, v);
}

void applyOverride(krr::experiments::NavTransferOptions& o, const std::string& f,
                   const std::string& v) {
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

struct Args {
  krr::experiments::NavExperimentFiles files;
  std::string domain, out, trials_out;
  std::size_t trials = 1000, begin = 0, threads = std::max(1u, std::thread::hardware_concurrency());
  std::uint64_t seed = 1;
  std::vector<std::pair<std::string, std::string>> overrides;  // applied after the options file

  /// @brief Declare the options on `p`; this object receives their values.
  void declare(krr::OptionParser& p) {
    p.add("--domain", "NAME", "navigation domain", &domain)
        .defaultText("the first domain of the navigation config");
    p.add("--trials", "N", "trials to run (at least 1)", &trials);
    p.add("--trial-begin", "K", "index of the first trial (trial i depends only on seed and i)",
          &begin);
    p.add("--threads", "N", "worker threads", &threads).defaultText("the number of cores");
    p.add("--seed", "S", "root seed", &seed);
    p.add("--out", "FILE", "per-episode means as CSV", &out);
    p.add("--trials-out", "FILE", "one CSV row per (trial, episode, condition)", &trials_out);
    files.declare(p, "config/experiments/nav_transfer.yaml", " when it exists");
    // Overrides of the options file, applied after it is read (a bad value fails now).
    const std::pair<const char*, const char*> experiment[] = {
        {"--target-episodes", "N"}, {"--source-episodes", "N"}, {"--convergence-episodes", "N"},
        {"--br", "B"}, {"--time", "TIME"}, {"--source", "PLACE"}, {"--target", "PLACE"},
        {"--rmax", "R"}, {"--step-cost", "C"}, {"--known", "M"}, {"--replan", "E"},
        {"--discount", "G"}};
    for (const auto& [flag, value] : experiment) {
      const std::string f = flag;
      p.add(f, value, "override of the options file", [this, f](const std::string& v) {
        krr::experiments::NavTransferOptions scratch;
        applyOverride(scratch, f, v);
        overrides.emplace_back(f, v);
      });
    }
  }
};

/**
 * @brief Refuse a start, source or target that is not a place of the domain's map, naming where
 * the name came from (the flag, or the options file and its field) and the places there are:
 * the experiment's places are the office's by default and a new map rarely has them.
 * @throws krr::ConfigError.
 */
void checkPlaces(const krr::nav::NavGrid& grid, const krr::experiments::NavTransferOptions& o,
                 const Args& a, const std::string& optionsFile) {
  const std::pair<const char*, const std::string*> fields[] = {
      {"start", &o.start}, {"source", &o.source}, {"target", &o.target}};
  for (const auto& [field, value] : fields) {
    bool known = false;
    std::string places;
    for (const auto& p : grid.places()) {
      known = known || p.name == *value;
      places += (places.empty() ? "" : ", ") + p.name;
    }
    if (known) continue;
    const std::string flag = std::string("--") + field;
    bool fromFlag = false;
    for (const auto& ov : a.overrides) fromFlag = fromFlag || ov.first == flag;
    const bool start = field == std::string("start");
    const std::string site = "the site's shop, " + a.files.shopSource();
    const std::string where =
        fromFlag ? "option " + flag
        : a.files.site ? (start ? site
                                : a.files.site->manifest() + ": field 'experiments.nav_transfer." +
                                      field + "' (not set: " + optionsFile + "'s; or " + flag + ")")
        : optionsFile.empty()
            ? (start ? site : "no options file: option " + flag)
            : optionsFile + ": field 'nav_transfer." + field + "'" +
                  (start ? " (default: " + site + ")" : " (or " + flag + ")");
    throw krr::ConfigError(where + ": unknown place '" + *value + "' (places of domain '" +
                           a.domain + "': " + places + ")");
  }
}

}  // namespace

/// @brief The program; main() runs it under guardedMain so that no exception aborts it.
static int mainBody(int argc, char** argv) {
  Args a;
  krr::OptionParser parser("nav_transfer", kSummary);
  a.declare(parser);
  parser.epilog(kEpilog);
  const auto check = [&] {
    if (a.trials == 0) throw krr::ConfigError("--trials must be at least 1");
    a.threads = std::max<std::size_t>(1, a.threads);
  };
  if (const auto status = parser.parse(argc, argv, check)) return *status;
  // Given, the options file must exist; by default, it may be absent.
  const bool givenOptions = !a.files.options.empty();
  a.files.resolveRoot();
  if (a.domain.empty()) a.domain = a.files.defaultDomain();
  // The start is the site's shop unless the options file names another.
  krr::experiments::NavTransferOptions o;
  o.start = a.files.siteShop();
  const bool loadedOptions = givenOptions || std::ifstream(a.files.options).good();
  if (loadedOptions) o = krr::experiments::loadNavTransferOptions(a.files.options, o);
  if (a.files.site) {
    // A site's places, not the options file's (the office's): its shop, site.yaml's
    // experiments.nav_transfer (checkPlaces names it when the site has none).
    o.start = a.files.siteShop();
    for (auto [field, value] : {std::pair{"source", &o.source}, std::pair{"target", &o.target}})
      if (!a.files.sitePlace("nav_transfer", field).empty())
        *value = a.files.sitePlace("nav_transfer", field);
  }
  for (const auto& [f, v] : a.overrides) applyOverride(o, f, v);
  o.validate();
  a.files.resolveInputs(a.domain);

  std::cerr << "nav_transfer: seed " << a.seed << ", trials [" << a.begin << ", "
            << a.begin + a.trials << "), " << a.threads << " threads, domain " << a.domain
            << ", M " << o.rmax.known_threshold << ", Rmax " << o.rmax.rmax << ", step cost "
            << o.rmax.step_cost << ", " << o.target_episodes << " target episodes\n";
  krr::Stopwatch clock;
  auto dom =
      krr::kb::NavDomain::load(a.files.navigationConfig(), a.domain, a.files.geometry,
                               a.files.knowledge);
  checkPlaces(*dom.grid, o, a, loadedOptions ? a.files.options : std::string());
  const auto trials =
      krr::experiments::runNavTransferTrials(dom, o, a.seed, a.begin, a.trials, a.threads);
  const auto s = krr::experiments::summarizeNavTransfer(trials);
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
}

int main(int argc, char** argv) {
  return krr::guardedMain("nav_transfer", mainBody, argc, argv);
}
