/**
 * @file engine.h
 * @brief Exact P-log inference on a ground network by variable elimination.
 *
 * Random attribute instances are the variables; each one contributes the factor
 * P(a(t) | parents) computed with P-log's rules (the applicable pr-atom, or the default: the
 * unassigned probability mass split evenly over the remaining possible values; value "undefined"
 * when no selection rule fires). Derived (non-random, dynamic) atoms are deterministic functions
 * of their random ancestors and are folded into the factors that mention them. Observations and
 * constraints are indicator factors; do() fixes an instance and removes its own factor.
 * Only instances relevant in the current context (after do() values have been substituted and
 * dead pr-atoms and rules dropped) are included, so independent exogenous attributes are never
 * enumerated jointly.
 */
#pragma once

#include <chrono>
#include <memory>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "krr_core/plog/grounder.h"

namespace krr {
namespace plog {

/// @brief A ground condition: a conjunction of dynamic literals plus a constant part
/// (static literals are evaluated by the caller into `constant`).
struct GCondition {
  std::vector<GLit> lits;
  bool constant = true;  ///< false: the condition can never hold
  bool truth = true;     ///< required truth value of the conjunction (obs(l, false))
};

/// @brief log2 of the largest table (factor) the native engine fills: a plan or an elimination
/// step beyond it is outside its fragment (OutsideFragmentError).
constexpr int kMaxFactorLog2 = 24;

/// @brief The tables an inference is about to fill (its plan, made after grounding and before
/// any row is evaluated): what Backend::Auto's cost estimate reads.
struct EnginePlan {
  double largest_log2 = 0;   ///< log2 rows of the largest table
  double rows = 0;           ///< rows of all tables
  std::size_t derived_rules = 0;  ///< ground rules of derived instances (evaluated per row)
  bool recursive = false;    ///< cyclic dependencies among derived atoms (fixpoint per row)
};

/// @brief Exact inference over one GroundProgram (which must outlive the engine).
class ExactEngine {
 public:
  explicit ExactEngine(const GroundProgram& g);

  /// @brief Wall-clock budget of the inference calls from now on (0: none); exhausting it
  /// throws BudgetExceededError from the next check point (factor rows, elimination steps).
  void setTimeBudget(double seconds);
  /// @brief Bytes by which inference may grow the heap (0: krr::memoryBudget()); `where` (the
  /// query) is named when it is exhausted (BudgetExceededError).
  void setMemoryBudget(std::size_t bytes, const SourceLocation& where);
  /// @brief Stop with CancelledError as soon as *flag is true (checked with the time budget).
  void setCancelFlag(const std::atomic<bool>* flag) { cancel_ = flag; }

  /// @brief Probability sums repaired during inference: "file:line:col: warning: ..." for
  /// each pr-atom set whose probabilities sum to 1 within rounding (|sum - 1| <= 1e-9 relative,
  /// more than floating-point noise) and were renormalised (see kSumTolerance in engine.cpp).
  const std::vector<std::string>& warnings() const { return warnings_; }

  /// @brief Before filling any table, the engine plans the tables of the inference (the
  /// relevant instances' CPTs with their parents, the constraints', derived conflicts' and
  /// conditions' indicators): when the largest has more than 2^log2_rows rows it throws
  /// CostlierError instead. Each row evaluates ground bodies, so the largest table is a lower
  /// bound on the work. Infinity (the default): no cap.
  /// With recursion among the ground derived atoms (a cyclic SCC, e.g. a transitive closure),
  /// every row re-evaluates it to a fixpoint, far more work per row than a solver's
  /// propagation: log2_rows_recursive applies instead.
  void setCostCap(double log2_rows, double log2_rows_recursive) {
    cost_cap_log2_ = log2_rows;
    cost_cap_recursive_log2_ = log2_rows_recursive;
  }
  /// @brief Called with the log2 rows of the largest planned table once the plan is made
  /// (grounding done, no row filled yet): Backend::Auto races clingo on the inference only.
  void setPlanCallback(std::function<void(const EnginePlan&)> callback) {
    on_plan_ = std::move(callback);
  }
  /// @brief log2 of the rows of the largest table planned by the last inference.
  double lastPlannedLog2() const { return last_planned_log2_; }
  /// @brief The plan of the last inference.
  const EnginePlan& lastPlan() const { return last_plan_; }

  /// @brief Intervention do(inst = value index); -1 removes it.
  void setFixed(int inst, int value);
  void clearFixed();

  /// @brief Unnormalised measures (Z(formula and evidence), Z(evidence)).
  /// @throws IncoherentError (sums above 1, empty dynamic ranges, conflicting pr-atoms).
  std::pair<double, double> measure(const std::vector<GCondition>& formula,
                                    const std::vector<GCondition>& evidence);

  /// @brief Unnormalised marginal of one instance over its domain plus a last entry for
  /// "undefined"; the sum is Z(evidence).
  std::vector<double> marginal(int inst, const std::vector<GCondition>& evidence);

