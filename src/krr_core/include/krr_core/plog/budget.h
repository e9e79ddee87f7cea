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
  /// @brief When set and true, grounding and inference stop with CancelledError (another
  /// back end answered first, see Reasoner's Backend::Auto).
  const std::atomic<bool>* cancel = nullptr;
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

}  // namespace plog
}  // namespace krr
