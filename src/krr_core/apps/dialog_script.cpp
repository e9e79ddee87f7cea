// dialog_script: talk to the robot's dialog manager from the command line, without ROS.
//
//   dialog_script --utterance "a coke for Bob to office2" --utterance coke --utterance yes
//                 [--question ask_item ...] [--no-policy] [--deliver [--check TEXT ...]
//                 [--legs ok,ok,fail]] [--out turns.csv] [--json] [--reach r1,...,r5
//                 [--reach-back b1,...,b5]] [--dialog-config F] [--language F]
//                 [--domain office_30x30] [--root DIR] [--cache DIR|none]
//
// The model is the robot's: DialogKnowledge::buildSpec over config/dialog.yaml and the
// knowledge base (prior and speech model by P-log), with P^N and trip costs from the
// navigation knowledge base (Procedure 2 on config/navigation.plog and the domain's geometry,
// human knowledge only) or, with --reach, from the given reach probabilities; the policy is
// solveDialogPolicy's (the same cache as dialog_node and the experiments).
//   - default: Figure 4. Turn 0 is the prior; the user speaks first; before each further
//     utterance the robot asks the next --question or the policy's question; per-turn marginals
//     (text, --json, CSV with --out).
//   - --deliver: the whole delivery through the robot's DeliveryManager (the class dialog_node
//     drives): the utterances answer the questions, the legs end as --legs says (default: all
//     arrive), at the room the person says the --check texts in order; prints the decisions
//     (JSON with --json), the same log dialog_node's rostests compare against.
// Errors: message on stderr, exit 1; bad arguments exit 2.
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/dialog/delivery_navigation.h"
#include "krr_core/dialog/dialog_knowledge.h"
#include "krr_core/dialog/dialog_policy.h"
#include "krr_core/dialog/dialog_script.h"
#include "krr_core/experiments/experiment_paths.h"

namespace {

const char* kUsage =
    "usage: dialog_script --utterance TEXT [--utterance TEXT ...] [--question ACTION ...]\n"
    "         [--no-policy] [--deliver [--check TEXT ...] [--legs ok,ok,fail]]\n"
    "         [--out turns.csv] [--json] [--reach r1,...,r5 [--reach-back b1,...,b5]]\n"
    "         [--dialog-config config/dialog.yaml] [--language config/language.yaml]\n"
    "         [--domain office_30x30] [--root DIR] [--cache DIR|none]\n";

struct Args {
  std::vector<std::string> utterances, questions, checks;
  std::vector<bool> legs;
  std::string out, dialogConfig, language, domain = "office_30x30", root, cache;
  bool json = false, noPolicy = false, deliver = false, haveCache = false;
  std::vector<double> reach, reachBack;
};

std::vector<double> numbers(const std::string& flag, const std::string& v) {
  std::vector<double> out;
  std::stringstream ss(v);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(krr::parseNumberOption(flag, item));
  return out;
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string f = argv[i];
    if (f == "-h" || f == "--help") {
      std::cout << kUsage;
      std::exit(0);
    }
    if (f == "--json") { a.json = true; continue; }
    if (f == "--no-policy") { a.noPolicy = true; continue; }
    if (f == "--deliver") { a.deliver = true; continue; }
    if (i + 1 >= argc) throw krr::ConfigError("option " + f + " needs a value");
    const std::string v = argv[++i];
    if (f == "--utterance") a.utterances.push_back(v);
    else if (f == "--question") a.questions.push_back(v);
    else if (f == "--check") a.checks.push_back(v);
    else if (f == "--out") a.out = v;
    else if (f == "--dialog-config") a.dialogConfig = v;
    else if (f == "--language") a.language = v;
    else if (f == "--domain") a.domain = v;
    else if (f == "--root") a.root = v;
    else if (f == "--cache") a.cache = v, a.haveCache = true;
    else if (f == "--reach") a.reach = numbers(f, v);
    else if (f == "--reach-back") a.reachBack = numbers(f, v);
    else if (f == "--legs") {
      std::stringstream ss(v);
      std::string item;
      while (std::getline(ss, item, ',')) {
        if (item != "ok" && item != "fail")
          throw krr::ConfigError("option --legs: '" + item + "' must be ok or fail");
        a.legs.push_back(item == "ok");
      }
    } else {
      throw krr::ConfigError("unknown option " + f);
    }
  }
  if (a.utterances.empty()) throw krr::ConfigError("at least one --utterance is required");
  if (a.deliver && (a.noPolicy || !a.questions.empty()))
    throw krr::ConfigError("--deliver runs the robot's policy: no --question / --no-policy");
  if (!a.deliver && (!a.checks.empty() || !a.legs.empty()))
    throw krr::ConfigError("--check and --legs need --deliver");
  if (!a.reachBack.empty() && a.reach.empty())
    throw krr::ConfigError("--reach-back needs --reach");
  return a;
}

}  // namespace

