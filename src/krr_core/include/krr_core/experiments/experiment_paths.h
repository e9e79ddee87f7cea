/**
 * @file experiment_paths.h
 * @brief Where the delivery experiments' inputs live: the repository's config/ and maps/.
 *
 * The CLIs (delivery_trials, dialog_entropy) run from anywhere: the repository root is the
 * --root option, else $KRR_ROOT, else the first directory holding config/dialog.yaml found
 * walking up from the working directory, then from the executable's directory.
 */
#pragma once

#include <string>

namespace krr {
namespace experiments {

/// @brief Input files of a delivery experiment on one navigation domain.
struct ExperimentPaths {
  std::string root;             ///< repository root
  std::string dialog_yaml;      ///< root/config/dialog.yaml
  /// root/config/experiments/delivery_trials.yaml: what the delivery experiments change
  std::string delivery_yaml;
  std::string navigation_yaml;  ///< root/config/navigation.yaml
  std::string navigation_plog;  ///< root/config/navigation.plog
  std::string geometry;         ///< root/maps/<domain>_geometry.plog
  std::string domain;           ///< the domain asked for, or navigation.yaml's default domain

  /**
   * @brief Resolve the paths for `domain` (see the file comment for `root_hint` = --root);
   * empty `domain`: the first domain of root/config/navigation.yaml.
   * @throws ConfigError naming what was searched when no root is found or a file is missing.
   */
  static ExperimentPaths find(const std::string& root_hint, const std::string& domain = "");
};

}  // namespace experiments
}  // namespace krr
