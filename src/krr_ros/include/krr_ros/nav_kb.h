/**
 * @file nav_kb.h
 * @brief The navigation knowledge-base parameters shared by reasoner_node, navigation_node and
 * learner_node, so that all three read the same map, grid and P-log files the same way.
 *
 * Parameters (private, relative paths resolved by ParamReader):
 *   ~navigation_config  config/navigation.yaml   map, places, domains, simulator, planner
 *   ~domain             the config's first domain   navigation domain (grid size, step limit)
 *   ~geometry           maps/<domain>_geometry.plog   generated P-log geometry of the grid
 *   ~navigation_files   [config/navigation.plog] human navigation knowledge, loaded in order
 */
#pragma once

#include <string>
#include <vector>

#include "krr_core/kb/nav_domain.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_ros/params.h"

namespace krr_ros {

/// @brief Where the navigation knowledge base comes from.
struct NavKbParams {
  std::string navigation_config;
  std::string domain;
  std::string geometry;
  std::vector<std::string> navigation_files;

  /// @brief Read (and check the files of) the parameters above.
  static NavKbParams read(ParamReader& params);
  /// @brief Load the map, derive the domain's grid, state space and simulator; knowledge_files
  /// are the geometry followed by navigation_files. @throws krr::Error naming file and field.
  krr::kb::NavDomain loadDomain() const;
  /// @brief The navigation config alone (navigation_config): the navigation task's reward and
  /// planning discount (`planning`) and R-Max (`rmax_learning`) live there, not in node YAMLs.
  /// @throws krr::ConfigError naming file and field.
  krr::nav::NavigationConfig loadConfig() const;
};

}  // namespace krr_ros
