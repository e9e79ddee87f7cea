// learner_node: Procedure 1 of the paper, the robot's free time.
//
// While no task is active, the node selects navigation tasks (kb::LeastKnownSelector: the route
// the knowledge base knows least), learns them with R-Max in the stochastic-blockage simulator
// (kb::FreeTimeLearner, starting from the model the knowledge base gives), and sends every
// newly learned or re-learned distribution to reasoner_node's add_knowledge service.
//
// A task is active while a goal of the navigation action is pending or active (watched on
// <navigation_action>/status) and for ~task_hold seconds after a service request or a user
// utterance (the dialog that precedes a delivery). Learning is interrupted between episodes;
// what was learned so far is extracted and sent before the node pauses.
//
// The robot's own moves: every krr_msgs/NavigationSample on ~sample_topic (navigation_node with
// ~executor move_base publishes one per executed move) is pooled with the practised samples of
// its time of day (kb::ObservedNavigation), and the area knowledge they teach is sent at most
// every ~sample_period s. The learning from real outcomes lives here, not in navigation_node, so
// that one node owns the pool of samples and the area knowledge of each time of day: two
// senders would overwrite each other's statements in the reasoner. On a real robot, set
// ~enabled false (practice in the simulator would teach the simulator's walkers): the observed
// moves are still learned.
#include "krr_ros/learner_node.h"

#include <actionlib_msgs/GoalStatusArray.h>
#include <krr_msgs/AddKnowledge.h>
#include <krr_msgs/NavigationSample.h>
#include <krr_msgs/ServiceRequest.h>
#include <krr_msgs/UserUtterance.h>
#include <ros/ros.h>
#include <std_msgs/String.h>

#include <filesystem>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"
#include "krr_core/kb/free_time_learner.h"
#include "krr_core/kb/observed_navigation.h"
#include "krr_ros/conversions.h"
#include "krr_ros/site_check.h"
#include "krr_ros/nav_kb.h"
#include "krr_ros/params.h"

