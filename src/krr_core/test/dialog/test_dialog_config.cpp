// DialogConfig: the bundled config/dialog.yaml carries the paper's numbers; every bad value is
// a ConfigError naming the field.
#include <gtest/gtest.h>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/dialog/dialog_config.h"
#include "delivery_test_support.h"

namespace {

using namespace krr::dialog;
using delivery_test::repo;

TEST(DialogConfig, BundledConfigHasThePapersNumbers) {
  const DialogConfig c = loadDialogConfig(repo("config/dialog.yaml"));
  EXPECT_DOUBLE_EQ(c.general_cost, 2.0);
  EXPECT_DOUBLE_EQ(c.confirm_cost, 1.5);
  EXPECT_DOUBLE_EQ(c.success_reward, 80.0);
  EXPECT_DOUBLE_EQ(c.failure_reward, -80.0);
  EXPECT_EQ(c.turn_limit, 20);
  // Undiscounted: the dialog is episodic with a turn limit; at 0.99 a serve worth -130
  // gained 1.3 per extra question by its delay alone, nearly a confirmation's cost, and at
  // br 0.7 the robot ran into the turn limit in 1.8 % of dialogs (0.35 % undiscounted).
  EXPECT_DOUBLE_EQ(c.discount, 1.0);
  EXPECT_EQ(c.max_redeliveries, 1);  // the paper's redelivery rule: one more trip
  EXPECT_EQ(c.serve_cost_mode, ServeCostMode::kExpected);
  EXPECT_DOUBLE_EQ(c.serve_cost_weight, 1.0);
  EXPECT_DOUBLE_EQ(c.wrong_delivery_penalty, 120.0);
  // Knowledge files are resolved against the YAML's directory and exist.
  EXPECT_NO_THROW(krr::readFile(c.office_plog));
  EXPECT_NO_THROW(krr::readFile(c.speech_plog));
  EXPECT_EQ(c.rmaxParams().known_threshold, c.known_threshold);
  EXPECT_DOUBLE_EQ(c.rmaxParams().rmax, c.rmax);
  // The time of day and R-Max's M come from navigation.yaml (context.time, rmax_learning).
  EXPECT_EQ(c.time, "morning");
  EXPECT_EQ(c.known_threshold, 5u);
  EXPECT_FALSE(c.refine_known);
}

TEST(DialogConfig, DefaultsWhenSectionsAreMissing) {
  const std::string dir = delivery_test::tempDir("dialog_cfg");
  krr::writeFileAtomic(dir + "/d.yaml", "dialog: {turn_limit: 7}\nnavigation: {shop: hall}\n");
  const DialogConfig c = loadDialogConfig(dir + "/d.yaml");
  EXPECT_EQ(c.turn_limit, 7);
  EXPECT_EQ(c.shop, "hall");
  EXPECT_DOUBLE_EQ(c.general_cost, 2.0);
  EXPECT_EQ(c.office_plog, dir + "/office.plog");
  // The struct's defaults for the fields not given.
  EXPECT_EQ(c.max_redeliveries, 1);
  EXPECT_EQ(c.serve_cost_mode, ServeCostMode::kExpected);
  EXPECT_DOUBLE_EQ(c.wrong_delivery_penalty, 120.0);
}

TEST(DialogConfig, NewFieldsAreRead) {
  const std::string dir = delivery_test::tempDir("dialog_cfg");
  krr::writeFileAtomic(dir + "/d.yaml",
                       "dialog: {discount: 1.0, max_redeliveries: 0}\n"
                       "serve_cost: {mode: none, wrong_delivery_penalty: 35.5}\n"
                       "navigation: {shop: hall}\n");
  const DialogConfig c = loadDialogConfig(dir + "/d.yaml");
  EXPECT_DOUBLE_EQ(c.discount, 1.0);  // undiscounted dialogs are allowed (finite horizon)
  EXPECT_EQ(c.max_redeliveries, 0);
  EXPECT_EQ(c.serve_cost_mode, ServeCostMode::kNone);
  EXPECT_DOUBLE_EQ(c.wrong_delivery_penalty, 35.5);
  krr::writeFileAtomic(dir + "/d.yaml",
                       "dialog: {max_redeliveries: 3}\nnavigation: {shop: hall}\n");
  EXPECT_EQ(loadDialogConfig(dir + "/d.yaml").max_redeliveries, 3);
}

TEST(DialogConfig, BadValuesNameTheField) {
  const std::string dir = delivery_test::tempDir("dialog_cfg");
  const std::pair<std::string, std::string> cases[] = {
      {"dialog: {general_question_cost: -2}\n", "dialog.general_question_cost"},
      {"dialog: {confirm_question_cost: abc}\n", "dialog.confirm_question_cost"},
      {"dialog: {turn_limit: -1}\n", "dialog.turn_limit"},
      {"dialog: {turn_limit: 2.5}\n", "dialog.turn_limit"},
      {"dialog: {discount: 0}\n", "dialog.discount"},
      {"dialog: {discount: 1.01}\n", "dialog.discount"},
      {"dialog: {max_redeliveries: -1}\n", "dialog.max_redeliveries"},
      {"dialog: {max_redeliveries: 1.5}\n", "dialog.max_redeliveries"},
      {"dialog: {success_reward: 10, failure_reward: 20}\n", "dialog.failure_reward"},
      {"dialog: {speech_accuracy: 0.8}\n", "dialog.speech_accuracy"},
      {"serve_cost: {mode: sometimes}\n", "serve_cost.mode"},
      {"serve_cost: {mode: tasks}\n", "serve_cost.mode"},  // removed mode
      {"serve_cost: {wrong_delivery_penalty: -1}\n", "serve_cost.wrong_delivery_penalty"},
      {"serve_cost: {wrong_delivery_penalty: lots}\n", "serve_cost.wrong_delivery_penalty"},
      {"serve_cost: {weight: -1}\n", "serve_cost.weight"},
      {"navigation: {rmax: 0}\n", "navigation.rmax"},
      {"navigation: {step_cost: 50}\n", "navigation.step_cost"},
      {"navigation: {discount: 0}\n", "navigation.discount"},
      {"navigation: {failure_penalty: -3}\n", "navigation.failure_penalty"},
      {"navigation: {shop: [a, b]}\n", "navigation.shop"},
      // No built-in shop name: a config that names none is refused, naming the field.
      {"navigation: {failure_penalty: 40}\n", "field 'navigation.shop': missing"},
      {"dialog: {turn_limit: 7}\n", "field 'navigation.shop': missing"},
      {"solver: {precision: 0}\n", "solver.precision"},
      {"solver: {max_trials: -5}\n", "solver.max_trials"},
      // R-Max's M and the time of day have one home, navigation.yaml: not fields here.
      {"learning: {known_threshold: 30}\n", "unknown field 'learning.known_threshold'"},
      {"navigation: {time: noon}\n", "unknown field 'navigation.time'"},
      {"learning: {rounds: 0}\n", "learning.rounds"},
      {"knowledge: {office: ''}\n", "knowledge.office"},
      {"dialog: 3\n", "dialog"},
      {"surprise: 1\n", "surprise"},
  };
  for (const auto& [text, field] : cases) {
    krr::writeFileAtomic(dir + "/bad.yaml", text);
    try {
      loadDialogConfig(dir + "/bad.yaml");
      ADD_FAILURE() << "no error for: " << text;
    } catch (const krr::ConfigError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(field), std::string::npos) << what;
      EXPECT_NE(what.find("bad.yaml"), std::string::npos) << what;
    }
  }
  krr::writeFileAtomic(dir + "/broken.yaml", "dialog: [1, 2\n");
  EXPECT_THROW(loadDialogConfig(dir + "/broken.yaml"), krr::ConfigError);
  krr::writeFileAtomic(dir + "/empty.yaml", "");
  EXPECT_THROW(loadDialogConfig(dir + "/empty.yaml"), krr::ConfigError);
  EXPECT_THROW(loadDialogConfig(dir + "/missing.yaml"), krr::ConfigError);
}

