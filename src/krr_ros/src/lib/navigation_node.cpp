// navigation_node: the robot's navigation in the simulated office, as a ROS action.
//
// Loads the map and the navigation domain, publishes the map (latched), the blocking areas and
// places (markers), and serves the `navigate` action: for each goal it gets the navigation MDP
// built from the knowledge base (Procedure 2; from reasoner_node's build_task_model service, or
// in-process from the same files with ~model_source local), solves it by value iteration, and
// executes the policy move by move in the stochastic-blockage simulator, driving an OMPL path
// for every executed move.
//
// The ROS navigation face (move_base's interface, one code path with `navigate`): a
// move_base_msgs/MoveBaseAction server at ~move_base_action (default move_base) and
// move_base_simple/goal (geometry_msgs/PoseStamped, what RViz's "2D Nav Goal" publishes, sent
// through that server as move_base does). A goal pose is taken in ~map_frame (other frames are
// transformed through tf) and mapped to the grid cell that contains it; feedback (base_position)
// after every move; a newer goal on either interface preempts the running one. Frames follow
// REP 105: map -> odom (identity: the simulated robot does not drift) and odom -> base_link
// (the pose), nav_msgs/Odometry on odom; the pose also goes out on robot_pose (map frame).
//
// ~executor move_base (issue 26): instead of the simulator, every move of the policy is sent as
// a goal (the target cell's centre in the map frame) to an external move_base action server at
// ~executor_action (a real robot's, or Gazebo / Stage's). The robot's cell is read from tf
// (map -> base_link); the node publishes none of the robot's frames nor odom then. Each
// observed move (reached / stayed / elsewhere / aborted, krr_core kb/observed_navigation.h) goes
// out as a krr_msgs/NavigationSample on ~sample_topic, which learner_node learns from.
#include "krr_ros/navigation_node.h"

#include <actionlib/server/simple_action_server.h>
#include <geometry_msgs/TransformStamped.h>
#include <krr_msgs/BuildTaskModel.h>
#include <krr_msgs/NavigateAction.h>
#include <krr_msgs/NavigationSample.h>
#include <actionlib/client/simple_action_client.h>
#include <move_base_msgs/MoveBaseAction.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <tf2/LinearMath/Transform.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <functional>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/kb/observed_navigation.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/trip.h"
#include "krr_core/mdp/solvers.h"
#include "krr_core/nav/ompl_planner.h"
#include "krr_ros/conversions.h"
#include "krr_ros/site_check.h"
#include "krr_ros/nav_kb.h"
#include "krr_ros/params.h"

