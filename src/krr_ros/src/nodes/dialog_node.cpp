// dialog_node: the POMDP dialog manager of the delivery robot.
//
// The user's free text (user_utterance) goes through the language front end
// (krr_core/dialog/language.h) to observations of the dialog POMDP; the node tracks the exact
// belief over the <item, room, person> requests, publishes it (dialog_belief) and asks what the
// point-based policy says (robot_utterance) until the policy serves or the turn limit forces the
// most likely request. The delivery is handed to navigation through the `navigate` action: to the
// shop to pick the item up, then to the room; at the room the person checks it ("yes", or "no,
// a soda for john to room5"); a wrong delivery goes back to the shop and is delivered again (the
// paper's redelivery rule). Progress and outcome go out on delivery_status.
//
// The dialog model is built from the knowledge base (krr_core/dialog/dialog_knowledge.h): prior
// and speech model by P-log reasoning, T^D by the paper's delivery equation over P^N of the
// navigation model of Procedure 2 (from reasoner_node's build_task_model, or built locally), or,
// with ~model_source reach, over reach probabilities given as parameters. After a knowledge
// update from the reasoner the model and policy are rebuilt before the next dialog.
#include <actionlib/client/simple_action_client.h>
#include <krr_msgs/BuildTaskModel.h>
#include <krr_msgs/DeliveryStatus.h>
#include <krr_msgs/DialogBelief.h>
#include <krr_msgs/KnowledgeUpdate.h>
#include <krr_msgs/NavigateAction.h>
#include <krr_msgs/RobotUtterance.h>
#include <krr_msgs/UserUtterance.h>
#include <ros/ros.h>

#include <array>
#include <filesystem>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/resources.h"
#include "krr_core/dialog/delivery_navigation.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/dialog/dialog_knowledge.h"
#include "krr_core/dialog/dialog_session.h"
#include "krr_core/dialog/language.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/dialog/delivery_experiment.h"
#include "krr_core/pomdp/point_based_solver.h"
#include "krr_ros/conversions.h"
#include "krr_ros/nav_kb.h"
#include "krr_ros/params.h"

namespace {

const char* const kLog = "dialog";
using NavigateClient = actionlib::SimpleActionClient<krr_msgs::NavigateAction>;
using krr_msgs::DeliveryStatus;
using krr_msgs::RobotUtterance;

/// @brief Validated parameters of dialog_node.
struct DialogParams {
  std::string dialog_config;     ///< ~dialog_config: costs, rewards, turn limit, KB files
  std::string language_config;   ///< ~language_config: the language front end's vocabulary
  std::string model_source;      ///< ~model_source: reasoner | local | reach
  std::string model_service;     ///< ~model_service: BuildTaskModel service (reasoner source)
  double model_timeout = 30;     ///< ~model_timeout: s to wait for the service
  std::vector<double> reach;     ///< ~reach_probabilities: P^N(shop, room) (reach source)
  std::vector<double> reach_back;  ///< ~reach_back: P^N(room, shop) (reach; [] = same)
  krr_ros::NavKbParams nav;      ///< map, grid, navigation P-log files (reasoner / local)
  double solver_time = 2;        ///< ~solver_time: s of point-based solving per model
  double solver_precision = 0.5; ///< ~solver_precision: target bound gap
  std::string action;            ///< ~navigation_action: the Navigate action server
  double server_wait = 10;       ///< ~server_wait: s to wait for the action server
  double leg_timeout = 600;      ///< ~navigation_timeout: s per trip before giving up
  double check_timeout = 30;     ///< ~check_timeout: s to wait for the person's check
  long max_redeliveries = 1;     ///< ~max_redeliveries
  std::string updates_topic;     ///< ~knowledge_updates: topic that triggers a rebuild
  std::uint64_t seed = 1;        ///< ~seed (the manager is deterministic; logged)