  /// @brief Sparse marginal: (value index, unnormalised mass) for the values that can have
  /// mass (index = domain size for "undefined"); the masses sum to Z(evidence).
  std::vector<std::pair<int, double>> marginalSparse(int inst,
                                                     const std::vector<GCondition>& evidence);

  /// @brief Build an index of ground bodies keyed by literals on these instances, so that with
  /// them fixed only the matching pr-atoms and selection rules are inspected (table queries).
  void indexBy(const std::vector<int>& conditioning_instances);

  /// @brief Number of factors / largest factor size of the last inference (diagnostics).
  size_t lastFactorCount() const { return last_factors_; }
  size_t lastMaxFactorSize() const { return last_max_factor_; }

 private:
  struct Factor {
    std::vector<int> vars;
    std::vector<int> card;
    std::vector<double> t;
  };
  struct Item {  // one ground selection rule (kind 0) or pr-atom (kind 1)
    int kind;
    int index;
  };

  int card(int inst) const;
  bool bodyDead(const std::vector<GLit>& body) const;
  bool litDeadFixed(const GLit& l) const;
  void liveItems(int inst, std::vector<Item>& out) const;
  const std::vector<Item>& liveItemsCached(int inst);
  void scopeOfLit(const GLit& l, std::vector<int>& out);
  /// @brief Appends the random instances that the live selection rules and pr-atoms of inst
  /// read (its parents in the factor graph; duplicates possible).
  void scopeOfItems(int inst, std::vector<int>& out);
  void scopeOfInstance(int inst, std::vector<int>& out);
  bool holds(const GLit& l);
  bool atomHolds(int inst, int value);
  int valueOf(int inst);
  bool bodyHolds(const std::vector<GLit>& body);
  /// @brief The factors of a query: the relevant instances (collectRelevant, collectEvidence),
  /// the plan of their tables (planFactors, which may stop the query), then the tables.
  void buildFactors(const std::vector<const std::vector<GCondition>*>& seeds, int seed_inst,
                    std::vector<Factor>& factors);
  struct Relevance;
  /// @brief Adds the instances of scope not yet relevant (their states computed, their
  /// parents queued).
  void addRelevant(Relevance& r, const std::vector<int>& scope);
  /// @brief Adds the parents of the queued instances, transitively.
  void closeRelevant(Relevance& r);
  /// @brief The random instances the conditions (and seed_inst, and every selection over a
  /// dynamic range) depend on.
  void collectRelevant(const std::vector<const std::vector<GCondition>*>& seeds, int seed_inst,
                       Relevance& r);
  /// @brief The live constraints and the derived instances that may get two values, with the
  /// instances they depend on.
  void collectEvidence(Relevance& r);
  /// @brief The sizes of the tables about to be filled, reported as the plan (reportPlan).
  void planFactors(const std::vector<const std::vector<GCondition>*>& seeds, Relevance& r);
  /// @brief Records the plan and gives it to on_plan_. @throws CostlierError over the cost cap.
  void reportPlan(double largest, double rows);
  /// @brief One CPT per relevant instance, an indicator per constraint and per derived
  /// instance with two live values.
  void fillFactors(const Relevance& r, std::vector<Factor>& factors);
  void computeStates(int inst);
  void buildAtomSccs();
  void evaluateScc(int scc);
  struct PendingError {
    size_t factor;
    size_t row;
    std::string message;
  };
  void checkPendingErrors(const std::vector<Factor>& factors);
  /// @brief The conditional table of random instance inst given its parents, row by row
  /// (a row that breaks coherence is left zero and kept in pending_errors_).
  void buildCpt(int inst, Factor& f);
  struct CptRow;
  /// @brief The parents of inst (sorted). @throws OutsideFragmentError when inst is among them.
  std::vector<int> cptParents(int inst);
  /// @brief f's variables and cardinalities (inst first); returns its number of entries.
  /// @throws OutsideFragmentError over kMaxFactor entries.
  size_t cptScope(int inst, const std::vector<int>& parents, Factor& f);
  /// @brief One row of the table, for the parents' values in assign_. @throws IncoherentError
  void fillCptRow(const GInstance& gi, const std::vector<Item>& items, CptRow& r);
  /// @brief The live selection rule of gi that applies (-1: none). @throws IncoherentError
  /// when two apply.
  int firedSelection(const GInstance& gi, const std::vector<Item>& items);
  /// @brief Marks the values the selection may choose in r.possible; returns how many.
  int markPossibleValues(const GSelection& sel, CptRow& r);
  /// @brief The probabilities the applicable pr-atoms assign to possible values (newer
  /// knowledge generations override older ones), added to sum; returns how many values.
  /// @throws IncoherentError on two different probabilities of one generation.
  int assignProbabilities(const GInstance& gi, const std::vector<Item>& items,
                          const GSelection& sel, CptRow& r, double& sum);
  /// @brief Measure of each state of the random, unfixed instance inst together with the
  /// evidence (states_[inst] order; one entry when the instance is not in the result scope).
  std::vector<double> unnormalisedMarginal(int inst, const std::vector<GCondition>& evidence);
  /// @brief 0/1 factor over scope (sorted and made unique here): 1 where holds() is true for
  /// the assignment of the scope's instances (set in assign_ while holds() runs).
  /// @throws OutsideFragmentError with message too_large when the table exceeds kMaxFactor.
  Factor indicatorFactor(std::vector<int> scope, const std::string& too_large,
                         const std::function<bool()>& holds);
  /// @brief A condition required true whose constant part holds: its literals are separate
  /// indicators (their product is the conjunction's indicator).
  static bool splitsIntoLiterals(const GCondition& c) {
    return c.truth && c.constant && !c.lits.empty();
  }
  void buildIndicator(const std::vector<GCondition>& conds, bool constraint_style,
                      const std::vector<GLit>* constraint_body, std::vector<Factor>& out);
  std::vector<double> eliminate(std::vector<Factor> factors, int keep);
  static Factor multiply(const Factor& a, const Factor& b);
  static Factor sumOut(const Factor& f, int var);
  void newStamp();
  /// @brief Throw BudgetExceededError past the time budget; reads the clock once every
  /// mask + 1 calls (rows can be expensive: one derived atom may have many ground rules).
  void checkTime(unsigned mask = 1023u);