namespace krr_ros {

namespace {

using NavigateServer = actionlib::SimpleActionServer<krr_msgs::NavigateAction>;
using MoveBaseServer = actionlib::SimpleActionServer<move_base_msgs::MoveBaseAction>;
using MoveBaseClient = actionlib::SimpleActionClient<move_base_msgs::MoveBaseAction>;

/// @brief A goal that cannot be accepted (unknown place, cell out of range...).
class GoalError : public krr::Error {
 public:
  using krr::Error::Error;
};

}  // namespace

NavigationParams NavigationParams::read(ParamReader& r) {
  NavigationParams p;
  p.seed = r.seed();
  p.kb = krr_ros::NavKbParams::read(r);
  p.model_source = r.str("model_source", "reasoner", {"reasoner", "local"});
  p.model_service = r.str("model_service", "/reasoner/build_task_model");
  p.model_timeout = r.number("model_timeout", 30, 0.1, 3600);
  p.learned_file = r.path("learned_file", "", false);
  // Default: the site's shop (nav_kb.h), never a name written here.
  p.start_place = r.str("start_place", p.kb.shop);
  if (p.start_place.empty()) r.refuse("start_place", "''", "must name a place of the map");
  p.blocking_rate = r.blockingRate("blocking_rate");
  p.sim_rate = r.number("sim_rate", 0, 0, 1000);
  p.step_limit = r.integer("step_limit", 0, 0, 1000000);
  // Defaults from the one home of these settings, navigation.yaml (context, planning).
  const krr::nav::NavigationConfig nav = p.kb.loadConfig();
  const krr::nav::PlanningConfig& planning = nav.planning;
  p.time = r.str("time", nav.time);
  p.discount = r.number("discount", planning.discount, 0.01, 1.0);
  p.step_cost = r.number("step_cost", planning.step_cost, 0.0, 1e6);
  p.rmax = r.number("rmax", planning.rmax, 1e-6, 1e9);
  p.ompl_paths = r.boolean("ompl_paths", true);
  p.pose_rate = r.number("pose_rate", 10, 0.1, 1000);
  p.map_frame = r.str("map_frame", "map");
  p.odom_frame = r.str("odom_frame", "odom");
  p.base_frame = r.str("base_frame", "base_link");
  if (p.map_frame.empty() || p.odom_frame.empty() || p.base_frame.empty() ||
      p.map_frame == p.base_frame || p.map_frame == p.odom_frame || p.odom_frame == p.base_frame)
    r.refuse("base_frame", "'" + p.base_frame + "'",
             "map_frame, odom_frame and base_frame must be three different, non-empty names "
             "(REP 105: map -> odom -> base_link)");
  p.move_base_action = r.str("move_base_action", "move_base");
  p.tf_timeout = r.number("tf_timeout", 0.5, 0.0, 60.0);
  p.executor = r.str("executor", "simulated", {"simulated", "move_base"});
  p.executor_action = r.str("executor_action", "move_base_external");
  p.executor_timeout = r.number("executor_timeout", 60, 0.1, 86400);
  p.executor_wait = r.number("executor_wait", 5, 0.0, 3600);
  p.sample_topic = r.str("sample_topic", "navigation_samples");
  if (p.executor == "move_base") {
    // Goals sent to our own move_base face would come back to this node: a deadlock.
    const std::string own = ros::names::resolve(p.move_base_action),
                      ext = ros::names::resolve(p.executor_action);
    if (p.executor_action.empty() || (!p.move_base_action.empty() && own == ext))
      r.refuse("executor_action", "'" + p.executor_action + "'",
               "must name the external move_base server, not this node's own move_base_action "
               "(" + own + "); e.g. executor_action:=/move_base with "
               "move_base_action:=krr/move_base");
  }
  if (p.step_cost >= p.rmax)
    r.refuse("step_cost", std::to_string(p.step_cost),
             "must be below rmax = " + std::to_string(p.rmax));
  p.check_site = readCheckSite(r);
  r.rejectUnknown();
  // The site's files agree before anything starts (site_check.h).
  if (p.check_site) requireConsistentSite(r, {p.kb.navigation_config, "", "", {}, p.kb.site.get()});
  return p;
}

class NavigationNode::Impl {
 public:
  Impl(ros::NodeHandle& nh, ros::NodeHandle& pnh, NavigationParams params)
      : p_(std::move(params)),
        dom_(p_.kb.loadDomain()),
        map_(krr::nav::loadMap(dom_.config.map)),
        rng_(krr::makeRng(p_.seed, "navigation_node")),
        tf_listener_(tf_buffer_),
        server_(nh, "navigate", [this](const krr_msgs::NavigateGoalConstPtr& g) { execute(g); },
                false) {
    krr::nav::seedOmpl(p_.seed);
    if (p_.ompl_paths)
      planner_ = std::make_unique<krr::nav::OmplPlanner>(map_, dom_.config.planner, p_.seed);
    const std::string param = "parameter " + ros::this_node::getName() + "/";
    context_ = krr::nav::Context::withRate(
        timeIndex(p_.time, param + "time = '" + p_.time + "'"), p_.blocking_rate);
    try {
      cell_ = dom_.grid->placeCell(p_.start_place);
    } catch (const krr::Error& e) {
      throw krr::ConfigError(param + "start_place = '" + p_.start_place + "': " + e.what());
    }
    pose_ = dom_.grid->cellCentre(cell_);
    if (p_.step_limit == 0) p_.step_limit = dom_.domain.step_limit;
    if (p_.model_source == "local")
      knowledge_ = std::make_unique<krr::kb::NavigationKnowledge>(*dom_.grid, dom_.knowledge_files);
    else
      model_client_ = nh.serviceClient<krr_msgs::BuildTaskModel>(p_.model_service);

    map_pub_ = nh.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
    markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("blocking_areas", 1, true);
    pose_pub_ = nh.advertise<geometry_msgs::PoseStamped>("robot_pose", 10, true);
    plan_pub_ = nh.advertise<nav_msgs::Path>("planned_path", 1, true);
    executed_pub_ = nh.advertise<nav_msgs::Path>("executed_path", 1, true);
    if (p_.executor == "move_base") {
      // The robot (or its simulator) owns map -> odom -> base_link and odom: publish none.
      executor_ = std::make_unique<MoveBaseClient>(nh, p_.executor_action, false);
      if (!p_.sample_topic.empty())
        sample_pub_ = nh.advertise<krr_msgs::NavigationSample>(p_.sample_topic, 100);
      pose_timer_ = pnh.createTimer(ros::Duration(1.0 / p_.pose_rate),
                                    [this](const ros::TimerEvent&) { republishObservedPose(); });
    } else {
      odom_pub_ = nh.advertise<nav_msgs::Odometry>("odom", 10);
      geometry_msgs::TransformStamped identity;  // REP 105: the simulated robot does not drift
      identity.header.stamp = ros::Time::now();
      identity.header.frame_id = p_.map_frame;
      identity.child_frame_id = p_.odom_frame;
      identity.transform.rotation.w = 1.0;
      tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
      static_tf_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
      static_tf_->sendTransform(identity);
      publishPose();
      pose_timer_ = pnh.createTimer(ros::Duration(1.0 / p_.pose_rate),
                                    [this](const ros::TimerEvent&) { publishPose(); });
    }
    const ros::Time now = ros::Time::now();
    map_pub_.publish(krr_ros::toMsg(map_, p_.map_frame, now));
    markers_pub_.publish(krr_ros::areaMarkers(*dom_.simulator, context_, p_.map_frame, now));
    server_.start();
    if (!p_.move_base_action.empty()) {
      move_base_ = std::make_unique<MoveBaseServer>(
          nh, p_.move_base_action,
          [this](const move_base_msgs::MoveBaseGoalConstPtr& g) { executeMoveBase(g); }, false);
      move_base_->start();
      // As move_base does: a simple goal becomes a goal of the action server.
      simple_goal_pub_ = nh.advertise<move_base_msgs::MoveBaseActionGoal>(
          ros::names::append(p_.move_base_action, "goal"), 1);
      simple_goal_sub_ = nh.subscribe("move_base_simple/goal", 1, &Impl::onSimpleGoal, this);
    }
    ROS_INFO_NAMED(kLog, "domain %s (%d x %d cells, %d free), robot at %s (cell %d), time %s, "
                   "model from %s, step limit %ld, sim_rate %g, executor %s", p_.kb.domain.c_str(),
                   dom_.grid->cols(), dom_.grid->rows(), dom_.grid->numFreeCells(),
                   p_.start_place.c_str(), cell_, p_.time.c_str(),
                   p_.model_source == "local" ? "the local knowledge base"
                                              : p_.model_service.c_str(),
                   p_.step_limit, p_.sim_rate,
                   executor_ ? ("move_base at " + ros::names::resolve(p_.executor_action) +
                                " (robot cell from tf " + p_.map_frame + " -> " + p_.base_frame +
                                "; start_place, sim_rate, blocking_rate, ompl_paths unused)")
                                   .c_str()
                             : "simulated");
  }

