/**
 * @file bench_procedure2.cpp
 * @brief Benchmark of Procedure 2 on the real knowledge base: the site's geometry
 * (maps/<domain>_geometry.plog) plus config/navigation.plog, built into the navigation
 * MDP by NavigationKnowledge::buildModel, before and after knowledge extraction.
 *
 * For each domain (in a child process, this program with --in-process, so the peak memory
 * is the domain's own):
 *  - construct: load and parse the knowledge files;
 *  - first build: buildModel({time}) on the human knowledge (grounding + table query);
 *  - rebuild after extraction: R-Max learns the navigation experiment's source task (start ->
 *    source of ROOT/config/experiments/nav_transfer.yaml, the start defaulting to the site's
 *    shop), its known pairs are extracted with addLearned, and the model is rebuilt (the
 *    paper's loop: learn, update the KB, rebuild);
 *  - a second extraction + rebuild on the target task (re-learning replaces pairs), and a
 *    "morning or noon" build;
 *  - peak RSS of the child.
 *
 * Usage: bench_procedure2 [--root DIR] [--time morning] [--repeat 3] [DOMAIN...]
 *        (default: every domain of ROOT/config/navigation.yaml)
 */
#include <algorithm>
#include <limits>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/random.h"
#include "krr_core/common/resource_locator.h"
#include "krr_core/common/resources.h"
#include "krr_core/common/subprocess.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/experiments/nav_transfer.h"
#include "krr_core/kb/nav_domain.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/kb/navigation_learning.h"
#include "krr_core/kb/simulated_navigation.h"
#include "krr_core/mdp/rmax_agent.h"
#include "krr_core/site/site.h"