  static DialogParams read(krr_ros::ParamReader& r) {
    DialogParams p;
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
    p.nav = krr_ros::NavKbParams::read(r);
    p.solver_time = r.number("solver_time", 2.0, 0.01, 3600);
    p.solver_precision = r.number("solver_precision", 0.5, 1e-6, 1e6);
    p.action = r.str("navigation_action", "navigate");
    p.server_wait = r.number("server_wait", 10, 0, 3600);
    p.leg_timeout = r.number("navigation_timeout", 600, 0.1, 86400);
    p.check_timeout = r.number("check_timeout", 30, 0.1, 86400);
    p.max_redeliveries = r.integer("max_redeliveries", 1, 0, 100);
    p.updates_topic = r.str("knowledge_updates", "/reasoner/knowledge_updates");
    if (p.action.empty()) throw krr::ConfigError("parameter navigation_action: empty name");
    r.rejectUnknown();
    return p;
  }
};

/// @brief The dialog model, its policy and the language front end, built together.
struct DialogModel {
  std::unique_ptr<krr::pomdp::DialogPomdp> pomdp;
  std::unique_ptr<krr::dialog::LanguageFrontEnd> language;
  krr::pomdp::AlphaVectorPolicy policy;
  krr::pomdp::BoundsReport bounds;
  Eigen::VectorXd reach;  ///< P^N(shop, room) the model was built with
};

class DialogNode {
 public:
  DialogNode(ros::NodeHandle& nh, ros::NodeHandle& pnh, DialogParams params)
      : p_(std::move(params)),
        config_(krr::dialog::loadDialogConfig(p_.dialog_config)),
        language_config_(krr::dialog::loadLanguageConfig(p_.language_config)),
        knowledge_(config_.office_plog, config_.speech_plog),
        nav_client_(nh, p_.action, false) {
    if (p_.model_source != "reach") domain_ = p_.nav.loadDomain();
    if (p_.model_source == "local")
      nav_kb_ = std::make_unique<krr::kb::NavigationKnowledge>(*domain_.grid, domain_.knowledge_files);
    if (p_.model_source == "reasoner")
      model_client_ = nh.serviceClient<krr_msgs::BuildTaskModel>(p_.model_service);
    rebuild();
    utterance_pub_ = nh.advertise<RobotUtterance>("robot_utterance", 20);
    belief_pub_ = nh.advertise<krr_msgs::DialogBelief>("dialog_belief", 10, true);
    status_pub_ = nh.advertise<DeliveryStatus>("delivery_status", 20, true);
    utterance_sub_ = nh.subscribe("user_utterance", 20, &DialogNode::onUtterance, this);
    if (!p_.updates_topic.empty())
      updates_sub_ = nh.subscribe(p_.updates_topic, 10, &DialogNode::onKnowledgeUpdate, this);
    timer_nh_ = pnh;
  }

 private:
  enum class State { kIdle, kDialog, kNavigating, kAwaitCheck };
  enum class Leg { kPickup, kToRoom, kReturn };

  // --- model --------------------------------------------------------------------------------
  /// @brief P^N from the navigation model of Procedure 2 for the configured time of day.
  krr::mdp::SparseModel navigationModel() {
    if (nav_kb_) return nav_kb_->buildModel({config_.time}, 0.95).dynamics;
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
    return krr_ros::navigationModelFromMsg(srv.response, *domain_.space);
  }

