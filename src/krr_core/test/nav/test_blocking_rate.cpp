// The one rule for a blocking rate (krr_core/nav/blocking_rate.h): what it accepts, its one
// message, and that readers in different modules (navigation.yaml, the simulator's
// configuration and context, the free-time learner, the experiments) refuse a bad rate with it.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/yaml_section.h"
#include "krr_core/experiments/delivery_experiment.h"
#include "krr_core/experiments/nav_transfer.h"
#include "krr_core/kb/free_time_learner.h"
#include "krr_core/nav/blocking_rate.h"
#include "krr_core/nav/navigation_config.h"

using namespace krr;
using namespace krr::nav;

namespace {

const double kNan = std::numeric_limits<double>::quiet_NaN();

/// The message of the ConfigError that `f` throws ("" and a failure if none).
std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no ConfigError";
  return "";
}

TEST(BlockingRate, TheRule) {
  for (const double v : {0.0, 0.3, 1.0}) {
    EXPECT_TRUE(isBlockingRate(v, RateUnset::kRefused)) << v;
    EXPECT_TRUE(isBlockingRate(v, RateUnset::kAllowed)) << v;
  }
  for (const double v : {1.0000001, 1.5, kNan, std::numeric_limits<double>::infinity()}) {
    EXPECT_FALSE(isBlockingRate(v, RateUnset::kRefused)) << v;
    EXPECT_FALSE(isBlockingRate(v, RateUnset::kAllowed)) << v;
  }
  // Negative: "not set" where a setting may leave the rates to the configuration.
  EXPECT_FALSE(isBlockingRate(-1.0, RateUnset::kRefused));
  EXPECT_TRUE(isBlockingRate(-1.0, RateUnset::kAllowed));
  EXPECT_EQ(checkBlockingRate(0.7, "here"), 0.7);
  EXPECT_EQ(checkBlockingRate(-1.0, "here", "blocking_rate", RateUnset::kAllowed), -1.0);
}

TEST(BlockingRate, OneMessageNamingWhatAndWhere) {
  EXPECT_EQ(errorOf([] { checkBlockingRate(1.5, "nav transfer"); }),
            "nav transfer: field 'blocking_rate': value 1.5 must be in [0, 1]");
  EXPECT_EQ(errorOf([] { checkBlockingRate(-0.1, "delivery experiment"); }),
            "delivery experiment: field 'blocking_rate': value -0.1 must be in [0, 1]");
  EXPECT_EQ(errorOf([] {
              checkBlockingRate(kNan, "free-time learning", "blocking_rate", RateUnset::kAllowed);
            }),
            "free-time learning: field 'blocking_rate': value nan must be in [0, 1] "
            "(negative: not set)");
}

TEST(BlockingRate, YamlField) {
  const YAML::Node node = YAML::Load("{blocking_rate: 2, other: lots}");
  const YamlSection s(node, "exp.yaml", "simulator", {"blocking_rate", "other"});
  EXPECT_EQ(errorOf([&] { readBlockingRate(s, "blocking_rate", RateUnset::kAllowed); }),
            "exp.yaml: field 'simulator.blocking_rate': value 2 must be in [0, 1] "
            "(negative: not set)");
  EXPECT_NE(errorOf([&] { readBlockingRate(s, "other", RateUnset::kRefused); })
                .find("exp.yaml: field 'simulator.other': value 'lots' is not a number"),
            std::string::npos);
  const YamlSection empty(YAML::Load("{}"), "exp.yaml", "simulator", {"blocking_rate"});
  EXPECT_EQ(readBlockingRate(empty, "blocking_rate", RateUnset::kRefused, 0.25), 0.25);
  EXPECT_EQ(errorOf([&] { readBlockingRate(empty, "blocking_rate", RateUnset::kRefused); }),
            "exp.yaml: missing field 'simulator.blocking_rate'");
}

// The same value, refused by readers in four modules with the same message.
TEST(BlockingRate, EveryReaderRefusesWithTheOneMessage) {
  const std::string rule = "field 'blocking_rate': value 1.5 must be in [0, 1]";
  SimulatorConfig sim;
  sim.blocking_rate = 1.5;
  EXPECT_EQ(errorOf([&] { validate(sim); }), "simulator config: " + rule);
  kb::FreeTimeOptions free_time;
  free_time.blocking_rate = 1.5;
  EXPECT_EQ(errorOf([&] { free_time.validate(); }),
            "free-time learning: " + rule + " (negative: not set)");
  experiments::NavTransferOptions transfer;
  transfer.blocking_rate = 1.5;
  EXPECT_EQ(errorOf([&] { transfer.validate(); }), "nav transfer: " + rule);
  experiments::DeliveryExperimentOptions delivery;
  delivery.blocking_rate = 1.5;
  EXPECT_EQ(errorOf([&] { delivery.validate(); }), "delivery experiment: " + rule);
  // A negative rate: "not set" for the learner, refused where the experiment needs one.
  free_time.blocking_rate = -1.0;
  EXPECT_NO_THROW(free_time.validate());
  transfer.blocking_rate = -1.0;
  EXPECT_EQ(errorOf([&] { transfer.validate(); }),
            "nav transfer: field 'blocking_rate': value -1 must be in [0, 1]");
}

TEST(BlockingRate, NavigationYaml) {
  std::string text = readFile(std::string(KRR_TEST_DATA_DIR) + "/../../../../config/navigation.yaml");
  const std::size_t pos = text.find("blocking_rate: 0.3");
  ASSERT_NE(pos, std::string::npos);
  text.replace(pos, 18, "blocking_rate: 1.5");
  const std::string p = ::testing::TempDir() + "/blocking_rate_nav.yaml";
  writeFileAtomic(p, text);
  EXPECT_EQ(errorOf([&] { loadNavigationConfig(p); }),
            p + ": field 'simulator.blocking_rate': value 1.5 must be in [0, 1]");
}

}  // namespace
