/**
 * @file navigation_node.h
 * @brief navigation_node: the robot's navigation as ROS actions (navigate, move_base), driven
 * by the grid simulator or, with ~executor move_base, by an external move_base server.
 *
 * Per goal it gets the navigation MDP from the knowledge base (Procedure 2), solves it by value
 * iteration and executes the policy move by move; src/lib/navigation_node.cpp describes the
 * topics, frames and the external executor.
 */
#pragma once

#include <ros/ros.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "krr_ros/nav_kb.h"
#include "krr_ros/params.h"

namespace krr_ros {

/// @brief Validated parameters of navigation_node (config/navigation_node.yaml documents each
/// with its default).
struct NavigationParams {
  NavKbParams kb;                      ///< map, grid, P-log files (nav_kb.h)
  std::string model_source;            ///< ~model_source: reasoner | local
  std::string model_service;           ///< ~model_service: BuildTaskModel service
  double model_timeout = 30;           ///< ~model_timeout: s to wait for the service
  std::string learned_file;            ///< ~learned_file: local source only ("" = none)
  std::string start_place;             ///< ~start_place: where the robot starts
  std::string time;                    ///< ~time: default time of day of goals
  double blocking_rate = -1;           ///< ~blocking_rate: br of the world (< 0: navigation.yaml)
  double sim_rate = 0;                 ///< ~sim_rate: simulated moves per second (0: no wait)
  long step_limit = 0;                 ///< ~step_limit: moves per goal (0: the domain's)
  /// ~discount, ~step_cost, ~rmax: overrides of navigation.yaml's planning (not set in
  /// navigation_node.yaml: the navigation task's settings have one home)
  double discount = 0.99, step_cost = 1, rmax = 40;
  bool ompl_paths = true;              ///< ~ompl_paths: plan an OMPL path per executed move
  double pose_rate = 10;               ///< ~pose_rate: tf / pose republish rate (Hz)
  std::string map_frame, odom_frame, base_frame;  ///< ~map_frame, ~odom_frame, ~base_frame
  std::string move_base_action;        ///< ~move_base_action: MoveBase server name ("": off)
  double tf_timeout = 0.5;             ///< ~tf_timeout: s to wait for a goal frame's transform
  std::string executor;                ///< ~executor: simulated | move_base
  std::string executor_action;         ///< ~executor_action: the external MoveBase server
  double executor_timeout = 60;        ///< ~executor_timeout: s one move (goal) may take
  double executor_wait = 5;            ///< ~executor_wait: s to wait for the server per trip
  std::string sample_topic;            ///< ~sample_topic: observed moves ("" = not published)
  std::uint64_t seed = 1;              ///< ~seed: simulator and OMPL
  bool check_site = true;              ///< ~check_site: refuse to start on an inconsistent site

  /// @brief Read and validate every parameter (unknown ones refused); with check_site, also
  /// the site (krr_ros/site_check.h).
  /// @throws krr::ConfigError naming the parameter and its value, or every finding of the site.
  static NavigationParams read(ParamReader& r);
};

/// @brief navigation_node (krr_ros/run_node.h's contract): map, pose, the navigate and move_base
/// action servers; one trip at a time.
class NavigationNode {
 public:
  using Params = NavigationParams;
  static constexpr const char* kLog = "navigation";

  /// @throws krr::Error on a configuration it cannot run (files, places, times).
  NavigationNode(ros::NodeHandle& nh, ros::NodeHandle& pnh, Params params);
  ~NavigationNode();
  NavigationNode(const NavigationNode&) = delete;
  NavigationNode& operator=(const NavigationNode&) = delete;

  /// @brief Run until ROS shuts down. @return the exit status (0).
  int spin();

 private:
  class Impl;  ///< topics, services, actions and state (src/lib/navigation_node.cpp)
  std::unique_ptr<Impl> impl_;
};

}  // namespace krr_ros
