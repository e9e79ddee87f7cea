// ExperimentPaths: finding the repository's config/ and maps/ for the CLIs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "krr_core/common/errors.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/experiments/experiment_cli.h"
#include "krr_core/experiments/experiment_paths.h"
#include "../dialog/delivery_test_support.h"

namespace {

using krr::experiments::ExperimentPaths;

TEST(ExperimentPaths, ResolvesTheRepositoryFiles) {
  const std::string root = delivery_test::repo("");
  const ExperimentPaths p = ExperimentPaths::find(root, "office_30x30");
  EXPECT_EQ(p.dialog_yaml, p.root + "/config/dialog.yaml");
  // Beside the navigation config's map (maps/office.yaml), canonical.
  EXPECT_EQ(p.geometry,
            std::filesystem::weakly_canonical(p.root + "/maps/office_30x30_geometry.plog").string());
  EXPECT_EQ(p.navigation_plog, p.root + "/config/navigation.plog");
  // Unknown domain: named with the option, the known domains and the file listing them.
  try {
    ExperimentPaths::find(root, "office_7x7");
    ADD_FAILURE() << "no error";
  } catch (const krr::ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("--domain: value 'office_7x7'"), std::string::npos) << m;
    EXPECT_NE(m.find("(domains: office_30x30, office_50x50) in " + p.navigation_yaml),
              std::string::npos) << m;
  }
  EXPECT_THROW(ExperimentPaths::find(delivery_test::tempDir("no_repo"), "office_30x30"),
               krr::ConfigError);
}

TEST(ExperimentPaths, TheDeliveryExperimentsNameOnlyTheSolverSettingsTheyChange) {
  ExperimentPaths p = ExperimentPaths::find(delivery_test::repo(""), "office_30x30");
  const krr::dialog::DialogConfig base = krr::dialog::loadDialogConfig(p.dialog_yaml);
  p.delivery_yaml = delivery_test::tempDir("solver_override") + "/delivery_trials.yaml";
  std::ofstream(p.delivery_yaml) << "solver:\n  max_trials: 77\n";
  const krr::dialog::DialogConfig c = krr::experiments::loadDeliveryExperimentConfig(p);
  EXPECT_EQ(c.solver_max_trials, 77u);
  EXPECT_EQ(c.solver_precision, base.solver_precision);  // not named: config/dialog.yaml's
  EXPECT_EQ(c.solver_timeout, base.solver_timeout);
  std::ofstream(p.delivery_yaml) << "solver:\n  max_trails: 77\n";
  try {
    krr::experiments::loadDeliveryExperimentConfig(p);
    ADD_FAILURE() << "no error";
  } catch (const krr::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("max_trails"), std::string::npos) << e.what();
  }
}

}  // namespace