  const GroundProgram& g_;
  std::vector<int> fixed_;
  std::vector<int> assign_;                 // current value index per instance (random)
  std::vector<int> atom_offset_;            // per instance, offset into atom memo
  std::vector<unsigned> atom_stamp_;
  std::vector<signed char> atom_state_;     // 0 false, 1 true, 2 in progress
  unsigned stamp_ = 1;
  std::vector<unsigned> scope_stamp_;
  std::vector<std::vector<int>> scope_cache_;
  std::vector<char> scope_busy_;
  std::vector<std::vector<int>> live_rules_;  // derived instance -> rules alive in this epoch
  std::vector<unsigned> live_stamp_;          // epoch of live_cache_ per instance
  std::vector<std::vector<Item>> live_cache_;
  std::vector<unsigned> rel_stamp_;
  unsigned rel_counter_ = 1;
  std::vector<int> touched_derived_;
  std::vector<int> conflict_derived_;
  std::vector<int> dynamic_range_;  ///< random instances whose dynamic range may be empty
  std::vector<int> atom_inst_;              // atom index -> instance
  std::vector<int> atom_scc_;               // atom -> cyclic SCC id or -1
  std::vector<std::vector<int>> scc_atoms_;
  std::vector<char> scc_negative_;          // SCC contains a negative edge       // derived instances with rules for >= 2 values

  std::vector<std::vector<int>> states_;    // per relevant instance: domain indices (+ undefined)
  // index for table queries
  bool indexed_ = false;
  std::vector<int> index_inst_;             // conditioning instances
  /// One keyed entry of the index: an item (or rule index) whose body has the literal
  /// index_inst_[k] = value. Sorted by (k, value) per instance, so the index is proportional to
  /// the program, not to instances x conditioning domain (a 50x50 grid has 2,500 cells).
  template <class T>
  struct Keyed {
    int k;
    int value;
    T item;
  };
  std::vector<char> index_has_;             // instance -> indexed (random, or derived with rules)
  std::vector<std::vector<Keyed<Item>>> keyed_;  // inst -> items keyed by a conditioning literal
  std::vector<std::vector<Item>> unkeyed_;  // inst -> items without a conditioning literal
  std::vector<int> cond_pos_;               // instance -> position in index_inst_ or -1
  std::vector<std::vector<Keyed<int>>> rule_keyed_;  // derived rules, keyed likewise
  std::vector<std::vector<int>> rule_unkeyed_;
  size_t last_factors_ = 0, last_max_factor_ = 0;
  double cost_cap_log2_ = std::numeric_limits<double>::infinity();
  double cost_cap_recursive_log2_ = std::numeric_limits<double>::infinity();
  double last_planned_log2_ = 0;
  EnginePlan last_plan_;
  std::function<void(const EnginePlan&)> on_plan_;
  std::vector<PendingError> pending_errors_;
  size_t pending_factor_ = 0;
  double budget_seconds_ = 0;
  const std::atomic<bool>* cancel_ = nullptr;
  unsigned budget_ticks_ = 0;
  std::shared_ptr<MemoryGuard> memory_;  ///< setMemoryBudget
  std::vector<std::string> warnings_;    ///< warnings()
  SourceLocation memory_where_;
  /// @brief Throws BudgetExceededError when `bytes` more would exceed the memory budget.
  void checkMemory(std::size_t bytes) const;
  std::chrono::steady_clock::time_point budget_start_;
};

}  // namespace plog
}  // namespace krr
