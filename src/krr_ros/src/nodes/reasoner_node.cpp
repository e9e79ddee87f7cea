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
//
// Concurrency (issue 24): calls are served by ~threads spinner threads at once, so a slow
// query never holds up the others. The committed knowledge is an immutable snapshot (the added
// statements and the learned text, with version numbers); every computation runs on its own
// copy of the knowledge bases (kept in a pool, brought up to the snapshot's version when taken:
// learned deltas replayed, the domain KB rebuilt), so no two calls share a reasoner. Updates
// are serialised and change nothing until their commit, which publishes the next snapshot
// atomically: a query sees the knowledge before an update or after it, never half of it.
//
// Time (issue 24): ~query_seconds covers a whole call, from its callback's start: queueing for
// a computation slot, bringing a copy up to date, parsing, grounding, inference and, for an
// update, its validation. The core's grounding and inference budgets are set to what is left of
// the call's time, so they stop a long phase with a BudgetExceededError naming the statement;
// phases that check no budget (parsing the query's text) are covered by the call's watchdog,
// which answers "refused" at the deadline and abandons the computation (its copy is discarded
// after it ends; an update abandoned before its commit point changes nothing).
#include <algorithm>
#include <krr_msgs/AddKnowledge.h>
#include <krr_msgs/BuildTaskModel.h>
#include <krr_msgs/KnowledgeUpdate.h>
#include <krr_msgs/QueryProbability.h>
#include <ros/ros.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <ctime>
#include <deque>
#include <exception>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/format.h"
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
using Clock = std::chrono::steady_clock;

/// @brief Validated parameters of reasoner_node.
struct ReasonerParams {
  std::vector<std::string> domain_files;  ///< ~domain_files: domain KB, loaded in order
  std::string domain_learned_file;        ///< ~domain_learned_file: added statements
  krr_ros::NavKbParams nav;               ///< navigation KB files (see nav_kb.h)
  std::string learned_file;               ///< ~learned_file: learned navigation knowledge
  double discount = 0.95;                 ///< ~discount: default discount of built models
                                          ///< (default: navigation.yaml planning.model_discount)
  double query_seconds = 10.0;            ///< ~query_seconds: the whole budget of one call
  int threads = 4;                        ///< ~threads: calls served at once
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
    p.threads = static_cast<int>(r.integer("threads", 4, 1, 64));
    p.backend = krr::plog::parseBackend(r.str("backend", "auto", {"auto", "native", "asp"}));
    r.rejectUnknown();
    return p;
  }
};

/// @brief The committed knowledge: what the files hold. Immutable once published; a new
/// update publishes a new one. Versions count the changes of each knowledge base.
struct Committed {
  std::uint64_t domain_version = 1;
  std::uint64_t nav_version = 1;
  std::string added_text;       ///< statements added to the domain KB (~domain_learned_file)
  std::size_t num_added = 0;
  std::string learned_text;     ///< learned navigation knowledge (~learned_file)
  std::size_t total_learned = 0;
};

/// @brief What one accepted update did to the navigation KB, replayed on older copies.
struct NavDelta {
  std::uint64_t version = 0;  ///< nav_version after it
  std::map<std::string, std::vector<krr::mdp::KnownPair>> pairs;
  std::string area_time, area_statements;
};

/// @brief One computation's knowledge bases (a pool keeps them between calls). Each part is
/// built when a call first needs it and carries the version of the snapshot it reflects.
struct Copy {
  std::uint64_t domain_version = 0;
  std::unique_ptr<krr::plog::Reasoner> domain;
  std::uint64_t nav_version = 0;
  std::unique_ptr<krr::kb::NavigationKnowledge> nav;
};

/// @brief A call and its computation thread: the computation reports here; the call abandons
/// it at its deadline, unless it has passed its commit point (an update writing its files).
struct Job {
  std::mutex m;
  std::condition_variable cv;
  bool done = false;
  bool abandoned = false;
  bool committing = false;
  std::exception_ptr error;
};

/// @brief Seconds as text for messages ("2", "0.5").
std::string secs(double s) { return krr::formatNumber(s, 4); }