namespace krr_ros {

namespace {

using Entry = krr::kb::NavigationKnowledge::LearnedEntry;

}  // namespace

LearnerParams LearnerParams::read(ParamReader& r) {
  LearnerParams p;
  p.seed = r.seed();
  p.kb = krr_ros::NavKbParams::read(r);
  p.learned_file = r.path("learned_file", "", false);
  p.knowledge_service = r.str("knowledge_service", "/reasoner/add_knowledge");
  p.service_timeout = r.number("service_timeout", 10, 0.1, 3600);
  p.navigation_action = r.str("navigation_action", "navigate");
  p.request_topic = r.str("request_topic", "service_request");
  p.utterance_topic = r.str("utterance_topic", "user_utterance");
  p.task_hold = r.number("task_hold", 30, 0, 86400);
  p.idle_delay = r.number("idle_delay", 1, 0, 86400);
  p.places = r.strings("places", {});
  // Default: the site's shop (nav_kb.h), never a name written here.
  p.start_place = r.str("start_place", p.kb.shop);
  if (p.start_place.empty()) r.refuse("start_place", "''", "must name a place of the map");
  p.enabled = r.boolean("enabled", true);
  p.rest_threshold = r.integer("rest_threshold", 5, 0, 1000000);
  p.rest_after = r.integer("rest_after", 10, 1, 1000000);
  p.rest_period = r.number("rest_period", 60, 0, 86400);
  p.sample_topic = r.str("sample_topic", "navigation_samples");
  p.sample_period = r.number("sample_period", 1, 0, 86400);
  krr::kb::FreeTimeOptions& o = p.options;
  // What extraction writes back: per blocking area (the default, as in the experiments) or
  // per (cell, move) pair.
  o.extraction = krr::kb::extractionFromString(r.str("extraction", "areas", {"areas", "pairs"}));
  o.blocking_rate = r.blockingRate("blocking_rate");
  o.max_episodes_per_task = static_cast<std::size_t>(r.integer("max_episodes_per_task", 300, 1, 1000000));
  o.convergence_episodes = static_cast<std::size_t>(r.integer("convergence_episodes", 20, 1, 1000000));
  o.max_tasks = static_cast<std::size_t>(r.integer("max_tasks", 0, 0, 1000000));
  // R-Max: the navigation task's reward (navigation.yaml planning) and learning settings
  // (rmax_learning); the parameters below only override them (learner_node.yaml sets none).
  const krr::nav::NavigationConfig nav = p.kb.loadConfig();
  o.time = r.str("time", nav.time);  // context.time of navigation.yaml unless overridden
  o.rmax = krr::nav::rmaxParamsOf(nav.planning, nav.rmax_learning, o.rmax);
  o.rmax.known_threshold = static_cast<std::uint32_t>(
      r.integer("known_threshold", nav.rmax_learning.known_threshold, 1, 1000000));
  o.rmax.rmax = r.number("rmax", nav.planning.rmax, 1e-6, 1e9);
  o.rmax.discount = r.number("discount", nav.rmax_learning.discount, 0.01, 1.0);
  o.rmax.step_cost = r.number("step_cost", nav.planning.step_cost, 0, 1e6);
  o.rmax.replan_every = static_cast<std::uint32_t>(
      r.integer("replan_every", nav.rmax_learning.replan_every, 0, 1000000));
  if (o.rmax.step_cost >= o.rmax.rmax)
    r.refuse("step_cost", std::to_string(o.rmax.step_cost),
             "must be below rmax = " + std::to_string(o.rmax.rmax));
  try {
    o.validate();
  } catch (const krr::Error& e) {
    throw krr::ConfigError("parameters of " + ros::this_node::getName() + ": " + e.what());
  }
  p.check_site = readCheckSite(r);
  r.rejectUnknown();
  // The site's files agree before anything starts (site_check.h).
  if (p.check_site) requireConsistentSite(r, {p.kb.navigation_config, "", "", {}, p.kb.site.get()});
  return p;
}

class LearnerNode::Impl {
 public:
  Impl(ros::NodeHandle& nh, ros::NodeHandle& pnh, LearnerParams params)
      : p_(std::move(params)),
        dom_(p_.kb.loadDomain()),
        knowledge_(*dom_.grid, dom_.knowledge_files),
        selector_(placesOrAll(), p_.start_place),
        rng_(krr::makeRng(p_.seed, "learner_node")),
        samples_(std::make_shared<krr::mdp::VisitCounts>(dom_.space->numStates(), 4)),
        observed_(*dom_.space) {
    observed_.share(p_.options.time, samples_);  // practice and the robot's moves: one pool
    checkParam("start_place", p_.start_place, [&] { dom_.grid->placeCell(p_.start_place); });
    for (const std::string& place : p_.places)
      checkParam("places", place, [&] { dom_.grid->placeCell(place); });
    checkParam("time", p_.options.time, [&] { dom_.simulator->timeOfDayIndex(p_.options.time); });
    if (!p_.learned_file.empty() && std::filesystem::exists(p_.learned_file)) {
      knowledge_.loadLearned(p_.learned_file);
      for (const Entry& e : knowledge_.learnedEntries()) sent_[key(e)] = e;
      sent_areas_ = knowledge_.learnedAreas();
    }
    client_ = nh.serviceClient<krr_msgs::AddKnowledge>(p_.knowledge_service);
    status_pub_ = pnh.advertise<std_msgs::String>("status", 10, true);
    if (!p_.navigation_action.empty())
      subs_.push_back(nh.subscribe(p_.navigation_action + "/status", 10,
                                   &Impl::onGoalStatus, this));
    if (!p_.request_topic.empty())
      subs_.push_back(nh.subscribe<krr_msgs::ServiceRequest>(
          p_.request_topic, 10, [this](const krr_msgs::ServiceRequestConstPtr&) {
            hold("service request");
          }));
    if (!p_.utterance_topic.empty())
      subs_.push_back(nh.subscribe<krr_msgs::UserUtterance>(
          p_.utterance_topic, 10, [this](const krr_msgs::UserUtteranceConstPtr&) {
            hold("user utterance");
          }));
    if (!p_.sample_topic.empty())
      subs_.push_back(nh.subscribe(p_.sample_topic, 1000, &Impl::onSample, this));
    ROS_INFO_NAMED(kLog, "%zu learned distribution(s) known at start; learning %s from %s at "
                   "time %s, up to %zu episodes per task, %s", sent_.size(),
                   p_.enabled ? "enabled" : "disabled", p_.start_place.c_str(),
                   p_.options.time.c_str(), p_.options.max_episodes_per_task,
                   p_.options.max_tasks ? (std::to_string(p_.options.max_tasks) + " tasks").c_str()
                                        : "until stopped");
  }

