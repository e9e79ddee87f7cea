// reasoner_node: the knowledge base of the robot as ROS services.
//
// Two P-log knowledge bases: the domain KB (config/office.plog: people, items, rooms, the
// request prior) and the navigation KB (grid geometry + config/navigation.plog + what the robot
// learned). Services: ~query_probability, ~add_knowledge, ~build_task_model. An update is
// validated completely (statements on a scratch copy of the domain KB) before anything
// changes; an accepted one is written to ~learned_file (navigation) and ~domain_learned_file
// (statements) as one FileTransaction, so a kill never leaves half of it. At start an
// interrupted transaction is finished, orphaned temporaries are removed, and a learned file
// that does not load is moved aside with a warning (the node starts from the rest).
#include <algorithm>
#include <krr_msgs/AddKnowledge.h>
#include <krr_msgs/BuildTaskModel.h>
#include <krr_msgs/KnowledgeUpdate.h>
#include <krr_msgs/QueryProbability.h>
#include <ros/ros.h>

#include <ctime>
#include <filesystem>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/journal.h"
#include "krr_core/common/resources.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/plog/grounder.h"
#include "krr_core/plog/reasoner.h"
#include "krr_ros/conversions.h"
#include "krr_ros/nav_kb.h"
#include "krr_ros/params.h"

namespace {

const char* const kLog = "reasoner";

/// @brief Validated parameters of reasoner_node.
struct ReasonerParams {
  std::vector<std::string> domain_files;  ///< ~domain_files: domain KB, loaded in order
  std::string domain_learned_file;        ///< ~domain_learned_file: added statements
  krr_ros::NavKbParams nav;               ///< navigation KB files (see nav_kb.h)
  std::string learned_file;               ///< ~learned_file: learned navigation knowledge
  double discount = 0.95;                 ///< ~discount: default discount of built models
                                          ///< (default: navigation.yaml planning.model_discount)
  double query_seconds = 10.0;            ///< ~query_seconds: grounding / inference budget
  /// ~backend: auto (native engine inside its fragment, clingo otherwise), native or asp
  krr::plog::Backend backend = krr::plog::Backend::Auto;
  std::uint64_t seed = 1;                 ///< ~seed (the reasoner is deterministic; logged)

  static ReasonerParams read(krr_ros::ParamReader& r) {
    ReasonerParams p;
    p.seed = r.seed();
    p.domain_files = r.paths("domain_files", {"config/office.plog"}, true);
    if (p.domain_files.empty())
      r.refuse("domain_files", "[]", "at least one P-log file is required");
    p.nav = krr_ros::NavKbParams::read(r);
    const std::string data = krr_ros::defaultDataDirectory();
    p.learned_file = r.path("learned_file", data + "/learned_navigation.plog", false);
    p.domain_learned_file = r.path("domain_learned_file", data + "/learned_domain.plog", false);
    if (p.learned_file.empty() || p.domain_learned_file.empty() ||
        p.learned_file == p.domain_learned_file)
      r.refuse("domain_learned_file", "'" + p.domain_learned_file + "'",
               "must be a non-empty path different from learned_file");
    // navigation.yaml's planning.model_discount; ~discount overrides it
    p.discount = r.number("discount", p.nav.loadConfig().planning.model_discount, 1e-6, 1.0);
    p.query_seconds = r.number("query_seconds", 10.0, 0.01, 3600.0);
    p.backend = krr::plog::parseBackend(r.str("backend", "auto", {"auto", "native", "asp"}));
    r.rejectUnknown();
    return p;
  }
};

class ReasonerNode {
 public:
  ReasonerNode(ros::NodeHandle& pnh, ReasonerParams params)
      : params_(std::move(params)), domain_(params_.nav.loadDomain()) {
    krr::Stopwatch clock;
    recoverFiles();
    domain_kb_ = loadDomainKb(added_text_, &num_added_);
    nav_ = loadNavigationKb();
    times_ = nav_->reasoner().sortValues("time");
    ROS_INFO_NAMED(kLog, "knowledge loaded in %.2f s: domain KB %zu file(s), %zu added "
                   "statement(s); navigation KB %s (%zu free cells), %zu learned distribution(s) "
                   "from %s", clock.seconds(), params_.domain_files.size(), num_added_,
                   params_.nav.domain.c_str(), domain_.space->numStates() - 1,
                   nav_->learnedEntries().size(), params_.learned_file.c_str());
    updates_pub_ = pnh.advertise<krr_msgs::KnowledgeUpdate>("knowledge_updates", 10);
    query_srv_ = pnh.advertiseService("query_probability", &ReasonerNode::query, this);
    add_srv_ = pnh.advertiseService("add_knowledge", &ReasonerNode::add, this);
    build_srv_ = pnh.advertiseService("build_task_model", &ReasonerNode::build, this);
  }

