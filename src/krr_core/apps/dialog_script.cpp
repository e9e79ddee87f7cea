// dialog_script: replay a scripted dialog and print the belief per turn (paper, Figure 4).
//
//   dialog_script --utterance "a coke for Bob to office2" --utterance coke --utterance yes
//                 --utterance yes [--question ask_item ...] [--out turns.csv] [--json]
//                 [--language config/language.yaml] [--knowledge config/office.plog
//                 [--speech config/dialog.plog]]
//                 [--reach 0.95,0.65,0.75,0.95,0.5] [--p-general 0.8] [--p-yesno 0.8]
//                 [--turn-limit 20] [--solve-time 2] [--precision 0.5] [--no-policy]
//
// The model is the 30-request delivery dialog POMDP: items coke, coffee, soda; rooms
// room1..room5; persons john, bob; prior: people ask for deliveries to their own office
// (config/office.plog: place(john, room5), place(bob, room2)) with probability 0.8, or the
// prior computed by P-log from --knowledge (P(request(I,R,P)) for every request) and, with
// --speech, the speech accuracies reasoned from that model (dialog::DialogKnowledge, replacing
// --p-general / --p-yesno); delivery
// success by the paper's equation from the reach probabilities shop -> room1..room5 (--reach).
// The robot's questions come from the policy of the point-based solver (--solve-time seconds,
// --precision) unless scripted with --question (one per utterance after the first; "none"
// for no question); --no-policy requires a question for every such utterance.
// Output: a transcript with the marginals per turn on stdout (JSON with --json) and the CSV
// of scriptToCsv with --out. Errors: message on stderr, exit 1; bad arguments exit 2.
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/dialog/dialog_knowledge.h"
#include "krr_core/dialog/dialog_script.h"
#include "krr_core/dialog/request_prior.h"
#include "krr_core/plog/reasoner.h"
#include "krr_core/pomdp/point_based_solver.h"

namespace {

const char* kUsage =
    "usage: dialog_script --utterance TEXT [--utterance TEXT ...] [--question ACTION ...]\n"
    "         [--out turns.csv] [--json] [--language config/language.yaml]\n"
    "         [--knowledge office.plog [--speech dialog.plog]] [--reach r1,r2,r3,r4,r5]\n"
    "         [--p-general 0.8] [--p-yesno 0.8] [--turn-limit 20] [--solve-time 2]\n"
    "         [--precision 0.5] [--no-policy]\n";

struct Args {
  std::vector<std::string> utterances, questions;
  std::string out, language = "config/language.yaml", knowledge, speech;
  bool json = false, noPolicy = false;
  std::vector<double> reach{0.95, 0.65, 0.75, 0.95, 0.5};
  double pGeneral = 0.8, pYesNo = 0.8, solveTime = 2.0, precision = 0.5;
  int turnLimit = 20;
};

double toNumber(const std::string& flag, const std::string& v) {
  return krr::parseNumberOption(flag, v);
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
    if (i + 1 >= argc) throw krr::ConfigError("option " + f + " needs a value");
    const std::string v = argv[++i];
    if (f == "--utterance") a.utterances.push_back(v);
    else if (f == "--question") a.questions.push_back(v);
    else if (f == "--out") a.out = v;
    else if (f == "--language") a.language = v;
    else if (f == "--knowledge") a.knowledge = v;
    else if (f == "--speech") a.speech = v;
    else if (f == "--p-general") a.pGeneral = toNumber(f, v);
    else if (f == "--p-yesno") a.pYesNo = toNumber(f, v);
    else if (f == "--solve-time") a.solveTime = toNumber(f, v);
    else if (f == "--precision") a.precision = toNumber(f, v);
    else if (f == "--turn-limit") {
      const double t = toNumber(f, v);
      if (t < 0 || t != static_cast<int>(t))
        throw krr::ConfigError("option --turn-limit: '" + v + "' is not a non-negative integer");
      a.turnLimit = static_cast<int>(t);
    } else if (f == "--reach") {
      a.reach.clear();
      std::stringstream ss(v);
      std::string item;
      while (std::getline(ss, item, ',')) a.reach.push_back(toNumber(f, item));
    } else {
      throw krr::ConfigError("unknown option " + f);
    }
  }
  if (a.utterances.empty()) throw krr::ConfigError("at least one --utterance is required");
  if (!a.speech.empty() && a.knowledge.empty())
    throw krr::ConfigError("--speech needs --knowledge (the office knowledge base)");
  if (!(a.solveTime > 0)) throw krr::ConfigError("--solve-time must be positive");
  if (!(a.precision > 0)) throw krr::ConfigError("--precision must be positive");
  return a;
}

