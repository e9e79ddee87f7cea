#include "krr_core/dialog/dialog_script.h"

#include <cstdio>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/json.h"

namespace krr {
namespace dialog {

namespace {

const char* kGreeting = "Hello! What can I deliver for you?";

std::string joinList(const std::vector<std::string>& v, const char* sep) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? sep : "") + v[i];
  return s;
}

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string num(double d) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6f", d);
  return buf;
}

std::vector<std::string> observationTexts(const HearResult& h) {
  std::vector<std::string> v;
  for (const auto& o : h.applied) v.push_back(o.description);
  return v;
}

std::string jsonList(const std::vector<std::string>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + jsonString(v[i]);
  return s + "]";
}

std::string jsonMarginal(const std::vector<std::string>& names, const Eigen::VectorXd& p) {
  std::string s = "{";
  for (std::size_t i = 0; i < names.size(); ++i)
    s += (i ? ", " : "") + jsonString(names[i]) + ": " + jsonNumber(p(static_cast<Eigen::Index>(i)));
  return s + "}";
}

std::string actionName(const DialogPomdp& d, long a) {
  return a < 0 ? kNoQuestion : d.model().actionNames()[static_cast<std::size_t>(a)];
}

}  // namespace

long actionByName(const DialogPomdp& dialog, const std::string& name) {
  if (name == kNoQuestion) return -1;
  const auto& names = dialog.model().actionNames();
  for (std::size_t a = 0; a < names.size(); ++a)
    if (names[a] == name) return static_cast<long>(a);
  std::string valid = std::string(kNoQuestion) + ", ask_item, ask_room, ask_person";
  for (std::size_t a = 3; a < names.size() && dialog.isQuestion(a); ++a) valid += ", " + names[a];
  throw ConfigError("unknown robot action '" + name + "' (valid: " + valid +
                    ", serve_<item>_<room>_<person>)");
}

ScriptResult runDialogScript(const DialogPomdp& dialog, const LanguageFrontEnd& language,
                             const pomdp::TurnLimitedPolicy* policy,
                             const std::vector<std::string>& questions,
                             const std::vector<std::string>& utterances) {
  if (utterances.empty()) throw ConfigError("dialog script: no user utterance");
  std::vector<long> scripted;
  for (const auto& q : questions) scripted.push_back(actionByName(dialog, q));
  if (!policy && scripted.size() + 1 < utterances.size())
    throw ConfigError("dialog script: " + std::to_string(utterances.size()) +
                      " utterances need " + std::to_string(utterances.size() - 1) +
                      " robot questions without a policy, got " +
                      std::to_string(scripted.size()));
  DialogSession session(dialog, &language, policy);
  ScriptResult r;
  // The action before utterance k (k >= 1, 0-based), or the one after the last utterance.
  auto actionBefore = [&](std::size_t k) -> long {
    if (k - 1 < scripted.size()) return scripted[k - 1];
    if (policy || session.atTurnLimit()) return static_cast<long>(session.nextAction());
    return -2;  // unknown
  };
  auto describeNext = [&](ScriptTurn& t, long a) {
    if (a == -2) return;
    t.nextAction = actionName(dialog, a);
    t.nextText = a < 0 ? "" : robotUtterance(dialog, static_cast<std::size_t>(a));
  };
  ScriptTurn t0;
  t0.robotAction = kNoQuestion;
  t0.robotText = kGreeting;
  t0.belief = session.summary();
  t0.nextAction = kNoQuestion;
  t0.nextText = kGreeting;
  r.turns.push_back(t0);
  long pending = -1;  // the greeting
  for (std::size_t k = 0; k < utterances.size(); ++k) {
    if (pending >= 0 && dialog.isServe(static_cast<std::size_t>(pending))) {
      session.act(static_cast<std::size_t>(pending));
      r.served = true;
      r.servedRequest = session.servedRequest();
      r.unusedUtterances.assign(utterances.begin() + static_cast<long>(k), utterances.end());
      return r;
    }
    if (pending >= 0) session.act(static_cast<std::size_t>(pending));
    ScriptTurn t;
    t.turn = static_cast<int>(k) + 1;
    t.robotAction = actionName(dialog, pending);
    t.robotText = pending < 0 ? (k == 0 ? kGreeting : "") : robotUtterance(dialog, pending);
    t.user = utterances[k];
    t.heard = session.hear(utterances[k]);
    t.belief = session.summary();
    pending = actionBefore(k + 1);
    describeNext(t, pending);
    r.turns.push_back(std::move(t));
  }
  if (pending >= 0 && dialog.isServe(static_cast<std::size_t>(pending))) {
    session.act(static_cast<std::size_t>(pending));
    r.served = true;
    r.servedRequest = session.servedRequest();
  }
  return r;
}