class ReasonerNode {
 public:
  ReasonerNode(ros::NodeHandle& pnh, ReasonerParams params)
      : params_(std::move(params)), domain_(params_.nav.loadDomain()) {
    krr::Stopwatch clock;
    for (const std::string& f : params_.domain_files)
      domain_texts_.emplace_back(f, krr::readFile(f));
    recoverFiles();
    auto first = std::make_unique<Copy>();
    auto committed = std::make_shared<Committed>();
    first->domain = loadDomainKb(*committed);
    first->nav = loadNavigationKb(*committed);
    first->domain_version = committed->domain_version;
    first->nav_version = committed->nav_version;
    times_ = first->nav->reasoner().sortValues("time");
    committed_ = committed;
    ROS_INFO_NAMED(kLog, "knowledge loaded in %.2f s: domain KB %zu file(s), %zu added "
                   "statement(s); navigation KB %s (%zu free cells), %zu learned distribution(s) "
                   "from %s; %d thread(s), %s s per call", clock.seconds(),
                   params_.domain_files.size(), committed->num_added, params_.nav.domain.c_str(),
                   domain_.space->numStates() - 1, committed->total_learned,
                   params_.learned_file.c_str(), params_.threads,
                   secs(params_.query_seconds).c_str());
    idle_.push_back(std::move(first));
    max_running_ = 2 * static_cast<std::size_t>(params_.threads);
    updates_pub_ = pnh.advertise<krr_msgs::KnowledgeUpdate>("knowledge_updates", 10);
    query_srv_ = pnh.advertiseService("query_probability", &ReasonerNode::query, this);
    add_srv_ = pnh.advertiseService("add_knowledge", &ReasonerNode::add, this);
    build_srv_ = pnh.advertiseService("build_task_model", &ReasonerNode::build, this);
  }

  /// @brief Wait up to `seconds` for the computations still running (abandoned ones included);
  /// true when none is left.
  bool drain(double seconds) {
    std::unique_lock<std::mutex> lock(slots_mutex_);
    return slots_cv_.wait_for(lock, std::chrono::duration<double>(seconds),
                              [&] { return running_ == 0; });
  }

 private:
  // --- files and start-up -------------------------------------------------------------------
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

  /// @brief The budgets of a grounding and inference that must end by `deadline`: what is
  /// left of the call's time (a call past its deadline is refused before it starts one).
  krr::plog::GroundingLimits limitsUntil(Clock::time_point deadline, const char* phase) const {
    const double left = std::chrono::duration<double>(deadline - Clock::now()).count();
    if (left <= 0.0)
      throw krr::plog::BudgetExceededError(std::string("~query_seconds = ") +
                                           secs(params_.query_seconds) + " s spent before " +
                                           phase);
    krr::plog::GroundingLimits l;
    l.max_ground_seconds = l.max_inference_seconds = left;
    return l;
  }
  /// @brief The limits of a whole call, for start-up loads (no call is waiting).
  krr::plog::GroundingLimits callLimits() const {
    krr::plog::GroundingLimits l;
    l.max_ground_seconds = l.max_inference_seconds = params_.query_seconds;
    return l;
  }

  /// @brief A domain KB: the domain files (read once, at start) plus `added`.
  std::unique_ptr<krr::plog::Reasoner> buildDomainKb(const std::string& added) const {
    auto kb = std::make_unique<krr::plog::Reasoner>();
    kb->setLimits(callLimits());
    kb->setBackend(params_.backend);
    kb->loadString(domain_texts_.front().second, domain_texts_.front().first);
    for (std::size_t i = 1; i < domain_texts_.size(); ++i)
      kb->addStatements(domain_texts_[i].second, "", domain_texts_[i].first);
    if (!added.empty()) kb->addStatements(added, "added", params_.domain_learned_file);
    return kb;
  }

  /// @brief At start: the domain KB with ~domain_learned_file (moved aside if it does not
  /// load); fills c.added_text and c.num_added.
  std::unique_ptr<krr::plog::Reasoner> loadDomainKb(Committed& c) {
    if (std::filesystem::exists(params_.domain_learned_file)) {
      const std::string added = krr::readFile(params_.domain_learned_file);
      try {
        auto with = buildDomainKb("");
        c.num_added = with->addStatements(added, "added", params_.domain_learned_file);
        with->answerProgramQueries();
        c.added_text = added;
        return with;
      } catch (const krr::Error& e) {
        moveAside(params_.domain_learned_file, e.what());
        c.num_added = 0;
      }
    }
    return buildDomainKb("");
  }

