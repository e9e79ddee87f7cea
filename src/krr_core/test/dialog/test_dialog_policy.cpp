// defaultCacheDir: where dialog_node and the experiments share solved policies.
#include <gtest/gtest.h>

#include <cstdlib>

#include "krr_core/dialog/dialog_policy.h"

namespace {

using namespace krr::dialog;

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