  krr::pomdp::DialogSpec buildSpec(Eigen::VectorXd* reach) {
    const krr::pomdp::DialogSpec& base = knowledge_.base();
    if (p_.model_source == "reach") {
      if (p_.reach.size() != base.rooms.size() ||
          (!p_.reach_back.empty() && p_.reach_back.size() != base.rooms.size()))
        throw krr::ConfigError("parameters reach_probabilities / reach_back: need one value per "
                               "room (" + std::to_string(base.rooms.size()) + ")");
      krr::pomdp::DialogSpec spec = base;
      spec.pGeneral = knowledge_.speech().p_general;
      spec.pYesNo = knowledge_.speech().p_yesno;
      spec.generalCost = config_.general_cost;
      spec.confirmCost = config_.confirm_cost;
      spec.successReward = config_.success_reward;
      spec.failureReward = config_.failure_reward;
      spec.discount = config_.discount;
      spec.turnLimit = config_.turn_limit;
      *reach = Eigen::Map<const Eigen::VectorXd>(p_.reach.data(), static_cast<Eigen::Index>(p_.reach.size()));
      Eigen::VectorXd back;
      if (!p_.reach_back.empty())
        back = Eigen::Map<const Eigen::VectorXd>(p_.reach_back.data(),
                                                 static_cast<Eigen::Index>(p_.reach_back.size()));
      spec.delivery = krr::pomdp::deliveryMatrix(base.items.size(), *reach, base.persons.size(), back);
      return spec;
    }
    const krr::mdp::SparseModel dynamics = navigationModel();
    krr::dialog::DeliveryNavigationOptions opt;
    opt.shop = config_.shop;
    opt.rooms = base.rooms;
    opt.reward = {config_.step_cost, config_.rmax};
    opt.discount = config_.nav_discount;
    opt.step_limit = domain_.domain.step_limit;
    opt.failure_penalty = config_.failure_penalty;
    krr::dialog::DeliveryNavigation nav(*domain_.space, dynamics, opt);
    *reach = nav.reachFromShop();
    return knowledge_.buildSpec(nav, config_);
  }

  /// @brief (Re)build the dialog POMDP from the knowledge base and solve it.
  void rebuild() {
    krr::Stopwatch clock;
    auto m = std::make_unique<DialogModel>();
    m->pomdp = std::make_unique<krr::pomdp::DialogPomdp>(buildSpec(&m->reach));
    m->language = std::make_unique<krr::dialog::LanguageFrontEnd>(*m->pomdp, language_config_,
                                                                  p_.language_config);
    // The same solving as the delivery experiments (incl. the exact serve-at-once vectors, so
    // that serving is compared with asking correctly at every belief), bounded by ~solver_time.
    krr::dialog::DialogConfig solve_config = config_;
    solve_config.solver_precision = p_.solver_precision;
    solve_config.solver_timeout = p_.solver_time;
    solve_config.solver_max_trials = 0;
    krr::dialog::PreparationReport prep;
    m->policy = krr::dialog::solveDialogPolicy(*m->pomdp, solve_config, "", &prep);
    m->bounds = prep.bounds;
    session_.reset();
    model_ = std::move(m);
    session_ = std::make_unique<krr::dialog::DialogSession>(*model_->pomdp, *model_->language,
                                                             &model_->policy);
    dirty_ = false;
    std::string reach;
    for (Eigen::Index r = 0; r < model_->reach.size(); ++r)
      reach += (r ? ", " : "") + model_->pomdp->spec().rooms[static_cast<std::size_t>(r)] + " " +
               std::to_string(model_->reach(r)).substr(0, 5);
    ROS_INFO_NAMED(kLog, "dialog model (%s): %zu requests, p_general %.3f, p_yesno %.3f, "
                   "P^N(shop, room): %s; policy: bounds [%.2f, %.2f] at the prior, %zu vectors; "
                   "built in %.2f s", p_.model_source.c_str(), model_->pomdp->numRequests(),
                   model_->pomdp->spec().pGeneral, model_->pomdp->spec().pYesNo, reach.c_str(),
                   model_->bounds.lower, model_->bounds.upper, model_->bounds.alphas,
                   clock.seconds());
  }

  void onKnowledgeUpdate(const krr_msgs::KnowledgeUpdate::ConstPtr& u) {
    dirty_ = true;
    ROS_INFO_NAMED(kLog, "knowledge update from '%s': the dialog model will be rebuilt before "
                   "the next dialog", u->source.c_str());
  }