  /// @brief Serve goals until shutdown (action execute callbacks run in their own threads).
  int spin() {
    ROS_INFO_NAMED(kLog, "ready: send goals to the 'navigate' action (or move_base / "
                   "move_base_simple/goal)");
    ros::spin();
    return 0;
  }

 private:
  int timeIndex(const std::string& time, const std::string& what) const {
    try {
      return dom_.simulator->timeOfDayIndex(time);
    } catch (const krr::Error& e) {
      throw GoalError(what + ": " + e.what());
    }
  }

  /// @brief The goal cell, or GoalError naming what is wrong with the goal.
  int resolveGoal(const krr_msgs::NavigateGoal& goal, int from) const {
    const krr::nav::NavGrid& g = *dom_.grid;
    int cell = goal.cell;
    if (!goal.place.empty()) {
      try {
        cell = g.placeCell(goal.place);
      } catch (const krr::Error&) {
        std::string known;
        for (const auto& pl : g.places()) known += (known.empty() ? "" : ", ") + pl.name;
        throw GoalError("unknown place '" + goal.place + "' (known places: " + known + ")");
      }
    } else if (!g.valid(cell)) {
      throw GoalError("goal cell " + std::to_string(cell) + " is out of range [0, " +
                      std::to_string(g.numCells() - 1) + "] (no place given)");
    } else if (!g.isFree(cell)) {
      throw GoalError("goal cell " + std::to_string(cell) + " is not a free cell");
    }
    const std::vector<int> reach = g.reachableFrom(from);
    if (!std::binary_search(reach.begin(), reach.end(), cell))
      throw GoalError("goal cell " + std::to_string(cell) + " cannot be reached from cell " +
                      std::to_string(from));
    return cell;
  }

  /// @brief Procedure 2: the transition model for `time`, from the knowledge base.
  krr::mdp::SparseModel model(const std::string& time) {
    if (knowledge_) {
      if (!p_.learned_file.empty() && std::filesystem::exists(p_.learned_file)) {
        const auto stamp = std::filesystem::last_write_time(p_.learned_file);
        if (stamp != learned_stamp_) {
          knowledge_->clearLearned();
          knowledge_->loadLearned(p_.learned_file);
          learned_stamp_ = stamp;
        }
      }
      return knowledge_->buildModel({time}, p_.discount).dynamics;
    }
    if (!model_client_.waitForExistence(ros::Duration(p_.model_timeout)))
      throw krr::IoError("service " + p_.model_service + " is not available (is reasoner_node "
                         "running?)");
    krr_msgs::BuildTaskModel srv;
    srv.request.task = "navigation";
    srv.request.times = {time};
    srv.request.discount = p_.discount;
    if (!model_client_.call(srv))
      throw krr::IoError("call to " + p_.model_service + " failed");
    if (!srv.response.success)
      throw krr::Error("the reasoner could not build the model: " + srv.response.message);
    return krr_ros::navigationModelFromMsg(srv.response, *dom_.space);
  }