TEST(DialogConfig, ValidateChecksConfigsBuiltInCode) {
  DialogConfig c;
  EXPECT_THROW(c.validate(), krr::ConfigError);  // no shop: a site's place, no default name
  c.shop = "hall";
  EXPECT_NO_THROW(c.validate());
  c.discount = 1.5;
  EXPECT_THROW(c.validate(), krr::ConfigError);
  c.discount = 1.0;
  EXPECT_NO_THROW(c.validate());
  c.discount = 0.0;
  EXPECT_THROW(c.validate(), krr::ConfigError);
  c = DialogConfig();
  c.wrong_delivery_penalty = -1.0;
  try {
    c.validate();
    ADD_FAILURE() << "accepted a negative wrong_delivery_penalty";
  } catch (const krr::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("wrong_delivery_penalty"), std::string::npos) << e.what();
  }
  c = DialogConfig();
  c.max_redeliveries = -1;
  EXPECT_THROW(c.validate(), krr::ConfigError);
  c = DialogConfig();
  c.learning_rounds = 0;
  EXPECT_THROW(c.validate(), krr::ConfigError);
  EXPECT_EQ(serveCostModeFromString("expected"), ServeCostMode::kExpected);
  EXPECT_EQ(toString(ServeCostMode::kNone), "none");
  EXPECT_EQ(toString(ServeCostMode::kExpected), "expected");
  EXPECT_EQ(serveCostModeFromString(toString(ServeCostMode::kNone)), ServeCostMode::kNone);
  EXPECT_THROW(serveCostModeFromString("all"), krr::ConfigError);
  EXPECT_THROW(serveCostModeFromString("tasks"), krr::ConfigError);  // removed mode
}

}  // namespace