  // --- user utterances ----------------------------------------------------------------------
  void onUtterance(const krr_msgs::UserUtterance::ConstPtr& msg) {
    try {
      if (msg->dialog_id != 0 && msg->dialog_id != dialog_id_) {
        notice("That answer is for dialog " + std::to_string(msg->dialog_id) +
               ", the current dialog is " + std::to_string(dialog_id_) + ": ignored.");
        return;
      }
      ROS_INFO_NAMED(kLog, "user: %s", msg->text.c_str());
      switch (state_) {
        case State::kIdle: startDialog(msg->text); break;
        case State::kDialog: dialogTurn(msg->text); break;
        case State::kNavigating: notice("I am on my way with the delivery, please wait."); break;
        case State::kAwaitCheck: checkAnswer(msg->text); break;
      }
    } catch (const std::exception& e) {
      ROS_ERROR_NAMED(kLog, "utterance '%s': %s", msg->text.c_str(), e.what());
      notice(std::string("Sorry, something went wrong: ") + e.what());
    }
  }

  void startDialog(const std::string& text) {
    if (dirty_) rebuild();
    session_->reset();
    const krr::dialog::HearResult h = session_->hear(text);
    report(h);
    if (!h.understood()) {
      session_->reset();
      notice("What can I deliver for you? (for example: a coke for bob to room2)");
      return;
    }
    ++dialog_id_;
    qa_cost_ = 0;
    state_ = State::kDialog;
    ROS_INFO_NAMED(kLog, "dialog %u started", dialog_id_);
    publishBelief();
    decide();
  }

  void dialogTurn(const std::string& text) {
    const krr::dialog::HearResult h = session_->hear(text);
    report(h);
    publishBelief();
    if (h.understood()) decide();
    else if (session_->lastQuestion() >= 0)  // the belief did not move: ask again, same turn
      say(static_cast<std::size_t>(session_->lastQuestion()));
  }

