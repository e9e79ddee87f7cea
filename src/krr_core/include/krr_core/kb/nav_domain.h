/**
 * @file nav_domain.h
 * @brief A navigation domain as the robot and the experiments load it: config, grid, abstract
 * states, simulator and knowledge files, built once and shared read-only.
 */
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/nav/blockage_simulator.h"
#include "krr_core/nav/navigation_config.h"

namespace krr {
namespace kb {

/// @brief A navigation domain loaded once and shared read-only by all its users.
struct NavDomain {
  nav::NavigationConfig config;
  nav::DomainConfig domain;
  std::shared_ptr<nav::NavGrid> grid;
  std::shared_ptr<NavStateSpace> space;
  std::shared_ptr<nav::BlockageSimulator> simulator;
  std::vector<std::string> knowledge_files;  ///< geometry, then human navigation knowledge

  /**
   * @brief Load config/navigation.yaml, derive the named domain's grid from the map, and
   * name its knowledge files: `geometry_file` (generated, e.g. maps/office_30x30_geometry.plog)
   * and `navigation_plog` (config/navigation.plog).
   */
  static NavDomain load(const std::string& navigation_yaml, const std::string& domain_name,
                        const std::string& geometry_file, const std::string& navigation_plog);
  /// @brief As above from a loaded navigation config (a site folder's, site/site.h).
  static NavDomain load(nav::NavigationConfig config, const std::string& domain_name,
                        const std::string& geometry_file, const std::string& navigation_plog);
};

}  // namespace kb
}  // namespace krr