 private:
  std::string journalPath() const { return params_.learned_file + ".journal"; }

  /// @brief Finish an update a kill interrupted, and remove temporaries of killed writes.
  void recoverFiles() {
    try {
      if (const std::size_t n = krr::FileTransaction::recover(journalPath()))
        ROS_WARN_NAMED(kLog, "finished an interrupted knowledge update (%zu file(s)) from %s", n,
                       journalPath().c_str());
    } catch (const krr::ParseError& e) {
      moveAside(journalPath(), e.what());
    }
    for (const std::string& f : {params_.learned_file, params_.domain_learned_file})
      for (const std::string& orphan : krr::removeOrphanTemporaries(krr::dirName(f)))
        ROS_WARN_NAMED(kLog, "removed %s, left by a write that was killed", orphan.c_str());
  }

  /// @brief Keep a file that cannot be used for inspection, out of the node's way.
  static void moveAside(const std::string& path, const std::string& why) {
    char stamp[32];
    const std::time_t now = std::time(nullptr);
    std::strftime(stamp, sizeof(stamp), "%Y%m%dT%H%M%S", std::gmtime(&now));
    const std::string aside = path + ".corrupt-" + stamp;
    std::error_code ec;
    std::filesystem::rename(path, aside, ec);
    ROS_WARN_NAMED(kLog, "%s cannot be loaded (%s); moved aside to %s, starting without it",
                   path.c_str(), why.c_str(), ec ? "(rename failed)" : aside.c_str());
  }

  /// @brief The domain KB from its files plus the added statements (`added`, read from
  /// ~domain_learned_file when `count` is given: a file that does not load is moved aside).
  /// @brief The budgets of every grounding and inference: a query, an update's check or a
  /// model build that exceeds them is refused (BudgetExceededError), the node stays responsive.
  krr::plog::GroundingLimits limits() const {
    krr::plog::GroundingLimits l;
    l.max_ground_seconds = l.max_inference_seconds = params_.query_seconds;
    return l;
  }

  std::unique_ptr<krr::plog::Reasoner> loadDomainKb(std::string& added, std::size_t* count) {
    auto kb = std::make_unique<krr::plog::Reasoner>();
    kb->setLimits(limits());
    kb->setBackend(params_.backend);
    kb->loadFile(params_.domain_files.front());
    for (std::size_t i = 1; i < params_.domain_files.size(); ++i)
      kb->addStatements(krr::readFile(params_.domain_files[i]), "", params_.domain_files[i]);
    if (count && std::filesystem::exists(params_.domain_learned_file)) {
      added = krr::readFile(params_.domain_learned_file);
      try {
        auto with = loadDomainKb(added, nullptr);
        *count = with->addStatements(added, "added", params_.domain_learned_file);
        with->answerProgramQueries();
        return with;
      } catch (const krr::Error& e) {
        moveAside(params_.domain_learned_file, e.what());
        added.clear();
        *count = 0;
      }
    }
    return kb;
  }

  /// @brief The navigation KB with ~learned_file (moved aside if it does not load).
  std::unique_ptr<krr::kb::NavigationKnowledge> loadNavigationKb() {
    auto nav = std::make_unique<krr::kb::NavigationKnowledge>(*domain_.grid,
                                                               domain_.knowledge_files);
    nav->reasoner().setLimits(limits());
    nav->reasoner().setBackend(params_.backend);
    if (!std::filesystem::exists(params_.learned_file)) return nav;
    try {
      nav->loadLearned(params_.learned_file);
      nav->buildModel({});  // a file that loads but gives no model is as unusable
      return nav;
    } catch (const krr::Error& e) {
      moveAside(params_.learned_file, e.what());
    }
    nav = std::make_unique<krr::kb::NavigationKnowledge>(*domain_.grid, domain_.knowledge_files);
    nav->reasoner().setLimits(limits());
    nav->reasoner().setBackend(params_.backend);
    return nav;
  }

  krr::plog::Reasoner& kbFor(const std::string& name) {
    if (name.empty() || name == "domain") return *domain_kb_;
    if (name == "navigation") return nav_->reasoner();
    throw krr::ConfigError("knowledge_base '" + name + "' is neither 'domain' nor 'navigation'");
  }

