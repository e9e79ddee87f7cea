/**
 * @file budget.h
 * @brief Size and time budgets of grounding and inference, so that a hostile or mistaken
 * program (an unbounded recursion over an untyped predicate, a huge cartesian product) ends in
 * a clean error instead of exhausting memory or hanging the reasoner.
 */
#pragma once

#include <atomic>
#include <cstddef>
#include <string>

#include "krr_core/common/errors.h"

namespace krr {
namespace plog {

/// @brief Budgets of one grounding (and of the inference on it). 0 disables a limit.
struct GroundingLimits {
  /// @brief Static facts plus dynamic attribute instances.
  std::size_t max_ground_atoms = 5000000;
  /// @brief Ground dynamic statements (selection rules, pr-atoms, rules, constraints).
  std::size_t max_ground_statements = 5000000;
  /// @brief Wall-clock seconds for one grounding.
  double max_ground_seconds = 60.0;
  /// @brief Wall-clock seconds for one inference (one query, one table row set).
  double max_inference_seconds = 60.0;
  /// @brief Bytes by which one grounding, and one inference, may grow the heap; 0:
  /// krr::memoryBudget() (from the machine's memory unless $KRR_MEMORY_BUDGET_MIB says otherwise).
  std::size_t memory_budget = 0;
  /// @brief When set and true, grounding and inference stop with CancelledError (another
  /// back end answered first, see Reasoner's Backend::Auto).
  const std::atomic<bool>* cancel = nullptr;
  /// @brief A query's grounding is restricted to the attribute instances its atoms reach
  /// (instance-level relevance cone, see groundProgram) when the attributes of its cone have
  /// at least this many instances by their declared sorts (instanceConePays). 0: always;
  /// SIZE_MAX: never (every instance of the cone's attributes is ground).
  std::size_t cone_restrict_min_instances = 10000;
};

/// @brief The computation was abandoned because another back end answered first.
class CancelledError : public Error {
 public:
  using Error::Error;
};

/// @brief The native engine's plan costs more than the other back end is expected to (see
/// ExactEngine::setCostCap): not a failure, a choice (Backend::Auto then asks clingo).
class CostlierError : public Error {
 public:
  using Error::Error;
};

/// @brief A grounding or inference budget was exhausted; what() names the statement being
/// processed (file:line:col) and the limit.
class BudgetExceededError : public Error {
 public:
  using Error::Error;
};

/**
 * @brief The memory budget of one phase of the P-log front end (reading, resolving, grounding,
 * inference, the ASP translation): the phase may grow the process's heap by at most `budget`
 * bytes from where it started. Phases check it before they allocate a structure whose size they
 * know (check with `about_to_allocate`) and every thousand steps while they grow (tick), so
 * that running out is a BudgetExceededError naming the phase and the statement, never
 * std::bad_alloc.
 */
class MemoryGuard {
 public:
  /// @brief budget in bytes; 0: krr::memoryBudget().
  explicit MemoryGuard(std::size_t budget = 0);
  /// @brief Throws BudgetExceededError ("where: memory budget of ... exhausted while phase")
  /// when the heap grew by more than the budget, counting `about_to_allocate` bytes more.
  void check(const char* phase, const SourceLocation& where,
             std::size_t about_to_allocate = 0) const;
  /// @brief check() on every 1024th call.
  void tick(const char* phase, const SourceLocation& where) {
    if ((++ticks_ & 1023u) == 0) check(phase, where);
  }
  /// @brief tick() with the location made by `where()` only when it is checked (a location
  /// copies the file's name: the lexer ticks once per token).
  template <class Where>
  void tickAt(const char* phase, const Where& where) {
    if ((++ticks_ & 1023u) == 0) check(phase, where());
  }
  std::size_t budget() const { return budget_; }
  /// @brief Heap growth since construction (0 when the heap shrank).
  std::size_t used() const;

 private:
  std::size_t budget_;
  std::size_t base_;
  mutable std::size_t calls_ = 0;  ///< check() calls: small requests are measured by sample
  unsigned ticks_ = 0;
};

}  // namespace plog
}  // namespace krr
