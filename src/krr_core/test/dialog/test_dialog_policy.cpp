// solveDialogPolicy's cache, cachedDialogPolicy (a look-up that never solves), and
// defaultCacheDir: where dialog_node and the experiments share solved policies.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "krr_core/dialog/dialog_policy.h"
#include "delivery_test_support.h"

namespace {

using namespace krr::dialog;

/// Two items, two rooms, one person, six turns: solved in milliseconds.
DialogPomdp smallDialog(double far_reach) {
  DialogSpec spec;
  spec.items = {"a", "b"};
  spec.rooms = {"near", "far"};
  spec.persons = {"p"};
  Eigen::VectorXd reach(2);
  reach << 1.0, far_reach;
  spec.delivery = deliveryMatrix(2, reach, 1);
  spec.turnLimit = 6;
  return DialogPomdp(spec);
}

DialogConfig smallConfig(std::size_t max_trials) {
  DialogConfig c;
  c.shop = "shop";
  c.turn_limit = 6;
  c.solver_max_trials = max_trials;
  c.solver_precision = 1e-6;
  return c;
}

TEST(DialogPolicy, CachedPolicyIsOnlyTheConfiguredOneAndNeverSolves) {
  const std::string dir = delivery_test::tempDir("dialog_policy_cache");
  std::filesystem::remove_all(dir);
  const DialogPomdp d = smallDialog(0.5);
  const DialogConfig certify = smallConfig(0), quick = smallConfig(3);
  PolicyReport rep;
  EXPECT_FALSE(cachedDialogPolicy(d, certify, dir, &rep));
  EXPECT_FALSE(std::filesystem::exists(dir)) << "a look-up must not create the cache";
  EXPECT_FALSE(cachedDialogPolicy(d, certify, ""));

  PolicyReport quick_rep;
  const auto quick_policy = solveDialogPolicy(d, quick, dir, &quick_rep);
  EXPECT_FALSE(quick_rep.from_cache);
  // Another budget is another policy: the quick one does not answer for the certified one.
  EXPECT_FALSE(cachedDialogPolicy(d, certify, dir));

  PolicyReport solved;
  const auto policy = solveDialogPolicy(d, certify, dir, &solved);
  ASSERT_TRUE(solved.converged);
  const auto cached = cachedDialogPolicy(d, certify, dir, &rep);
  ASSERT_TRUE(cached);
  EXPECT_TRUE(rep.from_cache);
  EXPECT_TRUE(rep.converged);
  EXPECT_EQ(rep.file, solved.file);
  EXPECT_EQ(rep.bounds.lower, solved.bounds.lower);
  EXPECT_EQ(rep.bounds.upper, solved.bounds.upper);
  EXPECT_EQ(cached->toText(), policy.toText());
  // A different model is not in the cache.
  EXPECT_FALSE(cachedDialogPolicy(smallDialog(0.25), certify, dir));
  std::filesystem::remove_all(dir);
}

TEST(DialogPolicy, DefaultCacheDirectoryFollowsTheEnvironment) {
  ::setenv("KRR_CACHE_DIR", "/tmp/some_cache", 1);
  EXPECT_EQ(defaultCacheDir(), "/tmp/some_cache");
  ::unsetenv("KRR_CACHE_DIR");
  ::setenv("XDG_CACHE_HOME", "/tmp/xdg", 1);
  EXPECT_EQ(defaultCacheDir(), "/tmp/xdg/krr_rl/delivery");
  ::unsetenv("XDG_CACHE_HOME");
  ::setenv("HOME", "/tmp/home", 1);
  EXPECT_EQ(defaultCacheDir(), "/tmp/home/.cache/krr_rl/delivery");
}

}  // namespace
