#include "krr_ros/reasoner_node.h"

#include <krr_msgs/KnowledgeUpdate.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <system_error>
#include <thread>
#include <utility>

#include "krr_core/common/errors.h"
#include "krr_core/common/format.h"
#include "krr_core/common/resources.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_ros/conversions.h"
#include "krr_ros/site_check.h"

#include <filesystem>

#include "krr_core/dialog/dialog_config.h"

namespace krr_ros {

namespace {

/// @brief Seconds as text for messages ("2", "0.5").
std::string secs(double s) { return krr::formatNumber(s, 4); }

/// @brief The core's settings of the knowledge files: loads and kept KBs get a whole call's
/// budget.
krr::kb::KnowledgeStoreOptions storeOptions(const ReasonerNode::Params& p) {
  krr::kb::KnowledgeStoreOptions o;
  o.domain_files = p.domain_files;
  o.domain_learned_file = p.domain_learned_file;
  o.learned_file = p.learned_file;
  o.backend = p.backend;
  o.limits.max_ground_seconds = o.limits.max_inference_seconds = p.query_seconds;
  return o;
}

}  // namespace

/// @brief What one accepted update did to the navigation KB, replayed on older copies.
struct ReasonerNode::NavDelta {
  std::uint64_t version = 0;  ///< nav_version after it
  std::map<std::string, std::vector<krr::mdp::KnownPair>> pairs;
  std::string area_time, area_statements;
};

/// @brief One computation's knowledge bases (a pool keeps them between calls). Each part is
/// built when a call first needs it and carries the version of the snapshot it reflects.
struct ReasonerNode::Copy {
  std::uint64_t domain_version = 0;
  std::unique_ptr<krr::plog::Reasoner> domain;
  std::uint64_t nav_version = 0;
  std::unique_ptr<krr::kb::NavigationKnowledge> nav;
};

/// @brief A call and its computation thread: the computation reports here; the call abandons
/// it at its deadline, unless it has passed its commit point (an update writing its files).
struct ReasonerNode::Job {
  std::mutex m;
  std::condition_variable cv;
  bool done = false;
  bool abandoned = false;
  bool committing = false;
  std::exception_ptr error;
};

/// @brief A copy of the knowledge bases, taken from the pool with the snapshot it must reflect
/// (taken together, so the copy is never newer than the snapshot); returned to the pool when
/// the lease ends unless discarded.
class ReasonerNode::Lease {
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

  std::shared_ptr<const krr::kb::KnowledgeState> snap;
  std::unique_ptr<Copy> copy;
  /// Not returned to the pool: changed without a commit, or a computation on it failed. A
  /// reasoner whose grounding stopped at a budget is not reused (the next query on it could
  /// crash in Reasoner::trimLog, seen with a grounding budget error followed by a query).
  bool discard = false;

