// dialog_script: talk to the robot's dialog manager from the command line, without ROS.
//
//   dialog_script --utterance "tea for Dave to the reading room" --utterance tea --utterance yes
//                 [--question ask_item ...] [--no-policy] [--deliver [--check TEXT ...]
//                 [--legs ok,ok,fail]] [--out turns.csv] [--json] [--reach P,...
//                 [--reach-back P,...]] [--dialog-config F] [--language F]
//                 [--domain NAME] [--root DIR] [--site DIR] [--cache DIR|none]
//
// --reach and --reach-back take one probability per room of the model, in the knowledge
// base's room order; --domain defaults to the first domain of config/navigation.yaml.
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
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resource_locator.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/dialog/delivery_navigation.h"
#include "krr_core/dialog/dialog_knowledge.h"
#include "krr_core/dialog/dialog_policy.h"
#include "krr_core/dialog/dialog_script.h"
#include "krr_core/experiments/experiment_paths.h"
#include "krr_core/site/site.h"

namespace {

const char* kSummary =
    "Talk to the robot's dialog manager without ROS. Default: Figure 4 (per-turn marginals;\n"
    "the user speaks first, before each further utterance the robot asks the next --question\n"
    "or the policy's question). --deliver: the whole delivery through the DeliveryManager.";

struct Args {
  std::vector<std::string> utterances, questions, checks;
  std::vector<bool> legs;
  std::string out, dialogConfig, language, domain, root, cache, site;
  bool json = false, noPolicy = false, deliver = false, haveCache = false;
  long solverTrials = -1;
  std::vector<double> reach, reachBack;

  /// @brief Declare the options on `p`; this object receives their values.
  void declare(krr::OptionParser& p) {
    p.add("--utterance", "TEXT", "what the person says, in order", &utterances).required();
    p.add("--question", "ACTION", "the robot's question before the next utterance", &questions);
    p.flag("--no-policy", "ask only the --question actions", &noPolicy);
    p.flag("--deliver", "run the whole delivery (the utterances answer the questions)", &deliver);
    p.add("--check", "TEXT", "with --deliver: what the person says at the room", &checks);
    p.add("--legs", "ok,fail,...", "with --deliver: how the navigation legs end (default: all ok)",
          [this](const std::string& v) {
            for (const std::string& item : krr::splitOption(v)) {
              if (item != "ok" && item != "fail")
                throw krr::ConfigError("option --legs: '" + item + "' must be ok or fail");
              legs.push_back(item == "ok");
            }
          });
    p.add("--out", "FILE", "per-turn marginals as CSV", &out);
    p.flag("--json", "print JSON", &json);
    p.add("--reach", "P,...",
          "P^N(shop, room), one per room of the model in its room order, instead of the "
          "knowledge base's",
          [this](const std::string& v) { reach = krr::parseNumberListOption("--reach", v); });
    p.add("--reach-back", "P,...", "with --reach: P^N(room, shop), one per room of the model",
          [this](const std::string& v) {
            reachBack = krr::parseNumberListOption("--reach-back", v);
          });
    p.add("--dialog-config", "FILE", "dialog settings", &dialogConfig)
        .defaultText("ROOT/config/dialog.yaml");
    p.add("--language", "FILE", "language front end", &language)
        .defaultText("ROOT/config/language.yaml");
    p.add("--domain", "NAME", "navigation domain", &domain)
        .defaultText("the first domain of ROOT/config/navigation.yaml");
    p.add("--root", "DIR", krr::kRepositoryRootHelp, &root);
    p.add("--site", "DIR",
          "site folder: its knowledge, shop, language and domains (config/sites/office, ...)",
          &site)
        .defaultText("the office of ROOT/config");
    p.add("--cache", "DIR|none", "solved policies; none: solve every run",
          [this](const std::string& v) { cache = v, haveCache = true; },
          "$KRR_CACHE_DIR or ~/.cache/krr_rl/delivery");
    p.add("--solver-trials", "N",
          "the dialog solver's trial budget (0: solve to the certified precision), as "
          "dialog_node's ~solver_max_trials",
          [this](const std::string& v) {
            solverTrials = static_cast<long>(krr::parseCountOption("--solver-trials", v));
          },
          "the dialog config's");
  }