  /// @brief A navigation KB with the learned text `learned` ("" = nothing learned).
  std::unique_ptr<krr::kb::NavigationKnowledge> buildNavigationKb(const std::string& learned) const {
    auto nav = std::make_unique<krr::kb::NavigationKnowledge>(*domain_.grid,
                                                               domain_.knowledge_files);
    nav->reasoner().setLimits(callLimits());
    nav->reasoner().setBackend(params_.backend);
    if (!learned.empty()) nav->loadLearnedText(learned, params_.learned_file);
    return nav;
  }

  /// @brief At start: the navigation KB with ~learned_file (moved aside if it does not load);
  /// fills c.learned_text and c.total_learned.
  std::unique_ptr<krr::kb::NavigationKnowledge> loadNavigationKb(Committed& c) {
    if (std::filesystem::exists(params_.learned_file)) {
      try {
        auto nav = buildNavigationKb(krr::readFile(params_.learned_file));
        nav->buildModel({});  // a file that loads but gives no model is as unusable
        c.learned_text = nav->learnedText();
        c.total_learned = nav->learnedEntries().size();
        return nav;
      } catch (const krr::Error& e) {
        moveAside(params_.learned_file, e.what());
      }
    }
    c.learned_text.clear();
    c.total_learned = 0;
    return buildNavigationKb("");
  }

  // --- the pool of copies -------------------------------------------------------------------
  /// @brief A copy of the knowledge bases, taken from the pool with the snapshot it must
  /// reflect (taken together, so the copy is never newer than the snapshot); returned to the
  /// pool when the lease ends unless discarded.
  class Lease {
   public:
    explicit Lease(ReasonerNode& node) : node_(node) {
      std::lock_guard<std::mutex> lock(node.pool_mutex_);
      snap = node.committed_;
      if (!node.idle_.empty()) {
        copy = std::move(node.idle_.back());
        node.idle_.pop_back();
      } else {
        copy = std::make_unique<Copy>();
      }
    }
    ~Lease() {
      if (!copy || discard) return;
      std::lock_guard<std::mutex> lock(node_.pool_mutex_);
      if (node_.idle_.size() < static_cast<std::size_t>(node_.params_.threads))
        node_.idle_.push_back(std::move(copy));
    }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;

    std::shared_ptr<const Committed> snap;
    std::unique_ptr<Copy> copy;
    /// Not returned to the pool: changed without a commit, or a computation on it failed. A
    /// reasoner whose grounding stopped at a budget is not reused (the next query on it could
    /// crash in Reasoner::trimLog, seen with a grounding budget error followed by a query).
    bool discard = false;

   private:
    ReasonerNode& node_;
  };

  /// @brief The lease's domain KB at its snapshot's version (rebuilt when older: cheap).
  krr::plog::Reasoner& domainOf(Lease& l) {
    Copy& c = *l.copy;
    if (!c.domain || c.domain_version != l.snap->domain_version) {
      c.domain.reset();
      c.domain = buildDomainKb(l.snap->added_text);
      c.domain_version = l.snap->domain_version;
    }
    return *c.domain;
  }

  /// @brief The lease's navigation KB at its snapshot's version: the learned deltas since the
  /// copy's version are replayed (the groundings stay and are patched), else it is rebuilt.
  krr::kb::NavigationKnowledge& navOf(Lease& l) {
    Copy& c = *l.copy;
    if (c.nav && c.nav_version == l.snap->nav_version) return *c.nav;
    if (c.nav && c.nav_version < l.snap->nav_version) {
      std::vector<std::shared_ptr<const NavDelta>> todo;
      {
        std::lock_guard<std::mutex> lock(pool_mutex_);
        for (const auto& d : deltas_)
          if (d->version > c.nav_version && d->version <= l.snap->nav_version) todo.push_back(d);
      }
      if (todo.size() == l.snap->nav_version - c.nav_version) {
        try {
          for (const auto& d : todo) {
            for (const auto& [time, list] : d->pairs) c.nav->addLearned(list, time);
            if (!d->area_time.empty()) c.nav->setLearnedAreas(d->area_time, d->area_statements);
            c.nav_version = d->version;
          }
          return *c.nav;
        } catch (const krr::Error& e) {
          ROS_WARN_NAMED(kLog, "replaying learned knowledge on a copy failed (%s): rebuilding it",
                         e.what());
        }
      }
    }
    c.nav.reset();
    c.nav = buildNavigationKb(l.snap->learned_text);
    c.nav_version = l.snap->nav_version;
    return *c.nav;
  }