  /// @brief The most likely route under the policy: follow each move's likeliest outcome.
  std::vector<krr::nav::Point2> intendedRoute(const krr::mdp::SparseModel& m,
                                              const std::vector<krr::mdp::ActionId>& policy,
                                              int from, int goal) const {
    std::vector<krr::nav::Point2> pts{dom_.grid->cellCentre(from)};
    std::vector<std::uint8_t> seen(dom_.space->numStates(), 0);
    krr::mdp::StateId s = dom_.space->stateOf(from);
    const krr::mdp::StateId g = dom_.space->stateOf(goal);
    for (long k = 0; k < p_.step_limit && s != g && !seen[s]; ++k) {
      seen[s] = 1;
      krr::mdp::StateId best = s;
      double bp = -1;
      for (krr::mdp::Outcome o : m.successors(s, policy[s]))
        if (o.state != dom_.space->trappedState() && o.state != s && o.probability > bp) {
          bp = o.probability;
          best = o.state;
        }
      if (best == s) break;
      s = best;
      pts.push_back(dom_.grid->cellCentre(dom_.space->cellOf(s)));
    }
    return pts;
  }

  /// @brief How a trip ended, for either action interface.
  struct Trip {
    std::string outcome = "error";  ///< reached | preempted | step_limit | trapped | ...
    std::string reason;
    int final_cell = -1;
    std::uint32_t steps = 0;
  };
  /// @brief One executed move (feedback for either interface).
  struct Step {
    int cell, goal_cell;
    std::uint32_t step;
    std::string move;
    bool blocked;
  };

  void execute(const krr_msgs::NavigateGoalConstPtr& goal) {
    const unsigned gen = ++goal_gen_;  // a newer goal on either interface preempts this one
    std::lock_guard<std::mutex> driving(drive_mutex_);
    krr_msgs::NavigateResult result;
    Trip trip;
    try {
      trip.final_cell = currentCell();
      const int goal_cell = resolveGoal(*goal, trip.final_cell);
      krr_msgs::NavigateFeedback fb;
      trip = runTrip(goal_cell, goal->time, goal->place.empty() ? "cell" : goal->place,
                     [&](const Step& st) {
                       fb.goal_cell = st.goal_cell;
                       fb.current_cell = st.cell;
                       fb.step = st.step;
                       fb.last_move = st.move;
                       fb.blocked = st.blocked;
                       fb.pose = krr_ros::poseMsg(pose(), yawNow(), p_.map_frame, ros::Time::now());
                       server_.publishFeedback(fb);
                     },
                     [&] { return server_.isPreemptRequested() || goal_gen_ != gen; });
    } catch (const GoalError& e) {
      trip.outcome = "rejected", trip.reason = e.what();
    } catch (const std::exception& e) {
      trip.outcome = "error", trip.reason = e.what();
    }
    result.outcome = trip.outcome;
    result.success = trip.outcome == "reached";
    result.failure_reason = trip.reason;
    result.final_cell = trip.final_cell;
    result.steps = trip.steps;
    logTrip(trip);
    if (result.success) server_.setSucceeded(result, "reached");
    else if (trip.outcome == "preempted") server_.setPreempted(result, trip.reason);
    else server_.setAborted(result, trip.reason);
  }

  void executeMoveBase(const move_base_msgs::MoveBaseGoalConstPtr& goal) {
    const unsigned gen = ++goal_gen_;
    std::lock_guard<std::mutex> driving(drive_mutex_);
    Trip trip;
    try {
      trip.final_cell = currentCell();
      const int goal_cell = poseCell(goal->target_pose, trip.final_cell);
      move_base_msgs::MoveBaseFeedback fb;
      trip = runTrip(goal_cell, "", "pose", [&](const Step&) {
                       fb.base_position = krr_ros::poseMsg(pose(), yawNow(), p_.map_frame, ros::Time::now());
                       move_base_->publishFeedback(fb);
                     },
                     [&] { return move_base_->isPreemptRequested() || goal_gen_ != gen; });
    } catch (const GoalError& e) {
      trip.outcome = "rejected", trip.reason = e.what();
    } catch (const std::exception& e) {
      trip.outcome = "error", trip.reason = e.what();
    }
    logTrip(trip);
    move_base_msgs::MoveBaseResult result;
    if (trip.outcome == "reached")
      move_base_->setSucceeded(result, "reached cell " + std::to_string(trip.final_cell) + " in " +
                                           std::to_string(trip.steps) + " moves");
    else if (trip.outcome == "preempted") move_base_->setPreempted(result, trip.reason);
    else move_base_->setAborted(result, trip.outcome + ": " + trip.reason);
  }

  /// @brief RViz's 2D Nav Goal: a goal of the move_base server (a newer one preempts).
  void onSimpleGoal(const geometry_msgs::PoseStamped::ConstPtr& pose) {
    move_base_msgs::MoveBaseActionGoal g;
    g.header.stamp = ros::Time::now();
    g.goal_id.stamp = g.header.stamp;
    g.goal.target_pose = *pose;
    ROS_INFO_NAMED(kLog, "simple goal (%.2f, %.2f) in '%s'", pose->pose.position.x,
                   pose->pose.position.y, pose->header.frame_id.c_str());
    simple_goal_pub_.publish(g);
  }

