/**
 * @file reasoner_node.h
 * @brief reasoner_node: the robot's knowledge bases as ROS services.
 *
 * Two P-log knowledge bases: the domain KB (config/office.plog: people, items, rooms, the
 * request prior) and the navigation KB (grid geometry + config/navigation.plog + what the robot
 * learned). Services: ~query_probability, ~add_knowledge, ~build_task_model; accepted updates
 * are republished on ~knowledge_updates. The knowledge files, their recovery at start and the
 * update transaction (validated completely before anything changes, journaled, a refusal
 * changes nothing) are the core's krr::kb::KnowledgeStore; this class serves it.
 *
 * Concurrency (issue 24): calls are served by ~threads spinner threads at once, so a slow
 * query never holds up the others. The committed knowledge is an immutable snapshot (a
 * krr::kb::KnowledgeState); every computation runs on its own copy of the knowledge bases
 * (kept in a pool, brought up to the snapshot's version when taken: learned deltas replayed,
 * the domain KB rebuilt), so no two calls share a reasoner. Updates are serialised and change
 * nothing until their commit, which publishes the next snapshot atomically: a query sees the
 * knowledge before an update or after it, never half of it.
 *
 * Time (issue 24): ~query_seconds covers a whole call, from its callback's start: queueing for
 * a computation slot, bringing a copy up to date, parsing, grounding, inference and, for an
 * update, its validation. The core's grounding and inference budgets are set to what is left of
 * the call's time, so they stop a long phase with a BudgetExceededError naming the statement;
 * phases that check no budget (parsing the query's text) are covered by the call's watchdog,
 * which answers "refused" at the deadline and abandons the computation (its copy is discarded
 * after it ends; an update abandoned before its commit point changes nothing).
 */
#pragma once

#include <krr_msgs/AddKnowledge.h>
#include <krr_msgs/BuildTaskModel.h>
#include <krr_msgs/QueryProbability.h>
#include <ros/ros.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "krr_core/kb/knowledge_store.h"
#include "krr_core/kb/nav_domain.h"
#include "krr_core/plog/reasoner.h"
#include "krr_ros/nav_kb.h"
#include "krr_ros/params.h"

namespace krr_ros {

/// @brief The reasoner node (see the file comment); started by runNode<ReasonerNode>.
class ReasonerNode {
 public:
  /// @brief Validated parameters of reasoner_node (config/reasoner.yaml documents them).
  struct Params {
    std::vector<std::string> domain_files;  ///< ~domain_files: domain KB, loaded in order
    std::string domain_learned_file;        ///< ~domain_learned_file: added statements
    NavKbParams nav;                        ///< navigation KB files (see nav_kb.h)
    std::string learned_file;               ///< ~learned_file: learned navigation knowledge
    /// ~discount: default discount of built models (default: navigation.yaml's
    /// planning.model_discount)
    double discount = 0.95;
    double query_seconds = 10.0;            ///< ~query_seconds: the whole budget of one call
    int threads = 4;                        ///< ~threads: calls served at once
    /// ~backend: auto (native engine inside its fragment, clingo otherwise), native or asp
    krr::plog::Backend backend = krr::plog::Backend::Auto;
    std::uint64_t seed = 1;                 ///< ~seed (the reasoner is deterministic; logged)
    bool check_site = true;                 ///< ~check_site: refuse an inconsistent site

    /// @brief Reads and validates; with check_site, also the site (krr_ros/site_check.h): the
    /// domain_files must include the dialog's knowledge.
    static Params read(ParamReader& r);
  };
  static constexpr const char* kLog = "reasoner";

  /// @brief Recover and load the knowledge files, then advertise the services.
  /// @throws krr::Error when the configured knowledge bases cannot be loaded.
  ReasonerNode(ros::NodeHandle& nh, ros::NodeHandle& pnh, Params params);
  ~ReasonerNode();
  ReasonerNode(const ReasonerNode&) = delete;
  ReasonerNode& operator=(const ReasonerNode&) = delete;

  /// @brief Serve with ~threads spinner threads until shutdown, then wait a little for
  /// abandoned computations; past that, end the process without destroying what they use.
  int spin();

 private:
  using Clock = std::chrono::steady_clock;
  struct NavDelta;
  struct Copy;
  struct Job;
  class Lease;

  void logStart(const krr::kb::StartReport& report) const;
  /// @brief Wait up to `seconds` for the computations still running (abandoned ones
  /// included); true when none is left.
  bool drain(double seconds);
  krr::plog::GroundingLimits limitsUntil(Clock::time_point deadline, const char* phase) const;
  krr::plog::Reasoner& domainOf(Lease& l);
  krr::kb::NavigationKnowledge& navOf(Lease& l);
  template <class Work>
  void runWithDeadline(const std::string& what, Work work);
  std::string refusal(const std::exception& e) const;
  std::shared_ptr<const krr::kb::KnowledgeState> snapshot();

  bool query(krr_msgs::QueryProbability::Request& req, krr_msgs::QueryProbability::Response& res);
  bool add(krr_msgs::AddKnowledge::Request& req, krr_msgs::AddKnowledge::Response& res);
  void addUnderDeadline(const krr_msgs::KnowledgeUpdate& u, krr_msgs::AddKnowledge::Response& res,
                        Job& job, Clock::time_point deadline);
  bool build(krr_msgs::BuildTaskModel::Request& req, krr_msgs::BuildTaskModel::Response& res);

  static constexpr std::size_t kMaxDeltas = 64;
  static constexpr int kGraceMs = 250;

  Params params_;
  krr::kb::NavDomain domain_;      ///< grid and state space: read-only after start
  krr::kb::KnowledgeStore store_;  ///< the knowledge files and the update transaction
  // pool_mutex_ guards committed_, deltas_ and idle_.
  std::mutex pool_mutex_;
  std::shared_ptr<const krr::kb::KnowledgeState> committed_;
  std::deque<std::shared_ptr<const NavDelta>> deltas_;
  std::vector<std::unique_ptr<Copy>> idle_;
  // Computation slots: at most max_running_ computations, abandoned ones included.
  std::mutex slots_mutex_;
  std::condition_variable slots_cv_;
  std::size_t running_ = 0;
  std::size_t max_running_ = 8;
  std::mutex update_mutex_;  ///< one update at a time (held by its computation)
  ros::Publisher updates_pub_;
  ros::ServiceServer query_srv_, add_srv_, build_srv_;
};

}  // namespace krr_ros