  // --- calls under a deadline ---------------------------------------------------------------
  /// @brief Run `work(job, deadline)` on a computation thread and wait for it until the call's
  /// deadline (~query_seconds from now) plus a short grace for the core's own budget errors,
  /// which name the statement, to arrive first. Past it, the computation is abandoned and the
  /// call refused, unless it is committing an update (then its end is awaited: a commit only
  /// writes two files). Every exception of `work` is rethrown here.
  template <class Work>
  void runWithDeadline(const std::string& what, Work work) {
    const Clock::time_point deadline =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(
                           std::chrono::duration<double>(params_.query_seconds));
    const Clock::time_point watchdog =
        deadline + std::chrono::milliseconds(kGraceMs);
    {
      std::unique_lock<std::mutex> lock(slots_mutex_);
      if (!slots_cv_.wait_until(lock, deadline, [&] { return running_ < max_running_; }))
        throw krr::plog::BudgetExceededError(
            what + ": no computation slot within ~query_seconds = " +
            secs(params_.query_seconds) + " s (" + std::to_string(running_) +
            " computations running, the most 2 x ~threads allows)");
      ++running_;
    }
    auto job = std::make_shared<Job>();
    try {
      std::thread([this, job, work, deadline]() mutable {
        try {
          work(*job, deadline);
        } catch (...) {
          job->error = std::current_exception();
        }
        {
          std::lock_guard<std::mutex> lock(job->m);
          job->done = true;
        }
        job->cv.notify_all();
        {
          std::lock_guard<std::mutex> lock(slots_mutex_);
          --running_;
        }
        slots_cv_.notify_all();
      }).detach();
    } catch (const std::system_error& e) {
      {
        std::lock_guard<std::mutex> lock(slots_mutex_);
        --running_;
      }
      slots_cv_.notify_all();
      throw krr::Error(what + ": cannot start a computation thread: " + e.what());
    }
    std::unique_lock<std::mutex> lock(job->m);
    if (!job->cv.wait_until(lock, watchdog, [&] { return job->done; })) {
      if (job->committing) {
        job->cv.wait(lock, [&] { return job->done; });
      } else {
        job->abandoned = true;
        throw krr::plog::BudgetExceededError(
            what + " took longer than ~query_seconds = " + secs(params_.query_seconds) +
            " s: refused, its computation abandoned");
      }
    }
    if (job->error) std::rethrow_exception(job->error);
  }
  static constexpr int kGraceMs = 250;

  /// @brief The message of a refused call: a budget the core exhausted is said to be the
  /// call's ~query_seconds (the core's budgets are what was left of it).
  std::string refusal(const std::exception& e) const {
    const std::string what = e.what();
    if (dynamic_cast<const krr::plog::BudgetExceededError*>(&e) &&
        what.find("~query_seconds") == std::string::npos)
      return "over the call's budget ~query_seconds = " + secs(params_.query_seconds) + " s: " +
             what;
    return what;
  }