namespace {

class ScriptedPerson : public DeliveryPerson {
 public:
  explicit ScriptedPerson(const DeliveryScript& s) : s_(s) {}
  void open(DeliveryManager& m) override {
    if (u_ < s_.utterances.size()) m.hear(s_.utterances[u_++]);
  }
  bool answer(DeliveryManager& m, std::size_t) override {
    if (u_ >= s_.utterances.size()) return false;
    m.hear(s_.utterances[u_++]);
    return true;
  }
  bool check(DeliveryManager& m) override {
    if (c_ >= s_.checks.size()) return false;
    m.check(s_.checks[c_++]);
    return true;
  }
  std::vector<std::string> unused() const {
    return {s_.utterances.begin() + static_cast<long>(u_), s_.utterances.end()};
  }

 private:
  const DeliveryScript& s_;
  std::size_t u_ = 0, c_ = 0;
};

class ScriptedNavigator : public DeliveryNavigator {
 public:
  explicit ScriptedNavigator(const std::vector<bool>& legs) : legs_(legs) {}
  LegRecord drive(const Leg& leg) override {
    const bool ok = k_ >= legs_.size() || legs_[k_];
    ++k_;
    return {leg, ok, 0, ok ? "" : "scripted failure"};
  }

 private:
  const std::vector<bool>& legs_;
  std::size_t k_ = 0;
};

}  // namespace

ScriptedDelivery runScriptedDelivery(const DialogPomdp& dialog,
                                     const LanguageFrontEnd& language,
                                     const pomdp::TurnLimitedPolicy& policy,
                                     const DialogConfig& config, const DeliveryScript& script) {
  if (script.utterances.empty()) throw ConfigError("scripted delivery: no user utterance");
  DeliveryManager m(dialog, policy, &language, config);
  ScriptedPerson person(script);
  ScriptedNavigator nav(script.legs);
  ScriptedDelivery d;
  d.completed = runDelivery(m, person, nav);
  d.record = m.record();
  d.decisions = m.decisions();
  d.unusedUtterances = person.unused();
  return d;
}

std::string scriptedDeliveryToJson(const DialogPomdp& dialog, const ScriptedDelivery& d) {
  const DeliveryRecord& r = d.record;
  std::ostringstream out;
  const bool served = r.attempts > 0;
  out << "{\"completed\": " << (d.completed ? "true" : "false")
      << ", \"decisions\": " << jsonList(d.decisions)
      << ", \"outcome\": " << jsonString(toString(r.outcome))
      << ", \"served\": " << (served ? jsonString(dialog.requestName(r.served)) : "null")
      << ", \"delivered\": " << (served ? jsonString(dialog.requestName(r.delivering)) : "null")
      << ", \"turns\": " << r.turns << ", \"qa_cost\": " << jsonNumber(r.qa_cost)
      << ", \"forced\": " << (r.forced ? "true" : "false")
      << ", \"served_probability\": " << jsonNumber(r.served_probability)
      << ", \"max_probability\": " << jsonNumber(r.max_probability)
      << ", \"entropy\": " << jsonNumber(r.entropy)
      << ", \"message\": " << jsonString(r.message)
      << ", \"unused_utterances\": " << jsonList(d.unusedUtterances) << "}\n";
  return out.str();
}

std::string scriptToCsv(const DialogPomdp& dialog, const ScriptResult& r) {
  const auto& s = dialog.spec();
  std::ostringstream out;
  out << "turn,robot_action,robot_text,user,observations,unknown_words,notes";
  for (const auto& n : s.items) out << ",item_" << n;
  for (const auto& n : s.persons) out << ",person_" << n;
  for (const auto& n : s.rooms) out << ",room_" << n;
  out << ",entropy,most_likely,most_likely_p,next_action,next_text\n";
  for (const auto& t : r.turns) {
    out << t.turn << ',' << csvField(t.robotAction) << ',' << csvField(t.robotText) << ','
        << csvField(t.user) << ',' << csvField(joinList(observationTexts(t.heard), ";")) << ','
        << csvField(joinList(t.heard.unknownWords, ";")) << ','
        << csvField(joinList(t.heard.notes, ";"));
    for (Eigen::Index i = 0; i < t.belief.items.size(); ++i) out << ',' << num(t.belief.items(i));
    for (Eigen::Index i = 0; i < t.belief.persons.size(); ++i)
      out << ',' << num(t.belief.persons(i));
    for (Eigen::Index i = 0; i < t.belief.rooms.size(); ++i) out << ',' << num(t.belief.rooms(i));
    out << ',' << num(t.belief.entropy) << ',' << dialog.requestName(t.belief.mostLikely) << ','
        << num(t.belief.mostLikelyProbability) << ',' << csvField(t.nextAction) << ','
        << csvField(t.nextText) << '\n';
  }
  return out.str();
}

