#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/nav/navigation_config.h"

using namespace krr;
using namespace krr::nav;

namespace {

const std::string kConfig =
    std::string(KRR_TEST_DATA_DIR) + "/../../../../config/navigation.yaml";

// The shipped config with `from` replaced by `to`, loaded from a temporary file.
void expectError(const std::string& from, const std::string& to, const std::string& what) {
  std::string text = readFile(kConfig);
  const size_t pos = text.find(from);
  ASSERT_NE(pos, std::string::npos) << from;
  text.replace(pos, from.size(), to);
  const std::string p = ::testing::TempDir() + "/nav_config_err.yaml";
  writeFileAtomic(p, text);
  try {
    loadNavigationConfig(p);
    ADD_FAILURE() << "no ConfigError for " << to;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("nav_config_err.yaml"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
  std::remove(p.c_str());
}

}  // namespace

TEST(NavigationConfig, LoadsShippedConfig) {
  NavigationConfig c = loadNavigationConfig(kConfig);
  ASSERT_EQ(c.domains.size(), 2u);
  EXPECT_EQ(c.domain("office_30x30").cols, 30);
  EXPECT_EQ(c.domain("office_30x30").step_limit, 200);  // paper: 200 steps in the small domain
  EXPECT_EQ(c.domain("office_50x50").rows, 50);
  EXPECT_EQ(c.domain("office_50x50").step_limit, 300);  // and 300 in the large one
  EXPECT_THROW(c.domain("office_10x10"), UnknownSymbolError);
  EXPECT_DOUBLE_EQ(c.simulator.blocking_rate, 0.3);      // paper's default br
  EXPECT_NEAR(c.simulator.move_success + c.simulator.slip_stay + c.simulator.slip_lateral, 1.0,
              1e-12);
  ASSERT_EQ(c.simulator.times_of_day.size(), 3u);
  EXPECT_EQ(c.simulator.times_of_day[1], "noon");
  EXPECT_EQ(c.planner.algorithm, "rrtconnect");
  EXPECT_TRUE(c.simulator.blocking_mode == BlockingMode::kPerCell);
  EXPECT_NE(c.map.find("maps/office.yaml"), std::string::npos);
}

// A domain name becomes maps/<name>.yaml: a path in it would write outside maps/ (issue 12).
TEST(NavigationConfig, DomainNamesMustBePlainIdentifiers) {
  expectError("office_30x30:", "../../x:", "name '../../x' must be a plain identifier");
  expectError("office_30x30:", "\"a/b\":", "name 'a/b' must be a plain identifier");
  expectError("office_30x30:", "\"..\":", "name '..' must be a plain identifier");
}

TEST(NavigationConfig, Errors) {
  expectError("blocking_rate: 0.3", "blocking_rate: 1.5", "'simulator.blocking_rate': value 1.5");
  expectError("blocking_rate: 0.3", "blocking_rate: lots", "'simulator.blocking_rate': value 'lots'");
  expectError("move_success: 0.92", "move_success: 0.95", "slip_lateral");
  expectError("trap_probability: 0.155", "trap_probabilty: 0.155", "unknown field 'simulator.trap_probabilty'");
  expectError("algorithm: rrtconnect", "algorithm: astar", "'planner.algorithm': unknown value 'astar'");
  expectError("timeout: 0.05", "timeout: 0", "'planner.timeout': value 0");
  expectError("robot_radius: 0.2", "robot_radius: -1", "'planner.robot_radius': value -1");
  expectError("{cols: 30, rows: 30, step_limit: 200}", "{cols: 30, rows: 30}",
              "missing field 'domains.office_30x30.step_limit'");
  expectError("{cols: 30, rows: 30, step_limit: 200}", "{cols: 0, rows: 30, step_limit: 200}",
              "'domains.office_30x30.cols': value 0");
  expectError("max_blocked_fraction: 0.25", "max_blocked_fraction: 0", "'grid.max_blocked_fraction'");
  expectError("  areas:\n", "  areas:\n    ba0: {rate: 2}\n", "'simulator.areas.ba0.rate': value 2");
  expectError("  areas:\n", "  areas:\n    ba0: {time_of_day: {night: 2}}\n",
              "'simulator.areas.ba0.time_of_day.night': unknown time of day");
  expectError("  areas:\n", "  areas:\n    ba0: {speed: 2}\n", "unknown field 'simulator.areas.ba0.speed'");
  expectError("    noon: 1.0", "    noon: -1", "'simulator.time_of_day.noon': value -1");
  expectError("map: ../maps/office.yaml", "mapp: ../maps/office.yaml", "unknown field 'mapp'");
  expectError("simulator:", "simulator: [", "broken YAML");
  expectError("blocking_rate: 0.3", "blocking_rate: 0.3\n  blocking_mode: sometimes",
              "'simulator.blocking_mode': unknown value 'sometimes'");
}

TEST(NavigationConfig, MissingFile) {
  EXPECT_THROW(loadNavigationConfig("/nonexistent/navigation.yaml"), ConfigError);
}

// navigation.yaml -> R-Max is one mapping (rmaxParamsOf) with one inverse (storeRMaxParams):
// the learner node, the dialog config and the experiments all go through it.
TEST(NavigationConfig, RMaxParamsRoundTrip) {
  PlanningConfig planning;
  planning.step_cost = 2.5;
  planning.rmax = 55.0;
  planning.discount = 0.9;
  RMaxLearningConfig learning;
  learning.known_threshold = 17;
  learning.discount = 0.8;
  learning.replan_every = 3;
  learning.optimism = "self_loop";
  learning.refine_known = true;
  mdp::RMaxParams base;
  base.step_limit = 123;
  base.epsilon = 0.5;
  const mdp::RMaxParams p = rmaxParamsOf(planning, learning, base);
  EXPECT_DOUBLE_EQ(p.step_cost, 2.5);
  EXPECT_DOUBLE_EQ(p.rmax, 55.0);
  EXPECT_EQ(p.known_threshold, 17u);
  EXPECT_DOUBLE_EQ(p.discount, 0.8);
  EXPECT_EQ(p.replan_every, 3u);
  EXPECT_TRUE(p.optimism == mdp::Optimism::kSelfLoop);
  EXPECT_TRUE(p.refine_known);
  EXPECT_EQ(p.step_limit, 123u);  // fields navigation.yaml does not set are the base's
  EXPECT_DOUBLE_EQ(p.epsilon, 0.5);

  PlanningConfig planning2;
  planning2.discount = 0.7;
  RMaxLearningConfig learning2;
  storeRMaxParams(p, planning2, learning2);
  EXPECT_DOUBLE_EQ(planning2.discount, 0.7);  // not an R-Max setting: kept
  EXPECT_DOUBLE_EQ(planning2.step_cost, 2.5);
  EXPECT_DOUBLE_EQ(planning2.rmax, 55.0);
  EXPECT_EQ(learning2.known_threshold, 17);
  EXPECT_DOUBLE_EQ(learning2.discount, 0.8);
  EXPECT_EQ(learning2.replan_every, 3);
  EXPECT_EQ(learning2.optimism, "self_loop");
  EXPECT_TRUE(learning2.refine_known);

  learning.optimism = "greedy";
  try {
    rmaxParamsOf(planning, learning);
    ADD_FAILURE() << "no ConfigError for optimism 'greedy'";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown value 'greedy'"), std::string::npos) << e.what();
  }
}

TEST(NavigationConfig, UnknownOptimismNamesTheField) {
  expectError("optimism: terminal_bonus", "optimism: greedy",
              "field 'rmax_learning.optimism': unknown value 'greedy' (expected terminal_bonus or "
              "self_loop)");
}