  /// @brief Unknown words and ignored content: logged and said back, never fatal.
  void report(const krr::dialog::HearResult& h) {
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

  /// @brief The policy's next action: a question, or the delivery.
  void decide() {
    const krr::pomdp::DialogPomdp& d = *model_->pomdp;
    const bool forced = session_->atTurnLimit();
    const std::size_t a = session_->nextAction();
    if (d.isQuestion(a)) {
      session_->act(a);
      qa_cost_ += a <= d.askPerson() ? d.spec().generalCost : d.spec().confirmCost;
      say(a);
      return;
    }
    const krr::dialog::BeliefSummary b = session_->summary();
    entropy_bits_ = krr::pomdp::entropy(session_->belief(), krr::pomdp::EntropyUnit::kBits);
    forced_ = forced;
    session_->act(a);
    const auto parts = d.requestParts(d.requestOfServe(a));
    request_ = {d.spec().items[parts[0]], d.spec().rooms[parts[1]], d.spec().persons[parts[2]]};
    say(a);
    ROS_INFO_NAMED(kLog, "dialog %u: serving <%s, %s, %s> after %d question(s), QA cost %.1f, "
                   "P = %.3f, entropy %.3f bits%s", dialog_id_, request_[0].c_str(),
                   request_[1].c_str(), request_[2].c_str(), session_->turns(), qa_cost_,
                   b.mostLikelyProbability, entropy_bits_, forced ? " (turn limit)" : "");
    attempt_ = 1;
    corrected_ = false;
    state_ = State::kNavigating;
    status(DeliveryStatus::SERVING, "picking up a " + request_[0] + " at the " + config_.shop);
    navigate(Leg::kPickup, config_.shop);
  }

  // --- delivery -----------------------------------------------------------------------------
  /// @brief Start a trip. The goal is sent from a timer, never from inside the action client's
  /// own callbacks (actionlib mis-tracks a goal sent from the previous goal's done callback),
  /// and only once the server is up (waiting at most ~server_wait, without blocking).
  void navigate(Leg leg, const std::string& place) {
    leg_ = leg;
    leg_place_ = place;
    const unsigned id = dialog_id_;
    wait_start_ = ros::Time::now();
    wait_timer_ = timer_nh_.createTimer(ros::Duration(0.05), [this, id, place](const ros::TimerEvent&) {
      guarded("navigation start", [&] {
        if (id != dialog_id_ || state_ != State::kNavigating) return wait_timer_.stop();
        if (nav_client_.isServerConnected()) {
          wait_timer_.stop();
          sendGoal(id, place);
        } else if ((ros::Time::now() - wait_start_).toSec() > p_.server_wait) {
          wait_timer_.stop();
          finish(DeliveryStatus::FAILED, "navigation action server '" + p_.action +
                                             "' is not available (is navigation_node running?)");
        }
      });
    });
  }

  void sendGoal(unsigned id, const std::string& place) {
    krr_msgs::NavigateGoal goal;
    goal.place = place;
    goal.time = config_.time;
    ROS_INFO_NAMED(kLog, "dialog %u: navigating to %s", id, place.c_str());
    nav_client_.sendGoal(goal, [this, id](const actionlib::SimpleClientGoalState& s,
                                          const krr_msgs::NavigateResultConstPtr& r) {
      guarded("navigation result", [&] { onNavigationDone(id, s, r); });
    });
    leg_timer_ = timer_nh_.createTimer(ros::Duration(p_.leg_timeout), [this, id](const ros::TimerEvent&) {
      guarded("navigation timeout", [&] {
        if (id != dialog_id_ || state_ != State::kNavigating) return;
        nav_client_.cancelGoal();
        finish(DeliveryStatus::FAILED, "navigation to " + leg_place_ + " took longer than " +
                                           std::to_string(p_.leg_timeout) + " s");
      });
    }, true);
  }

  void onNavigationDone(unsigned id, const actionlib::SimpleClientGoalState& s,
                        const krr_msgs::NavigateResultConstPtr& r) {
    if (id != dialog_id_ || state_ != State::kNavigating) return;
    leg_timer_.stop();
    if (s != actionlib::SimpleClientGoalState::SUCCEEDED || !r || !r->success) {
      const std::string why = r && !r->failure_reason.empty() ? r->failure_reason : s.toString();
      finish(DeliveryStatus::FAILED, "navigation to " + leg_place_ + " failed (" +
                                         (r ? r->outcome : std::string("no result")) + "): " + why);
      return;
    }
    if (leg_ == Leg::kPickup || leg_ == Leg::kReturn) {
      status(DeliveryStatus::TO_ROOM, "bringing a " + request_[0] + " for " + request_[2] +
                                          " to " + request_[1]);
      navigate(Leg::kToRoom, request_[1]);
      return;
    }
    state_ = State::kAwaitCheck;
    status(DeliveryStatus::ARRIVED, "at " + request_[1]);
    notice("Here is a " + request_[0] + " for " + request_[2] + " in " + request_[1] +
           ". Is that right? (yes / no, a <item> for <person> to <room>)");
    check_timer_ = timer_nh_.createTimer(ros::Duration(p_.check_timeout), [this, id](const ros::TimerEvent&) {
      guarded("check timeout", [&] {
        if (id != dialog_id_ || state_ != State::kAwaitCheck) return;
        if (corrected_)
          finish(DeliveryStatus::FAILED, "wrong delivery, and the right request was not given");
        else
          finish(DeliveryStatus::UNCONFIRMED, "nobody checked the delivery within " +
                                                  std::to_string(p_.check_timeout) + " s");
      });
    }, true);
  }

  /// @brief The person's check at the room: yes, or the right request (what differs).
  void checkAnswer(const std::string& text) {
    const krr::dialog::ParsedUtterance u = model_->language->parse(text);
    krr::dialog::HearResult h;
    h.text = text;
    h.unknownWords = u.unknownWords;
    report(h);
    const auto& spec = model_->pomdp->spec();
    const std::vector<std::string>* names[3] = {&spec.items, &spec.rooms, &spec.persons};
    std::array<std::set<std::size_t>, 3> said;
    for (const auto& m : u.mentions) said[static_cast<int>(m.factor)].insert(m.index);
    std::array<std::string, 3> right = request_;  // item, room, person
    for (int f = 0; f < 3; ++f) {
      if (said[f].size() > 1) {
        notice(std::string("Which ") + krr::dialog::factorName(static_cast<krr::dialog::Factor>(f)) +
               " was it? You named several.");
        return;
      }
      if (said[f].size() == 1) right[f] = (*names[f])[*said[f].begin()];
    }
    if (u.yes > 0 && u.no == 0 && right == request_) {
      finish(DeliveryStatus::FULFILLED, "the person confirmed the delivery");
      return;
    }
    if (right == request_) {
      if (u.no > 0) corrected_ = true;
      notice(u.no > 0 ? "Sorry! What did you ask for? (for example: no, a coke for bob to room2)"
                      : "Is this right? Please answer yes, or tell me what you asked for.");
      return;
    }
    if (attempt_ > static_cast<unsigned>(p_.max_redeliveries)) {
      finish(DeliveryStatus::FAILED, "wrong delivery: <" + right[0] + ", " + right[1] + ", " +
                                         right[2] + "> was asked for, no redelivery left");
      return;
    }
    check_timer_.stop();
    ROS_INFO_NAMED(kLog, "dialog %u: wrong delivery, redelivering <%s, %s, %s>", dialog_id_,
                   right[0].c_str(), right[1].c_str(), right[2].c_str());
    request_ = right;
    ++attempt_;
    state_ = State::kNavigating;
    status(DeliveryStatus::RETURNING, "wrong delivery: back to the " + config_.shop + " for a " +
                                          request_[0]);
    navigate(Leg::kReturn, config_.shop);
  }

  void finish(const std::string& final_status, const std::string& message) {
    check_timer_.stop();
    leg_timer_.stop();
    wait_timer_.stop();
    state_ = State::kIdle;
    status(final_status, message);
    if (final_status == DeliveryStatus::FULFILLED)
      ROS_INFO_NAMED(kLog, "dialog %u: delivery %s: %s", dialog_id_, final_status.c_str(),
                     message.c_str());
    else
      ROS_WARN_NAMED(kLog, "dialog %u: delivery %s: %s", dialog_id_, final_status.c_str(),
                     message.c_str());
    notice(final_status == DeliveryStatus::FULFILLED ? "Enjoy! What else can I deliver?"
                                                      : "Delivery " + final_status + ": " + message);
  }

  // --- publishing ---------------------------------------------------------------------------
  void say(std::size_t a) {
    const krr::pomdp::DialogPomdp& d = *model_->pomdp;
    RobotUtterance u;
    u.header.stamp = ros::Time::now();
    u.dialog_id = dialog_id_;
    u.turn = static_cast<std::uint32_t>(session_->turns());
    u.text = krr::dialog::robotUtterance(d, a);
    const auto& s = d.spec();
    switch (d.actionKind(a)) {
      case krr::pomdp::DialogActionKind::kAskItem: u.kind = RobotUtterance::ASK_ITEM; break;
      case krr::pomdp::DialogActionKind::kAskRoom: u.kind = RobotUtterance::ASK_ROOM; break;
      case krr::pomdp::DialogActionKind::kAskPerson: u.kind = RobotUtterance::ASK_PERSON; break;
      case krr::pomdp::DialogActionKind::kConfirmItem:
        u.kind = RobotUtterance::CONFIRM_ITEM;
        u.value = s.items[a - d.confirmItem(0)];
        break;
      case krr::pomdp::DialogActionKind::kConfirmRoom:
        u.kind = RobotUtterance::CONFIRM_ROOM;
        u.value = s.rooms[a - d.confirmRoom(0)];
        break;
      case krr::pomdp::DialogActionKind::kConfirmPerson:
        u.kind = RobotUtterance::CONFIRM_PERSON;
        u.value = s.persons[a - d.confirmPerson(0)];
        break;
      case krr::pomdp::DialogActionKind::kServe: {
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
    utterance_pub_.publish(u);
  }

  void notice(const std::string& text) {
    RobotUtterance u;
    u.header.stamp = ros::Time::now();
    u.dialog_id = dialog_id_;
    u.turn = session_ ? static_cast<std::uint32_t>(session_->turns()) : 0;
    u.kind = RobotUtterance::NOTICE;
    u.text = text;
    utterance_pub_.publish(u);
  }

  void publishBelief() {
    const krr::pomdp::DialogPomdp& d = *model_->pomdp;
    const krr::dialog::BeliefSummary b = session_->summary();
    krr_msgs::DialogBelief m;
    m.header.stamp = ros::Time::now();
    m.dialog_id = dialog_id_;
    m.turn = static_cast<std::uint32_t>(session_->turns());
    m.items = d.spec().items;
    m.rooms = d.spec().rooms;
    m.persons = d.spec().persons;
    m.item_probabilities.assign(b.items.data(), b.items.data() + b.items.size());
    m.room_probabilities.assign(b.rooms.data(), b.rooms.data() + b.rooms.size());
    m.person_probabilities.assign(b.persons.data(), b.persons.data() + b.persons.size());
    m.entropy = krr::pomdp::entropy(session_->belief(), krr::pomdp::EntropyUnit::kBits);
    const auto p = d.requestParts(b.mostLikely);
    m.most_likely.header.stamp = m.header.stamp;
    m.most_likely.item = d.spec().items[p[0]];
    m.most_likely.room = d.spec().rooms[p[1]];
    m.most_likely.person = d.spec().persons[p[2]];
    m.most_likely_probability = b.mostLikelyProbability;
    belief_pub_.publish(m);
  }

  void status(const std::string& s, const std::string& message) {
    DeliveryStatus m;
    m.header.stamp = ros::Time::now();
    m.dialog_id = dialog_id_;
    m.status = s;
    m.request.header.stamp = m.header.stamp;
    m.request.item = request_[0];
    m.request.room = request_[1];
    m.request.person = request_[2];
    m.attempt = attempt_;
    m.turns = static_cast<std::uint32_t>(session_->turns());
    m.qa_cost = qa_cost_;
    m.entropy = entropy_bits_;
    m.forced = forced_;
    m.message = message;
    status_pub_.publish(m);
  }

  /// @brief Run a callback body; an exception fails the delivery instead of killing the node.
  template <class F>
  void guarded(const char* what, F&& f) {
    try {
      f();
    } catch (const std::exception& e) {
      ROS_ERROR_NAMED(kLog, "%s: %s", what, e.what());
      if (state_ == State::kNavigating || state_ == State::kAwaitCheck)
        finish(DeliveryStatus::FAILED, std::string(what) + ": " + e.what());
    }
  }

  DialogParams p_;
  krr::dialog::DialogConfig config_;
  krr::dialog::LanguageConfig language_config_;
  krr::dialog::DialogKnowledge knowledge_;
  krr::kb::NavDomain domain_;
  std::unique_ptr<krr::kb::NavigationKnowledge> nav_kb_;
  ros::ServiceClient model_client_;
  std::unique_ptr<DialogModel> model_;
  std::unique_ptr<krr::dialog::DialogSession> session_;
  bool dirty_ = false;
  State state_ = State::kIdle;
  unsigned dialog_id_ = 0;
  double qa_cost_ = 0, entropy_bits_ = 0;
  bool forced_ = false, corrected_ = false;
  std::array<std::string, 3> request_;  // item, room, person being delivered
  unsigned attempt_ = 0;
  Leg leg_ = Leg::kPickup;
  std::string leg_place_;
  ros::Time wait_start_;
  NavigateClient nav_client_;
  ros::NodeHandle timer_nh_;
  ros::Timer wait_timer_, leg_timer_, check_timer_;
  ros::Publisher utterance_pub_, belief_pub_, status_pub_;
  ros::Subscriber utterance_sub_, updates_sub_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "dialog");
  ros::NodeHandle nh, pnh("~");
  std::unique_ptr<DialogNode> node;
  try {
    krr_ros::ParamReader reader(pnh);
    DialogParams params = DialogParams::read(reader);
    ROS_INFO_NAMED(kLog, "seed %lu (the dialog manager is deterministic), base_dir %s",
                   static_cast<unsigned long>(params.seed), reader.baseDir().c_str());
    node = std::make_unique<DialogNode>(nh, pnh, std::move(params));
  } catch (const std::exception& e) {
    ROS_FATAL_NAMED(kLog, "cannot start: %s", e.what());
    return 1;
  }
  ROS_INFO_NAMED(kLog, "ready: talk to me on user_utterance");
  ros::spin();
  return 0;
}
