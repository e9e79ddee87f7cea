/**
 * @file learner_node.h
 * @brief learner_node: Procedure 1 (free-time practice with R-Max) and learning from the robot's
 * own moves, sent to reasoner_node's add_knowledge service.
 *
 * src/lib/learner_node.cpp describes when it learns, what it sends and why it (not
 * navigation_node) learns from navigation_node's observed moves.
 */
#pragma once

#include <ros/ros.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "krr_core/kb/free_time_learner.h"
#include "krr_ros/nav_kb.h"
#include "krr_ros/params.h"

namespace krr_ros {

/// @brief Validated parameters of learner_node (config/learner_node.yaml documents each
/// with its default).
struct LearnerParams {
  NavKbParams kb;                     ///< map, grid, P-log files (nav_kb.h)
  std::string learned_file;           ///< ~learned_file: knowledge to start from ("" = none)
  std::string knowledge_service;      ///< ~knowledge_service: AddKnowledge service
  double service_timeout = 10;        ///< ~service_timeout (s)
  std::string navigation_action;      ///< ~navigation_action: action whose goals are tasks
  std::string request_topic;          ///< ~request_topic: ServiceRequest ("" = not watched)
  std::string utterance_topic;        ///< ~utterance_topic: UserUtterance ("" = not watched)
  double task_hold = 30;              ///< ~task_hold: s paused after a request / utterance
  double idle_delay = 1;              ///< ~idle_delay: s idle after a task before learning
  std::vector<std::string> places;    ///< ~places: goal candidates ([] = every place)
  std::string start_place;            ///< ~start_place
  bool enabled = true;                ///< ~enabled
  long rest_threshold = 5;            ///< ~rest_threshold: a task changing fewer distributions
                                      ///< than this taught (almost) nothing;
  long rest_after = 10;               ///< ~rest_after: after so many such tasks in a row ...
  double rest_period = 60;            ///< ~rest_period: ... before resting this long (s)
  std::string sample_topic;           ///< ~sample_topic: observed moves ("" = not learned)
  double sample_period = 1;           ///< ~sample_period: s between sends of what they taught
  krr::kb::FreeTimeOptions options;   ///< ~time, ~blocking_rate, ~max_*, ~convergence_episodes;
                                      ///< R-Max from navigation.yaml (~known_threshold, ~rmax,
                                      ///< ~discount, ~step_cost, ~replan_every override it)
  std::uint64_t seed = 1;             ///< ~seed: task selection, simulator, R-Max
  bool check_site = true;             ///< ~check_site: refuse to start on an inconsistent site

  /// @brief Read and validate every parameter (unknown ones refused); with check_site, also
  /// the site (krr_ros/site_check.h).
  /// @throws krr::ConfigError naming the parameter and its value, or every finding of the site.
  static LearnerParams read(ParamReader& r);
};

/// @brief learner_node (krr_ros/run_node.h's contract): learns between tasks and from observed
/// moves, on its own thread; callbacks on a spinner thread.
class LearnerNode {
 public:
  using Params = LearnerParams;
  static constexpr const char* kLog = "learner";

  /// @throws krr::Error on a configuration it cannot run (files, places, times).
  LearnerNode(ros::NodeHandle& nh, ros::NodeHandle& pnh, Params params);
  ~LearnerNode();
  LearnerNode(const LearnerNode&) = delete;
  LearnerNode& operator=(const LearnerNode&) = delete;

  /// @brief Run until ROS shuts down. @return the exit status (0).
  int spin();

 private:
  class Impl;  ///< topics, services, actions and state (src/lib/learner_node.cpp)
  std::unique_ptr<Impl> impl_;
};

}  // namespace krr_ros
