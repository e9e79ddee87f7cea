/**
 * @file language.h
 * @brief The dialog manager's language front end: user text -> observations of the dialog POMDP.
 *
 * The dialog POMDP (DialogPomdp) observes one answer per question: an item / room /
 * person name after a general question, yes / no after a confirming question. People do not
 * talk like that ("I'd like tea for Dave to the reading room"), so this front end maps free
 * text to a list of such observations. It is deliberately simple and fully documented:
 *
 * 1. Normalisation. The text is truncated to `max_utterance_chars`, lower-cased (ASCII), and
 *    split into words at every character that is not a letter, a digit or an apostrophe
 *    (punctuation and white space separate words; bytes >= 0x80, e.g. UTF-8, stay inside
 *    words so that they are reported; bytes that are not valid UTF-8 are written as \xNN, so
 *    reports are always valid UTF-8). In each word a possessive "'s" suffix
 *    is dropped ("dave's" -> "dave") and the remaining apostrophes are removed ("i'd" -> "id").
 * 2. Lexicon. Phrases of one or more words, each with a meaning:
 *    - the value names of the model (items, rooms, persons, case-insensitive),
 *    - `synonyms` (phrase -> value name, e.g. "reading room" -> library, "chai" -> tea),
 *    - `yes` and `no` words,
 *    - `ignore` words (articles, prepositions, politeness: understood, carry nothing).
 *    Every phrase whose last word is letters followed by digits ("lab2", "office12") is
 *    also accepted with a space before the digits ("lab 2", "office 12").
 * 3. Matching, left to right, longest phrase first. A word that starts no phrase is an
 *    unknown word: it is returned in ParsedUtterance::unknownWords (never thrown).
 * 4. Interpretation (interpret()), relative to the robot's last question:
 *    - every distinct value mentioned becomes one observation of the general question of its
 *      factor, in the order of first mention: "tea for Dave to the reading room" is the
 *      three successive observations (ask_item, item_tea), (ask_person, person_dave),
 *      (ask_room, room_library). The dialog model's questions do not change the hidden request
 *      and answers are independent given the request, so the order does not change the
 *      resulting belief; mentioning the same value twice in one utterance counts once;
 *    - yes / no is the answer to the last question if it was a confirming question, and is
 *      otherwise ignored with a note; an utterance with both yes and no words is
 *      contradictory: both are ignored with a note;
 *    - negation is not understood ("not tea" is a mention of tea): "not" is deliberately
 *      in neither list, so it is reported as an unknown word.
 * 5. Empty or garbage input gives no observation, the unknown words and a note.
 *
 * Configuration (YAML, e.g. a site folder's language.yaml):
 * @code
 *   yes: [yes, yeah, correct]
 *   no: [no, nope, wrong]
 *   ignore: [a, an, the, for, to, please]
 *   synonyms: {"reading room": library, chai: tea, "dave's office": library}
 *   max_utterance_chars: 500
 * @endcode
 * A phrase with two meanings, a synonym of an unknown value name or an empty phrase is a
 * ConfigError naming the file and the phrase; unknown keys are refused too.
 */
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "krr_core/dialog/dialog_pomdp.h"

