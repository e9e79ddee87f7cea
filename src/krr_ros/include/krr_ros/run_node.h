/**
 * @file run_node.h
 * @brief The one main() of every krr_ros node: each node file is a call to runNode<Node>.
 *
 * A node class (in krr_ros/src/lib, declared in include/krr_ros/<name>.h) provides
 *  - `using Params = ...;` with `static Params Params::read(krr_ros::ParamReader&)`, which reads
 *    and validates every parameter (and calls rejectUnknown());
 *  - `static constexpr const char* kLog`: its ROS_*_NAMED logger name;
 *  - a constructor `Node(ros::NodeHandle& nh, ros::NodeHandle& pnh, Params params)` that wires
 *    topics, services and actions, and throws on a configuration it cannot run;
 *  - `int spin()`: runs the node until shutdown (its own spinner choice and shutdown rules)
 *    and returns the exit status.
 * runNode answers --help without a master, logs the root seed and the base directory, and
 * turns any exception at start into one ROS_FATAL line and exit status 1: a node never starts
 * on a half-understood configuration, and never dies with an uncaught exception.
 */
#pragma once

#include <ros/ros.h>

#include <cstdint>
#include <exception>
#include <memory>
#include <string>
#include <utility>

#include "krr_ros/params.h"

namespace krr_ros {

/// @brief Start `Node` as ROS node `rosName` (program `program` for --help); see the file
/// comment. @return the process exit status.
template <class Node>
int runNode(int argc, char** argv, const std::string& program, const std::string& rosName) {
  exitOnHelp(argc, argv, program);
  ros::init(argc, argv, rosName);
  ros::NodeHandle nh, pnh("~");
  std::unique_ptr<Node> node;
  try {
    ParamReader reader(pnh);
    typename Node::Params params = Node::Params::read(reader);
    ROS_INFO_NAMED(Node::kLog, "seed %lu, base_dir %s", static_cast<unsigned long>(params.seed),
                   reader.baseDir().c_str());
    node = std::make_unique<Node>(nh, pnh, std::move(params));
  } catch (const std::exception& e) {
    ROS_FATAL_NAMED(Node::kLog, "cannot start: %s", e.what());
    return 1;
  }
  return node->spin();
}

}  // namespace krr_ros
