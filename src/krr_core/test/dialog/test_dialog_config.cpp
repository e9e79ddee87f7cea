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
  EXPECT_EQ(c.serve_cost_mode, ServeCostMode::kTasks);
  // Knowledge files are resolved against the YAML's directory and exist.
  EXPECT_NO_THROW(krr::readFile(c.office_plog));
  EXPECT_NO_THROW(krr::readFile(c.speech_plog));
  EXPECT_EQ(c.rmaxParams().known_threshold, c.known_threshold);
  EXPECT_DOUBLE_EQ(c.rmaxParams().rmax, c.rmax);
}

TEST(DialogConfig, DefaultsWhenSectionsAreMissing) {
  const std::string dir = delivery_test::tempDir("dialog_cfg");
  krr::writeFileAtomic(dir + "/d.yaml", "dialog: {turn_limit: 7}\n");
  const DialogConfig c = loadDialogConfig(dir + "/d.yaml");
  EXPECT_EQ(c.turn_limit, 7);
  EXPECT_DOUBLE_EQ(c.general_cost, 2.0);
  EXPECT_EQ(c.office_plog, dir + "/office.plog");
}

TEST(DialogConfig, BadValuesNameTheField) {
  const std::string dir = delivery_test::tempDir("dialog_cfg");
  const std::pair<std::string, std::string> cases[] = {
      {"dialog: {general_question_cost: -2}\n", "dialog.general_question_cost"},
      {"dialog: {confirm_question_cost: abc}\n", "dialog.confirm_question_cost"},
      {"dialog: {turn_limit: -1}\n", "dialog.turn_limit"},
      {"dialog: {turn_limit: 2.5}\n", "dialog.turn_limit"},
      {"dialog: {discount: 1.0}\n", "dialog.discount"},
      {"dialog: {success_reward: 10, failure_reward: 20}\n", "dialog.failure_reward"},
      {"dialog: {speech_accuracy: 0.8}\n", "dialog.speech_accuracy"},
      {"serve_cost: {mode: sometimes}\n", "serve_cost.mode"},
      {"serve_cost: {weight: -1}\n", "serve_cost.weight"},
      {"navigation: {rmax: 0}\n", "navigation.rmax"},
      {"navigation: {step_cost: 50}\n", "navigation.step_cost"},
      {"navigation: {discount: 0}\n", "navigation.discount"},
      {"navigation: {failure_penalty: -3}\n", "navigation.failure_penalty"},
      {"navigation: {shop: [a, b]}\n", "navigation.shop"},
      {"solver: {precision: 0}\n", "solver.precision"},
      {"solver: {max_trials: -5}\n", "solver.max_trials"},
      {"learning: {known_threshold: 0}\n", "learning.known_threshold"},
      {"learning: {refine_known: maybe}\n", "learning.refine_known"},
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
  EXPECT_NO_THROW(c.validate());
  c.discount = 1.5;
  EXPECT_THROW(c.validate(), krr::ConfigError);
  c = DialogConfig();
  c.learning_rounds = 0;
  EXPECT_THROW(c.validate(), krr::ConfigError);
  EXPECT_EQ(serveCostModeFromString("expected"), ServeCostMode::kExpected);
  EXPECT_EQ(toString(ServeCostMode::kNone), "none");
  EXPECT_THROW(serveCostModeFromString("all"), krr::ConfigError);
}

}  // namespace