/// @brief The program; main() runs it under guardedMain so that no exception aborts it.
static int mainBody(int argc, char** argv) {
  Args a;
  try {
    a = parse(argc, argv);
  } catch (const krr::Error& e) {
    std::cerr << "dialog_script: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    using namespace krr::dialog;
    const std::string root = krr::findRepositoryRoot(a.root, "config/dialog.yaml");
    const DialogConfig config =
        loadDialogConfig(a.dialogConfig.empty() ? root + "/config/dialog.yaml" : a.dialogConfig);
    const std::string languageFile = a.language.empty() ? root + "/config/language.yaml" : a.language;
    const DialogKnowledge knowledge(config.office_plog, config.speech_plog);
    TripTable trips;
    if (!a.reach.empty()) {
      trips = TripTable::fromReach(knowledge.base().rooms, a.reach, a.reachBack, config.failure_penalty);
    } else {
      const ExperimentPaths paths = ExperimentPaths::find(root, a.domain);
      const krr::kb::NavDomain domain = krr::kb::NavDomain::load(
          paths.navigation_yaml, a.domain, paths.geometry, paths.navigation_plog);
      krr::kb::NavigationKnowledge nav(*domain.grid, domain.knowledge_files);
      trips = deliveryNavigationFromKnowledge(domain, nav, config, knowledge.base().rooms)->trips();
    }
    const krr::pomdp::DialogPomdp dialog(knowledge.buildSpec(trips, config));
    const LanguageFrontEnd language(dialog, loadLanguageConfig(languageFile), languageFile);
    std::fprintf(stderr, "# P^N(shop, room):");
    for (std::size_t r = 0; r < trips.rooms.size(); ++r)
      std::fprintf(stderr, " %s %.3f", trips.rooms[r].c_str(), trips.to_room[r].reach);
    std::fprintf(stderr, "\n");
    krr::pomdp::TurnLimitedPolicy policy;
    if (!a.noPolicy) {
      PolicyReport rep;
      const std::string cache = a.haveCache ? (a.cache == "none" ? "" : a.cache) : defaultCacheDir();
      policy = solveDialogPolicy(dialog, config, cache, &rep);
      std::fprintf(stderr, "# policy: %s in %.2f s, bounds at the prior [%.3f, %.3f] (gap %.3f), "
                   "%zu trials, %zu vectors\n", rep.from_cache ? "loaded" : "solved", rep.seconds,
                   rep.bounds.lower, rep.bounds.upper, rep.bounds.gap(), rep.bounds.trials,
                   policy.size());
    }
    if (a.deliver) {
      const ScriptedDelivery d =
          runScriptedDelivery(dialog, language, policy, config, {a.utterances, a.checks, a.legs});
      if (a.json) {
        std::cout << scriptedDeliveryToJson(dialog, d);
      } else {
        for (const auto& s : d.decisions) std::cout << s << "\n";
        if (!d.completed) std::cout << "(the script ended before the delivery did)\n";
      }
      return 0;
    }
    const auto result = runDialogScript(dialog, language, a.noPolicy ? nullptr : &policy,
                                        a.questions, a.utterances);
    std::cout << (a.json ? scriptToJson(dialog, result) : scriptToText(dialog, result));
    if (!a.out.empty()) krr::writeFileAtomic(a.out, scriptToCsv(dialog, result));
  } catch (const krr::Error& e) {
    std::cerr << "dialog_script: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

int main(int argc, char** argv) {
  return krr::guardedMain("dialog_script", mainBody, argc, argv);
}
