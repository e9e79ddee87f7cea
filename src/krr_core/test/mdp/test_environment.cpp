#include <gtest/gtest.h>

#include "krr_core/common/errors.h"
#include "krr_core/examples/grid_world.h"
#include "krr_core/mdp/environment.h"
#include "krr_core/mdp/solvers.h"

namespace krr {
namespace mdp {
using examples::GridWorldEnvironment;
namespace {

// 1x3 corridor: "right" moves right w.p. 1 except in cell 1 where it fails (trapped) w.p. 0.5.
GridDynamics corridor() {
  GridDynamics d(3, 1);
  d.p(0, kActRight, kStay) = 0.0;
  d.p(0, kActRight, kRight) = 1.0;
  d.p(1, kActRight, kStay) = 0.0;
  d.p(1, kActRight, kRight) = 0.5;
  d.p(1, kActRight, kFail) = 0.5;
  return d;
}

TEST(Environment, GridWorldRealisesThePaperRewards) {
  NavigationReward r;  // step cost 1, Rmax 40
  GridWorldEnvironment env(corridor(), 0, {2}, r);
  FixedPolicyAgent right(std::vector<ActionId>(4, kActRight));
  Rng rng = makeRng(3, "env");
  int success = 0;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    EpisodeResult e = runEpisode(env, right, 10, r.rmax, rng);
    EXPECT_EQ(e.steps, 2u);
    EXPECT_FALSE(e.timed_out);
    if (e.success) {
      EXPECT_DOUBLE_EQ(e.total_reward, -1.0 + (-1.0 + 40.0));  // two moves, goal bonus
    } else {
      EXPECT_TRUE(e.failed);
      EXPECT_DOUBLE_EQ(e.total_reward, -1.0 + (-1.0 - 40.0));  // trapped
    }
    success += e.success;
  }
  // p = 0.5, sd = sqrt(0.25/4000) = 0.0079; 5 sd.
  EXPECT_NEAR(success / static_cast<double>(n), 0.5, 5 * 0.0079);
}

TEST(Environment, StepLimitAddsTheTimeoutPenalty) {
  GridWorldEnvironment env(corridor(), 0, {2}, NavigationReward());
  FixedPolicyAgent left(std::vector<ActionId>(4, kActLeft));  // stays in place forever
  Rng rng = makeRng(3, "env2");
  EpisodeResult e = runEpisode(env, left, 200, 40.0, rng);
  EXPECT_TRUE(e.timed_out);
  EXPECT_FALSE(e.success);
  EXPECT_EQ(e.steps, 200u);
  EXPECT_DOUBLE_EQ(e.total_reward, -200.0 - 40.0);
  EXPECT_THROW(runEpisode(env, left, 0, 40.0, rng), ConfigError);
}

TEST(Environment, ModelEnvironmentFollowsTheModel) {
  GridModel g = makeNavigationGridModel(corridor(), {2}, NavigationReward(), 0.95);
  SparseModel m = g.toSparse();
  ModelEnvironment env(m, 0, {2});
  FixedPolicyAgent right(std::vector<ActionId>(4, kActRight));
  Rng rng = makeRng(4, "env3");
  int success = 0;
  for (int i = 0; i < 2000; ++i) success += runEpisode(env, right, 10, 40.0, rng).success;
  EXPECT_NEAR(success / 2000.0, 0.5, 5 * 0.0112);
}

TEST(Environment, InvalidSetupThrowsConfigError) {
  EXPECT_THROW(GridWorldEnvironment(corridor(), 2, {2}, NavigationReward()), ConfigError);
  EXPECT_THROW(GridWorldEnvironment(corridor(), 0, {5}, NavigationReward()), ConfigError);
  GridWorldEnvironment env(corridor(), 0, {2}, NavigationReward());
  Rng rng = makeRng(1, "x");
  EXPECT_THROW(env.step(4, rng), ConfigError);
  FixedPolicyAgent bad(std::vector<ActionId>(4, 7));
  EXPECT_THROW(runEpisode(env, bad, 5, 40.0, rng), ConfigError);
}

}  // namespace
}  // namespace mdp
}  // namespace krr
