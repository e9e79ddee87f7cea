/**
 * @file experiment_paths.h
 * @brief Where the delivery experiments' inputs live: the repository's config/ and maps/.
 *
 * The CLIs (delivery_trials, dialog_entropy) run from anywhere: the repository root is the
 * --root option, else $KRR_ROOT, else the first directory holding config/dialog.yaml found
 * walking up from the working directory, then from the executable's directory. With a site
 * folder (--site DIR, site/site.h) the building's files are the site's and the generic
 * settings the root's config/.
 */
#pragma once

#include <memory>
#include <string>

#include "krr_core/dialog/dialog_config.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_core/site/site.h"

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
  std::string geometry;         ///< root/maps/<domain>_geometry.plog (a site's: beside its map)
  std::string domain;           ///< the domain asked for, or navigation.yaml's default domain
  /// The site folder the paths are a site's (nullptr: the repository's config/ and maps/).
  std::shared_ptr<const site::Site> site;

  /// @brief The navigation config: navigation_yaml, or the site's (the base with its names).
  nav::NavigationConfig navigationConfig() const;
  /// @brief The dialog config: dialog_yaml, or the site's (the base with its knowledge, shop).
  dialog::DialogConfig dialogConfig() const;

  /**
   * @brief Resolve the paths for `domain` (see the file comment for `root_hint` = --root);
   * empty `domain`: the first domain of root/config/navigation.yaml (of the site's).
   * `site_dir`: a site folder, loaded and checked (site::Site::load).
   * @throws ConfigError naming what was searched when no root is found or a file is missing.
   */
  static ExperimentPaths find(const std::string& root_hint, const std::string& domain = "",
                              const std::string& site_dir = "");
};

}  // namespace experiments
}  // namespace krr
