/**
 * @file dialog_policy.h
 * @brief Solve once, use everywhere: the one way a dialog model becomes the policy that the
 * robot (dialog_node, dialog_script) and the experiments (delivery trials, Table II) run.
 *
 * The dialog POMDP is solved with its turn limit by CertifiedDialogSolver (a search over the
 * dialog's sufficient statistics with proven bounds; the policy knows it must serve after
 * turn_limit questions) under config/dialog.yaml's solver options. With a cache
 * directory the policy is saved under a hash of everything that determines it (the exact
 * model as Cassandra text, the turn limit, the solver options and a fingerprint of the
 * solver's behaviour), with its bounds beside it, so a process that builds the same model
 * from the same knowledge loads the same policy, and a changed model or solver never reuses
 * a stale one. Only reproducible solves (stopped by the precision or the trial budget, not by
 * the timeout) are cached.
 */
#pragma once

#include <optional>
#include <string>

#include "krr_core/dialog/dialog_config.h"
#include "krr_core/dialog/dialog_pomdp.h"
#include "krr_core/dialog/certified_dialog_solver.h"
#include "krr_core/pomdp/point_based_solver.h"
#include "krr_core/pomdp/turn_limited_policy.h"

namespace krr {
namespace dialog {

/// @brief How a dialog policy was obtained and how good it is certified to be.
struct PolicyReport {
  /// At the prior, turn 0 (also for cached policies). lower: the exported policy's value
  /// there (what executing it guarantees); upper: the proven bound on the optimum.
  pomdp::BoundsReport bounds;
  bool converged = false;       ///< bounds.gap() <= config precision
  bool reproducible = false;    ///< stopped by the precision or the trial budget
  bool from_cache = false;
  std::string file;             ///< cache file ("" without a cache directory)
  double seconds = 0.0;         ///< solving (or loading) time
  std::string stop;             ///< why the solve stopped (toString(SolveStop)); "" if cached
};

/**
 * @brief Why `policy` cannot drive `dialog`, or "" if it can: the one check that a policy
 * (solved, cached or given) fits the model, its state count and turn limit being the model's.
 * The text is "policy has S states and turn limit T, the dialog model S' and T'"; callers put
 * what and where in front and throw the error type of their input.
 */
std::string policyMismatch(const pomdp::TurnLimitedPolicy& policy, const DialogPomdp& dialog);

/**
 * @brief The policy of `dialog` (see the file comment).
 * @throws ConfigError for an inconsistent model or options; IoError / ParseError for a broken
 *         cache file (it is then not used silently: the message names it).
 */
pomdp::TurnLimitedPolicy solveDialogPolicy(const DialogPomdp& dialog,
                                           const DialogConfig& config,
                                           const std::string& cache_dir,
                                           PolicyReport* report = nullptr);

/**
 * @brief The policy solveDialogPolicy would load from `cache_dir` for `dialog` and `config`,
 * or none if the cache does not hold it: nothing is solved. Lets a robot that must serve at
 * once start on a cheaper policy while the configured one is solved (dialog_node).
 * @throws as solveDialogPolicy for a broken cache entry.
 */
std::optional<pomdp::TurnLimitedPolicy> cachedDialogPolicy(const DialogPomdp& dialog,
                                                           const DialogConfig& config,
                                                           const std::string& cache_dir,
                                                           PolicyReport* report = nullptr);

/// @brief The solver options solveDialogPolicy uses for `config`.
CertifiedSolverOptions certifiedSolverOptions(const DialogConfig& config);

/**
 * @brief Default directory of solved policies (and of the experiments' learned knowledge):
 * $KRR_CACHE_DIR, else $XDG_CACHE_HOME/krr_rl/delivery, else $HOME/.cache/krr_rl/delivery;
 * empty if none is set. Here because dialog_node and the experiments must share one cache.
 */
std::string defaultCacheDir();

}  // namespace dialog
}  // namespace krr