 private:
  ReasonerNode& node_;
};

namespace {

/// @brief ~domain_files with a site folder: the base dialog config's knowledge (the office's,
/// as config/reasoner_node.yaml names it) replaced by the site's; other files (a test's extra
/// knowledge) kept. A list without the base knowledge is kept as given, and the site check
/// tells whether it holds the site's.
std::string dialogKnowledge(const ParamReader& r) {
  return krr::dialog::loadDialogConfig(r.resolve("config/dialog.yaml")).office_plog;
}

std::vector<std::string> siteDomainFiles(const ParamReader& r, std::vector<std::string> files,
                                         const krr::site::Site& site) {
  namespace fs = std::filesystem;
  const std::string base = dialogKnowledge(r);
  std::error_code ec;
  for (std::string& f : files)
    if (fs::equivalent(f, base, ec)) f = site.knowledge();
  return files;
}

}  // namespace

ReasonerNode::Params ReasonerNode::Params::read(ParamReader& r) {
  Params p;
  p.seed = r.seed();
  // Default: the dialog's knowledge (config/dialog.yaml's knowledge.office, or the site
  // folder's), its one home; a list replaces it (a test's extra knowledge).
  const bool givenFiles = r.has("domain_files");
  p.domain_files = r.paths("domain_files", {dialogKnowledge(r)}, true);
  if (p.domain_files.empty()) r.refuse("domain_files", "[]", "at least one P-log file is required");
  p.nav = NavKbParams::read(r);
  if (p.nav.site)
    p.domain_files = givenFiles ? siteDomainFiles(r, p.domain_files, *p.nav.site)
                                : std::vector<std::string>{p.nav.site->knowledge()};
  const std::string data = defaultDataDirectory();
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
  p.check_site = readCheckSite(r);
  r.rejectUnknown();
  // The site's files agree before anything is loaded (site_check.h): the knowledge this node
  // loads (~domain_files) is the dialog's, its navigation config names the places.
  if (p.check_site) requireConsistentSite(r, {p.nav.navigation_config, "", "", p.domain_files, p.nav.site.get()});
  return p;
}

ReasonerNode::ReasonerNode(ros::NodeHandle& /*nh*/, ros::NodeHandle& pnh, Params params)
    : params_(std::move(params)),
      domain_(params_.nav.loadDomain()),
      store_(storeOptions(params_), domain_.grid, domain_.knowledge_files) {
  krr::Stopwatch clock;
  krr::kb::KnowledgeStore::Opened opened = store_.open();
  logStart(opened.report);
  auto first = std::make_unique<Copy>();
  auto committed = std::make_shared<krr::kb::KnowledgeState>(opened.state);
  first->domain = std::move(opened.domain);
  first->nav = std::move(opened.nav);
  first->domain_version = committed->domain_version;
  first->nav_version = committed->nav_version;
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

ReasonerNode::~ReasonerNode() = default;

int ReasonerNode::spin() {
  ROS_INFO_NAMED(kLog, "ready");
  ros::AsyncSpinner spinner(static_cast<std::uint32_t>(params_.threads));
  spinner.start();
  ros::waitForShutdown();
  spinner.stop();
  // Computations abandoned at their deadline may still run: they stop at their next budget
  // check. Wait a little; past that, end without destroying what they use.
  if (!drain(2.0)) {
    std::fprintf(stderr, "[ WARN] reasoner_node: shutting down with computations still "
                 "running (abandoned at their deadline)\n");
    std::fflush(stdout);
    std::fflush(stderr);
    std::_Exit(0);
  }
  return 0;
}

bool ReasonerNode::drain(double seconds) {
  std::unique_lock<std::mutex> lock(slots_mutex_);
  return slots_cv_.wait_for(lock, std::chrono::duration<double>(seconds),
                            [&] { return running_ == 0; });
}

/// @brief What the store's recovery did, in the node's log: an interrupted update finished,
/// files moved aside, temporaries of killed writes removed.
void ReasonerNode::logStart(const krr::kb::StartReport& report) const {
  if (report.journal_files)
    ROS_WARN_NAMED(kLog, "finished an interrupted knowledge update (%zu file(s)) from %s",
                   report.journal_files, store_.journalPath().c_str());
  for (const std::string& orphan : report.orphans)
    ROS_WARN_NAMED(kLog, "removed %s, left by a write that was killed", orphan.c_str());
  for (const krr::kb::StartReport::SetAside& s : report.set_aside)
    ROS_WARN_NAMED(kLog, "%s cannot be loaded (%s); moved aside to %s, starting without it",
                   s.path.c_str(), s.why.c_str(),
                   s.aside.empty() ? "(rename failed)" : s.aside.c_str());
}

/// @brief The budgets of a grounding and inference that must end by `deadline`: what is left
/// of the call's time (a call past its deadline is refused before it starts one).
krr::plog::GroundingLimits ReasonerNode::limitsUntil(Clock::time_point deadline,
                                                     const char* phase) const {
  const double left = std::chrono::duration<double>(deadline - Clock::now()).count();
  if (left <= 0.0)
    throw krr::plog::BudgetExceededError(std::string("~query_seconds = ") +
                                         secs(params_.query_seconds) + " s spent before " + phase);
  krr::plog::GroundingLimits l;
  l.max_ground_seconds = l.max_inference_seconds = left;
  return l;
}

/// @brief The lease's domain KB at its snapshot's version (rebuilt when older: cheap).
krr::plog::Reasoner& ReasonerNode::domainOf(Lease& l) {
  Copy& c = *l.copy;
  if (!c.domain || c.domain_version != l.snap->domain_version) {
    c.domain.reset();
    c.domain = store_.buildDomainKb(l.snap->added_text);
    c.domain_version = l.snap->domain_version;
  }
  return *c.domain;
}

/// @brief The lease's navigation KB at its snapshot's version: the learned deltas since the
/// copy's version are replayed (the groundings stay and are patched), else it is rebuilt.
krr::kb::NavigationKnowledge& ReasonerNode::navOf(Lease& l) {
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
  c.nav = store_.buildNavigationKb(l.snap->learned_text);
  c.nav_version = l.snap->nav_version;
  return *c.nav;
}

/// @brief Run `work(job, deadline)` on a computation thread and wait for it until the call's
/// deadline (~query_seconds from now) plus a short grace for the core's own budget errors,
/// which name the statement, to arrive first. Past it, the computation is abandoned and the
/// call refused, unless it is committing an update (then its end is awaited: a commit only
/// writes two files). Every exception of `work` is rethrown here.
template <class Work>
void ReasonerNode::runWithDeadline(const std::string& what, Work work) {
  const Clock::time_point deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(params_.query_seconds));
  const Clock::time_point watchdog = deadline + std::chrono::milliseconds(kGraceMs);
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

/// @brief The message of a refused call: a budget the core exhausted is said to be the
/// call's ~query_seconds (the core's budgets are what was left of it).
std::string ReasonerNode::refusal(const std::exception& e) const {
  const std::string what = e.what();
  if (dynamic_cast<const krr::plog::BudgetExceededError*>(&e) &&
      what.find("~query_seconds") == std::string::npos)
    return "over the call's budget ~query_seconds = " + secs(params_.query_seconds) + " s: " + what;
  return what;
}

std::shared_ptr<const krr::kb::KnowledgeState> ReasonerNode::snapshot() {
  std::lock_guard<std::mutex> lock(pool_mutex_);
  return committed_;
}

// --- services -------------------------------------------------------------------------------
bool ReasonerNode::query(krr_msgs::QueryProbability::Request& req,
                         krr_msgs::QueryProbability::Response& res) {
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

bool ReasonerNode::add(krr_msgs::AddKnowledge::Request& req,
                       krr_msgs::AddKnowledge::Response& res) {
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

/// @brief An update, on a computation thread: validated by the store on copies, then committed
/// (files, then the next snapshot) unless the call was abandoned before.
void ReasonerNode::addUnderDeadline(const krr_msgs::KnowledgeUpdate& u,
                                    krr_msgs::AddKnowledge::Response& res, Job& job,
                                    Clock::time_point deadline) {
  std::unique_lock<std::mutex> serial(update_mutex_);  // one update at a time
  krr::kb::KnowledgeUpdate update;
  update.source = u.source;
  update.pairs = toKnownPairs(u.atoms, *domain_.space, store_.times());
  update.area_time = u.area_time;
  update.area_statements = u.area_statements;
  update.statements = u.statements;
  Lease lease(*this);  // the latest snapshot: no other update can commit before this one
  const krr::kb::KnowledgeState& snap = *lease.snap;
  krr::kb::PreparedUpdate next_files = store_.prepare(
      update, snap,
      [&]() -> krr::kb::NavigationKnowledge& {
        lease.discard = true;  // changed without a commit until the commit succeeds
        return navOf(lease);
      },
      [&](const char* phase) { return limitsUntil(deadline, phase); });
  lease.discard = true;
  {
    std::lock_guard<std::mutex> lock(job.m);
    if (job.abandoned)  // the call has answered "refused": nothing may change now
      throw krr::plog::BudgetExceededError("update abandoned at its deadline");
    job.committing = true;
  }
  std::string restore_error;
  std::shared_ptr<const krr::kb::KnowledgeState> next;
  try {
    next = std::make_shared<const krr::kb::KnowledgeState>(
        store_.commit(next_files, snap, &restore_error));
  } catch (...) {
    if (!restore_error.empty())
      ROS_ERROR_NAMED(kLog, "after a failed update, the old knowledge files could not be "
                      "written back: %s", restore_error.c_str());
    throw;
  }
  // The next snapshot, atomically for every later call.
  auto delta = std::make_shared<NavDelta>();
  delta->version = next->nav_version;
  delta->pairs = update.pairs;
  if (update.hasAreas()) {
    delta->area_time = update.area_time;
    delta->area_statements = update.area_statements;
  }
  {
    std::lock_guard<std::mutex> lock(pool_mutex_);
    committed_ = next;
    if (next_files.navigation) {
      deltas_.push_back(delta);
      while (deltas_.size() > kMaxDeltas) deltas_.pop_front();
    }
  }
  // The lease's copy is now exactly the new snapshot: back to the pool.
  if (next_files.domain) {
    lease.copy->domain = std::move(next_files.domain);
    lease.copy->domain_version = next->domain_version;
  } else if (lease.copy->domain && lease.copy->domain_version == snap.domain_version) {
    lease.copy->domain_version = next->domain_version;
  }
  if (next_files.navigation) lease.copy->nav_version = next->nav_version;
  else if (lease.copy->nav && lease.copy->nav_version == snap.nav_version)
    lease.copy->nav_version = next->nav_version;
  lease.discard = false;
  res.statements_added = static_cast<std::uint32_t>(next_files.statements_added);
  res.atoms_added = static_cast<std::uint32_t>(next_files.atoms_added);
  res.total_learned = static_cast<std::uint32_t>(next->total_learned);
  res.success = true;
  res.message = "added " + std::to_string(res.atoms_added) + " learned distribution(s)" +
                (update.hasAreas() ? ", area knowledge for " + u.area_time : std::string()) +
                " and " + std::to_string(res.statements_added) + " statement(s)";
  updates_pub_.publish(u);
}

bool ReasonerNode::build(krr_msgs::BuildTaskModel::Request& req,
                         krr_msgs::BuildTaskModel::Response& res) {
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
      fillNavigationModel(model, *domain_.space, out.get());
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

}  // namespace krr_ros