  /// @brief The combinations the options allow. @throws ConfigError.
  void check() const {
    if (deliver && (noPolicy || !questions.empty()))
      throw krr::ConfigError("--deliver runs the robot's policy: no --question / --no-policy");
    if (!deliver && (!checks.empty() || !legs.empty()))
      throw krr::ConfigError("--check and --legs need --deliver");
    if (!reachBack.empty() && reach.empty()) throw krr::ConfigError("--reach-back needs --reach");
    if (!site.empty() && (!dialogConfig.empty() || !language.empty()))
      throw krr::ConfigError("--site names the knowledge and the language: no --dialog-config "
                             "or --language with it");
  }
};

/// @brief One value per room of the model, whatever the site's room count; the error lists the
/// rooms in order so that the values can be lined up with them. @throws krr::ConfigError.
void checkReachCount(const std::string& flag, const std::vector<double>& values,
                     const std::vector<std::string>& rooms) {
  if (values.size() == rooms.size()) return;
  std::string names;
  for (const std::string& r : rooms) names += (names.empty() ? "" : ", ") + r;
  throw krr::ConfigError("option " + flag + ": " + std::to_string(values.size()) +
                         " values, but the model has " + std::to_string(rooms.size()) +
                         " rooms (" + names + "): give one per room, in this order");
}

}  // namespace

/// @brief The program; main() runs it under guardedMain so that no exception aborts it.
static int mainBody(int argc, char** argv) {
  Args a;
  krr::OptionParser parser("dialog_script", kSummary);
  a.declare(parser);
  if (const auto status = parser.parse(argc, argv, [&] { a.check(); })) return *status;
  using namespace krr::dialog;
  const std::string root = krr::findRepositoryRoot(a.root, "config/dialog.yaml");
  std::shared_ptr<const krr::site::Site> site;
  if (!a.site.empty())
    site = std::make_shared<krr::site::Site>(krr::site::Site::load(a.site, root + "/config"));
  DialogConfig config =
      site ? site->dialog()
           : loadDialogConfig(a.dialogConfig.empty() ? root + "/config/dialog.yaml" : a.dialogConfig);
  if (a.solverTrials >= 0) config.solver_max_trials = static_cast<std::size_t>(a.solverTrials);
  const std::string languageFile =
      site ? site->language() : a.language.empty() ? root + "/config/language.yaml" : a.language;
  const DialogKnowledge knowledge(config.office_plog, config.speech_plog);
  TripTable trips;
  if (!a.reach.empty()) {
    checkReachCount("--reach", a.reach, knowledge.base().rooms);
    if (!a.reachBack.empty()) checkReachCount("--reach-back", a.reachBack, knowledge.base().rooms);
    trips = TripTable::fromReach(knowledge.base().rooms, a.reach, a.reachBack, config.failure_penalty);
  } else {
    const auto paths = krr::experiments::ExperimentPaths::find(root, a.domain, a.site);
    const krr::kb::NavDomain domain = krr::kb::NavDomain::load(
        paths.navigationConfig(), paths.domain, paths.geometry, paths.navigation_plog);
    krr::kb::NavigationKnowledge nav(*domain.grid, domain.knowledge_files);
    trips = deliveryNavigationFromKnowledge(domain, nav, config, knowledge.base().rooms)->trips();
  }
  const krr::dialog::DialogPomdp dialog(knowledge.buildSpec(trips, config));
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
                 "%zu trials, %zu vectors, %s\n", rep.from_cache ? "loaded" : "solved",
                 rep.seconds, rep.bounds.lower, rep.bounds.upper, rep.bounds.gap(),
                 rep.bounds.trials, policy.size(),
                 rep.converged ? "certified"
                 : rep.stop.empty() ? "NOT certified to the configured precision"
                                    : ("NOT certified to the configured precision: stopped by the " +
                                       rep.stop).c_str());
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
  return 0;
}

int main(int argc, char** argv) {
  return krr::guardedMain("dialog_script", mainBody, argc, argv);
}