namespace krr {
namespace dialog {

/// @brief The three factors of a service request.
enum class Factor { kItem, kRoom, kPerson };

/// @brief "item", "room" or "person".
const char* factorName(Factor f);

/// @brief Vocabulary settings of the front end (see the file comment).
struct LanguageConfig {
  std::vector<std::string> yesWords{"yes"};
  std::vector<std::string> noWords{"no"};
  std::vector<std::string> ignoreWords;
  std::map<std::string, std::string> synonyms;  ///< phrase -> value name
  std::size_t maxUtteranceChars = 500;
};

/**
 * @brief Parse a language configuration from YAML text (keys yes, no, ignore, synonyms,
 * max_utterance_chars; all optional). @throws ConfigError "name: ..." naming the key.
 */
LanguageConfig parseLanguageConfig(const std::string& yamlText,
                                   const std::string& name = "<string>");
/// @brief parseLanguageConfig of a file. @throws IoError / ConfigError naming the file.
LanguageConfig loadLanguageConfig(const std::string& path);

/// @brief A value of a factor mentioned in an utterance.
struct Mention {
  Factor factor = Factor::kItem;
  std::size_t index = 0;  ///< index of the value in the model's item / room / person list
  std::string phrase;     ///< the normalised words that mentioned it ("office 2")
};

/// @brief What the front end recognised in one utterance, before interpretation.
struct ParsedUtterance {
  std::vector<Mention> mentions;          ///< values, in the order mentioned
  int yes = 0;                            ///< number of yes words
  int no = 0;                             ///< number of no words
  std::vector<std::string> words;         ///< all normalised words
  std::vector<std::string> unknownWords;  ///< words the lexicon does not know, in order
  bool truncated = false;                 ///< the text was longer than max_utterance_chars
  /// @brief True if anything meaningful (a value, yes or no) was recognised.
  bool understood() const { return !mentions.empty() || yes > 0 || no > 0; }
};

/// @brief One observation of the dialog POMDP derived from an utterance.
struct DialogObservation {
  std::size_t action = 0;       ///< the question it answers (model action index)
  std::size_t observation = 0;  ///< model observation index
  std::string description;      ///< "ask_item -> item_coke"
};

/// @brief The observations of an utterance and what could not be used.
struct Interpretation {
  std::vector<DialogObservation> observations;
  std::vector<std::string> unknownWords;
  std::vector<std::string> notes;  ///< human-readable reasons for ignored content
};

/// @brief Maps text to dialog observations for one item / room / person vocabulary.
class LanguageFrontEnd {
 public:
  /// @throws ConfigError naming the phrase on conflicts or synonyms of unknown values.
  LanguageFrontEnd(const std::vector<std::string>& items, const std::vector<std::string>& rooms,
                   const std::vector<std::string>& persons, const LanguageConfig& config,
                   const std::string& configName = "<language config>");
  /// @brief The vocabulary of a dialog model.
  LanguageFrontEnd(const DialogPomdp& dialog, const LanguageConfig& config,
                   const std::string& configName = "<language config>");

  /// @brief Steps 1-3 of the file comment. Never throws on any input.
  ParsedUtterance parse(const std::string& text) const;

  /**
   * @brief Step 4: the observations of a parsed utterance for `dialog`.
   * @param lastQuestion the robot's last question (model action index) or -1 if none (e.g.
   *        the user spoke first). yes / no answer it only if it is a confirming question.
   * @throws ConfigError if the dialog's vocabulary sizes differ from the front end's.
   */
  Interpretation interpret(const ParsedUtterance& parsed, const DialogPomdp& dialog,
                           long lastQuestion) const;
  /// @brief interpret(parse(text), dialog, lastQuestion), with the parse notes.
  Interpretation understand(const std::string& text, const DialogPomdp& dialog,
                            long lastQuestion) const;

  /// @brief Number of phrases in the lexicon (including generated "room 2" variants).
  std::size_t lexiconSize() const { return lexicon_.size(); }
  const LanguageConfig& config() const { return config_; }

 private:
  enum class Kind { kValue, kYes, kNo, kIgnore };
  struct Entry {
    Kind kind = Kind::kIgnore;
    Factor factor = Factor::kItem;
    std::size_t index = 0;
    std::string source;  ///< what defined it, for conflict messages
  };
  void add(const std::string& phrase, const Entry& e, const std::string& configName);
  std::vector<std::string> tokenize(const std::string& text) const;

  LanguageConfig config_;
  std::size_t sizes_[3];
  std::map<std::string, Entry> lexicon_;  ///< phrase (words joined by one space) -> meaning
  std::size_t maxPhraseWords_ = 1;
};

/**
 * @brief What the robot says for a model action: "Which item is it?", "Should I deliver a
 * tea?", "Should I deliver to library?", "Is it for dave?", "OK, I am delivering a tea for
 * dave to library." @throws ConfigError for an action index out of range.
 */
std::string robotUtterance(const DialogPomdp& dialog, std::size_t action);

/**
 * @brief A request in the model's own names, "a <item> for <person> to <room>" (the first of
 * each), for prompts and correction hints: the example a person is shown must be one this
 * building's robot understands. @throws ConfigError when the spec lacks items, rooms or persons.
 */
std::string exampleRequest(const DialogSpec& spec);

}  // namespace dialog
}  // namespace krr
