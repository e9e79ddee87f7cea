// ExperimentPaths: finding the repository's config/ and maps/ for the CLIs.
#include <gtest/gtest.h>

#include "krr_core/common/errors.h"
#include "krr_core/experiments/experiment_paths.h"
#include "../dialog/delivery_test_support.h"

namespace {

using krr::experiments::ExperimentPaths;

TEST(ExperimentPaths, ResolvesTheRepositoryFiles) {
  const std::string root = delivery_test::repo("");
  const ExperimentPaths p = ExperimentPaths::find(root, "office_30x30");
  EXPECT_EQ(p.dialog_yaml, p.root + "/config/dialog.yaml");
  EXPECT_EQ(p.geometry, p.root + "/maps/office_30x30_geometry.plog");
  EXPECT_EQ(p.navigation_plog, p.root + "/config/navigation.plog");
  // Unknown domain: no geometry file, named in the error.
  try {
    ExperimentPaths::find(root, "office_7x7");
    ADD_FAILURE() << "no error";
  } catch (const krr::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("office_7x7"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ExperimentPaths::find(delivery_test::tempDir("no_repo"), "office_30x30"),
               krr::ConfigError);
}

}  // namespace