  /// @brief The free, reachable cell containing a goal pose (transformed into the map frame
  /// through tf when given in another), or GoalError naming what is wrong.
  int poseCell(const geometry_msgs::PoseStamped& goal, int from) {
    const std::string& frame = goal.header.frame_id;
    const geometry_msgs::Point& q = goal.pose.position;
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
      throw GoalError("goal pose has a non-finite position");
    krr::nav::Point2 p{q.x, q.y};
    if (frame.empty())
      throw GoalError("goal pose has no frame_id (give '" + p_.map_frame + "')");
    if (frame != p_.map_frame && frame != "/" + p_.map_frame) {
      geometry_msgs::TransformStamped t;
      try {
        t = tf_buffer_.lookupTransform(p_.map_frame, frame, ros::Time(0),
                                       ros::Duration(p_.tf_timeout));
      } catch (const std::exception& e) {
        throw GoalError("goal pose in frame '" + frame + "': no transform to '" + p_.map_frame +
                        "' (" + e.what() + ")");
      }
      p = transformPoint(t.transform, q);
    }
    char where[96];
    std::snprintf(where, sizeof where, "goal pose (%.3f, %.3f) in %s", p.x, p.y, p_.map_frame.c_str());
    const int cell = dom_.grid->cellAt(p);
    if (cell < 0) throw GoalError(std::string(where) + " is off the map");
    if (!dom_.grid->isFree(cell))
      throw GoalError(std::string(where) + " is in an obstacle (cell " + std::to_string(cell) + ")");
    krr_msgs::NavigateGoal g;
    g.cell = cell;
    return resolveGoal(g, from);  // reachability, with its message
  }

  /// @brief The x, y of point q under a tf transform (tf2's own arithmetic).
  static krr::nav::Point2 transformPoint(const geometry_msgs::Transform& t,
                                         const geometry_msgs::Point& q) {
    const auto& r = t.rotation;
    const tf2::Transform tr(tf2::Quaternion(r.x, r.y, r.z, r.w).normalized(),
                            tf2::Vector3(t.translation.x, t.translation.y, t.translation.z));
    const tf2::Vector3 p = tr * tf2::Vector3(q.x, q.y, q.z);
    return {p.x(), p.y()};
  }

  void logTrip(const Trip& t) const {
    if (t.outcome == "reached")
      ROS_INFO_NAMED(kLog, "goal reached at cell %d in %u moves", t.final_cell, t.steps);
    else if (t.outcome == "preempted")
      ROS_INFO_NAMED(kLog, "goal %s", t.reason.c_str());
    else
      ROS_WARN_NAMED(kLog, "goal failed (%s): %s", t.outcome.c_str(), t.reason.c_str());
  }

  /// @brief Build the model for `time` ("" = the default time), solve the task to goal_cell
  /// and drive it; onStep after every move, preempted before every move.
  Trip runTrip(int goal_cell, const std::string& time, const std::string& what,
               const std::function<void(const Step&)>& onStep,
               const std::function<bool()>& preempted) {
    const std::string t = time.empty() ? p_.time : time;
    const krr::nav::Context ctx(timeIndex(t, "goal time"), context_.blockingRate());
    ROS_INFO_NAMED(kLog, "goal: %s (cell %d) from cell %d, time %s", what.c_str(), goal_cell,
                   currentCell(), t.c_str());
    return drive(goal_cell, model(t), ctx, t, onStep, preempted);
  }

