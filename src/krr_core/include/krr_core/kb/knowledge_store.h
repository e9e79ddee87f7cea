/**
 * @file knowledge_store.h
 * @brief The robot's knowledge files and the one transaction that changes them.
 *
 * Two P-log knowledge bases live on disk beside the configured ones: the statements added to
 * the domain KB (`domain_learned_file`) and the learned navigation knowledge (`learned_file`).
 * An update reaches them only through this class, so the guarantees hold wherever it runs (the
 * ROS reasoner node, a test, a tool):
 *  - validated completely before anything changes: statements on a scratch copy of the domain
 *    KB (parsed, the KB's queries answered, the whole program ground under the budget), learned
 *    knowledge on a navigation KB the caller throws away on refusal. A refused update changes
 *    nothing, neither in memory nor on disk;
 *  - committed as one krr::FileTransaction (journal `learned_file + ".journal"`, written
 *    atomically: it is the commit point), so a kill never leaves half an update;
 *  - recovered at open(): an interrupted transaction is finished, orphaned temporaries are
 *    removed, and a journal or learned file that cannot be used is moved aside
 *    ("<file>.corrupt-<UTC time>") and reported with its typed error, never a crash.
 *
 * The class keeps no current state: the caller holds the KnowledgeState it last committed
 * (the reasoner node publishes it as an immutable snapshot) and serialises updates (prepare on
 * the latest state, then commit). Building KBs runs on any number of threads at once.
 */
#pragma once

#include <atomic>
#include <cstdint>
#include <exception>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/mdp/rmax_model.h"
#include "krr_core/nav/nav_grid.h"
#include "krr_core/plog/budget.h"
#include "krr_core/plog/reasoner.h"

namespace krr {
namespace kb {

/// @brief One knowledge update, with its learned pairs already checked against the grid (the
/// ROS layer converts krr_msgs/KnowledgeUpdate's atoms to these).
struct KnowledgeUpdate {
  std::string source;  ///< who sent it: in error locations and in the added file's comments
  std::map<std::string, std::vector<mdp::KnownPair>> pairs;  ///< learned pairs by time of day
  std::string area_time;        ///< time of day of area_statements
  std::string area_statements;  ///< learned area knowledge (kb/area_knowledge.h); blank: none
  std::string statements;       ///< P-log statements for the domain KB; blank: none

  bool hasAreas() const;
  bool hasStatements() const;
  /// @brief Learned pairs or area knowledge: the navigation KB changes.
  bool changesNavigation() const { return !pairs.empty() || hasAreas(); }
};

/// @brief What the knowledge files hold. Versions count the changes of each KB, so a copy of a
/// KB can tell whether it is out of date.
struct KnowledgeState {
  std::uint64_t domain_version = 1;
  std::uint64_t nav_version = 1;
  std::string added_text;        ///< statements added to the domain KB (domain_learned_file)
  std::size_t num_added = 0;     ///< how many statements added_text holds
  std::string learned_text;      ///< learned navigation knowledge (learned_file)
  std::size_t total_learned = 0; ///< learned distributions in learned_text
};

/// @brief Where the knowledge comes from and goes to.
struct KnowledgeStoreOptions {
  std::vector<std::string> domain_files;  ///< domain KB, loaded in order (at least one)
  std::string domain_learned_file;        ///< added statements
  std::string learned_file;               ///< learned navigation knowledge
  plog::Backend backend = plog::Backend::Auto;
  plog::GroundingLimits limits;           ///< budgets of loads and of KBs kept between calls
};

/// @brief What open() found and did, for the caller to report.
struct StartReport {
  /// @brief A file that could not be used, moved out of the way and kept for inspection.
  struct SetAside {
    std::string path;           ///< the file
    std::string aside;          ///< where it is now; empty when the rename failed
    std::exception_ptr error;   ///< why: ParseError for a torn journal, the load's krr::Error
    std::string why;            ///< error's what()
  };
  std::size_t journal_files = 0;      ///< files an interrupted update's journal finished
  std::vector<SetAside> set_aside;    ///< in the order found: journal, statements, learned
  std::vector<std::string> orphans;   ///< temporaries of killed writes, removed
};

/// @brief An update validated on scratch copies: everything commit() writes, nothing written.
struct PreparedUpdate {
  /// The domain KB with the statements (null when the update has none): the copy callers
  /// keep for the next state.
  std::unique_ptr<plog::Reasoner> domain;
  std::string added_text;           ///< domain_learned_file's next content
  std::string learned_text;         ///< learned_file's next content
  std::size_t total_learned = 0;    ///< learned distributions after the update
  std::size_t statements_added = 0;
  std::size_t atoms_added = 0;      ///< learned distributions written
  bool statements = false;          ///< domain_learned_file changes
  bool navigation = false;          ///< learned_file's knowledge changes
};

/// @brief The knowledge files, their recovery at start and the update transaction.
class KnowledgeStore {
 public:
  /// @brief The budgets of one phase of an update, asked before it starts with the phase's
  /// name (e.g. "the statements' check"); it may throw plog::BudgetExceededError when the
  /// caller's time is already spent.
  using PhaseLimits = std::function<plog::GroundingLimits(const char* phase)>;
  /// @brief The navigation KB an update's learned knowledge is applied to, at the state the
  /// update is prepared on; asked only when needed. It is changed: the caller discards it
  /// unless the update is committed.
  using ScratchNavigation = std::function<NavigationKnowledge&()>;

