/**
 * @file nav_kb.h
 * @brief The navigation knowledge-base parameters shared by reasoner_node, navigation_node and
 * learner_node, so that all three read the same map, grid and P-log files the same way.
 *
 * Parameters (private, relative paths resolved by ParamReader):
 *   ~site               ""                       a site folder (krr_core/site/site.h): its
 *                       map, places, domains, areas, knowledge, shop and language over the
 *                       settings of the files below; "" = the office of config/
 *   ~navigation_config  config/navigation.yaml   map, places, domains, simulator, planner
 *   ~domain             the site's first domain  navigation domain (grid size, step limit)
 *   ~geometry           <domain>_geometry.plog beside the map (the office's: maps/)
 *                                                generated P-log geometry of the grid
 *   ~navigation_files   [config/navigation.plog] human navigation knowledge, loaded in order
 */
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "krr_core/kb/nav_domain.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_core/site/site.h"
#include "krr_ros/params.h"

namespace krr_ros {

/// @brief Where the navigation knowledge base comes from.
struct NavKbParams {
  std::string navigation_config;
  std::string domain;
  std::string geometry;
  std::vector<std::string> navigation_files;
  std::string site_dir;  ///< ~site ("" = none)
  /// The site of ~site (read, not yet checked: the node's site check does that), or nullptr.
  std::shared_ptr<const krr::site::Site> site;

  /// @brief Where the robot starts and deliveries begin: the site's shop (~site), else the
  /// base dialog config's navigation.shop (config/dialog.yaml under ~base_dir).
  std::string shop;

  /// @brief Read (and check the files of) the parameters above.
  static NavKbParams read(ParamReader& params);
  /// @brief Load the map, derive the domain's grid, state space and simulator; knowledge_files
  /// are the geometry followed by navigation_files. @throws krr::Error naming file and field.
  krr::kb::NavDomain loadDomain() const;
  /// @brief The navigation config (navigation_config, with the site's names over it): the navigation task's reward and
  /// planning discount (`planning`) and R-Max (`rmax_learning`) live there, not in node YAMLs.
  /// @throws krr::ConfigError naming file and field.
  krr::nav::NavigationConfig loadConfig() const;
};

}  // namespace krr_ros
