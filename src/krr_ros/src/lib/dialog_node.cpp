#include "krr_ros/dialog_node.h"

#include <krr_msgs/BuildTaskModel.h>
#include <krr_msgs/DeliveryStatus.h>
#include <krr_msgs/DialogBelief.h>
#include <krr_msgs/DialogPolicy.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <system_error>
#include <utility>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resources.h"
#include "krr_core/dialog/delivery_navigation.h"
#include "krr_ros/conversions.h"
#include "krr_ros/site_check.h"

namespace krr_ros {

using krr_msgs::DeliveryStatus;
using krr_msgs::RobotUtterance;

namespace {

/// @brief The dialog config the node solves with: the file's (under the site's names), its
/// trial budget replaced by ~solver_max_trials when given.
krr::dialog::DialogConfig nodeDialogConfig(const DialogNode::Params& p) {
  krr::dialog::DialogConfig c = krr::dialog::loadDialogConfig(p.dialog_config);
  if (p.nav.site) c = p.nav.site->dialogOver(c);
  if (p.solver_max_trials >= 0) c.solver_max_trials = static_cast<std::size_t>(p.solver_max_trials);
  return c;
}

}  // namespace

/// @brief The dialog model, its policy, the language front end and the delivery manager,
/// built together (a rebuild replaces all of them between deliveries).
struct DialogNode::Model {
  std::unique_ptr<krr::dialog::DialogPomdp> pomdp;
  std::unique_ptr<krr::dialog::LanguageFrontEnd> language;
  krr::pomdp::TurnLimitedPolicy policy;
  krr::dialog::PolicyReport report;
  Eigen::VectorXd reach;  ///< P^N(shop, room) the model was built with
  std::unique_ptr<krr::dialog::DeliveryManager> manager;
  bool provisional = false;  ///< solved in ~startup_max_trials while the configured one solves
};

DialogNode::Params DialogNode::Params::read(ParamReader& r) {
  Params p;
  p.seed = r.seed();
  p.dialog_config = r.path("dialog_config", "config/dialog.yaml", true);
  p.language_config = r.path("language_config", "config/language.yaml", true);
  p.model_source = r.str("model_source", "reasoner", {"reasoner", "local", "reach"});
  p.model_service = r.str("model_service", "/reasoner/build_task_model");
  p.model_timeout = r.number("model_timeout", 30, 0.1, 3600);
  p.reach = r.numbers("reach_probabilities", {}, 0.0, 1.0);
  p.reach_back = r.numbers("reach_back", {}, 0.0, 1.0);
  if (p.model_source == "reach" && p.reach.empty())
    throw krr::ConfigError("parameter reach_probabilities: required with model_source reach "
                           "(one P^N(shop, room) per room)");
  p.nav = NavKbParams::read(r);
  // A site folder's language file is the site's (its synonyms name the site's values).
  if (p.nav.site) p.language_config = p.nav.site->language();
  p.policy_cache = r.str("policy_cache", "");
  p.action = r.str("navigation_action", "navigate");
  p.server_wait = r.number("server_wait", 10, 0, 3600);
  p.leg_timeout = r.number("navigation_timeout", 600, 0.1, 86400);
  p.check_timeout = r.number("check_timeout", 30, 0.1, 86400);
  p.updates_topic = r.str("knowledge_updates", "/reasoner/knowledge_updates");
  p.state_file = r.path("state_file", "", false);
  p.speech_input = r.str("speech_input", "");
  p.speech_output = r.str("speech_output", "");
  p.check_site = readCheckSite(r);
  p.solver_max_trials = r.integer("solver_max_trials", -1, -1, 1000000000);
  p.startup_max_trials = r.integer("startup_max_trials", 1500, 0, 1000000000);
  if (p.action.empty()) throw krr::ConfigError("parameter navigation_action: empty name");
  r.rejectUnknown();
  // The site's files agree before anything starts (site_check.h): this node's navigation,
  // dialog and language files, the rest of the site from the repository's config/.
  if (p.check_site)
    requireConsistentSite(r, {p.nav.navigation_config, p.dialog_config, p.language_config, {},
                              p.nav.site.get()});
  return p;
}

DialogNode::DialogNode(ros::NodeHandle& nh, ros::NodeHandle& pnh, Params params)
    : p_(std::move(params)),
      config_(nodeDialogConfig(p_)),
      language_config_(krr::dialog::loadLanguageConfig(p_.language_config)),
      knowledge_(config_.office_plog, config_.speech_plog),
      nav_client_(nh, p_.action, false) {
  if (p_.model_source != "reach") domain_ = p_.nav.loadDomain();
  if (p_.model_source == "local")
    nav_kb_ = std::make_unique<krr::kb::NavigationKnowledge>(*domain_.grid, domain_.knowledge_files);
  if (p_.model_source == "reasoner")
    model_client_ = nh.serviceClient<krr_msgs::BuildTaskModel>(p_.model_service);
  cache_dir_ = p_.policy_cache == "none" ? ""
               : p_.policy_cache.empty() ? krr::dialog::defaultCacheDir() : p_.policy_cache;
  {
    krr::Stopwatch clock;
    model_ = buildModel(true);  // before serving, in this thread (a failure stops the node)
    logModel(*model_, "", clock.seconds());
  }
  policy_pub_ = pnh.advertise<krr_msgs::DialogPolicy>("policy", 1, true);
  publishPolicy(*model_);
  utterance_pub_ = nh.advertise<RobotUtterance>("robot_utterance", 20);
  belief_pub_ = nh.advertise<krr_msgs::DialogBelief>("dialog_belief", 10, true);
  status_pub_ = nh.advertise<DeliveryStatus>("delivery_status", 20, true);
  decisions_pub_ = pnh.advertise<std_msgs::String>("decisions", 50);
  utterance_sub_ = nh.subscribe("user_utterance", 20, &DialogNode::onUtterance, this);
  if (!p_.speech_input.empty()) {
    speech_sub_ = nh.subscribe(p_.speech_input, 20, &DialogNode::onSpeech, this);
    ROS_INFO_NAMED(kLog, "listening to recognised speech on %s", speech_sub_.getTopic().c_str());
  }
  if (!p_.speech_output.empty()) {
    speech_pub_ = nh.advertise<std_msgs::String>(p_.speech_output, 20);
    ROS_INFO_NAMED(kLog, "speaking on %s", speech_pub_.getTopic().c_str());
  }
  if (!p_.updates_topic.empty())
    updates_sub_ = nh.subscribe(p_.updates_topic, 10, &DialogNode::onKnowledgeUpdate, this);
  timer_nh_ = pnh;
  if (model_->provisional) {
    std::lock_guard<std::mutex> lock(rebuild_mutex_);
    startWorker("solving the configured policy in the background (serving with the provisional "
                "policy meanwhile)");
  }
  announceRestart();
  install_timer_ = nh.createTimer(ros::Duration(kInstallPeriod), [this](const ros::TimerEvent&) {
    if (idle()) installPending();
  });
}

DialogNode::~DialogNode() {
  if (worker_.joinable()) worker_.join();
}

/// @brief A clean shutdown is not a crash: the next start is a new session, with nobody
/// to tell, so the state file is removed.
void DialogNode::forgetState() {
  std::error_code ec;
  if (!p_.state_file.empty()) std::filesystem::remove(p_.state_file, ec);
}

/// @brief True while a background rebuild is running (or about to run again).
bool DialogNode::rebuilding() {
  std::lock_guard<std::mutex> lock(rebuild_mutex_);
  return worker_running_;
}

krr::dialog::DeliveryManager& DialogNode::manager() { return *model_->manager; }
/// @brief No dialog or delivery in progress: the model may be replaced.
bool DialogNode::idle() { return manager().phase() == Phase::kIdle || manager().phase() == Phase::kDone; }

// --- model --------------------------------------------------------------------------------
/// @brief Procedure 2's navigation model for the configured time of day.
krr::mdp::SparseModel DialogNode::navigationModel() {
  if (!model_client_.waitForExistence(ros::Duration(p_.model_timeout)))
    throw krr::IoError("service " + p_.model_service + " is not available (is reasoner_node "
                       "running?)");
  krr_msgs::BuildTaskModel srv;
  srv.request.task = "navigation";
  srv.request.times = {config_.time};
  if (!model_client_.call(srv)) throw krr::IoError("call to " + p_.model_service + " failed");
  if (!srv.response.success)
    throw krr::Error("the reasoner could not build the navigation model: " +
                     srv.response.message);
  return navigationModelFromMsg(srv.response, *domain_.space);
}

/// @brief Every delivery trip's P^N and cost, from the configured source.
krr::dialog::TripTable DialogNode::trips() {
  const auto& rooms = knowledge_.base().rooms;
  if (p_.model_source == "reach")
    return krr::dialog::TripTable::fromReach(rooms, p_.reach, p_.reach_back, config_.failure_penalty);
  if (nav_kb_)
    return krr::dialog::deliveryNavigationFromKnowledge(domain_, *nav_kb_, config_, rooms)->trips();
  const krr::dialog::DeliveryNavigation nav(
      *domain_.space, navigationModel(),
      krr::dialog::DeliveryNavigationOptions::fromConfig(
          config_, rooms, static_cast<std::size_t>(domain_.domain.step_limit)));
  return nav.trips();
}

/// @brief Build the dialog model from the knowledge base and get its policy (solved, or the
/// experiments' cached one for the same model). With provisional_allowed (the start), a
/// configured policy that is not cached and costs more than ~startup_max_trials is replaced
/// by a provisional one of that budget. Touches only state no callback uses (knowledge_,
/// domain_, nav_kb_, model_client_, read-only config), so it runs in the background worker
/// too (one build at a time: the constructor's, then the worker's).
std::unique_ptr<DialogNode::Model> DialogNode::buildModel(bool provisional_allowed) {
  auto m = std::make_unique<Model>();
  const krr::dialog::TripTable t = trips();
  m->reach = t.reachFromShop();
  m->pomdp = std::make_unique<krr::dialog::DialogPomdp>(knowledge_.buildSpec(t, config_));
  m->language = std::make_unique<krr::dialog::LanguageFrontEnd>(*m->pomdp, language_config_,
                                                                p_.language_config);
  if (provisional_allowed && provisionalNeeded(*m->pomdp, *m)) {
    krr::dialog::DialogConfig quick = config_;
    quick.solver_max_trials = static_cast<std::size_t>(p_.startup_max_trials);
    m->policy = krr::dialog::solveDialogPolicy(*m->pomdp, quick, cache_dir_, &m->report);
    m->provisional = true;
  } else if (m->report.from_cache) {
    // provisionalNeeded loaded the configured policy from the cache
  } else {
    m->policy = krr::dialog::solveDialogPolicy(*m->pomdp, config_, cache_dir_, &m->report);
  }
  m->manager = std::make_unique<krr::dialog::DeliveryManager>(*m->pomdp, m->policy,
                                                              m->language.get(), config_);
  return m;
}

/// @brief Whether the start needs a provisional policy: a provisional budget is set, the
/// configured budget is larger (0: none), and the cache does not hold the configured policy
/// (if it does, it is loaded into m).
bool DialogNode::provisionalNeeded(const krr::dialog::DialogPomdp& d, Model& m) {
  const auto startup = static_cast<std::size_t>(p_.startup_max_trials);
  if (startup == 0 || (config_.solver_max_trials != 0 && config_.solver_max_trials <= startup))
    return false;
  if (auto cached = krr::dialog::cachedDialogPolicy(d, config_, cache_dir_, &m.report)) {
    m.policy = std::move(*cached);
    return false;
  }
  return true;
}

/// @brief The served policy's bounds, latched on ~policy.
void DialogNode::publishPolicy(const Model& m) {
  krr_msgs::DialogPolicy msg;
  msg.header.stamp = ros::Time::now();
  const krr::dialog::PolicyReport& rep = m.report;
  msg.status = m.provisional    ? krr_msgs::DialogPolicy::PROVISIONAL
               : rep.converged ? krr_msgs::DialogPolicy::CERTIFIED
                               : krr_msgs::DialogPolicy::UNCERTIFIED;
  msg.lower = rep.bounds.lower;
  msg.upper = rep.bounds.upper;
  msg.gap = rep.bounds.gap();
  msg.precision = config_.solver_precision;
  msg.trials = rep.bounds.trials;
  msg.vectors = m.policy.size();
  msg.from_cache = rep.from_cache;
  msg.cache_file = rep.file;
  policy_pub_.publish(msg);
}

/// @brief Log a model, its policy and its bounds at the prior; `what` prefixes the line.
void DialogNode::logModel(const Model& m, const std::string& what, double seconds) const {
  std::string reach;
  for (Eigen::Index r = 0; r < m.reach.size(); ++r)
    reach += (r ? ", " : "") + m.pomdp->spec().rooms[static_cast<std::size_t>(r)] + " " +
             std::to_string(m.reach(r)).substr(0, 5);
  const krr::dialog::PolicyReport& rep = m.report;
  ROS_INFO_NAMED(kLog, "%sdialog model (%s): %zu requests, p_general %.3f, p_yesno %.3f, "
                 "P^N(shop, room): %s; %spolicy %s: bounds [%.2f, %.2f] at the prior (gap %.2f, "
                 "%zu trials), %zu vectors; built in %.2f s", what.c_str(),
                 p_.model_source.c_str(), m.pomdp->numRequests(), m.pomdp->spec().pGeneral,
                 m.pomdp->spec().pYesNo, reach.c_str(), m.provisional ? "provisional " : "",
                 rep.from_cache ? "cached" : "solved", rep.bounds.lower, rep.bounds.upper,
                 rep.bounds.gap(), rep.bounds.trials, m.policy.size(), seconds);
  if (m.provisional)
    ROS_INFO_NAMED(kLog, "the configured policy is not in the cache: serving with a provisional "
                   "policy (%ld trials) until it is solved to the precision %.2f",
                   p_.startup_max_trials, config_.solver_precision);
  else if (!rep.converged)
    ROS_WARN_NAMED(kLog, "the dialog policy is not certified to the configured precision %.2f "
                   "(gap %.2f at the prior)", config_.solver_precision, rep.bounds.gap());
}

/// @brief A knowledge update: rebuild in the background (or once more after the running
/// rebuild); the current model keeps serving until the new one is installed.
void DialogNode::onKnowledgeUpdate(const krr_msgs::KnowledgeUpdate::ConstPtr& u) {
  std::lock_guard<std::mutex> lock(rebuild_mutex_);
  if (worker_running_) {
    rerun_ = true;
    ROS_INFO_NAMED(kLog, "knowledge update from '%s': a background rebuild is running, another "
                   "one will follow it", u->source.c_str());
    return;
  }
  startWorker("knowledge update from '" + u->source + "': background rebuild started (building "
              "the dialog model and solving its policy; serving with the current policy "
              "meanwhile)");
}

/// @brief Start the background rebuild (rebuild_mutex_ held, no run in progress).
void DialogNode::startWorker(const std::string& why) {
  if (worker_.joinable()) worker_.join();  // its run has ended (worker_running_ is false)
  ROS_INFO_NAMED(kLog, "%s", why.c_str());
  try {
    worker_ = std::thread(&DialogNode::rebuildInBackground, this);
    worker_running_ = true;
  } catch (const std::system_error& e) {
    ROS_ERROR_NAMED(kLog, "cannot start the background rebuild, keeping the current dialog "
                    "model: %s", e.what());
  }
}

/// @brief The worker thread: build + solve, hand the model over (pending_), again while
/// updates arrived during a run. Every exception stops at this boundary: the current model
/// (and any model already pending) stays.
void DialogNode::rebuildInBackground() {
  for (;;) {
    try {
      krr::Stopwatch clock;
      std::unique_ptr<Model> m = buildModel(false);
      logModel(*m, "background rebuild done, installed when no dialog is in progress: ",
               clock.seconds());
      std::lock_guard<std::mutex> lock(rebuild_mutex_);
      pending_ = std::move(m);
    } catch (const std::exception& e) {
      ROS_ERROR_NAMED(kLog, "background rebuild failed, keeping the current dialog model: %s",
                      e.what());
    } catch (...) {
      ROS_ERROR_NAMED(kLog, "background rebuild failed (unknown exception), keeping the current "
                      "dialog model");
    }
    std::lock_guard<std::mutex> lock(rebuild_mutex_);
    if (!rerun_) {
      worker_running_ = false;
      return;
    }
    rerun_ = false;
    ROS_INFO_NAMED(kLog, "background rebuild started again (knowledge updated during the "
                   "last run)");
  }
}

/// @brief Swap in the model the worker finished, if any. Called from callbacks only (one
/// spinner thread) and only between dialogs, so no dialog sees its model change.
void DialogNode::installPending() {
  std::unique_ptr<Model> old;
  {
    std::lock_guard<std::mutex> lock(rebuild_mutex_);
    if (!pending_) return;
    old = std::move(model_);
    model_ = std::move(pending_);
  }
  const krr::dialog::PolicyReport& rep = model_->report;
  ROS_INFO_NAMED(kLog, "new dialog policy installed (%s, %s): bounds [%.2f, %.2f] at the prior "
                 "(gap %.2f, %zu trials), %zu vectors", rep.from_cache ? "cached" : "solved",
                 rep.converged ? "certified" : "not certified", rep.bounds.lower,
                 rep.bounds.upper, rep.bounds.gap(), rep.bounds.trials, model_->policy.size());
  publishPolicy(*model_);
}

// --- restarts -----------------------------------------------------------------------------
/// @brief Record whether a dialog is in progress ("idle" or its phase), atomically. A
/// failure is logged: it only costs the restart notice.
void DialogNode::saveState(const std::string& phase) {
  if (p_.state_file.empty()) return;
  try {
    ensureParentDirectory(p_.state_file);
    krr::writeFileAtomic(p_.state_file, "krr-dialog-state 1\ndialog " +
                                            std::to_string(dialog_id_) + "\nphase " + phase +
                                            "\n");
  } catch (const std::exception& e) {
    ROS_WARN_NAMED(kLog, "cannot record the dialog state in %s: %s", p_.state_file.c_str(),
                   e.what());
  }
}

/// @brief At start: a dialog in progress in ~state_file means the node restarted during it.
/// Dialog ids continue after it; the person is told once someone listens on robot_utterance
/// (at most 10 s after start), then the state is idle.
void DialogNode::announceRestart() {
  if (p_.state_file.empty() || !std::filesystem::exists(p_.state_file)) return;
  std::string phase;
  unsigned id = 0;
  try {
    std::istringstream in(krr::readFile(p_.state_file));
    std::string magic, key;
    int version = 0;
    if (!(in >> magic >> version) || magic != "krr-dialog-state" || version != 1)
      throw krr::ParseError({p_.state_file, 1, 1}, "not a dialog state file");
    while (in >> key) {
      if (key == "dialog") in >> id;
      else if (key == "phase") in >> phase;
      else throw krr::ParseError({p_.state_file, 1, 1}, "unknown field '" + key + "'");
    }
  } catch (const std::exception& e) {
    ROS_WARN_NAMED(kLog, "ignoring the dialog state file: %s", e.what());
    return;
  }
  if (phase.empty() || phase == "idle") return;
  dialog_id_ = id;  // ids continue after the lost dialog
  ROS_WARN_NAMED(kLog, "restarted during dialog %u (%s): telling the person", id, phase.c_str());
  restart_phase_ = phase;
  const ros::Time started = ros::Time::now();
  restart_timer_ = timer_nh_.createTimer(ros::Duration(0.1), [this, id, started](const ros::TimerEvent&) {
    const bool listened = utterance_pub_.getNumSubscribers() > 0;
    if (!listened && (ros::Time::now() - started).toSec() < 10.0) return;
    restart_timer_.stop();
    if (listened) ros::Duration(0.3).sleep();  // the subscriber's connection completes
    RobotUtterance u;
    u.header.stamp = ros::Time::now();
    u.dialog_id = id;
    u.turn = 0;
    u.kind = RobotUtterance::NOTICE;
    u.text = "Sorry, I had to restart and lost our conversation (dialog " + std::to_string(id) +
             ", " + restart_phase_ + "). Please tell me again what I can deliver for you.";
    speak(u);
    ROS_WARN_NAMED(kLog, "told the person of dialog %u that the dialog node restarted", id);
    saveState("idle");
  });
}

/// @brief The phase written to ~state_file while a delivery is in progress.
const char* DialogNode::phaseName(Phase p) {
  switch (p) {
    case Phase::kDialog: return "asking";
    case Phase::kNavigating: return "delivering";
    case Phase::kAwaitCheck: return "awaiting-check";
    default: return "idle";
  }
}

// --- user utterances ----------------------------------------------------------------------
void DialogNode::onUtterance(const krr_msgs::UserUtterance::ConstPtr& msg) {
  try {
    if (msg->dialog_id != 0 && msg->dialog_id != dialog_id_) {
      notice("That answer is for dialog " + std::to_string(msg->dialog_id) +
             ", the current dialog is " + std::to_string(dialog_id_) + ": ignored.");
      return;
    }
    ROS_INFO_NAMED(kLog, "user: %s", msg->text.c_str());
    switch (manager().phase()) {
      case Phase::kIdle:
      case Phase::kDone: startDialog(msg->text); break;
      case Phase::kDialog: dialogTurn(msg->text); break;
      case Phase::kNavigating: notice("I am on my way with the delivery, please wait."); break;
      case Phase::kAwaitCheck: checkAnswer(msg->text); break;
    }
  } catch (const std::exception& e) {
    ROS_ERROR_NAMED(kLog, "utterance '%s': %s", msg->text.c_str(), e.what());
    notice(std::string("Sorry, something went wrong: ") + e.what());
    if (model_ && manager().phase() != Phase::kIdle && manager().phase() != Phase::kDone)
      end(std::string("error: ") + e.what());
  }
}

/// @brief Recognised speech: the same path as typed text (no dialog id: the current dialog).
void DialogNode::onSpeech(const std_msgs::String::ConstPtr& msg) {
  auto u = boost::make_shared<krr_msgs::UserUtterance>();
  u->header.stamp = ros::Time::now();
  u->text = msg->data;
  onUtterance(u);
}

/// @brief Everything the robot says goes out here: robot_utterance, and ~speech_output.
void DialogNode::speak(const RobotUtterance& u) {
  utterance_pub_.publish(u);
  if (speech_pub_) {
    std_msgs::String t;
    t.data = u.text;
    speech_pub_.publish(t);
  }
}

void DialogNode::startDialog(const std::string& text) {
  installPending();  // a model rebuilt since the last dialog
  manager().start();
  const krr::dialog::HearResult h = manager().hear(text);
  report(h);
  if (!h.understood()) {
    manager().reset();
    notice("What can I deliver for you? (for example: " +
           krr::dialog::exampleRequest(model_->pomdp->spec()) + ")");
    return;
  }
  ++dialog_id_;
  published_ = 0;
  ROS_INFO_NAMED(kLog, "dialog %u started", dialog_id_);
  saveState(phaseName(Phase::kDialog));
  publishBelief();
  decide();
}

void DialogNode::dialogTurn(const std::string& text) {
  const krr::dialog::HearResult h = manager().hear(text);
  report(h);
  publishBelief();
  decide();  // nothing understood: the manager asks the same question again
}

/// @brief Unknown words and ignored content: logged and said back, never fatal.
void DialogNode::report(const krr::dialog::HearResult& h) {
  if (!h.unknownWords.empty()) {
    std::string words;
    for (const auto& w : h.unknownWords) words += (words.empty() ? "'" : ", '") + w + "'";
    ROS_WARN_NAMED(kLog, "unknown word(s) in '%s': %s", h.text.c_str(), words.c_str());
    notice("I did not understand " + words + ".");
  }
  for (const auto& n : h.notes) {
    ROS_INFO_NAMED(kLog, "%s", n.c_str());
    notice(n);
  }
}

/// @brief The manager's next action: a question, or the serve and the first leg.
void DialogNode::decide() {
  const std::size_t a = manager().decide();
  publishDecisions();
  say(a);
  if (model_->pomdp->isQuestion(a)) return;
  const krr::dialog::DeliveryRecord& r = manager().record();
  const auto req = manager().requestNames(r.served);
  ROS_INFO_NAMED(kLog, "dialog %u: serving <%s, %s, %s> after %d question(s), QA cost %.1f, "
                 "P = %.3f (most likely %.3f), entropy %.3f nats%s", dialog_id_, req[0].c_str(),
                 req[1].c_str(), req[2].c_str(), r.turns, r.qa_cost, r.served_probability,
                 r.max_probability, r.entropy, r.forced ? " (turn limit)" : "");
  status(DeliveryStatus::SERVING, "picking up a " + req[0] + " at the " + config_.shop);
  saveState(phaseName(Phase::kNavigating));
  navigate();
}

// --- delivery -----------------------------------------------------------------------------
/// @brief Start the manager's current leg. The goal is sent from a timer, never from inside
/// the action client's own callbacks (actionlib mis-tracks a goal sent from the previous
/// goal's done callback), and only once the server is up (waiting at most ~server_wait).
void DialogNode::navigate() {
  const unsigned id = dialog_id_;
  wait_start_ = ros::Time::now();
  wait_timer_ = timer_nh_.createTimer(ros::Duration(0.05), [this, id](const ros::TimerEvent&) {
    guarded("navigation start", [&] {
      if (id != dialog_id_ || manager().phase() != Phase::kNavigating) return wait_timer_.stop();
      if (nav_client_.isServerConnected()) {
        wait_timer_.stop();
        sendGoal(id, manager().leg().place);
      } else if ((ros::Time::now() - wait_start_).toSec() > p_.server_wait) {
        wait_timer_.stop();
        end("navigation action server '" + p_.action + "' is not available (is "
            "navigation_node running?)");
      }
    });
  });
}

void DialogNode::sendGoal(unsigned id, const std::string& place) {
  krr_msgs::NavigateGoal goal;
  goal.place = place;
  goal.time = config_.time;
  ROS_INFO_NAMED(kLog, "dialog %u: navigating to %s", id, place.c_str());
  nav_client_.sendGoal(goal, [this, id](const actionlib::SimpleClientGoalState& s,
                                        const krr_msgs::NavigateResultConstPtr& r) {
    guarded("navigation result", [&] { onNavigationDone(id, s, r); });
  });
  leg_timer_ = timer_nh_.createTimer(ros::Duration(p_.leg_timeout), [this, id, place](const ros::TimerEvent&) {
    guarded("navigation timeout", [&] {
      if (id != dialog_id_ || manager().phase() != Phase::kNavigating) return;
      nav_client_.cancelGoal();
      manager().legDone(false, 0, "took longer than " + std::to_string(p_.leg_timeout) + " s");
      afterLeg();
    });
  }, true);
}

void DialogNode::onNavigationDone(unsigned id, const actionlib::SimpleClientGoalState& s,
                      const krr_msgs::NavigateResultConstPtr& r) {
  if (id != dialog_id_ || manager().phase() != Phase::kNavigating) return;
  leg_timer_.stop();
  const bool ok = s == actionlib::SimpleClientGoalState::SUCCEEDED && r && r->success;
  std::string why;
  if (!ok)
    why = (r ? r->outcome : std::string("no result")) + ": " +
          (r && !r->failure_reason.empty() ? r->failure_reason : s.toString());
  manager().legDone(ok, r ? r->steps : 0, why);
  afterLeg();
}

/// @brief After a leg: the next leg, the check at the room, or the end.
void DialogNode::afterLeg() {
  publishDecisions();
  const krr::dialog::DeliveryRecord& r = manager().record();
  const auto req = manager().requestNames(r.delivering);
  switch (manager().phase()) {
    case Phase::kNavigating:
      if (manager().leg().kind == krr::dialog::Leg::Kind::kToRoom)
        status(DeliveryStatus::TO_ROOM, "bringing a " + req[0] + " for " + req[2] + " to " + req[1]);
      navigate();
      return;
    case Phase::kAwaitCheck: {
      status(DeliveryStatus::ARRIVED, "at " + req[1]);
      notice("Here is a " + req[0] + " for " + req[2] + " in " + req[1] +
             ". Is that right? (yes / no, a <item> for <person> to <room>)");
      const unsigned id = dialog_id_;
      check_timer_ = timer_nh_.createTimer(ros::Duration(p_.check_timeout), [this, id](const ros::TimerEvent&) {
        guarded("check timeout", [&] {
          if (id != dialog_id_ || manager().phase() != Phase::kAwaitCheck) return;
          manager().checkTimedOut();
          afterLeg();
        });
      }, true);
      return;
    }
    case Phase::kDone:
      finish();
      return;
    default:
      return;
  }
}

/// @brief The person's check at the room: yes, or the right request (what differs).
void DialogNode::checkAnswer(const std::string& text) {
  krr::dialog::HearResult h;
  h.text = text;
  h.unknownWords = model_->language->parse(text).unknownWords;
  report(h);
  std::string reply;
  const krr::dialog::CheckResult c = manager().check(text, &reply);
  publishDecisions();
  if (c == krr::dialog::CheckResult::kUnclear) {
    notice(reply);
    return;
  }
  check_timer_.stop();
  if (c == krr::dialog::CheckResult::kRedelivering) {
    const auto req = manager().requestNames(manager().record().delivering);
    ROS_INFO_NAMED(kLog, "dialog %u: wrong delivery, redelivering <%s, %s, %s>", dialog_id_,
                   req[0].c_str(), req[1].c_str(), req[2].c_str());
    status(DeliveryStatus::RETURNING, "wrong delivery: back to the " + config_.shop + " for a " + req[0]);
    navigate();
    return;
  }
  finish();
}

/// @brief End the delivery as failed (errors, missing servers).
void DialogNode::end(const std::string& why) {
  manager().fail(why);
  publishDecisions();
  finish();
}

/// @brief The delivery ended (the manager says how): stop timers, report.
void DialogNode::finish() {
  check_timer_.stop();
  leg_timer_.stop();
  wait_timer_.stop();
  const krr::dialog::DeliveryRecord& r = manager().record();
  const std::string outcome = krr::dialog::toString(r.outcome);
  saveState("idle");
  status(outcome, r.message);
  if (r.outcome == krr::dialog::DeliveryOutcome::kFulfilled)
    ROS_INFO_NAMED(kLog, "dialog %u: delivery %s: %s", dialog_id_, outcome.c_str(), r.message.c_str());
  else
    ROS_WARN_NAMED(kLog, "dialog %u: delivery %s: %s", dialog_id_, outcome.c_str(), r.message.c_str());
  notice(r.outcome == krr::dialog::DeliveryOutcome::kFulfilled ? "Enjoy! What else can I deliver?"
                                                                : "Delivery " + outcome + ": " + r.message);
}

// --- publishing ---------------------------------------------------------------------------
/// @brief The manager's decisions not yet published, one message each.
void DialogNode::publishDecisions() {
  const auto& d = manager().decisions();
  for (; published_ < d.size(); ++published_) {
    std_msgs::String m;
    m.data = d[published_];
    decisions_pub_.publish(m);
    ROS_INFO_NAMED(kLog, "dialog %u decision: %s", dialog_id_, m.data.c_str());
  }
}

void DialogNode::say(std::size_t a) {
  const krr::dialog::DialogPomdp& d = *model_->pomdp;
  RobotUtterance u;
  u.header.stamp = ros::Time::now();
  u.dialog_id = dialog_id_;
  u.turn = static_cast<std::uint32_t>(manager().session().turns());
  u.text = krr::dialog::robotUtterance(d, a);
  const auto& s = d.spec();
  switch (d.actionKind(a)) {
    case krr::dialog::DialogActionKind::kAskItem: u.kind = RobotUtterance::ASK_ITEM; break;
    case krr::dialog::DialogActionKind::kAskRoom: u.kind = RobotUtterance::ASK_ROOM; break;
    case krr::dialog::DialogActionKind::kAskPerson: u.kind = RobotUtterance::ASK_PERSON; break;
    case krr::dialog::DialogActionKind::kConfirmItem:
      u.kind = RobotUtterance::CONFIRM_ITEM;
      u.value = s.items[a - d.confirmItem(0)];
      break;
    case krr::dialog::DialogActionKind::kConfirmRoom:
      u.kind = RobotUtterance::CONFIRM_ROOM;
      u.value = s.rooms[a - d.confirmRoom(0)];
      break;
    case krr::dialog::DialogActionKind::kConfirmPerson:
      u.kind = RobotUtterance::CONFIRM_PERSON;
      u.value = s.persons[a - d.confirmPerson(0)];
      break;
    case krr::dialog::DialogActionKind::kServe: {
      const auto p = d.requestParts(d.requestOfServe(a));
      u.kind = RobotUtterance::SERVE;
      u.value = s.items[p[0]] + "," + s.rooms[p[1]] + "," + s.persons[p[2]];
      u.request.header.stamp = u.header.stamp;
      u.request.item = s.items[p[0]];
      u.request.room = s.rooms[p[1]];
      u.request.person = s.persons[p[2]];
      break;
    }
  }
  ROS_INFO_NAMED(kLog, "robot (turn %u): %s", u.turn, u.text.c_str());
  speak(u);
}

void DialogNode::notice(const std::string& text) {
  RobotUtterance u;
  u.header.stamp = ros::Time::now();
  u.dialog_id = dialog_id_;
  u.turn = model_ ? static_cast<std::uint32_t>(manager().session().turns()) : 0;
  u.kind = RobotUtterance::NOTICE;
  u.text = text;
  speak(u);
}

void DialogNode::publishBelief() {
  const krr::dialog::DialogPomdp& d = *model_->pomdp;
  const krr::dialog::BeliefSummary b = manager().session().summary();
  krr_msgs::DialogBelief m;
  m.header.stamp = ros::Time::now();
  m.dialog_id = dialog_id_;
  m.turn = static_cast<std::uint32_t>(manager().session().turns());
  m.items = d.spec().items;
  m.rooms = d.spec().rooms;
  m.persons = d.spec().persons;
  m.item_probabilities.assign(b.items.data(), b.items.data() + b.items.size());
  m.room_probabilities.assign(b.rooms.data(), b.rooms.data() + b.rooms.size());
  m.person_probabilities.assign(b.persons.data(), b.persons.data() + b.persons.size());
  m.entropy = krr::pomdp::entropy(manager().session().belief(), krr::pomdp::EntropyUnit::kBits);
  const auto p = d.requestParts(b.mostLikely);
  m.most_likely.header.stamp = m.header.stamp;
  m.most_likely.item = d.spec().items[p[0]];
  m.most_likely.room = d.spec().rooms[p[1]];
  m.most_likely.person = d.spec().persons[p[2]];
  m.most_likely_probability = b.mostLikelyProbability;
  belief_pub_.publish(m);
}

void DialogNode::status(const std::string& s, const std::string& message) {
  const krr::dialog::DeliveryRecord& r = manager().record();
  DeliveryStatus m;
  m.header.stamp = ros::Time::now();
  m.dialog_id = dialog_id_;
  m.status = s;
  const auto req = manager().requestNames(r.delivering);
  m.request.header.stamp = m.header.stamp;
  m.request.item = req[0];
  m.request.room = req[1];
  m.request.person = req[2];
  m.attempt = static_cast<std::uint32_t>(r.attempts);
  m.turns = static_cast<std::uint32_t>(r.turns);
  m.qa_cost = r.qa_cost;
  m.entropy = r.entropy / std::log(2.0);  // the message carries bits
  m.forced = r.forced;
  m.message = message;
  status_pub_.publish(m);
}

/// @brief Run a callback body; an exception fails the delivery instead of killing the node.
template <class F>
void DialogNode::guarded(const char* what, F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    ROS_ERROR_NAMED(kLog, "%s: %s", what, e.what());
    const Phase ph = manager().phase();
    if (ph == Phase::kNavigating || ph == Phase::kAwaitCheck) end(std::string(what) + ": " + e.what());
  }
}

int DialogNode::spin() {
  ROS_INFO_NAMED(kLog, "ready: talk to me on user_utterance");
  ros::spin();  // one thread: every callback; a background rebuild needs none of them
  forgetState();
  if (rebuilding()) {
    // The solve cannot be interrupted; joining it could delay shutdown by up to the solver's
    // timeout. Nothing half-written stays behind: cache files are written atomically. (rosconsole
    // is shut down with ros::spin's return, hence stderr.)
    std::fprintf(stderr, "[ WARN] dialog_node: shutting down during a background rebuild: the "
                 "rebuild is abandoned\n");
    std::fflush(stdout);
    std::fflush(stderr);
    std::_Exit(0);
  }
  return 0;
}

}  // namespace krr_ros
