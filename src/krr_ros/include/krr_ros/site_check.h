/**
 * @file site_check.h
 * @brief The site check every node runs at start (krr_core/site/site_check.h): one rule for
 * reasoner_node, navigation_node, learner_node and dialog_node.
 *
 * ~check_site (default true) turns it on. The files checked are the node's own where it has a
 * parameter for one (~navigation_config for every node; ~dialog_config and ~language_config for
 * dialog_node; ~domain_files, resolved, for reasoner_node), the rest the repository's config/
 * under ~base_dir (dialog.yaml, language.yaml, navigation.yaml, reasoner_node.yaml). A node reads
 * its parameters, calls rejectUnknown(), then requireConsistentSite(): an inconsistent site
 * throws one krr::ConfigError listing every finding (file, field, value), which runNode logs as
 * one ROS_FATAL line before the node exits with status 1.
 *
 * A node given a site folder (~site) checks the site's files instead (krr::site::Site::files()).
 *
 * A node started on other knowledge on purpose (a test's extra P-log files) sets
 * check_site: false.
 */
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "krr_core/site/site.h"
#include "krr_core/site/site_check.h"
#include "krr_ros/params.h"

namespace krr_ros {

/// @brief The site files a node has its own parameters for (empty: config/ under ~base_dir).
struct NodeSiteFiles {
  std::string navigation_config;  ///< ~navigation_config (every node, nav_kb.h)
  std::string dialog_config;      ///< ~dialog_config (dialog_node)
  std::string language_config;    ///< ~language_config (dialog_node)
  /// ~domain_files as reasoner_node loads them (resolved); unset: config/reasoner_node.yaml's.
  std::optional<std::vector<std::string>> reasoner_domain_files;
  /// The node's site folder (~site, nav_kb.h), or nullptr: its files and names are checked
  /// instead of config/'s (the reasoner's domain_files still its own).
  const krr::site::Site* site = nullptr;
};

/// @brief ~check_site: whether the node checks the site at start (default true).
bool readCheckSite(ParamReader& r);

/**
 * @brief The site check of a starting node: krr::site::requireConsistentSite() on `own` files
 * and, for the others, the repository's config/ under the reader's base directory.
 * @return the report of a consistent site.
 * @throws krr::site::InconsistentSiteError (a krr::ConfigError) listing every finding.
 */
krr::site::SiteReport requireConsistentSite(const ParamReader& r, const NodeSiteFiles& own);

}  // namespace krr_ros