/// The dialog model of the paper's office: the prior from the KB file or the 0.8 own-office rule.
krr::pomdp::DialogSpec makeSpec(const Args& a) {
  krr::pomdp::DialogSpec spec;
  spec.pGeneral = a.pGeneral;
  spec.pYesNo = a.pYesNo;
  if (!a.speech.empty()) {
    krr::dialog::DialogKnowledge kb(a.knowledge, a.speech);
    spec = kb.base();
    spec.pGeneral = kb.speech().p_general;
    spec.pYesNo = kb.speech().p_yesno;
  } else if (!a.knowledge.empty()) {
    krr::plog::Reasoner kb;
    kb.loadFile(a.knowledge);
    spec = krr::dialog::dialogSpecFromKnowledge(kb, a.knowledge);
    spec.pGeneral = a.pGeneral;
    spec.pYesNo = a.pYesNo;
  } else {
    // config/office.plog: place(john, room5), place(bob, room2); pr(...) = 8/10.
    spec.persons = {"john", "bob"};
    spec.prior = krr::pomdp::ownOfficePrior(3, 5, {4, 1}, 0.8);
  }
  spec.turnLimit = a.turnLimit;
  if (a.reach.size() != spec.rooms.size())
    throw krr::ConfigError("--reach has " + std::to_string(a.reach.size()) +
                           " values, the model has " + std::to_string(spec.rooms.size()) +
                           " rooms");
  Eigen::VectorXd reach(static_cast<Eigen::Index>(a.reach.size()));
  for (std::size_t r = 0; r < a.reach.size(); ++r) reach(static_cast<Eigen::Index>(r)) = a.reach[r];
  spec.delivery = krr::pomdp::deliveryMatrix(spec.items.size(), reach, spec.persons.size());
  return spec;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  try {
    a = parse(argc, argv);
  } catch (const krr::Error& e) {
    std::cerr << "dialog_script: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    krr::pomdp::DialogPomdp dialog(makeSpec(a));
    krr::dialog::LanguageFrontEnd language(dialog, krr::dialog::loadLanguageConfig(a.language),
                                           a.language);
    krr::pomdp::AlphaVectorPolicy policy;
    const krr::pomdp::AlphaVectorPolicy* policyPtr = nullptr;
    if (!a.noPolicy) {
      krr::pomdp::SolverOptions opt;
      opt.precision = a.precision;
      opt.timeout = a.solveTime;
      krr::pomdp::PointBasedSolver solver(dialog.model(), dialog.model().initialBelief(), opt);
      solver.solve();
      const auto rep = solver.report();
      std::fprintf(stderr, "# policy: %.3f s, bounds at the prior [%.3f, %.3f] (gap %.3f), %zu alpha vectors\n",
                   rep.time, rep.lower, rep.upper, rep.gap(), rep.alphas);
      policy = solver.policy();
      policyPtr = &policy;
    }
    const auto result =
        krr::dialog::runDialogScript(dialog, language, policyPtr, a.questions, a.utterances);
    std::cout << (a.json ? krr::dialog::scriptToJson(dialog, result)
                         : krr::dialog::scriptToText(dialog, result));
    if (!a.out.empty()) krr::writeFileAtomic(a.out, krr::dialog::scriptToCsv(dialog, result));
  } catch (const krr::Error& e) {
    std::cerr << "dialog_script: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