  bool query(krr_msgs::QueryProbability::Request& req, krr_msgs::QueryProbability::Response& res) {
    try {
      krr::plog::Reasoner& kb = kbFor(req.knowledge_base);
      if (req.query.empty() == req.attribute.empty())
        throw krr::ConfigError("give exactly one of 'query' and 'attribute'");
      if (!req.query.empty()) {
        res.probability = kb.probability(req.query);
        res.message = "P(" + req.query + ") = " + std::to_string(res.probability);
      } else {
        for (const krr::plog::ValueProb& vp : kb.distribution(req.attribute, req.evidence)) {
          res.values.push_back(vp.value);
          res.probabilities.push_back(vp.probability);
        }
        res.message = "distribution of " + req.attribute + ": " +
                      std::to_string(res.values.size()) + " value(s)";
      }
      res.success = true;
      ROS_DEBUG_NAMED(kLog, "%s", res.message.c_str());
    } catch (const std::exception& e) {
      res.success = false;
      res.message = e.what();
      ROS_WARN_NAMED(kLog, "query '%s%s' refused: %s", req.query.c_str(), req.attribute.c_str(),
                     e.what());
    }
    return true;
  }

  bool add(krr_msgs::AddKnowledge::Request& req, krr_msgs::AddKnowledge::Response& res) {
    const krr_msgs::KnowledgeUpdate& u = req.update;
    try {
      // Validate everything before changing anything.
      const auto pairs = krr_ros::toKnownPairs(u.atoms, *domain_.space, times_);
      const bool hasAreas = u.area_statements.find_first_not_of(" \t\r\n") != std::string::npos;
      const bool hasStatements = u.statements.find_first_not_of(" \t\r\n") != std::string::npos;
      if (u.atoms.empty() && !hasAreas && !hasStatements)
        throw krr::ConfigError("the update holds neither atoms, area knowledge nor statements");
      if (hasAreas && std::find(times_.begin(), times_.end(), u.area_time) == times_.end())
        throw krr::ConfigError("area_time '" + u.area_time + "' is not a time of day of the "
                               "navigation knowledge base");
      const std::string tag = "update" + std::to_string(++updates_);
      const std::string where = "<update from " + u.source + ">";
      std::unique_ptr<krr::plog::Reasoner> domain_next;
      if (hasStatements) {
        // On a copy: the live domain KB is never touched by statements that are refused.
        std::string added = added_text_;
        domain_next = loadDomainKb(added, nullptr);
        if (!added_text_.empty())
          domain_next->addStatements(added_text_, "added", params_.domain_learned_file);
        res.statements_added =
            static_cast<std::uint32_t>(domain_next->addStatements(u.statements, tag, where));
        try {
          domain_next->answerProgramQueries();
        } catch (const krr::Error& e) {
          throw krr::IncoherentError(std::string("the statements make the domain knowledge "
                                                 "base incoherent: ") + e.what());
        }
        // The KB's own queries may not reach the new statements (relevance cone), so the
        // whole program is ground once under the budget: a runaway rule is refused here
        // instead of failing every later query that touches it.
        std::set<std::string> all;
        for (const auto& a : domain_next->program().attributes) all.insert(a.name);
        try {
          krr::plog::groundProgram(domain_next->program(), all, limits());
        } catch (const krr::plog::BudgetExceededError&) {
          throw;
        } catch (const krr::Error&) {
          // outside the native grounder's fragment: the query check above decides
        }
      }
      const std::string added_next =
          hasStatements ? added_text_ + "% added by " + (u.source.empty() ? "?" : u.source) +
                              "\n" + u.statements + "\n"
                        : added_text_;
      // Apply, then write both files as one transaction; if anything fails, the old files are
      // written back (one transaction too) and both knowledge bases reloaded from them.
      const std::string nav_before = nav_->learnedText();
      try {
        for (const auto& [time, list] : pairs)
          res.atoms_added += static_cast<std::uint32_t>(nav_->addLearned(list, time));
        if (hasAreas) nav_->setLearnedAreas(u.area_time, u.area_statements);
        krr_ros::ensureParentDirectory(params_.learned_file);
        krr_ros::ensureParentDirectory(params_.domain_learned_file);
        krr::FileTransaction t(journalPath());
        t.write(params_.learned_file, nav_->learnedText());
        if (hasStatements) t.write(params_.domain_learned_file, added_next);
        t.commit();
      } catch (...) {
        restoreFiles(nav_before, hasStatements);
        throw;
      }
      if (domain_next) domain_kb_ = std::move(domain_next);
      added_text_ = added_next;
      res.total_learned = static_cast<std::uint32_t>(nav_->learnedEntries().size());
      res.success = true;
      res.message = "added " + std::to_string(res.atoms_added) + " learned distribution(s)" +
                    (hasAreas ? ", area knowledge for " + u.area_time : std::string()) +
                    " and " + std::to_string(res.statements_added) + " statement(s)";
      ROS_INFO_NAMED(kLog, "update from '%s': %s; %u learned in total, saved to %s",
                     u.source.c_str(), res.message.c_str(), res.total_learned,
                     params_.learned_file.c_str());
      updates_pub_.publish(u);
    } catch (const std::exception& e) {
      res = krr_msgs::AddKnowledge::Response();
      res.success = false;
      res.total_learned = static_cast<std::uint32_t>(nav_->learnedEntries().size());
      res.message = std::string("update refused, nothing changed: ") + e.what();
      ROS_WARN_NAMED(kLog, "update from '%s' refused: %s", u.source.c_str(), e.what());
    }
    return true;
  }