  /// @brief The free-time loop (callbacks on a spinner thread); returns 0 at shutdown.
  int spin() {
    ros::AsyncSpinner spinner(1);
    spinner.start();
    std::size_t done = 0;
    ros::Rate wait(20);
    while (ros::ok()) {
      learnObserved();
      if (ros::WallTime::now() < rest_until_) {
        setStatus("resting: fewer than " + std::to_string(p_.rest_threshold) +
                  " distribution(s) learned per task in " + std::to_string(p_.rest_after) +
                  " task(s) in a row");
        wait.sleep();
        continue;
      }
      const std::string reason = busyReason();
      const bool finished = !p_.enabled || (p_.options.max_tasks && done >= p_.options.max_tasks);
      if (finished || !reason.empty()) {
        setStatus(finished ? (p_.enabled ? "finished: " + std::to_string(done) + " task(s)"
                                         : "disabled")
                           : "paused: " + reason);
        wait.sleep();
        continue;
      }
      krr::kb::FreeTimeOptions o = p_.options;
      if (o.max_tasks) o.max_tasks -= done;
      try {
        krr::kb::FreeTimeLearner learner(dom_, knowledge_, selector_, o, samples_);
        setStatus("learning");
        const krr::kb::FreeTimeReport r = learner.run(
            rng_,
            [this] {
              return !ros::ok() || !busyReason().empty() || ros::WallTime::now() < rest_until_;
            },
            [this](const krr::kb::NavTask& t) { onTask(t); });
        done += r.tasks.size();
      } catch (const std::exception& e) {
        ROS_ERROR_NAMED(kLog, "free-time learning failed: %s; retrying in 5 s", e.what());
        setStatus(std::string("error: ") + e.what());
        ros::Duration(5).sleep();
      }
    }
    return 0;
  }

 private:
  /// @brief Run a check of a parameter's value, naming the parameter if it fails.
  template <class Check>
  static void checkParam(const std::string& name, const std::string& value, Check check) {
    try {
      check();
    } catch (const krr::Error& e) {
      throw krr::ConfigError("parameter " + ros::this_node::getName() + "/" + name + " = '" +
                             value + "': " + e.what());
    }
  }

  static std::tuple<int, int, std::string> key(const Entry& e) {
    return std::make_tuple(e.cell, e.move, e.time);
  }

  std::vector<std::string> placesOrAll() const {
    if (!p_.places.empty()) return p_.places;
    std::vector<std::string> all;
    for (const auto& pl : dom_.grid->places()) all.push_back(pl.name);
    return all;
  }

  /// @brief After each practised task: send what changed to the reasoner.
  void onTask(const krr::kb::NavTask& task) {
    if (p_.options.extraction == krr::kb::Extraction::kAreas) return sendAreas(task);
    std::vector<Entry> changed;
    for (const Entry& e : knowledge_.learnedEntries()) {
      auto it = sent_.find(key(e));
      if (it == sent_.end() || it->second.outcomes != e.outcomes ||
          it->second.denominator != e.denominator)
        changed.push_back(e);
    }
    setStatus("learned " + task.start + "->" + task.goal + ": " +
              std::to_string(changed.size()) + " new or updated distribution(s)");
    const long n = static_cast<long>(changed.size());
    unproductive_ = n < p_.rest_threshold ? unproductive_ + 1 : 0;
    if (unproductive_ >= p_.rest_after) {  // the knowledge base has what practice can teach
      unproductive_ = 0;
      rest_until_ = ros::WallTime::now() + ros::WallDuration(p_.rest_period);
    }
    if (changed.empty()) return;
    krr_msgs::AddKnowledge srv;
    srv.request.update.header.stamp = ros::Time::now();
    srv.request.update.source = ros::this_node::getName();
    srv.request.update.atoms = krr_ros::toAtoms(changed);
    if (!client_.waitForExistence(ros::Duration(p_.service_timeout)) || !client_.call(srv)) {
      ROS_WARN_NAMED(kLog, "service %s unavailable: %zu distribution(s) kept for the next "
                     "attempt", p_.knowledge_service.c_str(), changed.size());
      return;
    }
    if (!srv.response.success) {
      ROS_ERROR_NAMED(kLog, "the reasoner refused the update: %s", srv.response.message.c_str());
      return;
    }
    for (const Entry& e : changed) sent_[key(e)] = e;
    ROS_INFO_NAMED(kLog, "task %s->%s: sent %zu distribution(s); the reasoner knows %u",
                   task.start.c_str(), task.goal.c_str(), changed.size(),
                   srv.response.total_learned);
  }