  // --- services -----------------------------------------------------------------------------
  bool query(krr_msgs::QueryProbability::Request& req, krr_msgs::QueryProbability::Response& res) {
    try {
      const std::string kb_name = req.knowledge_base;
      if (!(kb_name.empty() || kb_name == "domain" || kb_name == "navigation"))
        throw krr::ConfigError("knowledge_base '" + kb_name +
                               "' is neither 'domain' nor 'navigation'");
      if (req.query.empty() == req.attribute.empty())
        throw krr::ConfigError("give exactly one of 'query' and 'attribute'");
      auto out = std::make_shared<krr_msgs::QueryProbability::Response>();
      runWithDeadline("query", [this, req, out](Job&, Clock::time_point deadline) {
        Lease lease(*this);
        lease.discard = true;  // kept only if the query ends normally (see Lease::discard)
        krr::plog::Reasoner& kb =
            req.knowledge_base == "navigation" ? navOf(lease).reasoner() : domainOf(lease);
        kb.setLimits(limitsUntil(deadline, "the query"));
        if (!req.query.empty()) {
          out->probability = kb.probability(req.query);
          out->message = "P(" + req.query + ") = " + std::to_string(out->probability);
        } else {
          for (const krr::plog::ValueProb& vp : kb.distribution(req.attribute, req.evidence)) {
            out->values.push_back(vp.value);
            out->probabilities.push_back(vp.probability);
          }
          out->message = "distribution of " + req.attribute + ": " +
                         std::to_string(out->values.size()) + " value(s)";
        }
        out->success = true;
        lease.discard = false;
      });
      res = *out;
      ROS_DEBUG_NAMED(kLog, "%s", res.message.c_str());
    } catch (const std::exception& e) {
      res = krr_msgs::QueryProbability::Response();
      res.success = false;
      res.message = refusal(e);
      const std::string q = req.query + req.attribute;
      ROS_WARN_NAMED(kLog, "query '%s%s' refused: %s",
                     q.size() > 200 ? q.substr(0, 200).c_str() : q.c_str(),
                     q.size() > 200 ? "..." : "", e.what());
    }
    return true;
  }

  bool add(krr_msgs::AddKnowledge::Request& req, krr_msgs::AddKnowledge::Response& res) {
    const krr_msgs::KnowledgeUpdate& u = req.update;
    try {
      auto out = std::make_shared<krr_msgs::AddKnowledge::Response>();
      runWithDeadline("update", [this, u, out](Job& job, Clock::time_point deadline) {
        addUnderDeadline(u, *out, job, deadline);
      });
      res = *out;
      ROS_INFO_NAMED(kLog, "update from '%s': %s; %u learned in total, saved to %s",
                     u.source.c_str(), res.message.c_str(), res.total_learned,
                     params_.learned_file.c_str());
    } catch (const std::exception& e) {
      res = krr_msgs::AddKnowledge::Response();
      res.success = false;
      res.total_learned = static_cast<std::uint32_t>(snapshot()->total_learned);
      res.message = std::string("update refused, nothing changed: ") + refusal(e);
      ROS_WARN_NAMED(kLog, "update from '%s' refused: %s", u.source.c_str(), e.what());
    }
    return true;
  }

  std::shared_ptr<const Committed> snapshot() {
    std::lock_guard<std::mutex> lock(pool_mutex_);
    return committed_;
  }