  Trip drive(int goal_cell, const krr::mdp::SparseModel& dynamics, const krr::nav::Context& ctx,
             const std::string& time, const std::function<void(const Step&)>& onStep,
             const std::function<bool()>& preempted) {
    const krr::kb::NavStateSpace& sp = *dom_.space;
    const krr::mdp::StateId goal = sp.stateOf(goal_cell);
    const krr::mdp::SparseModel task = krr::mdp::makeNavigationTask(
        dynamics, {goal}, {sp.trappedState()}, {p_.step_cost, p_.rmax});
    krr::mdp::SolverOptions opt;
    opt.epsilon = 1e-3;
    const std::vector<krr::mdp::ActionId> policy = krr::mdp::valueIteration(task, opt).policy;
    int cell = currentCell();
    Trip trip;
    trip.final_cell = cell;
    const auto end = [&](const char* outcome, const std::string& reason) {
      trip.outcome = outcome;
      trip.reason = reason;
      return trip;
    };
    std::vector<krr::nav::Point2> executed{dom_.grid->cellCentre(cell)};
    plan_pub_.publish(krr_ros::pathMsg(intendedRoute(dynamics, policy, cell, goal_cell),
                                       p_.map_frame, ros::Time::now()));
    ros::Rate rate(p_.sim_rate > 0 ? p_.sim_rate : 1.0);
    // How the trip ends is the core's one rule (mdp::runTrip); the moves are this node's.
    MoveResult last;
    int expected = cell, moved = 0;
    const krr::mdp::TripSummary summary = krr::mdp::runTrip(
        cell == goal_cell, static_cast<std::size_t>(p_.step_limit),
        [&] { return preempted() || !ros::ok(); },
        [&](std::size_t k) {
          const long step = static_cast<long>(k);
          moved = static_cast<int>(policy[sp.stateOf(cell)]);
          expected = dom_.grid->neighbour(cell, moved);
          last = executor_ ? moveExternally(cell, moved, step, time, preempted)
                           : moveSimulated(cell, moved, ctx, &executed);
          krr::mdp::TripMove m;
          m.stopped = !last.stop_outcome.empty();
          if (m.stopped) return m;
          if (executor_ && last.cell != cell) executed.push_back(dom_.grid->cellCentre(last.cell));
          cell = last.cell;
          trip.final_cell = cell;
          trip.steps = static_cast<std::uint32_t>(step);
          onStep({cell, goal_cell, trip.steps, krr::nav::moveName(moved), last.blocked});
          executed_pub_.publish(krr_ros::pathMsg(executed, p_.map_frame, ros::Time::now()));
          m.failed = last.trapped;
          m.reached = !last.trapped && cell == goal_cell;
          if (!m.failed) {
            if (!m.reached && cell != expected)  // slipped or blocked: show the new route
              plan_pub_.publish(krr_ros::pathMsg(intendedRoute(dynamics, policy, cell, goal_cell),
                                                 p_.map_frame, ros::Time::now()));
            if (p_.sim_rate > 0 && !executor_) rate.sleep();
          }
          return m;
        });
    switch (summary.end) {
      case krr::mdp::TripEnd::kReached:
        return end("reached", "");
      case krr::mdp::TripEnd::kStepLimit:
        return end("step_limit", "step limit of " + std::to_string(p_.step_limit) +
                                     " moves reached at cell " + std::to_string(cell));
      case krr::mdp::TripEnd::kFailed:
        if (executor_) return end("aborted", last.reason);
        return end("trapped", "trapped by walkers" + areasOf(expected) + " moving " +
                                  krr::nav::moveName(moved) + " from cell " +
                                  std::to_string(cell) + " after " +
                                  std::to_string(summary.moves) + " moves");
      case krr::mdp::TripEnd::kStopped:
        break;
    }
    if (!last.stop_outcome.empty()) return end(last.stop_outcome.c_str(), last.reason);
    return end("preempted", "preempted after " + std::to_string(summary.moves) + " moves");
  }

  /// @brief What became of one move of the policy; a non-empty stop_outcome ends the trip
  /// without a sample (preempted, or the executor failed).
  struct MoveResult {
    int cell = -1;           ///< the robot's cell after the move
    bool blocked = false;    ///< the move did not arrive (stayed or aborted)
    bool trapped = false;    ///< the trip cannot go on (simulated: trapped; external: aborted)
    std::string stop_outcome, reason;
  };

  /// @brief One move in the stochastic-blockage simulator, driven along an OMPL path.
  MoveResult moveSimulated(int cell, int move, const krr::nav::Context& ctx,
                           std::vector<krr::nav::Point2>* executed) {
    const krr::nav::Outcome out = dom_.simulator->step(cell, move, ctx, rng_);
    if (out.cell != cell) moveAlong(cell, out.cell, executed);
    MoveResult r;
    r.cell = out.cell;
    r.blocked = out.blocked;
    r.trapped = out.trapped;
    return r;
  }

  /**
   * @brief One move through the external move_base server: the target cell's centre as a goal
   * (facing along the move), waited for at most ~executor_timeout (then cancelled), the robot's
   * cell then read from tf and the observed move published as a sample. A move into a wall is
   * not sent: the robot stays, as in the knowledge base.
   */
  MoveResult moveExternally(int cell, int move, long step, const std::string& time,
                            const std::function<bool()>& preempted) {
    const krr::nav::NavGrid& g = *dom_.grid;
    const int target = g.neighbour(cell, move);
    const std::string leg = "move " + std::to_string(step) + " (" + krr::nav::moveName(move) +
                            " from cell " + std::to_string(cell) +
                            (target >= 0 ? " to cell " + std::to_string(target) : "") + ")";
    const std::string server = "move_base server " + ros::names::resolve(p_.executor_action);
    MoveResult r;
    r.cell = cell;
    if (target < 0) {
      r.blocked = true;
      publishSample(time, cell, move, target, cell, krr::kb::MoveOutcome::kStayed);
      return r;
    }
    const auto stop = [&](const char* outcome, const std::string& why) {
      r.stop_outcome = outcome;
      r.reason = why;
      return r;
    };
    // waitForServer(0) would wait for ever: executor_wait 0 means "do not wait".
    if (!executor_->isServerConnected() &&
        !(p_.executor_wait > 0 && executor_->waitForServer(ros::Duration(p_.executor_wait)))) {
      char waited[32];
      std::snprintf(waited, sizeof waited, "%g", p_.executor_wait);
      return stop("error", server + " is not available (waited " + waited + " s before " + leg +
                               ")");
    }
    const krr::nav::Point2 a = g.cellCentre(cell), b = g.cellCentre(target);
    move_base_msgs::MoveBaseGoal goal;
    goal.target_pose = krr_ros::poseMsg(b, std::atan2(b.y - a.y, b.x - a.x), p_.map_frame,
                                        ros::Time::now());
    executor_->sendGoal(goal);
    const ros::Time deadline = ros::Time::now() + ros::Duration(p_.executor_timeout);
    bool timed_out = false;
    ros::WallRate poll(100);
    while (!executor_->getState().isDone()) {
      if (preempted() || !ros::ok()) {
        cancelAndWait();
        return stop("preempted", "preempted during " + leg);
      }
      if (!executor_->isServerConnected()) {
        executor_->stopTrackingGoal();
        return stop("error", server + " vanished during " + leg);
      }
      if (ros::Time::now() > deadline) {  // too slow: cancel, then see where the robot got to
        timed_out = true;
        if (!cancelAndWait())
          return stop("error", server + " did not end " + leg + " within 1 s of its cancel");
        break;
      }
      poll.sleep();
    }
    const actionlib::SimpleClientGoalState state = executor_->getState();
    const bool aborted = state == actionlib::SimpleClientGoalState::ABORTED ||
                         state == actionlib::SimpleClientGoalState::REJECTED;
    if (!aborted && state != actionlib::SimpleClientGoalState::SUCCEEDED &&
        state != actionlib::SimpleClientGoalState::PREEMPTED &&
        state != actionlib::SimpleClientGoalState::RECALLED)
      return stop("error", server + " ended " + leg + " in state " + state.toString());
    r.cell = observeCell(ros::Time::now());
    const krr::kb::MoveOutcome o = krr::kb::classifyMove(g, cell, move, r.cell, aborted);
    publishSample(time, cell, move, target, aborted ? -1 : r.cell, o);
    r.blocked = o == krr::kb::MoveOutcome::kStayed || o == krr::kb::MoveOutcome::kAborted;
    r.trapped = aborted;
    if (aborted) {
      const std::string text = executor_->getState().getText();
      r.reason = server + " aborted " + leg + areasOf(target) +
                 (text.empty() ? "" : ": " + text);
    }
    ROS_DEBUG_NAMED(kLog, "%s: %s%s, robot at cell %d", leg.c_str(),
                    krr::kb::toString(o).c_str(), timed_out ? " (timed out)" : "", r.cell);
    return r;
  }