  /// @brief Area extraction: send the time's area knowledge when it changed.
  void sendAreas(const krr::kb::NavTask& task) {
    // Practice teaches something while some probability moves by 0.005 or more per task (the
    // pool is the learner's samples and the observed moves of this time).
    const std::optional<krr::kb::AreaKnowledge> now = observed_.estimate(p_.options.time);
    const double moved = now ? krr::kb::largestChange(taught_, *now) : 0.0;
    if (now) taught_ = now;
    const bool changed = sendAreaKnowledge(p_.options.time, task.start + "->" + task.goal);
    setStatus("learned " + task.start + "->" + task.goal + ": area knowledge " +
              (changed ? "updated (largest change " + std::to_string(moved).substr(0, 6) + ")"
                       : "unchanged"));
    unproductive_ = moved >= 0.005 ? 0 : unproductive_ + 1;
    if (unproductive_ >= p_.rest_after) {
      unproductive_ = 0;
      rest_until_ = ros::WallTime::now() + ros::WallDuration(p_.rest_period);
    }
  }

  /**
   * @brief Send the area knowledge of `time` to the reasoner if it differs from what was sent.
   * @return whether it differed (sent, or kept for the next attempt when the service failed).
   */
  bool sendAreaKnowledge(const std::string& time, const std::string& what) {
    const auto& areas = knowledge_.learnedAreas();
    const auto it = areas.find(time);
    if (it == areas.end() || sent_areas_[time] == it->second) return false;
    krr_msgs::AddKnowledge srv;
    srv.request.update.header.stamp = ros::Time::now();
    srv.request.update.source = ros::this_node::getName();
    srv.request.update.area_time = time;
    srv.request.update.area_statements = it->second;
    if (!client_.waitForExistence(ros::Duration(p_.service_timeout)) || !client_.call(srv)) {
      ROS_WARN_NAMED(kLog, "service %s unavailable: area knowledge kept for the next attempt",
                     p_.knowledge_service.c_str());
      return true;
    }
    if (!srv.response.success) {
      ROS_ERROR_NAMED(kLog, "the reasoner refused the update: %s", srv.response.message.c_str());
      return true;
    }
    sent_areas_[time] = it->second;
    ROS_INFO_NAMED(kLog, "%s: sent area knowledge for %s", what.c_str(), time.c_str());
    return true;
  }

  /// @brief A move the robot made (navigation_node ~executor move_base): queued for the
  /// learning thread, which owns the pool and the knowledge.
  void onSample(const krr_msgs::NavigationSampleConstPtr& msg) {
    krr::kb::ObservedMove m;
    m.cell = msg->cell;
    m.move = -1;
    for (int k = 0; k < krr::nav::kNumMoves; ++k)
      if (msg->move == krr::nav::moveName(k)) m.move = k;
    m.time = msg->time.empty() ? p_.options.time : msg->time;
    try {
      m.next_cell = krr::kb::moveOutcomeFromString(msg->outcome) == krr::kb::MoveOutcome::kAborted
                        ? -1 : msg->next_cell;
    } catch (const krr::ConfigError& e) {
      ROS_WARN_NAMED(kLog, "navigation sample dropped: %s", e.what());
      return;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    observed_queue_.push_back(m);
  }

  /// @brief Pool the queued moves of the robot; at most every ~sample_period s, extract the area
  /// knowledge of each time they taught something about and send it (learning thread only).
  void learnObserved() {
    std::vector<krr::kb::ObservedMove> moves;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      moves.swap(observed_queue_);
    }
    for (const krr::kb::ObservedMove& m : moves) {
      try {
        observed_.add(m);
        observed_times_.insert(m.time);
        ++observed_count_;
      } catch (const krr::Error& e) {
        ROS_WARN_NAMED(kLog, "navigation sample (cell %d, move %d, time %s) dropped: %s", m.cell,
                       m.move, m.time.c_str(), e.what());
      }
    }
    const ros::WallTime now = ros::WallTime::now();
    if (observed_times_.empty() || now < next_observed_send_) return;
    next_observed_send_ = now + ros::WallDuration(p_.sample_period);
    for (auto t = observed_times_.begin(); t != observed_times_.end();) {
      try {
        if (!observed_.extract(knowledge_, *t)) {  // no free move yet: the noise is unknown
          ++t;
          continue;
        }
      } catch (const krr::Error& e) {
        ROS_ERROR_NAMED(kLog, "learning from the robot's moves at %s failed: %s", t->c_str(),
                        e.what());
        t = observed_times_.erase(t);
        continue;
      }
      sendAreaKnowledge(*t, std::to_string(observed_.moves(*t)) + " observed move(s) (" +
                                std::to_string(observed_count_) + " in all)");
      // Not delivered (the reasoner is down): kept, and tried again after sample_period.
      const bool delivered = sent_areas_[*t] == knowledge_.learnedAreas().at(*t);
      t = delivered ? observed_times_.erase(t) : std::next(t);
    }
  }