  /**
   * @brief Reads the domain files (once: every later domain KB is built from their text).
   * Touches neither learned file: open() does.
   * @param grid the navigation domain's grid
   * @param navigation_files the navigation KB (geometry, then human knowledge)
   * @throws ConfigError (no domain file, learned files missing, equal), IoError (unreadable)
   */
  KnowledgeStore(KnowledgeStoreOptions options, std::shared_ptr<const nav::NavGrid> grid,
                 std::vector<std::string> navigation_files);

  /// @brief What open() loaded: the committed state and KBs that reflect it.
  struct Opened {
    KnowledgeState state;
    std::unique_ptr<plog::Reasoner> domain;
    std::unique_ptr<NavigationKnowledge> nav;
    StartReport report;
  };
  /**
   * @brief Start-up: finish an update a kill interrupted, remove temporaries of killed writes,
   * load both learned files (the learned navigation knowledge must also give a model). A torn
   * journal or a learned file that does not load is moved aside and reported; the store opens
   * without it. Sets times().
   * @throws IoError when the journal's files cannot be written (the journal is kept), and the
   * errors of loading the configured KBs.
   */
  Opened open();

  /// @brief A domain KB: the domain files plus `added` (a KnowledgeState's added_text).
  std::unique_ptr<plog::Reasoner> buildDomainKb(const std::string& added) const;
  /// @brief A navigation KB with the learned text `learned` ("" = nothing learned).
  std::unique_ptr<NavigationKnowledge> buildNavigationKb(const std::string& learned) const;

  /**
   * @brief Validate `update` against the committed state `state`, changing nothing but the
   * scratch navigation KB. @throws ConfigError (empty update, unknown area time),
   * UnknownSymbolError (a pair's time), ParseError / UnknownSymbolError (statements),
   * IncoherentError (statements that make the domain KB incoherent), BudgetExceededError.
   */
  PreparedUpdate prepare(const KnowledgeUpdate& update, const KnowledgeState& state,
                         const ScratchNavigation& scratch, const PhaseLimits& limits) const;

  /**
   * @brief Write a prepared update as one transaction: its commit point is the journal.
   * @return the state after it (versions of the changed KBs advanced).
   * @throws IoError when it could not be written: the old contents are then written back
   * through a new journal; if even that fails, `restore_error` (when given) says why, and the
   * journal finishes one of the two at the next open().
   */
  KnowledgeState commit(const PreparedUpdate& update, const KnowledgeState& state,
                        std::string* restore_error = nullptr) const;

  /// @brief The values of sort time of the navigation KB (set by open()).
  const std::vector<std::string>& times() const { return times_; }
  const KnowledgeStoreOptions& options() const { return options_; }
  /// @brief The journal of the update transaction.
  std::string journalPath() const { return options_.learned_file + ".journal"; }

 private:
  std::unique_ptr<plog::Reasoner> loadDomainKb(KnowledgeState& state, StartReport& report) const;
  std::unique_ptr<NavigationKnowledge> loadNavigationKb(KnowledgeState& state,
                                                        StartReport& report) const;
  /// @brief Check the statements on a new domain KB (at `state`), which is returned.
  std::unique_ptr<plog::Reasoner> checkStatements(const KnowledgeUpdate& update,
                                                  const KnowledgeState& state,
                                                  const PhaseLimits& limits,
                                                  std::size_t& added) const;

  KnowledgeStoreOptions options_;
  std::shared_ptr<const nav::NavGrid> grid_;
  std::vector<std::string> navigation_files_;
  std::vector<std::pair<std::string, std::string>> domain_texts_;  ///< (file, text)
  std::vector<std::string> times_;
  mutable std::atomic<unsigned long> updates_{0};  ///< tags of the updates' statements
};

}  // namespace kb
}  // namespace krr
