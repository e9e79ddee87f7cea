/**
 * @file point_based_solver.h
 * @brief Anytime point-based POMDP solver with certified bounds (HSVI2 / SARSOP family).
 *
 * The dialog manager needs a policy within a fraction of a second after the knowledge base
 * changes the delivery success rates, and we want to know how far from optimal it is. The
 * solver keeps
 *  - a lower bound: alpha vectors, each the value of a conditional plan (initialised with the
 *    blind policies "always do a"), improved by point-based backups; its max at a belief is
 *    achieved by executing the greedy policy, so the returned policy is worth at least it;
 *  - an upper bound: corner values from the fast informed bound (FIB, tighter than QMDP) plus
 *    belief points with sawtooth interpolation, improved by Bellman backups at the points.
 * Trials start at the initial belief, follow the action of the best upper bound and the
 * observation with the largest weighted excess gap, and back up both bounds on the way back.
 * Trial precision adapts to the current gap at the root (anytime). Both bounds are valid for
 * every discounted POMDP; the dialog structure is exploited without being assumed: identity
 * transitions (questions) skip the prediction step, absorbing zero-reward states (after serve)
 * get exact zero bounds and end trials, and the per-action observation support limits
 * branching to the answers a question can produce.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "krr_core/pomdp/alpha_policy.h"
#include "krr_core/common/resources.h"
#include "krr_core/pomdp/model.h"

namespace krr {
namespace pomdp {

/// @brief Solver parameters.
struct SolverOptions {
  double precision = 1e-3;         ///< stop when upper - lower <= precision at the root
  double timeout = 10.0;           ///< seconds of solver time for solve(), set-up included
  /// Stop after this many trials in total (0: no limit). Unlike the timeout, this budget makes
  /// the result reproducible (with initTimeLimit not reached, the run is deterministic).
  std::size_t maxTrials = 0;
  std::size_t maxDepth = 1000;     ///< cap on trial depth
  double trialGapFactor = 0.95;    ///< trial precision = max(precision, factor * root gap)
  /// A trial also stops at a node whose weighted gap P(path) gamma^depth (U - L) is below this
  /// fraction of the root gap (0: pure HSVI depth rule). With discounts close to 1, HSVI's
  /// rule alone sends trials deep into improbable branches (the dialog model certifies its
  /// bounds about 10x faster with 0.1). Halved after 16 trials without progress at the root,
  /// so the bounds keep converging. Exploration only: the bounds stay valid.
  double trialWeightCutoff = 0.1;
  std::size_t initIterations = 100000;  ///< cap on FIB iterations (every iterate is valid)
  double initTimeLimit = 1.0;      ///< seconds allowed for the FIB iterations
  /// Sawtooth interpolation at beliefs that are not stored points. Off: the upper bound at a
  /// new belief is the FIB bound only (cheaper, weaker); stored points are found by hashing.
  bool sawtooth = true;
  /// Also prune lower-bound vectors that are not the best at b0 or at any stored point.
  bool witnessPruning = true;
  /// Seconds the set-up in the constructor may take (0: half the timeout, so that the search
  /// gets the other half even on models whose exact set-up is slow). Every set-up phase checks it
  /// and keeps what it has when it is spent: at worst the blind-policy bound started at
  /// min_s R(s, a) / (1 - gamma) and the trivial upper bound max R / (1 - gamma), both valid.
  double setupTimeLimit = 0.0;
};

/// @brief Where the constructor's set-up time went and how far each phase got, so that a run
/// that ends with loose bounds says why (a phase cut short by the time budget).
struct SetupReport {
  double lowerSeconds = 0.0;      ///< blind-policy lower bound
  double mdpSeconds = 0.0;        ///< MDP values (the QMDP upper bound)
  double fibSeconds = 0.0;        ///< fast informed bound iterations
  bool lowerExact = false;        ///< blind policies evaluated exactly (LU) or to convergence
  std::size_t lowerSweeps = 0;    ///< Gauss-Seidel sweeps of the blind-policy evaluation
  bool mdpExact = false;          ///< MDP solved (policy iteration or converged sweeps)
  std::size_t mdpSweeps = 0;      ///< value-iteration sweeps (0 with policy iteration)
  std::size_t fibIterations = 0;  ///< complete FIB iterations
  bool fibConverged = false;
  bool timedOut = false;          ///< some phase stopped at the set-up time limit
  double seconds() const { return lowerSeconds + mdpSeconds + fibSeconds; }
};

/// @brief Bounds at the root at one moment of the run.
struct BoundsReport {
  double time = 0.0;         ///< solver seconds so far
  double lower = 0.0;        ///< lower bound at the initial belief
  double upper = 0.0;        ///< upper bound at the initial belief
  std::size_t alphas = 0;    ///< alpha vectors in the lower bound
  std::size_t points = 0;    ///< belief points in the upper bound
  std::size_t trials = 0;    ///< trials run
  double gap() const { return upper - lower; }
};

/// @brief HSVI2-style anytime solver; construct, then call runUntil() repeatedly or solve().
class PointBasedSolver {
 public:
  /// @throws ConfigError if the discount is not below 1 or b0 is not a belief over S.
  PointBasedSolver(const Model& model, const Belief& b0, SolverOptions options = {});

  /// @brief Run trials until the solver has used untilSeconds in total or has converged.
  /// @return true when the root gap is <= precision.
  bool runUntil(double untilSeconds);
  /// @brief runUntil(options.timeout).
  bool solve() { return runUntil(options_.timeout); }

  bool converged() const;
  BoundsReport report() const;

  /// @brief Lower bound max_i alpha_i . b.
  double lowerBound(const Belief& b) const;
  /// @brief Sawtooth upper bound at b.
  double upperBound(const Belief& b) const;
  /// @brief The greedy policy of the lower bound (all alpha vectors with their actions).
  AlphaVectorPolicy policy() const;
  /// @brief FIB value of each state (the upper bound at the corners).
  const Eigen::VectorXd& cornerUpper() const { return corner_; }
  /// @brief How the set-up went (phase times, whether each phase finished).
  const SetupReport& setupReport() const { return setup_; }

  /// @brief Models with at most this many states get exact dense (LU) evaluations in the
  /// set-up; larger ones sparse sweeps that stop at the set-up deadline (an O(S^3) LU of a
  /// 3000-state model took 7 s and could not be interrupted).
  static constexpr std::size_t kDenseSetupStates = 500;

 private:
  void initLower(double deadline);
  void initUpper(double mdpDeadline, double setupEnd);
  void trial();
  /// Per trial node: Q_U per action, and P(o | b, a) and U(b_ao) per (action, observation).
  struct NodeCache {
    std::vector<double> q, p, u;
    std::size_t action = 0;  ///< greedy w.r.t. the upper bound
  };
  /// Full upper-bound backup at b (fills c, adds a point when it improves).
  void upperBackup(const Eigen::VectorXd& b, NodeCache& c);
  /// Re-evaluate one child (action a, observation slot k) and redo the max.
  void refreshUpper(const Eigen::VectorXd& b, NodeCache& c, std::size_t a, std::size_t k,
                    const Eigen::VectorXd& child);
  void finishUpper(const Eigen::VectorXd& b, NodeCache& c);
  /// Point-based backup of the lower bound at b (adds a vector when it improves).
  void lowerBackup(const Eigen::VectorXd& b);
  double lowerRaw(const double* b) const;
  double upperRaw(const double* b) const;
  /// children[k]: the vector the plan of `alpha` follows after observation slot k of action.
  void addAlpha(const Eigen::VectorXd& alpha, std::size_t action,
                std::vector<std::uint32_t> children);
  void addPoint(const Eigen::VectorXd& b, double v);
  void pruneAlphas();
  /// Unnormalised successor O_ao .* (T_a^T b); returns its mass.
  double successor(const Eigen::VectorXd& b, std::size_t a, std::size_t o,
                   Eigen::VectorXd& out) const;

  const Model& m_;
  SolverOptions options_;
  std::size_t s_, a_;
  double gamma_;
  Eigen::VectorXd b0_;
  std::vector<std::vector<Eigen::VectorXd>> obsCol_;  // obsCol_[a][k] = O_a column of obs k
  // Lower bound: flat alpha storage (N x S), action per vector.
  std::vector<double> alpha_;
  std::vector<std::size_t> alphaAction_;
  // Per vector, the vectors its plan continues with (one per observation slot of its action).
  // Pruning keeps them (or a vector dominating them): then every vector is at most the backup
  // of the set at every belief, so the greedy policy of the set earns the lower bound.
  std::vector<std::vector<std::uint32_t>> alphaChildren_;
  std::vector<std::uint32_t> bestChildren_, candChildren_;
  std::size_t prunedAt_ = 0;
  // Upper bound: corner values and sawtooth points.
  Eigen::VectorXd corner_;
  std::vector<double> point_;     // N x S beliefs
  std::vector<double> improve_;   // v_i - corner . b_i (<= 0)
  std::vector<std::size_t> order_;  // point indices by increasing improvement
  void insertOrdered(std::size_t i);
  std::vector<double> inv_, pen_; // 1 / b_i(s) on the support; 2 off it (see upperRaw)
  std::size_t sp_ = 0;            // S rounded up to a multiple of 4: stride of inv_ / pen_
  mutable std::vector<double> bpad_;  // scratch: the belief padded to sp_
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> pointIndex_;
  static constexpr std::size_t kNoPoint = static_cast<std::size_t>(-1);
  std::uint64_t beliefKey(const double* b) const;
  std::size_t findPoint(const double* b) const;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> fibMat_;  // K x S
  mutable Eigen::VectorXd fibBuf_;  // scratch for fibMat_ * b
  double rootUpper_ = 0.0;
  double rootLower_ = 0.0;
  double elapsed_ = 0.0;
  std::size_t trials_ = 0;
  double cutoffScale_ = 1.0;    // multiplies options_.trialWeightCutoff (halved on stalls)
  std::size_t stalled_ = 0;     // consecutive trials without progress at the root
  std::size_t lowerStalled_ = 0;  // consecutive trials without progress of the root's lower bound
  // Scratch buffers (no per-step allocation in the hot loop).
  Eigen::VectorXd pred_, child_, acc_, bestAlpha_, candidate_;
  Eigen::MatrixXd children_, scores_;  // lowerBackup: S x slots children, N x slots scores
  double now() const;
  SetupReport setup_;
  Stopwatch clock_;
  double clockOffset_ = 0.0;
  double deadline_ = 0.0;
  std::vector<Eigen::VectorXd> path_;
  std::vector<NodeCache> cache_;
  std::vector<std::size_t> chosenObs_;
  std::vector<std::size_t> obsOffset_;  // obsOffset_[a] = first slot of action a
  std::vector<char> toTerminal_;        // action leads only to terminal states (serve)
  std::vector<std::size_t> support_;
};

}  // namespace pomdp
}  // namespace krr
