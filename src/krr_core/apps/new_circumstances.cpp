// new_circumstances: the paper's "generate controllers for new circumstances" experiment,
// headless. Learns navigation in three settings (times of day), merges them through P-log
// into a controller for "morning or noon, unknown", and compares it in the simulator with a
// baseline that picks one of the per-setting controllers at random. Writes one CSV row per
// trial (trial i depends only on (seed, i), so ranges can be run in separate processes and
// concatenated) and prints a summary.
#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resources.h"
#include "krr_core/kb/new_circumstances.h"

namespace {

const char* kUsage =
    "usage: new_circumstances --trials N --seed S [--threads T] [--trial-begin K]\n"
    "         [--out trials.csv] [--no-header] [--repo DIR]\n"
    "         [--options config/new_circumstances.yaml] [--config config/navigation.yaml]\n"
    "         [--domain office_30x30] [--geometry maps/<domain>_geometry.plog]\n"
    "         [--knowledge config/navigation.plog] [--goal room2] [--br 0.1]\n"
    "         [--learn-episodes N] [--selector fixed|least_known]\n"
    "Paths default to DIR (default: $KRR_ROOT, else the checkout holding the working directory\n"
    "or this program). Flags override the options file.\n";

double toNumber(const std::string& flag, const std::string& v) {
  return krr::parseNumberOption(flag, v);
}

std::size_t toCount(const std::string& flag, const std::string& v) {
  return krr::parseCountOption(flag, v);
}

}  // namespace

int main(int argc, char** argv) {
  std::string repo, options_file, config, domain, geometry, knowledge, out;
  std::size_t trials = 0, threads = std::max(1u, std::thread::hardware_concurrency()), begin = 0;
  std::uint64_t seed = 1;
  bool have_trials = false, header = true;
  std::vector<std::pair<std::string, std::string>> overrides;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string f = argv[i];
      if (f == "-h" || f == "--help") {
        std::cout << kUsage;
        return 0;
      }
      if (f == "--no-header") {
        header = false;
        continue;
      }
      if (i + 1 >= argc) throw krr::ConfigError("option " + f + " needs a value");
      const std::string v = argv[++i];
      if (f == "--trials") {
        trials = toCount(f, v);
        have_trials = true;
      } else if (f == "--seed") seed = toCount(f, v);
      else if (f == "--threads") threads = std::max<std::size_t>(1, toCount(f, v));
      else if (f == "--trial-begin") begin = toCount(f, v);
      else if (f == "--out") out = v;
      else if (f == "--repo") repo = v;
      else if (f == "--options") options_file = v;
      else if (f == "--config") config = v;
      else if (f == "--domain") domain = v;
      else if (f == "--geometry") geometry = v;
      else if (f == "--knowledge") knowledge = v;
      else if (f == "--goal" || f == "--br" || f == "--learn-episodes" || f == "--selector")
        overrides.emplace_back(f, v);
      else throw krr::ConfigError("unknown option " + f);
    }
    if (!have_trials || trials == 0) throw krr::ConfigError("--trials N (N >= 1) is required");
  } catch (const krr::Error& e) {
    std::cerr << "new_circumstances: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    repo = krr::findRepositoryRoot(repo);
    if (options_file.empty()) options_file = repo + "/config/new_circumstances.yaml";
    krr::kb::NewCircumstancesOptions o = krr::kb::loadNewCircumstancesOptions(options_file);
    for (const auto& [f, v] : overrides) {
      if (f == "--goal") o.goal = v;
      else if (f == "--br") o.blocking_rate = toNumber(f, v);
      else if (f == "--learn-episodes") o.learn_episodes = toCount(f, v);
      else if (f == "--selector") o.selector = v;
    }
    if (!domain.empty()) o.domain = domain;
    o.validate();
    if (config.empty()) config = repo + "/config/navigation.yaml";
    if (geometry.empty()) geometry = repo + "/maps/" + o.domain + "_geometry.plog";
    if (knowledge.empty()) knowledge = repo + "/config/navigation.plog";

    std::cerr << "new_circumstances: seed " << seed << ", trials [" << begin << ", "
              << begin + trials << "), " << threads << " threads, domain " << o.domain << ", "
              << o.start << " -> " << o.goal << "\n";
    krr::Stopwatch clock;
    const auto dom = krr::kb::NavDomain::load(config, o.domain, geometry, knowledge);
    const auto res = krr::kb::runNewCircumstances(dom, o, seed, begin, trials, threads);
    std::ostringstream csv;
    if (header) csv << krr::kb::newCircumstancesCsvHeader(o) << "\n";
    for (const auto& t : res) csv << krr::kb::newCircumstancesCsvRow(t) << "\n";
    if (!out.empty()) krr::writeFileAtomic(out, csv.str());

    std::vector<double> sm, sb, so, pm, pb, po, em, eb, diff;
    std::vector<std::vector<double>> self(o.learn_times.size());
    for (const auto& t : res) {
      sm.push_back(t.success_merged);
      sb.push_back(t.success_baseline);
      so.push_back(t.success_oracle);
      pm.push_back(t.p_merged);
      pb.push_back(t.p_baseline);
      po.push_back(t.p_oracle);
      em.push_back(t.expected_merged);
      eb.push_back(t.expected_baseline);
      diff.push_back(t.expected_merged - t.expected_baseline);
      for (std::size_t k = 0; k < self.size(); ++k) self[k].push_back(t.p_self[k]);
    }
    auto line = [](const char* name, const std::vector<double>& x) {
      const krr::kb::MeanCi m = krr::kb::meanCi(x);
      std::printf("  %-34s %.3f +- %.3f\n", name, m.mean, m.ci95);
    };
    std::printf("new circumstances (%s, %s -> %s, br %g): %zu trials, setting unknown among {",
                o.domain.c_str(), o.start.c_str(), o.goal.c_str(), o.blocking_rate, res.size());
    for (std::size_t k = 0; k < o.unknown_times.size(); ++k)
      std::printf("%s%s", k ? ", " : "", o.unknown_times[k].c_str());
    std::printf("}\n");
    line("success, merged (KRR-RL)", sm);
    line("success, baseline (random policy)", sb);
    line("success, oracle (knows the time)", so);
    line("exact P(success), merged", pm);
    line("exact P(success), baseline", pb);
    line("exact P(success), oracle", po);
    line("expected P(success), merged", em);
    line("expected P(success), baseline", eb);
    line("expected merged - baseline", diff);
    for (std::size_t k = 0; k < self.size(); ++k)
      line(("own controller in " + o.learn_times[k]).c_str(), self[k]);
    std::printf("  (%.1f s)\n", clock.seconds());
    return 0;
  } catch (const krr::Error& e) {
    std::cerr << "new_circumstances: " << e.what() << "\n";
    return 1;
  }
}