namespace {

double best(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

/// Wall-clock and CPU time of this thread (the machine may be shared: CPU time is the figure
/// that does not depend on the load).
class Timer {
 public:
  Timer() { reset(); }
  void reset() {
    wall_.reset();
    cpu0_ = krr::threadCpuSeconds();
  }
  double wall() const { return wall_.seconds(); }
  double cpu() const { return krr::threadCpuSeconds() - cpu0_; }

 private:
  krr::Stopwatch wall_;
  double cpu0_ = 0;
};

struct Figure {
  std::vector<double> wall, cpu;
  void add(const Timer& t) {
    cpu.push_back(t.cpu());
    wall.push_back(t.wall());
  }
  std::string str() const {
    char b[96];
    std::snprintf(b, sizeof(b), "%.4f s (CPU %.4f s)", best(wall), best(cpu));
    return b;
  }
};

int runDomain(const std::string& repo, const std::string& name, const std::string& time,
              int repeat) {
  // The tasks: the navigation experiment's (start, source, target), the start the site's shop
  // unless the experiment names another.
  krr::experiments::NavTransferOptions tasks;
  tasks.start = krr::dialog::loadDialogConfig(repo + "/config/dialog.yaml").shop;
  tasks = krr::experiments::loadNavTransferOptions(
      repo + "/config/experiments/nav_transfer.yaml", tasks);
  const std::string config = repo + "/config/navigation.yaml";
  krr::kb::NavDomain dom = krr::kb::NavDomain::load(
      config, name,
      krr::site::geometryFileBeside(krr::nav::loadNavigationConfig(config).map, name),
      repo + "/config/navigation.plog");
  Figure t_construct, t_first, t_rebuild, t_rebuild2, t_mixed, t_add, t_add2, t_clear;
  std::vector<double> g_first, g_rebuild;
  std::size_t rows_rebuild = 0;
  std::size_t pairs = 0, learned_rows = 0, rows = 0;
  for (int r = 0; r < repeat; ++r) {
    Timer sw;
    krr::kb::NavigationKnowledge kb(*dom.grid, dom.knowledge_files);
    t_construct.add(sw);
    sw.reset();
    krr::kb::NavModel m0 = kb.buildModel({time});
    t_first.add(sw);
    g_first.push_back(kb.reasoner().stats().ground_seconds);
    rows = m0.dynamics.getS();

    // Learn start -> source with R-Max (not timed), extract, rebuild.
    krr::mdp::RMaxParams p;
    p.step_limit = static_cast<std::uint32_t>(dom.domain.step_limit);
    const krr::nav::Context ctx(dom.simulator->timeOfDayIndex(time));
    krr::kb::SimulatedNavigation env(*dom.simulator, *dom.space, dom.grid->placeCell(tasks.start),
                                     {dom.grid->placeCell(tasks.source)}, ctx,
                                     p.navigationReward());
    krr::mdp::RMaxAgent agent = krr::kb::makeNavigationAgent(dom, env, p, nullptr);
    krr::Rng rng = krr::makeRng(1, "bench_procedure2", static_cast<std::uint64_t>(r));
    krr::kb::learnUntilConverged(env, agent, 200, 20, rng, {}, nullptr);
    sw.reset();
    pairs = kb.addLearned(agent.model().knownPairs(), time);
    t_add.add(sw);
    sw.reset();
    krr::kb::NavModel m1 = kb.buildModel({time});
    t_rebuild.add(sw);
    rows_rebuild = kb.reasoner().stats().table_rows_computed;
    g_rebuild.push_back(kb.reasoner().stats().ground_seconds);
    learned_rows = m1.numLearned();

    // More learning on start -> target (from the KB's model), extraction, rebuild.
    krr::kb::SimulatedNavigation env2(*dom.simulator, *dom.space, dom.grid->placeCell(tasks.start),
                                      {dom.grid->placeCell(tasks.target)}, ctx,
                                      p.navigationReward());
    krr::mdp::RMaxAgent agent2 = krr::kb::makeNavigationAgent(dom, env2, p, &m1);
    krr::kb::learnUntilConverged(env2, agent2, 100, 20, rng, {}, nullptr);
    sw.reset();
    kb.addLearned(agent2.model().knownPairs(), time);
    t_add2.add(sw);
    sw.reset();
    kb.buildModel({time});
    t_rebuild2.add(sw);
    sw.reset();
    kb.buildModel({"morning", "noon"});
    t_mixed.add(sw);
    sw.reset();
    kb.clearLearned();
    kb.buildModel({time});
    t_clear.add(sw);
  }
  std::printf("%s: %zu states, best of %d runs\n", name.c_str(), rows, repeat);
  std::printf("  construct (parse knowledge files)         %s\n", t_construct.str().c_str());
  std::printf("  first build (human knowledge)             %s, grounding %.4f s\n",
              t_first.str().c_str(), best(g_first));
  std::printf("  addLearned (%zu pairs)                   %s\n", pairs, t_add.str().c_str());
  std::printf("  rebuild after extraction (%zu learned)   %s, grounding %.4f s, %zu rows\n",
              learned_rows, t_rebuild.str().c_str(), best(g_rebuild), rows_rebuild);
  std::printf("  second extraction: addLearned             %s\n", t_add2.str().c_str());
  std::printf("  second extraction: rebuild                %s\n", t_rebuild2.str().c_str());
  std::printf("  build for \"morning or noon\"               %s\n", t_mixed.str().c_str());
  std::printf("  clearLearned + rebuild                    %s\n", t_clear.str().c_str());
  std::printf("  peak RSS                                 %.1f MiB\n", krr::peakRssMiB());
  std::fflush(stdout);
  return 0;
}

/// @brief Each domain in a child process (this program with --in-process): its peak RSS is
/// the domain's own. @return 0 if every child exited with 0.
int runChildren(const std::string& repo, const std::string& time, int repeat,
                const std::vector<std::string>& domains) {
  int status_all = 0;
  for (const std::string& d : domains) {
    std::fflush(stdout);
    std::vector<std::string> argv = {"/proc/self/exe", "--in-process", "--time", time,
                                     "--repeat", std::to_string(repeat), d};
    if (!repo.empty()) argv.insert(argv.begin() + 2, {"--root", repo});
    krr::Subprocess child(argv);
    child.setStdout(krr::Subprocess::Stream::inherit())
        .setStderr(krr::Subprocess::Stream::inherit());
    child.start();
    const krr::SubprocessResult r = child.wait(std::numeric_limits<double>::infinity());
    if (r.end != krr::SubprocessResult::End::kExited || r.exit_code != 0) {
      std::fprintf(stderr, "bench_procedure2: %s: the child %s\n", d.c_str(),
                   r.end == krr::SubprocessResult::End::kSignalled
                       ? ("died of signal " + std::to_string(r.signal)).c_str()
                       : ("exited with " + std::to_string(r.exit_code)).c_str());
      status_all = 1;
    }
  }
  return status_all;
}

}  // namespace

/// @brief The benchmark; main() runs it under guardedMain, which reports a bad option or file.
static int mainBody(int argc, char** argv) {
  std::string repo, time = "morning";
  int repeat = 3;
  bool inProcess = false;
  std::vector<std::string> domains;
  krr::OptionParser cli("bench_procedure2",
                        "Procedure 2 on the real knowledge base (the site's geometry +\n"
                        "config/navigation.plog), before and after knowledge extraction; one child\n"
                        "process per domain, so the peak memory is the domain's own.");
  cli.add("--root", "DIR", krr::kRepositoryRootHelp, &repo).deprecatedAlias("--repo");
  cli.add("--time", "TIME", "time of day of the builds", &time);
  cli.add("--repeat", "N", "runs per figure (the best is printed)", &repeat);
  cli.flag("--in-process", "run the domains in this process (what each child does; the peak "
           "RSS is then the largest domain's so far)", &inProcess);
  cli.positional("DOMAIN", "domains (default: every domain of ROOT/config/navigation.yaml)",
                 [&](const std::string& v) { domains.push_back(v); }, true);
  if (const auto status = cli.parse(argc, argv)) return *status;
  repeat = std::max(1, repeat);
  if (domains.empty()) {
    const auto cfg =
        krr::nav::loadNavigationConfig(krr::findRepositoryRoot(repo) + "/config/navigation.yaml");
    for (const auto& d : cfg.domains) domains.push_back(d.name);
  }
  if (!inProcess) return runChildren(repo, time, repeat, domains);
  int status_all = 0;
  for (const std::string& d : domains)
    if (runDomain(krr::findRepositoryRoot(repo), d, time, repeat) != 0) status_all = 1;
  return status_all;
}

int main(int argc, char** argv) {
  return krr::guardedMain("bench_procedure2", mainBody, argc, argv);
}
