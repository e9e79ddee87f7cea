/**
 * @file dialog_node.h
 * @brief dialog_node: the delivery robot's dialog manager, a thin ROS driver of the core's
 * krr::dialog::DeliveryManager (the class the delivery experiments drive too).
 *
 * The user's free text (user_utterance) goes through the language front end to observations of
 * the dialog POMDP; the node publishes the belief (dialog_belief) and what the manager decides:
 * questions and the serve (robot_utterance), every decision in the manager's vocabulary
 * (~decisions), and the delivery's progress (delivery_status). Navigation legs go to the
 * `navigate` action (to the shop to pick the item up, then to the room); at the room the person
 * checks the delivery ("yes", or "no, water for Erin to the studio"), and a wrong delivery goes
 * back to the shop and is delivered again (the paper's redelivery rule).
 *
 * The dialog model is the one builder's (DialogKnowledge::buildSpec over config/dialog.yaml,
 * the knowledge base, and the trips of the navigation model of Procedure 2 from reasoner_node's
 * build_task_model, or built locally, or given P^N); its turn-limited policy comes from
 * solveDialogPolicy with the config's solver options and the shared policy cache, so the robot
 * runs the policy the experiments measure for the same knowledge. config/dialog.yaml solves to
 * the certified precision (10-40 s cold on the office models); ~solver_max_trials overrides its
 * trial budget. The first model is built before the node serves: if the cache holds its
 * configured policy, that one; otherwise the node serves at once with a provisional policy
 * solved in ~startup_max_trials trials (seconds) and solves the configured one in the
 * background, like a rebuild (~startup_max_trials 0: wait for it instead). Every installed
 * policy's bounds are published, latched, on ~policy. After a knowledge update the model is
 * rebuilt and its policy
 * solved in a background thread (one run at a time; an update during a run schedules one more
 * run after it) while the node keeps serving with the current policy; the new model replaces
 * the current one only between dialogs (when the next dialog starts, or on an idle timer). A
 * failed rebuild is logged and the current model kept.
 *
 * Restarts (issue 24): the node records in ~state_file whether a dialog is in progress (its id
 * and phase; written atomically when a dialog starts, when the robot serves and when the
 * delivery ends). A node that starts (e.g. respawned after a crash) and finds a dialog in
 * progress there tells the person on robot_utterance (kind notice, that dialog's id) that it
 * restarted and lost the dialog, and asks for the request again; dialog ids continue after it.
 *
 * Speech, the common way (both off by default): ~speech_input names a std_msgs/String topic of
 * recognised text (the speech recognisers' convention is recognizer/output), handled exactly
 * like user_utterance text; ~speech_output names a std_msgs/String topic on which everything
 * the robot says (robot_utterance's text) is republished for a text-to-speech node.
 */
#pragma once

#include <actionlib/client/simple_action_client.h>
#include <krr_msgs/KnowledgeUpdate.h>
#include <krr_msgs/NavigateAction.h>
#include <krr_msgs/RobotUtterance.h>
#include <krr_msgs/UserUtterance.h>
#include <ros/ros.h>
#include <std_msgs/String.h>

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "krr_core/dialog/delivery_manager.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/dialog/dialog_knowledge.h"
#include "krr_core/dialog/dialog_policy.h"
#include "krr_core/dialog/language.h"
#include "krr_core/kb/nav_domain.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_ros/nav_kb.h"
#include "krr_ros/params.h"

namespace krr_ros {

/// @brief The dialog node (see the file comment); started by runNode<DialogNode>.
class DialogNode {
 public:
  /// @brief Validated parameters of dialog_node (config/dialog_node.yaml documents them).
  struct Params {
    std::string dialog_config;     ///< ~dialog_config: costs, rewards, turn limit, KB files
    std::string language_config;   ///< ~language_config: the language front end's vocabulary
    std::string model_source;      ///< ~model_source: reasoner | local | reach
    std::string model_service;     ///< ~model_service: BuildTaskModel service (reasoner source)
    double model_timeout = 30;     ///< ~model_timeout: s to wait for the service
    std::vector<double> reach;     ///< ~reach_probabilities: P^N(shop, room) (reach source)
    std::vector<double> reach_back;  ///< ~reach_back: P^N(room, shop) (reach; [] = same)
    NavKbParams nav;               ///< map, grid, navigation P-log files (reasoner / local)
    std::string policy_cache;      ///< ~policy_cache: "" = $KRR_CACHE_DIR (the experiments'), none
    std::string action;            ///< ~navigation_action: the Navigate action server
    double server_wait = 10;       ///< ~server_wait: s to wait for the action server
    double leg_timeout = 600;      ///< ~navigation_timeout: s per trip before giving up
    double check_timeout = 30;     ///< ~check_timeout: s to wait for the person's check
    std::string updates_topic;     ///< ~knowledge_updates: topic that triggers a rebuild
    std::string state_file;        ///< ~state_file: dialog in progress, for a restarted node
    std::string speech_input;      ///< ~speech_input: std_msgs/String recogniser text ("": off)
    std::string speech_output;     ///< ~speech_output: std_msgs/String of what the robot says
    std::uint64_t seed = 1;        ///< ~seed (the manager is deterministic; logged)
    bool check_site = true;        ///< ~check_site: refuse to start on an inconsistent site
    long solver_max_trials = -1;   ///< ~solver_max_trials: -1 = the dialog config's (0: none)
    long startup_max_trials = 1500;  ///< ~startup_max_trials: provisional budget (0: none)

