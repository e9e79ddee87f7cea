/**
 * @file conversions.h
 * @brief Conversions between krr_core types and ROS messages.
 *
 * Everything that comes from a message is validated here, so that the nodes can hand it to the
 * core without further checks: a malformed message raises a krr::Error naming the field and the
 * offending value (e.g. "atoms[2].move: 'sideways' is not up, down, left or right"), which the
 * node's callback turns into an error reply.
 */
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <krr_msgs/BuildTaskModel.h>
#include <krr_msgs/LearnedAtom.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Path.h>
#include <ros/time.h>
#include <visualization_msgs/MarkerArray.h>

#include <map>
#include <string>
#include <vector>

#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/mdp/rmax_model.h"
#include "krr_core/mdp/sparse_model.h"
#include "krr_core/nav/blockage_simulator.h"
#include "krr_core/nav/occupancy_grid.h"

namespace krr_ros {

/// @brief Index of a move name (up, down, left, right), -1 if it is none of them.
int moveIndex(const std::string& name);

/// @brief A map as nav_msgs/OccupancyGrid (same cell order: row 0 at the bottom).
nav_msgs::OccupancyGrid toMsg(const krr::nav::OccupancyGrid& map, const std::string& frame,
                              const ros::Time& stamp);

/// @brief A planar pose (z = 0) in `frame`.
geometry_msgs::PoseStamped poseMsg(const krr::nav::Point2& p, double yaw,
                                   const std::string& frame, const ros::Time& stamp);

/// @brief A path through the points, each pose facing the next point.
nav_msgs::Path pathMsg(const std::vector<krr::nav::Point2>& points, const std::string& frame,
                       const ros::Time& stamp);

/**
 * @brief RViz markers of the blocking areas (flat boxes, redder for higher blocking rates under
 * `context`, labelled with name and rate) and of the named places (labelled discs).
 */
visualization_msgs::MarkerArray areaMarkers(const krr::nav::BlockageSimulator& sim,
                                            const krr::nav::Context& context,
                                            const std::string& frame, const ros::Time& stamp);

/// @brief Learned knowledge as messages (one atom per learned (cell, move, time)).
std::vector<krr_msgs::LearnedAtom> toAtoms(
    const std::vector<krr::kb::NavigationKnowledge::LearnedEntry>& entries);

/**
 * @brief Validate atoms and turn them into R-Max known pairs, grouped by time of day, for
 * NavigationKnowledge::addLearned (samples = the atom's denominator, so the fractions are kept
 * exactly).
 * @param times the values of sort time of the knowledge base.
 * @throws krr::ConfigError / krr::UnknownSymbolError naming atoms[i] and the field: unknown
 * move or time, a cell that is not free, an outcome that is neither a free cell nor "trapped",
 * counts that are not positive or do not sum to samples, duplicate outcomes or atoms.
 */
std::map<std::string, std::vector<krr::mdp::KnownPair>> toKnownPairs(
    const std::vector<krr_msgs::LearnedAtom>& atoms, const krr::kb::NavStateSpace& space,
    const std::vector<std::string>& times);

/// @brief Fill the navigation part of a BuildTaskModel response from a NavModel.
void fillNavigationModel(const krr::kb::NavModel& model, const krr::kb::NavStateSpace& space,
                         krr_msgs::BuildTaskModel::Response* res);

/**
 * @brief The transition model of a BuildTaskModel response, over `space`'s states (rewards 0,
 * trapped terminal).
 * @throws krr::ConfigError when the response does not describe a model over this space
 * (different cells, malformed rows, probabilities not summing to 1).
 */
krr::mdp::SparseModel navigationModelFromMsg(const krr_msgs::BuildTaskModel::Response& res,
                                             const krr::kb::NavStateSpace& space);

}  // namespace krr_ros