  /// @brief An update, on a computation thread: validated completely on copies, then
  /// committed (files, then the next snapshot) unless the call was abandoned before.
  void addUnderDeadline(const krr_msgs::KnowledgeUpdate& u, krr_msgs::AddKnowledge::Response& res,
                        Job& job, Clock::time_point deadline) {
    std::unique_lock<std::mutex> serial(update_mutex_);  // one update at a time
    // Validate everything before changing anything.
    const auto pairs = krr_ros::toKnownPairs(u.atoms, *domain_.space, times_);
    const bool hasAreas = u.area_statements.find_first_not_of(" \t\r\n") != std::string::npos;
    const bool hasStatements = u.statements.find_first_not_of(" \t\r\n") != std::string::npos;
    if (u.atoms.empty() && !hasAreas && !hasStatements)
      throw krr::ConfigError("the update holds neither atoms, area knowledge nor statements");
    if (hasAreas && std::find(times_.begin(), times_.end(), u.area_time) == times_.end())
      throw krr::ConfigError("area_time '" + u.area_time + "' is not a time of day of the "
                             "navigation knowledge base");
    Lease lease(*this);  // the latest snapshot: no other update can commit before this one
    const Committed& snap = *lease.snap;
    const std::string tag = "update" + std::to_string(++updates_);
    const std::string where = "<update from " + u.source + ">";
    std::unique_ptr<krr::plog::Reasoner> domain_next;
    if (hasStatements) {
      // On a new copy: no reasoner in use is touched by statements that are refused.
      domain_next = buildDomainKb(snap.added_text);
      domain_next->setLimits(limitsUntil(deadline, "the statements' check"));
      res.statements_added =
          static_cast<std::uint32_t>(domain_next->addStatements(u.statements, tag, where));
      try {
        domain_next->answerProgramQueries();
      } catch (const krr::plog::BudgetExceededError&) {
        throw;
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
        krr::plog::groundProgram(domain_next->program(), all,
                                 limitsUntil(deadline, "grounding the statements"));
      } catch (const krr::plog::BudgetExceededError&) {
        throw;
      } catch (const krr::Error&) {
        // outside the native grounder's fragment: the query check above decides
      }
      domain_next->setLimits(callLimits());
    }
    const std::string added_next =
        hasStatements ? snap.added_text + "% added by " + (u.source.empty() ? "?" : u.source) +
                            "\n" + u.statements + "\n"
                      : snap.added_text;
    // The learned knowledge on the lease's copy, which is discarded unless the commit succeeds.
    lease.discard = true;
    std::string learned_next = snap.learned_text;
    std::size_t total = snap.total_learned;
    const bool navChanges = !u.atoms.empty() || hasAreas;
    if (navChanges) {
      krr::kb::NavigationKnowledge& nav = navOf(lease);
      nav.reasoner().setLimits(limitsUntil(deadline, "applying the learned knowledge"));
      for (const auto& [time, list] : pairs)
        res.atoms_added += static_cast<std::uint32_t>(nav.addLearned(list, time));
      if (hasAreas) nav.setLearnedAreas(u.area_time, u.area_statements);
      nav.reasoner().setLimits(callLimits());
      learned_next = nav.learnedText();
      total = nav.learnedEntries().size();
    }
    {
      std::lock_guard<std::mutex> lock(job.m);
      if (job.abandoned)  // the call has answered "refused": nothing may change now
        throw krr::plog::BudgetExceededError("update abandoned at its deadline");
      job.committing = true;
    }
    // Write both files as one transaction; if that fails, the old contents are written back.
    try {
      krr_ros::ensureParentDirectory(params_.learned_file);
      krr_ros::ensureParentDirectory(params_.domain_learned_file);
      krr::FileTransaction t(journalPath());
      t.write(params_.learned_file, learned_next);
      if (hasStatements) t.write(params_.domain_learned_file, added_next);
      t.commit();
    } catch (...) {
      restoreFiles(snap, hasStatements);
      throw;
    }
    // The next snapshot, atomically for every later call.
    auto next = std::make_shared<Committed>(snap);
    next->added_text = added_next;
    next->num_added += res.statements_added;
    next->learned_text = learned_next;
    next->total_learned = total;
    if (hasStatements) ++next->domain_version;
    if (navChanges) ++next->nav_version;
    auto delta = std::make_shared<NavDelta>();
    delta->version = next->nav_version;
    delta->pairs = pairs;
    if (hasAreas) {
      delta->area_time = u.area_time;
      delta->area_statements = u.area_statements;
    }
    {
      std::lock_guard<std::mutex> lock(pool_mutex_);
      committed_ = next;
      if (navChanges) {
        deltas_.push_back(delta);
        while (deltas_.size() > kMaxDeltas) deltas_.pop_front();
      }
    }
    // The lease's copy is now exactly the new snapshot: back to the pool.
    if (domain_next) {
      lease.copy->domain = std::move(domain_next);
      lease.copy->domain_version = next->domain_version;
    } else if (lease.copy->domain && lease.copy->domain_version == snap.domain_version) {
      lease.copy->domain_version = next->domain_version;
    }
    if (navChanges) lease.copy->nav_version = next->nav_version;
    else if (lease.copy->nav && lease.copy->nav_version == snap.nav_version)
      lease.copy->nav_version = next->nav_version;
    lease.discard = false;
    res.total_learned = static_cast<std::uint32_t>(total);
    res.success = true;
    res.message = "added " + std::to_string(res.atoms_added) + " learned distribution(s)" +
                  (hasAreas ? ", area knowledge for " + u.area_time : std::string()) + " and " +
                  std::to_string(res.statements_added) + " statement(s)";
    updates_pub_.publish(u);
  }
  static constexpr std::size_t kMaxDeltas = 64;