  /// @brief Undo a failed update: the files get their old contents back (replacing the
  /// update's journal, if it was written), and both KBs are reloaded from them.
  void restoreFiles(const std::string& nav_before, bool statements) {
    try {
      krr::FileTransaction undo(journalPath());
      undo.write(params_.learned_file, nav_before);
      if (statements) undo.write(params_.domain_learned_file, added_text_);
      undo.commit();
    } catch (const std::exception& e) {
      ROS_ERROR_NAMED(kLog, "after a failed update, the old knowledge files could not be "
                      "written back: %s", e.what());
    }
    domain_kb_ = loadDomainKb(added_text_, &num_added_);
    nav_ = loadNavigationKb();
  }

  bool build(krr_msgs::BuildTaskModel::Request& req, krr_msgs::BuildTaskModel::Response& res) {
    try {
      if (req.task == "dialog")
        throw krr::ConfigError("task model 'dialog' is not available from reasoner_node");
      if (req.task != "navigation")
        throw krr::ConfigError("task '" + req.task + "' is neither 'navigation' nor 'dialog'");
      if (!(req.discount == 0 || (req.discount > 0 && req.discount <= 1)))
        throw krr::ConfigError("discount " + std::to_string(req.discount) + " is not in (0, 1]");
      krr::Stopwatch clock;
      const krr::kb::NavModel model =
          nav_->buildModel(req.times, req.discount > 0 ? req.discount : params_.discount);
      krr_ros::fillNavigationModel(model, *domain_.space, &res);
      res.success = true;
      res.message = "navigation model: " + std::to_string(res.num_states) + " states, " +
                    std::to_string(res.next_states.size()) + " transitions, " +
                    std::to_string(res.num_learned) + " learned pairs";
      ROS_INFO_NAMED(kLog, "%s (built in %.2f s)", res.message.c_str(), clock.seconds());
    } catch (const std::exception& e) {
      res = krr_msgs::BuildTaskModel::Response();
      res.success = false;
      res.message = e.what();
      ROS_WARN_NAMED(kLog, "build_task_model '%s' refused: %s", req.task.c_str(), e.what());
    }
    return true;
  }

  ReasonerParams params_;
  krr::kb::NavDomain domain_;
  std::unique_ptr<krr::plog::Reasoner> domain_kb_;
  std::unique_ptr<krr::kb::NavigationKnowledge> nav_;
  std::vector<std::string> times_;
  std::string added_text_;
  std::size_t num_added_ = 0;
  unsigned long updates_ = 0;
  ros::Publisher updates_pub_;
  ros::ServiceServer query_srv_, add_srv_, build_srv_;
};

}  // namespace

int main(int argc, char** argv) {
  krr_ros::exitOnHelp(argc, argv, "reasoner_node");
  ros::init(argc, argv, "reasoner");
  ros::NodeHandle pnh("~");
  std::unique_ptr<ReasonerNode> node;
  try {
    krr_ros::ParamReader reader(pnh);
    ReasonerParams params = ReasonerParams::read(reader);
    ROS_INFO_NAMED(kLog, "seed %lu, base_dir %s", static_cast<unsigned long>(params.seed),
                   reader.baseDir().c_str());
    node = std::make_unique<ReasonerNode>(pnh, std::move(params));
  } catch (const std::exception& e) {
    ROS_FATAL_NAMED(kLog, "cannot start: %s", e.what());
    return 1;
  }
  ROS_INFO_NAMED(kLog, "ready");
  ros::spin();
  return 0;
}