  /// @brief Cancel the external goal and wait up to 1 s for the server to end it.
  bool cancelAndWait() {
    executor_->cancelGoal();
    const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(1.0);
    while (!executor_->getState().isDone() && ros::WallTime::now() < until && ros::ok() &&
           executor_->isServerConnected())
      ros::WallDuration(0.01).sleep();
    const bool done = executor_->getState().isDone();
    if (!done) executor_->stopTrackingGoal();
    return done;
  }

  /// @brief An observed move on ~sample_topic (learner_node learns from it).
  void publishSample(const std::string& time, int cell, int move, int target, int next,
                     krr::kb::MoveOutcome outcome) {
    if (p_.sample_topic.empty()) return;
    krr_msgs::NavigationSample m;
    m.header.stamp = ros::Time::now();
    m.header.frame_id = p_.map_frame;
    m.time = time;
    m.cell = cell;
    m.move = krr::nav::moveName(move);
    m.target_cell = target;
    m.next_cell = next;
    m.outcome = krr::kb::toString(outcome);
    sample_pub_.publish(m);
  }

  /// @brief The robot's free cell from tf (map -> base_link) at `stamp` (the newest transform
  /// if none that recent arrives within ~tf_timeout); updates the pose.
  /// @throws krr::IoError when there is no transform or the pose is not in a free cell.
  int observeCell(const ros::Time& stamp) {
    geometry_msgs::TransformStamped t;
    try {
      if (stamp.isZero() ||
          !tf_buffer_.canTransform(p_.map_frame, p_.base_frame, stamp,
                                   ros::Duration(p_.tf_timeout)))
        t = tf_buffer_.lookupTransform(p_.map_frame, p_.base_frame, ros::Time(0),
                                       ros::Duration(stamp.isZero() ? p_.tf_timeout : 0.0));
      else
        t = tf_buffer_.lookupTransform(p_.map_frame, p_.base_frame, stamp);
    } catch (const std::exception& e) {
      throw krr::IoError("the robot's pose: no transform " + p_.map_frame + " -> " +
                         p_.base_frame + " (is the robot's localisation running?): " + e.what());
    }
    const krr::nav::Point2 p{t.transform.translation.x, t.transform.translation.y};
    const int cell = dom_.grid->cellAt(p);
    if (cell < 0 || !dom_.grid->isFree(cell)) {
      char where[96];
      std::snprintf(where, sizeof where, "the robot's pose (%.3f, %.3f) in %s", p.x, p.y,
                    p_.map_frame.c_str());
      throw krr::IoError(std::string(where) +
                         (cell < 0 ? " is off the map" : " is in an obstacle cell"));
    }
    const auto& q = t.transform.rotation;
    std::lock_guard<std::mutex> lock(mutex_);
    pose_ = p;
    yaw_ = std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
    cell_ = cell;
    return cell;
  }

