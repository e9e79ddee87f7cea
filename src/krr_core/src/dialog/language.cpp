#include "krr_core/dialog/language.h"

#include <algorithm>
#include <cstdio>
#include <set>

#include <yaml-cpp/yaml.h>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/yaml_section.h"

namespace krr {
namespace dialog {

namespace {

bool isWordByte(unsigned char c) {
  return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '\'' || c >= 0x80;
}

std::string join(const std::vector<std::string>& w, std::size_t from, std::size_t to) {
  std::string s;
  for (std::size_t i = from; i < to; ++i) {
    if (i > from) s += ' ';
    s += w[i];
  }
  return s;
}

/// "lab2" -> "lab 2" if the word is letters followed by digits, else "".
std::string splitDigits(const std::string& word) {
  std::size_t k = 0;
  while (k < word.size() && word[k] >= 'a' && word[k] <= 'z') ++k;
  if (k == 0 || k == word.size()) return "";
  for (std::size_t j = k; j < word.size(); ++j)
    if (word[j] < '0' || word[j] > '9') return "";
  return word.substr(0, k) + " " + word.substr(k);
}

/// The word with every byte that is not part of a valid UTF-8 sequence written as \xNN, so
/// that reports (ROS strings, JSON) are always valid UTF-8.
std::string printable(const std::string& w) {
  std::string out;
  const std::size_t n = w.size();
  for (std::size_t i = 0; i < n;) {
    const auto c = static_cast<unsigned char>(w[i]);
    std::size_t len = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
    bool ok = len > 0 && i + len <= n && !(len == 2 && c < 0xc2);
    for (std::size_t j = 1; ok && j < len; ++j)
      ok = (static_cast<unsigned char>(w[i + j]) & 0xc0) == 0x80;
    if (ok) {
      out.append(w, i, len);
      i += len;
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
      ++i;
    }
  }
  return out;
}

}  // namespace

const char* factorName(Factor f) {
  switch (f) {
    case Factor::kItem: return "item";
    case Factor::kRoom: return "room";
    case Factor::kPerson: return "person";
  }
  return "?";
}

namespace {

LanguageConfig parseLanguageConfigNode(const YAML::Node& root, const std::string& name) {
  static const std::set<std::string> kKeys = {"yes", "no", "ignore", "synonyms",
                                              "max_utterance_chars"};
  // Unknown keys are reported as "unknown key" with the expected ones before the shared reader
  // checks them (its wording is "unknown field").
  if (root.IsMap()) {
    for (const auto& kv : root) {
      const std::string key = kv.first.as<std::string>();
      if (!kKeys.count(key))
        throw ConfigError(name + ": unknown key '" + key +
                          "' (expected yes, no, ignore, synonyms, max_utterance_chars)");
    }
  }
  const YamlSection top(root, name, "", kKeys);  // null = all defaults; not a mapping: error
  LanguageConfig c;
  c.yesWords = top.strings("yes", c.yesWords);
  c.noWords = top.strings("no", c.noWords);
  c.ignoreWords = top.strings("ignore", c.ignoreWords);
  c.maxUtteranceChars = top.count("max_utterance_chars", c.maxUtteranceChars, 1, 100000);
  const YAML::Node synonyms = top.get("synonyms");
  if (synonyms && !synonyms.IsNull()) {
    if (!synonyms.IsMap()) top.fail("synonyms", "must map phrases to value names");
    for (const auto& kv : synonyms) {
      if (!kv.second.IsScalar())
        throw ConfigError(name + ": synonym '" + kv.first.as<std::string>() +
                          "' must map to one value name");
      c.synonyms[kv.first.as<std::string>()] = kv.second.as<std::string>();
    }
  }
  return c;
}

}  // namespace

LanguageConfig parseLanguageConfig(const std::string& text, const std::string& name) {
  const YAML::Node root = parseYaml(text, name);
  try {
    return parseLanguageConfigNode(root, name);
  } catch (const YAML::Exception& e) {
    throw ConfigError(name + ":" + std::to_string(e.mark.line + 1) + ":" +
                      std::to_string(e.mark.column + 1) + ": " + e.msg);
  }
}

LanguageConfig loadLanguageConfig(const std::string& path) {
  return parseLanguageConfig(readFile(path), path);
}

LanguageFrontEnd::LanguageFrontEnd(const DialogPomdp& dialog, const LanguageConfig& config,
                                   const std::string& configName)
    : LanguageFrontEnd(dialog.spec().items, dialog.spec().rooms, dialog.spec().persons, config,
                       configName) {}

LanguageFrontEnd::LanguageFrontEnd(const std::vector<std::string>& items,
                                   const std::vector<std::string>& rooms,
                                   const std::vector<std::string>& persons,
                                   const LanguageConfig& config, const std::string& configName)
    : config_(config), sizes_{items.size(), rooms.size(), persons.size()} {
  if (config_.maxUtteranceChars == 0)
    throw ConfigError(configName + ": max_utterance_chars must be positive");
  auto norm = [this](const std::string& text) {
    const auto w = tokenize(text);
    return join(w, 0, w.size());
  };
  std::map<std::string, Entry> values;  // normalised value name -> entry
  const std::vector<std::string>* lists[3] = {&items, &rooms, &persons};
  const Factor factors[3] = {Factor::kItem, Factor::kRoom, Factor::kPerson};
  for (int f = 0; f < 3; ++f)
    for (std::size_t i = 0; i < lists[f]->size(); ++i) {
      Entry e{Kind::kValue, factors[f], i,
              std::string(factorName(factors[f])) + " name '" + (*lists[f])[i] + "'"};
      const std::string phrase = norm((*lists[f])[i]);
      add(phrase, e, configName);
      values[phrase] = e;
    }
  for (const auto& w : config_.yesWords)
    add(norm(w), {Kind::kYes, Factor::kItem, 0, "yes word '" + w + "'"}, configName);
  for (const auto& w : config_.noWords)
    add(norm(w), {Kind::kNo, Factor::kItem, 0, "no word '" + w + "'"}, configName);
  for (const auto& w : config_.ignoreWords)
    add(norm(w), {Kind::kIgnore, Factor::kItem, 0, "ignored word '" + w + "'"}, configName);
  // Every synonym whose target the model lacks, listed at once: a language file written for
  // another building has many, and fixing them one run at a time is slow.
  std::string stale;
  std::size_t staleCount = 0;
  for (const auto& [phrase, target] : config_.synonyms) {
    if (values.count(norm(target))) continue;
    stale += std::string(staleCount++ ? ", " : "") + "'" + phrase + "' -> '" + target + "'";
  }
  if (staleCount > 0) {
    std::string names;
    for (int f = 0; f < 3; ++f)
      for (const std::string& v : *lists[f]) names += (names.empty() ? "" : ", ") + v;
    throw ConfigError(configName + ": field 'synonyms': " + std::to_string(staleCount) +
                      (staleCount == 1 ? " synonym names" : " synonyms name") +
                      " no item, room or person of the model: " + stale + " (the model's names: " +
                      names + ")");
  }
  for (const auto& [phrase, target] : config_.synonyms) {
    Entry e = values.find(norm(target))->second;
    e.source = "synonym '" + phrase + "' of " + target;
    add(norm(phrase), e, configName);
  }
  // "lab2" also as "lab 2" (explicit entries win over generated variants).
  std::vector<std::pair<std::string, Entry>> variants;
  for (const auto& [phrase, e] : lexicon_) {
    const std::size_t sp = phrase.rfind(' ');
    const std::string last = sp == std::string::npos ? phrase : phrase.substr(sp + 1);
    const std::string split = splitDigits(last);
    if (split.empty()) continue;
    variants.emplace_back(sp == std::string::npos ? split : phrase.substr(0, sp + 1) + split, e);
  }
  for (auto& [phrase, e] : variants)
    if (!lexicon_.count(phrase)) {
      lexicon_[phrase] = e;
      maxPhraseWords_ = std::max<std::size_t>(
          maxPhraseWords_, std::count(phrase.begin(), phrase.end(), ' ') + 1);
    }
}

void LanguageFrontEnd::add(const std::string& phrase, const Entry& e,
                           const std::string& configName) {
  if (phrase.empty())
    throw ConfigError(configName + ": empty phrase in " + e.source +
                      " (a phrase needs at least one letter or digit)");
  auto it = lexicon_.find(phrase);
  if (it != lexicon_.end()) {
    const Entry& o = it->second;
    const bool same = o.kind == e.kind &&
                      (e.kind != Kind::kValue || (o.factor == e.factor && o.index == e.index));
    if (!same)
      throw ConfigError(configName + ": phrase '" + phrase + "' has two meanings: " + o.source +
                        " and " + e.source);
    return;
  }
  lexicon_[phrase] = e;
  maxPhraseWords_ =
      std::max<std::size_t>(maxPhraseWords_, std::count(phrase.begin(), phrase.end(), ' ') + 1);
}

std::vector<std::string> LanguageFrontEnd::tokenize(const std::string& text) const {
  std::vector<std::string> words;
  std::string cur;
  auto flush = [&]() {
    if (cur.size() >= 2 && cur.compare(cur.size() - 2, 2, "'s") == 0) cur.resize(cur.size() - 2);
    cur.erase(std::remove(cur.begin(), cur.end(), '\''), cur.end());
    if (!cur.empty()) words.push_back(printable(cur));
    cur.clear();
  };
  for (unsigned char c : text) {
    if (c >= 'A' && c <= 'Z') c = static_cast<unsigned char>(c - 'A' + 'a');
    if (isWordByte(c)) cur += static_cast<char>(c);
    else flush();
  }
  flush();
  return words;
}

ParsedUtterance LanguageFrontEnd::parse(const std::string& text) const {
  ParsedUtterance p;
  std::string t = text;
  if (t.size() > config_.maxUtteranceChars) {
    t.resize(config_.maxUtteranceChars);
    p.truncated = true;
  }
  p.words = tokenize(t);
  const std::size_t n = p.words.size();
  for (std::size_t i = 0; i < n;) {
    bool matched = false;
    for (std::size_t len = std::min(maxPhraseWords_, n - i); len >= 1; --len) {
      const std::string key = join(p.words, i, i + len);
      auto it = lexicon_.find(key);
      if (it == lexicon_.end()) continue;
      const Entry& e = it->second;
      if (e.kind == Kind::kValue) p.mentions.push_back({e.factor, e.index, key});
      else if (e.kind == Kind::kYes) ++p.yes;
      else if (e.kind == Kind::kNo) ++p.no;
      i += len;
      matched = true;
      break;
    }
    if (!matched) p.unknownWords.push_back(p.words[i++]);
  }
  return p;
}

Interpretation LanguageFrontEnd::interpret(const ParsedUtterance& parsed,
                                           const DialogPomdp& dialog,
                                           long lastQuestion) const {
  const auto& spec = dialog.spec();
  if (spec.items.size() != sizes_[0] || spec.rooms.size() != sizes_[1] ||
      spec.persons.size() != sizes_[2])
    throw ConfigError("language front end: built for " + std::to_string(sizes_[0]) + " items, " +
                      std::to_string(sizes_[1]) + " rooms, " + std::to_string(sizes_[2]) +
                      " persons, but the dialog model has " + std::to_string(spec.items.size()) +
                      ", " + std::to_string(spec.rooms.size()) + ", " +
                      std::to_string(spec.persons.size()));
  Interpretation r;
  r.unknownWords = parsed.unknownWords;
  const auto& obsNames = dialog.model().observationNames();
  const auto& actNames = dialog.model().actionNames();
  auto describe = [&](std::size_t a, std::size_t o) {
    return (a < actNames.size() ? actNames[a] : std::to_string(a)) + " -> " +
           (o < obsNames.size() ? obsNames[o] : std::to_string(o));
  };
  if (parsed.truncated)
    r.notes.push_back("utterance truncated to " + std::to_string(config_.maxUtteranceChars) +
                      " characters");
  if (parsed.words.empty()) {
    r.notes.push_back("empty utterance: nothing to understand");
    return r;
  }
  if (!parsed.understood()) {
    r.notes.push_back("nothing understood (no item, room, person, yes or no)");
    return r;
  }
  // Answers to a confirming question first (the order does not change the belief).
  if (parsed.yes > 0 || parsed.no > 0) {
    const bool confirming =
        lastQuestion >= 0 && dialog.isQuestion(static_cast<std::size_t>(lastQuestion)) &&
        static_cast<std::size_t>(lastQuestion) > dialog.askPerson();
    if (parsed.yes > 0 && parsed.no > 0) {
      r.notes.push_back("both yes and no in one utterance: the answer is ignored");
    } else if (!confirming) {
      r.notes.push_back(std::string("'") + (parsed.yes ? "yes" : "no") +
                        "' ignored: the robot's last question was not a confirming question");
    } else {
      const auto a = static_cast<std::size_t>(lastQuestion);
      const std::size_t o = parsed.yes ? dialog.obsYes() : dialog.obsNo();
      r.observations.push_back({a, o, describe(a, o)});
    }
  }
  std::set<std::pair<int, std::size_t>> seen;
  for (const Mention& m : parsed.mentions) {
    if (!seen.insert({static_cast<int>(m.factor), m.index}).second) continue;
    std::size_t a = 0, o = 0;
    switch (m.factor) {
      case Factor::kItem: a = dialog.askItem(); o = dialog.obsItem(m.index); break;
      case Factor::kRoom: a = dialog.askRoom(); o = dialog.obsRoom(m.index); break;
      case Factor::kPerson: a = dialog.askPerson(); o = dialog.obsPerson(m.index); break;
    }
    r.observations.push_back({a, o, describe(a, o)});
  }
  return r;
}

Interpretation LanguageFrontEnd::understand(const std::string& text,
                                            const DialogPomdp& dialog,
                                            long lastQuestion) const {
  return interpret(parse(text), dialog, lastQuestion);
}

std::string exampleRequest(const DialogSpec& spec) {
  if (spec.items.empty() || spec.rooms.empty() || spec.persons.empty())
    throw ConfigError("exampleRequest: the dialog model needs items, rooms and persons");
  return "a " + spec.items.front() + " for " + spec.persons.front() + " to " + spec.rooms.front();
}

std::string robotUtterance(const DialogPomdp& dialog, std::size_t action) {
  const auto& s = dialog.spec();
  if (action >= dialog.model().getA())
    throw ConfigError("robotUtterance: action " + std::to_string(action) + " out of range (" +
                      std::to_string(dialog.model().getA()) + " actions)");
  switch (dialog.actionKind(action)) {
    case DialogActionKind::kAskItem: return "Which item is it?";
    case DialogActionKind::kAskRoom: return "Which room should I deliver to?";
    case DialogActionKind::kAskPerson: return "Who is it for?";
    case DialogActionKind::kConfirmItem:
      return "Should I deliver a " + s.items[action - dialog.confirmItem(0)] + "?";
    case DialogActionKind::kConfirmRoom:
      return "Should I deliver to " + s.rooms[action - dialog.confirmRoom(0)] + "?";
    case DialogActionKind::kConfirmPerson:
      return "Is it for " + s.persons[action - dialog.confirmPerson(0)] + "?";
    case DialogActionKind::kServe: {
      const auto p = dialog.requestParts(dialog.requestOfServe(action));
      return "OK, I am delivering a " + s.items[p[0]] + " for " + s.persons[p[2]] + " to " +
             s.rooms[p[1]] + ".";
    }
  }
  return "";
}

}  // namespace dialog
}  // namespace krr