std::string scriptToJson(const DialogPomdp& dialog, const ScriptResult& r) {
  const auto& s = dialog.spec();
  std::ostringstream out;
  out << "{\"turns\": [";
  for (std::size_t k = 0; k < r.turns.size(); ++k) {
    const auto& t = r.turns[k];
    out << (k ? ",\n  " : "\n  ") << "{\"turn\": " << t.turn
        << ", \"robot_action\": " << jsonString(t.robotAction)
        << ", \"robot_text\": " << jsonString(t.robotText) << ", \"user\": " << jsonString(t.user)
        << ", \"observations\": " << jsonList(observationTexts(t.heard))
        << ", \"unknown_words\": " << jsonList(t.heard.unknownWords)
        << ", \"notes\": " << jsonList(t.heard.notes)
        << ", \"items\": " << jsonMarginal(s.items, t.belief.items)
        << ", \"persons\": " << jsonMarginal(s.persons, t.belief.persons)
        << ", \"rooms\": " << jsonMarginal(s.rooms, t.belief.rooms)
        << ", \"entropy\": " << jsonNumber(t.belief.entropy)
        << ", \"most_likely\": " << jsonString(dialog.requestName(t.belief.mostLikely))
        << ", \"most_likely_p\": " << jsonNumber(t.belief.mostLikelyProbability)
        << ", \"next_action\": " << jsonString(t.nextAction)
        << ", \"next_text\": " << jsonString(t.nextText) << "}";
  }
  out << "\n], \"served\": " << (r.served ? "true" : "false") << ", \"served_request\": "
      << (r.served ? jsonString(dialog.requestName(r.servedRequest)) : "null")
      << ", \"unused_utterances\": " << jsonList(r.unusedUtterances) << "}\n";
  return out.str();
}

std::string scriptToText(const DialogPomdp& dialog, const ScriptResult& r) {
  const auto& s = dialog.spec();
  std::ostringstream out;
  auto marg = [&](const char* label, const std::vector<std::string>& names,
                  const Eigen::VectorXd& p) {
    out << "   " << label << ":";
    for (std::size_t i = 0; i < names.size(); ++i) {
      char buf[64];
      std::snprintf(buf, sizeof buf, " %s %.3f", names[i].c_str(), p(static_cast<Eigen::Index>(i)));
      out << buf;
    }
    out << "\n";
  };
  for (const auto& t : r.turns) {
    out << "turn " << t.turn << "\n";
    if (t.turn > 0) {
      if (!t.robotText.empty()) out << "   robot: " << t.robotText << "\n";
      out << "   user:  " << t.user << "\n";
      out << "   understood: "
          << (t.heard.applied.empty() ? "(nothing)" : joinList(observationTexts(t.heard), ", "))
          << "\n";
      if (!t.heard.unknownWords.empty())
        out << "   unknown words: " << joinList(t.heard.unknownWords, ", ") << "\n";
      for (const auto& n : t.heard.notes) out << "   note: " << n << "\n";
    }
    marg("items  ", s.items, t.belief.items);
    marg("persons", s.persons, t.belief.persons);
    marg("rooms  ", s.rooms, t.belief.rooms);
    char buf[160];
    std::snprintf(buf, sizeof buf, "   entropy %.4f nats, most likely %s (%.3f)\n",
                  t.belief.entropy, dialog.requestName(t.belief.mostLikely).c_str(),
                  t.belief.mostLikelyProbability);
    out << buf;
  }
  if (r.served) {
    out << "robot: " << robotUtterance(dialog, dialog.serveAction(r.servedRequest)) << "\n";
  } else if (!r.turns.empty() && !r.turns.back().nextText.empty()) {
    out << "robot (next): " << r.turns.back().nextText << "\n";
  }
  if (!r.unusedUtterances.empty())
    out << "unused utterances (the robot served first): " << joinList(r.unusedUtterances, " | ")
        << "\n";
  return out.str();
}

}  // namespace dialog
}  // namespace krr