  /// @brief Undo a failed commit: the files get their old contents back (replacing the
  /// update's journal, if it was written). The snapshot never changed.
  void restoreFiles(const Committed& snap, bool statements) {
    try {
      krr::FileTransaction undo(journalPath());
      undo.write(params_.learned_file, snap.learned_text);
      if (statements) undo.write(params_.domain_learned_file, snap.added_text);
      undo.commit();
    } catch (const std::exception& e) {
      ROS_ERROR_NAMED(kLog, "after a failed update, the old knowledge files could not be "
                      "written back: %s", e.what());
    }
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
      auto out = std::make_shared<krr_msgs::BuildTaskModel::Response>();
      runWithDeadline("build_task_model", [this, req, out](Job&, Clock::time_point deadline) {
        Lease lease(*this);
        lease.discard = true;  // kept only if the build ends normally (see Lease::discard)
        krr::kb::NavigationKnowledge& nav = navOf(lease);
        nav.reasoner().setLimits(limitsUntil(deadline, "the model build"));
        const krr::kb::NavModel model =
            nav.buildModel(req.times, req.discount > 0 ? req.discount : params_.discount);
        krr_ros::fillNavigationModel(model, *domain_.space, out.get());
        out->success = true;
        lease.discard = false;
        out->message = "navigation model: " + std::to_string(out->num_states) + " states, " +
                       std::to_string(out->next_states.size()) + " transitions, " +
                       std::to_string(out->num_learned) + " learned pairs";
      });
      res = *out;
      ROS_INFO_NAMED(kLog, "%s (built in %.2f s)", res.message.c_str(), clock.seconds());
    } catch (const std::exception& e) {
      res = krr_msgs::BuildTaskModel::Response();
      res.success = false;
      res.message = refusal(e);
      ROS_WARN_NAMED(kLog, "build_task_model '%s' refused: %s", req.task.c_str(), e.what());
    }
    return true;
  }

  ReasonerParams params_;
  krr::kb::NavDomain domain_;  ///< grid and state space: read-only after start
  std::vector<std::pair<std::string, std::string>> domain_texts_;  ///< (file, text), read once
  std::vector<std::string> times_;                                 ///< read-only after start
  // pool_mutex_ guards committed_, deltas_ and idle_.
  std::mutex pool_mutex_;
  std::shared_ptr<const Committed> committed_;
  std::deque<std::shared_ptr<const NavDelta>> deltas_;
  std::vector<std::unique_ptr<Copy>> idle_;
  // Computation slots: at most max_running_ computations, abandoned ones included.
  std::mutex slots_mutex_;
  std::condition_variable slots_cv_;
  std::size_t running_ = 0;
  std::size_t max_running_ = 8;
  std::mutex update_mutex_;   ///< one update at a time (held by its computation)
  unsigned long updates_ = 0;  ///< guarded by update_mutex_
  ros::Publisher updates_pub_;
  ros::ServiceServer query_srv_, add_srv_, build_srv_;
};

}  // namespace

int main(int argc, char** argv) {
  krr_ros::exitOnHelp(argc, argv, "reasoner_node");
  ros::init(argc, argv, "reasoner");
  ros::NodeHandle pnh("~");
  std::unique_ptr<ReasonerNode> node;
  int threads = 1;
  try {
    krr_ros::ParamReader reader(pnh);
    ReasonerParams params = ReasonerParams::read(reader);
    ROS_INFO_NAMED(kLog, "seed %lu, base_dir %s", static_cast<unsigned long>(params.seed),
                   reader.baseDir().c_str());
    threads = params.threads;
    node = std::make_unique<ReasonerNode>(pnh, std::move(params));
  } catch (const std::exception& e) {
    ROS_FATAL_NAMED(kLog, "cannot start: %s", e.what());
    return 1;
  }
  ROS_INFO_NAMED(kLog, "ready");
  ros::AsyncSpinner spinner(static_cast<std::uint32_t>(threads));
  spinner.start();
  ros::waitForShutdown();
  spinner.stop();
  // Computations abandoned at their deadline may still run: they stop at their next budget
  // check. Wait a little; past that, end without destroying what they use.
  if (!node->drain(2.0)) {
    std::fprintf(stderr, "[ WARN] reasoner_node: shutting down with computations still "
                 "running (abandoned at their deadline)\n");
    std::fflush(stdout);
    std::fflush(stderr);
    std::_Exit(0);
  }
  return 0;
}
