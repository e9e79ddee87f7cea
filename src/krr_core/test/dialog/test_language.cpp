// Tests of the dialog language front end (LanguageFrontEnd, LanguageConfig, robotUtterance).
#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/dialog/language.h"
#include "../support/office_dialog.h"

namespace krr {
namespace dialog {
namespace {

DialogPomdp makeDialog() {
  DialogSpec spec = test::officeSpec();
  spec.persons = {"john", "bob"};
  return DialogPomdp(spec);
}

const char* kConfig = R"(
yes: [yes, yeah, "that's right"]
no: [no, nope]
ignore: [a, an, the, for, to, please, i, id, like, deliver]
synonyms:
  office2: room2
  office5: room5
  cola: coke
  "john's office": room5
max_utterance_chars: 200
)";

class LanguageTest : public ::testing::Test {
 protected:
  DialogPomdp dialog = makeDialog();
  LanguageFrontEnd lang{dialog, parseLanguageConfig(kConfig, "test.yaml"), "test.yaml"};

  std::vector<std::string> obsOf(const Interpretation& in) {
    std::vector<std::string> v;
    for (const auto& o : in.observations) v.push_back(o.description);
    return v;
  }
};

TEST_F(LanguageTest, FullRequestGivesThreeGeneralObservationsInOrder) {
  auto in = lang.understand("I'd like a coke for Bob to office2, please!", dialog, -1);
  EXPECT_EQ(obsOf(in), (std::vector<std::string>{"ask_item -> item_coke", "ask_person -> person_bob",
                                                 "ask_room -> room_room2"}));
  EXPECT_TRUE(in.unknownWords.empty());
  EXPECT_TRUE(in.notes.empty());
  EXPECT_EQ(in.observations[0].action, dialog.askItem());
  EXPECT_EQ(in.observations[0].observation, dialog.obsItem(0));
  EXPECT_EQ(in.observations[2].observation, dialog.obsRoom(1));
}

TEST_F(LanguageTest, CaseSpacingPunctuationAndDigitSplitting) {
  for (const char* text : {"ROOM3", "room 3", "  Room-3?? ", "room3."}) {
    auto in = lang.understand(text, dialog, -1);
    ASSERT_EQ(in.observations.size(), 1u) << text;
    EXPECT_EQ(in.observations[0].observation, dialog.obsRoom(2)) << text;
    EXPECT_TRUE(in.unknownWords.empty()) << text;
  }
  // Synonyms get the same variant: "office 2" and "Office2".
  for (const char* text : {"office 2", "Office2"}) {
    auto in = lang.understand(text, dialog, -1);
    ASSERT_EQ(in.observations.size(), 1u) << text;
    EXPECT_EQ(in.observations[0].observation, dialog.obsRoom(1)) << text;
  }
}

TEST_F(LanguageTest, SingleWordsAndMultiWordSynonyms) {
  auto coffee = lang.understand("coffee", dialog, dialog.askItem());
  ASSERT_EQ(coffee.observations.size(), 1u);
  EXPECT_EQ(coffee.observations[0].observation, dialog.obsItem(1));
  auto cola = lang.understand("Cola", dialog, -1);
  ASSERT_EQ(cola.observations.size(), 1u);
  EXPECT_EQ(cola.observations[0].observation, dialog.obsItem(0));
  // "john's office" is a two-word phrase (longest match) meaning room5, not the person john.
  auto in = lang.understand("to John's office", dialog, -1);
  EXPECT_EQ(obsOf(in), (std::vector<std::string>{"ask_room -> room_room5"}));
  auto john = lang.understand("for john", dialog, -1);
  EXPECT_EQ(obsOf(john), (std::vector<std::string>{"ask_person -> person_john"}));
}

TEST_F(LanguageTest, YesNoAnswerTheLastConfirmingQuestion) {
  auto yes = lang.understand("Yes.", dialog, dialog.confirmItem(0));
  ASSERT_EQ(yes.observations.size(), 1u);
  EXPECT_EQ(yes.observations[0].action, dialog.confirmItem(0));
  EXPECT_EQ(yes.observations[0].observation, dialog.obsYes());
  auto no = lang.understand("nope", dialog, dialog.confirmRoom(1));
  ASSERT_EQ(no.observations.size(), 1u);
  EXPECT_EQ(no.observations[0].action, dialog.confirmRoom(1));
  EXPECT_EQ(no.observations[0].observation, dialog.obsNo());
  auto phrase = lang.understand("that's right", dialog, dialog.confirmPerson(1));
  ASSERT_EQ(phrase.observations.size(), 1u);
  EXPECT_EQ(phrase.observations[0].observation, dialog.obsYes());
  // "no, coffee" after "should I deliver a coke?": a no and a coffee answer.
  auto both = lang.understand("no, coffee", dialog, dialog.confirmItem(0));
  EXPECT_EQ(obsOf(both), (std::vector<std::string>{"confirm_item_coke -> no",
                                                   "ask_item -> item_coffee"}));
}

TEST_F(LanguageTest, YesWithoutConfirmingQuestionIsIgnoredWithANote) {
  for (long last : {-1L, static_cast<long>(dialog.askItem()), static_cast<long>(dialog.askPerson())}) {
    auto in = lang.understand("yes", dialog, last);
    EXPECT_TRUE(in.observations.empty()) << last;
    ASSERT_EQ(in.notes.size(), 1u);
    EXPECT_NE(in.notes[0].find("not a confirming question"), std::string::npos) << in.notes[0];
  }
  auto contradictory = lang.understand("yes no", dialog, dialog.confirmItem(0));
  EXPECT_TRUE(contradictory.observations.empty());
  ASSERT_EQ(contradictory.notes.size(), 1u);
  EXPECT_NE(contradictory.notes[0].find("both yes and no"), std::string::npos);
}

TEST_F(LanguageTest, UnknownWordsAreReportedNotThrown) {
  auto in = lang.understand("a coke for Bob to office2 not tomorrow", dialog, -1);
  EXPECT_EQ(in.observations.size(), 3u);
  EXPECT_EQ(in.unknownWords, (std::vector<std::string>{"not", "tomorrow"}));
  // Repeated mentions count once.
  auto twice = lang.understand("coke, coke, COKE", dialog, -1);
  EXPECT_EQ(twice.observations.size(), 1u);
  // Conflicting values are both applied as answers.
  auto conflict = lang.understand("coke or coffee", dialog, -1);
  EXPECT_EQ(conflict.observations.size(), 2u);
  EXPECT_EQ(conflict.unknownWords, (std::vector<std::string>{"or"}));
}

TEST_F(LanguageTest, EmptyAndGarbageInputGiveNoObservationAndANote) {
  for (const std::string& text : {std::string(""), std::string("   "), std::string("?!.,;"),
                                 std::string("\0\x01\x7f", 3)}) {
    auto in = lang.understand(text, dialog, -1);
    EXPECT_TRUE(in.observations.empty());
    EXPECT_TRUE(in.unknownWords.empty());
    ASSERT_EQ(in.notes.size(), 1u);
    EXPECT_NE(in.notes[0].find("empty"), std::string::npos);
  }
  auto garbage = lang.understand("xq7 zzz##%% \xff\xfe caf\xc3\xa9", dialog, -1);
  EXPECT_TRUE(garbage.observations.empty());
  EXPECT_EQ(garbage.unknownWords,
            (std::vector<std::string>{"xq7", "zzz", "\\xff\\xfe", "caf\xc3\xa9"}));
  ASSERT_EQ(garbage.notes.size(), 1u);
  EXPECT_NE(garbage.notes[0].find("nothing understood"), std::string::npos);
  // Over-long input is truncated with a note, never a crash.
  std::string longText(5000, 'x');
  longText = "coke " + longText;
  auto lng = lang.understand(longText, dialog, -1);
  EXPECT_EQ(lng.observations.size(), 1u);
  ASSERT_FALSE(lng.notes.empty());
  EXPECT_NE(lng.notes[0].find("truncated to 200"), std::string::npos);
}

TEST_F(LanguageTest, ParseKeepsWordsAndMentions) {
  ParsedUtterance p = lang.parse("Bob's coke, please");
  EXPECT_EQ(p.words, (std::vector<std::string>{"bob", "coke", "please"}));
  ASSERT_EQ(p.mentions.size(), 2u);
  EXPECT_EQ(p.mentions[0].factor, Factor::kPerson);
  EXPECT_EQ(p.mentions[0].index, 1u);
  EXPECT_EQ(p.mentions[1].factor, Factor::kItem);
  EXPECT_TRUE(p.understood());
  EXPECT_FALSE(lang.parse("please").understood());
}

TEST(LanguageConfig, BadConfigurationsAreRefusedWithTheirName) {
  DialogPomdp d = makeDialog();
  auto refuses = [&](const std::string& yaml, const std::string& expect) {
    try {
      LanguageFrontEnd f(d, parseLanguageConfig(yaml, "bad.yaml"), "bad.yaml");
      ADD_FAILURE() << "accepted: " << yaml;
    } catch (const ConfigError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("bad.yaml"), std::string::npos) << what;
      EXPECT_NE(what.find(expect), std::string::npos) << what;
    }
  };
  refuses("synonyms: {office9: room9}", "room9");
  // Every stale synonym in one message, with the field and the model's names.
  refuses("synonyms: {office9: room9, cola: pepsi, \"carol's office\": room7}",
          "field 'synonyms': 3 synonyms name no item, room or person of the model: 'carol's "
          "office' -> 'room7', 'cola' -> 'pepsi', 'office9' -> 'room9'");
  refuses("synonyms: {coke: coffee}", "two meanings");
  refuses("yes: [yes, coke]", "two meanings");
  refuses("ignore: [no]", "two meanings");
  refuses("yes: ['...']", "empty phrase");
  refuses("colour: red", "unknown key 'colour'");
  refuses("yes: yes", "list");
  refuses("max_utterance_chars: 0", "max_utterance_chars");
  refuses("max_utterance_chars: many", "max_utterance_chars");
  refuses("synonyms: [a, b]", "synonyms");
  refuses("yes: [unclosed", "bad.yaml:");
  refuses("- just a list", "mapping");
  EXPECT_NO_THROW(parseLanguageConfig("", "empty.yaml"));
  EXPECT_THROW(loadLanguageConfig("/nonexistent/language.yaml"), IoError);
}

TEST(ExampleRequest, IsInTheModelsOwnNamesAndUnderstood) {
  DialogSpec spec;
  spec.items = {"tea", "juice"};
  spec.rooms = {"lab", "mailroom", "studio"};
  spec.persons = {"carol", "dave", "erin"};
  const DialogPomdp d(spec);
  const std::string example = exampleRequest(d.spec());
  EXPECT_EQ(example, "a tea for carol to lab");
  const LanguageFrontEnd f(d, parseLanguageConfig("ignore: [a, for, to]", "site.yaml"), "site.yaml");
  const ParsedUtterance p = f.parse(example);
  EXPECT_EQ(p.mentions.size(), 3u);
  EXPECT_TRUE(p.unknownWords.empty());
  spec.persons.clear();
  EXPECT_THROW(exampleRequest(spec), ConfigError);
}

TEST(LanguageConfig, InterpretRefusesAModelWithAnotherVocabulary) {
  DialogPomdp d = makeDialog();
  DialogSpec small = test::officeSpec();
  small.items = {"tea"};
  DialogPomdp other(small);
  LanguageFrontEnd f(d, LanguageConfig{});
  EXPECT_THROW(f.understand("tea", other, -1), ConfigError);
}

TEST(RobotUtterance, WordsEveryKindOfAction) {
  DialogPomdp d = makeDialog();
  EXPECT_EQ(robotUtterance(d, d.askItem()), "Which item is it?");
  EXPECT_EQ(robotUtterance(d, d.confirmItem(0)), "Should I deliver a coke?");
  EXPECT_EQ(robotUtterance(d, d.confirmRoom(1)), "Should I deliver to room2?");
  EXPECT_EQ(robotUtterance(d, d.confirmPerson(1)), "Is it for bob?");
  EXPECT_EQ(robotUtterance(d, d.serveAction(d.requestIndex(0, 1, 1))),
            "OK, I am delivering a coke for bob to room2.");
  EXPECT_THROW(robotUtterance(d, d.model().getA()), ConfigError);
}

}  // namespace
}  // namespace dialog
}  // namespace krr