    /// @brief Reads and validates; with check_site, also the site (krr_ros/site_check.h).
    static Params read(ParamReader& r);
  };
  static constexpr const char* kLog = "dialog";

  /// @brief Build the first dialog model and solve its policy (before serving: a failure
  /// stops the node), then wire topics, the action client and the timers.
  DialogNode(ros::NodeHandle& nh, ros::NodeHandle& pnh, Params params);
  ~DialogNode();
  DialogNode(const DialogNode&) = delete;
  DialogNode& operator=(const DialogNode&) = delete;

  /// @brief Serve every callback on one thread until shutdown; then forget the dialog state
  /// (a clean shutdown is not a crash) and, during a background rebuild, end the process
  /// without waiting for the solver.
  int spin();

 private:
  using Phase = krr::dialog::DeliveryPhase;
  using NavigateClient = actionlib::SimpleActionClient<krr_msgs::NavigateAction>;
  struct Model;
  static constexpr double kInstallPeriod = 0.2;  ///< s between checks for a rebuilt model when idle

  void forgetState();
  bool rebuilding();
  krr::dialog::DeliveryManager& manager();
  bool idle();

  // model
  krr::mdp::SparseModel navigationModel();
  krr::dialog::TripTable trips();
  std::unique_ptr<Model> buildModel(bool provisional_allowed);
  bool provisionalNeeded(const krr::dialog::DialogPomdp& d, Model& m);
  void startWorker(const std::string& why);
  void publishPolicy(const Model& m);
  void logModel(const Model& m, const std::string& what, double seconds) const;
  void onKnowledgeUpdate(const krr_msgs::KnowledgeUpdate::ConstPtr& u);
  void rebuildInBackground();
  void installPending();

  // restarts
  void saveState(const std::string& phase);
  void announceRestart();
  static const char* phaseName(Phase p);

  // user utterances and the delivery
  void onUtterance(const krr_msgs::UserUtterance::ConstPtr& msg);
  void onSpeech(const std_msgs::String::ConstPtr& msg);
  void speak(const krr_msgs::RobotUtterance& u);
  void startDialog(const std::string& text);
  void dialogTurn(const std::string& text);
  void report(const krr::dialog::HearResult& h);
  void decide();
  void navigate();
  void sendGoal(unsigned id, const std::string& place);
  void onNavigationDone(unsigned id, const actionlib::SimpleClientGoalState& s,
                        const krr_msgs::NavigateResultConstPtr& r);
  void afterLeg();
  void checkAnswer(const std::string& text);
  void end(const std::string& why);
  void finish();

  // publishing
  void publishDecisions();
  void say(std::size_t a);
  void notice(const std::string& text);
  void publishBelief();
  void status(const std::string& s, const std::string& message);
  template <class F>
  void guarded(const char* what, F&& f);

  Params p_;
  krr::dialog::DialogConfig config_;
  krr::dialog::LanguageConfig language_config_;
  krr::dialog::DialogKnowledge knowledge_;
  krr::kb::NavDomain domain_;
  std::unique_ptr<krr::kb::NavigationKnowledge> nav_kb_;
  std::string cache_dir_;
  ros::ServiceClient model_client_;
  std::unique_ptr<Model> model_;  ///< the serving model (callbacks only)
  // Background rebuild: rebuild_mutex_ guards worker_running_, rerun_, pending_ and the swap
  // of model_ with pending_ (worker_ itself is started and joined in callbacks only).
  std::mutex rebuild_mutex_;
  std::thread worker_;
  bool worker_running_ = false;
  bool rerun_ = false;               ///< an update arrived during the running rebuild
  std::unique_ptr<Model> pending_;   ///< rebuilt, not yet installed
  ros::Timer install_timer_;
  unsigned dialog_id_ = 0;
  std::size_t published_ = 0;  // decisions of the current delivery already published
  ros::Time wait_start_;
  NavigateClient nav_client_;
  ros::NodeHandle timer_nh_;
  ros::Timer wait_timer_, leg_timer_, check_timer_, restart_timer_;
  std::string restart_phase_;  ///< phase of the dialog a restart lost
  ros::Publisher utterance_pub_, belief_pub_, status_pub_, decisions_pub_, speech_pub_,
      policy_pub_;
  ros::Subscriber utterance_sub_, updates_sub_, speech_sub_;
};

}  // namespace krr_ros