  void onGoalStatus(const actionlib_msgs::GoalStatusArrayConstPtr& msg) {
    bool active = false;
    for (const auto& s : msg->status_list)
      active = active || s.status == s.PENDING || s.status == s.ACTIVE ||
               s.status == s.PREEMPTING || s.status == s.RECALLING;
    std::lock_guard<std::mutex> lock(mutex_);
    if (goal_active_ && !active) idle_until_ = ros::WallTime::now() + ros::WallDuration(p_.idle_delay);
    goal_active_ = active;
  }

  void hold(const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex_);
    hold_until_ = ros::WallTime::now() + ros::WallDuration(p_.task_hold);
    hold_reason_ = what;
  }

  /// @brief Why learning must not run now ("" = free time).
  std::string busyReason() {
    std::lock_guard<std::mutex> lock(mutex_);
    const ros::WallTime now = ros::WallTime::now();
    if (goal_active_) return "navigation goal active";
    if (now < hold_until_) return hold_reason_ + " received";
    if (now < idle_until_) return "task just ended";
    return "";
  }

  void setStatus(const std::string& s) {
    if (s == status_) return;
    status_ = s;
    std_msgs::String msg;
    msg.data = s;
    status_pub_.publish(msg);
    ROS_INFO_NAMED(kLog, "%s", s.c_str());
  }

  LearnerParams p_;
  krr::kb::NavDomain dom_;
  krr::kb::NavigationKnowledge knowledge_;
  krr::kb::LeastKnownSelector selector_;
  krr::Rng rng_;
  std::map<std::tuple<int, int, std::string>, Entry> sent_;
  std::shared_ptr<krr::mdp::VisitCounts> samples_;  // every sample of ~time, pooled across
                                                    // sessions and with the observed moves
  krr::kb::ObservedNavigation observed_;            // the robot's moves (learning thread)
  std::map<std::string, std::string> sent_areas_;   // area knowledge last sent, by time
  std::optional<krr::kb::AreaKnowledge> taught_;    // area knowledge after the last task
  std::set<std::string> observed_times_;            // times with moves not yet extracted
  std::uint64_t observed_count_ = 0;
  ros::WallTime next_observed_send_;
  long unproductive_ = 0;           // tasks in a row that changed nothing (learning thread)
  ros::WallTime rest_until_;        // learning thread only
  ros::ServiceClient client_;
  ros::Publisher status_pub_;
  std::vector<ros::Subscriber> subs_;
  std::mutex mutex_;  // guards the task state below (callback thread vs learning thread)
  bool goal_active_ = false;
  ros::WallTime hold_until_, idle_until_;
  std::string hold_reason_, status_;
  std::vector<krr::kb::ObservedMove> observed_queue_;  // guarded by mutex_
};

LearnerNode::LearnerNode(ros::NodeHandle& nh, ros::NodeHandle& pnh, Params params)
    : impl_(std::make_unique<Impl>(nh, pnh, std::move(params))) {}

LearnerNode::~LearnerNode() = default;

int LearnerNode::spin() { return impl_->spin(); }

}  // namespace krr_ros