  /// @brief ~executor move_base: robot_pose from tf (silent until the robot's tf exists).
  void republishObservedPose() {
    try {
      observeCell(ros::Time(0));
    } catch (const krr::IoError& e) {
      ROS_DEBUG_THROTTLE_NAMED(10, kLog, "%s", e.what());
      return;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    pose_pub_.publish(krr_ros::poseMsg(pose_, yaw_, p_.map_frame, ros::Time::now()));
  }

  /// @brief " in ba1, ba2" for the blocking areas of a cell ("" if none or invalid).
  std::string areasOf(int cell) const {
    if (!dom_.grid->valid(cell)) return "";
    std::string names;
    for (std::size_t a = 0; a < dom_.grid->areas().size(); ++a)
      if (dom_.grid->areaMask(cell) & (1u << a))
        names += (names.empty() ? " in " : ", ") + dom_.grid->areas()[a].name;
    return names;
  }

  /// @brief Drive the robot from one cell to the next along an OMPL path (straight line if
  /// OMPL finds none in time) and record it.
  void moveAlong(int from, int to, std::vector<krr::nav::Point2>* executed) {
    std::vector<krr::nav::Point2> path;
    if (planner_) {
      try {
        path = planner_->planCellMove(*dom_.grid, from, to);
      } catch (const krr::Error& e) {
        ROS_WARN_NAMED(kLog, "OMPL: %s; driving straight from cell %d to %d", e.what(), from, to);
      }
    }
    if (path.empty()) path = {dom_.grid->cellCentre(from), dom_.grid->cellCentre(to)};
    executed->insert(executed->end(), path.begin(), path.end());
    std::lock_guard<std::mutex> lock(mutex_);
    const krr::nav::Point2 a = path.size() > 1 ? path[path.size() - 2] : pose_;
    pose_ = path.back();
    if (std::hypot(pose_.x - a.x, pose_.y - a.y) > 1e-9) yaw_ = std::atan2(pose_.y - a.y, pose_.x - a.x);
    cell_ = to;
    publishPoseLocked();
  }

  int currentCell() {
    if (executor_) return observeCell(ros::Time(0));
    std::lock_guard<std::mutex> lock(mutex_);
    return cell_;
  }

  krr::nav::Point2 pose() {
    std::lock_guard<std::mutex> lock(mutex_);
    return pose_;
  }

  double yawNow() {
    std::lock_guard<std::mutex> lock(mutex_);
    return yaw_;
  }

  void publishPose() {
    std::lock_guard<std::mutex> lock(mutex_);
    publishPoseLocked();
  }

  void publishPoseLocked() {
    const geometry_msgs::PoseStamped pose =
        krr_ros::poseMsg(pose_, yaw_, p_.map_frame, ros::Time::now());
    pose_pub_.publish(pose);
    // REP 105: odom -> base_link carries the pose (map -> odom is the identity).
    geometry_msgs::TransformStamped tf;
    tf.header = pose.header;
    tf.header.frame_id = p_.odom_frame;
    tf.child_frame_id = p_.base_frame;
    tf.transform.translation.x = pose.pose.position.x;
    tf.transform.translation.y = pose.pose.position.y;
    tf.transform.rotation = pose.pose.orientation;
    tf_->sendTransform(tf);
    nav_msgs::Odometry odom;
    odom.header = tf.header;
    odom.child_frame_id = p_.base_frame;
    odom.pose.pose = pose.pose;
    odom_pub_.publish(odom);
  }

  NavigationParams p_;
  krr::kb::NavDomain dom_;
  krr::nav::OccupancyGrid map_;
  krr::Rng rng_;
  krr::nav::Context context_;
  std::unique_ptr<krr::nav::OmplPlanner> planner_;
  std::unique_ptr<krr::kb::NavigationKnowledge> knowledge_;
  std::filesystem::file_time_type learned_stamp_{};
  ros::ServiceClient model_client_;
  // Before the servers and the timer: their threads may still read tf while the node is
  // destroyed (members are destroyed in reverse order).
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  std::mutex mutex_;  // guards cell_, pose_, yaw_ (timer thread vs action thread)
  int cell_ = -1;
  krr::nav::Point2 pose_;
  double yaw_ = 0;
  ros::Publisher map_pub_, markers_pub_, pose_pub_, plan_pub_, executed_pub_, odom_pub_;
  ros::Publisher simple_goal_pub_, sample_pub_;
  ros::Subscriber simple_goal_sub_;
  // The robot's frames, simulated executor only (not even advertised with an external one).
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> static_tf_;
  ros::Timer pose_timer_;
  NavigateServer server_;
  std::unique_ptr<MoveBaseServer> move_base_;
  std::unique_ptr<MoveBaseClient> executor_;  ///< ~executor move_base: the external server
  std::mutex drive_mutex_;             ///< one trip at a time (two action interfaces)
  std::atomic<unsigned> goal_gen_{0};  ///< goals received: a trip stops when a newer one comes
};

NavigationNode::NavigationNode(ros::NodeHandle& nh, ros::NodeHandle& pnh, Params params)
    : impl_(std::make_unique<Impl>(nh, pnh, std::move(params))) {}

NavigationNode::~NavigationNode() = default;

int NavigationNode::spin() { return impl_->spin(); }

}  // namespace krr_ros
