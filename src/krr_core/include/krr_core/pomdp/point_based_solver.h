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
 * observation with the largest weighted excess gap, and stop by HSVI's depth rule (trial
 * precision half the root gap, as SARSOP) or SARSOP's upper target; both bounds are backed up
 * on the way back. Beliefs are sparse (sorted state / probability pairs), so a bound evaluation
 * or backup costs the belief's support, not S; the best vector at each visited belief and at
 * each of its children is cached and only re-scored against vectors added since (what made
 * RockSample 7,8, 12,545 states, reach SARSOP's 60 s lower bound within 10 s). Sawtooth points
 * that the others dominate are pruned whenever the point set has doubled (prunePoints(): the
 * upper bound stays the same function, its evaluation gets cheaper). Both bounds are
 * valid for every discounted POMDP; the dialog structure is exploited without being assumed:
 * identity transitions (questions) skip the prediction step, absorbing zero-reward states
 * (after serve) get exact zero bounds and end trials, and the per-action observation support
 * limits branching to the answers a question can produce. With a trial budget (maxTrials) the
 * search is deterministic: it makes no random choice.
 */
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

#include "krr_core/pomdp/alpha_policy.h"
#include "krr_core/common/resources.h"
#include "krr_core/pomdp/model.h"
#include "krr_core/pomdp/solver_clock.h"

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
  /// Trial precision = max(precision, factor * root gap), and a trial goes on while the gap
  /// at depth t exceeds that precision / gamma^t (HSVI's rule). 0.5, SARSOP's default: with
  /// 0.95 trials stopped after about 6 steps on RockSample, too shallow for the plans that
  /// raise the lower bound (RockSample 5,7 at 10 s: 23.5 with 0.95, 24.4 with 0.5).
  double trialGapFactor = 0.5;
  /// A trial also stops at a node whose weighted gap P(path) gamma^depth (U - L) is below this
  /// fraction of the root gap (0: pure HSVI depth rule, the default). Halved after 16 trials
  /// without progress at the root, so the bounds keep converging. Exploration only: the bounds
  /// stay valid. With 0.1, RockSample trials stopped after 6 steps (Tag at 10 s: -6.71 with
  /// 0.01, -6.21 with 0); models with discounts close to 1 whose bounds converge (the dialog)
  /// may still gain from it.
  double trialWeightCutoff = 0.0;
  std::size_t initIterations = 100000;  ///< cap on FIB iterations (every iterate is valid)
  double initTimeLimit = 1.0;      ///< seconds allowed for the FIB iterations
  /// Sawtooth interpolation at beliefs that are not stored points. Off: the upper bound at a
  /// new belief is the FIB bound only (cheaper, weaker); stored points are found by hashing.
  bool sawtooth = true;
  /// Also prune lower-bound vectors that are not the best at b0 or at any stored point.
  bool witnessPruning = true;
  /// Drop sawtooth points that the other points (or the FIB vectors) dominate, whenever the
  /// point set has doubled since the last pruning (see PointBasedSolver::prunePoints()). It
  /// never changes the upper bound, only the time and memory it costs.
  bool pointPruning = true;
  /// Seconds the set-up in the constructor may take (0: half the timeout, so that the search
  /// gets the other half even on models whose exact set-up is slow). Every set-up phase checks it
  /// and keeps what it has when it is spent: at worst the blind-policy bound started at
  /// min_s R(s, a) / (1 - gamma) and the trivial upper bound max R / (1 - gamma), both valid.
  double setupTimeLimit = 0.0;
  /// Bytes the bounds (alpha vectors, their plans, belief points) may hold (0: no limit). The
  /// constructor throws ConfigError when the initial bounds alone exceed it; during the search,
  /// a vector or point that would exceed it is not added and the search stops, keeping valid
  /// bounds (memoryLimited() then says so).
  std::size_t memoryLimit = 0;
};

/// @brief Where the search's time went (pomdp_solve --verbose prints it): seconds per kind of
/// work and how often it ran, so that a slow run says which part to speed up.
struct SearchProfile {
  double upperBackupSeconds = 0.0, lowerBackupSeconds = 0.0, pruneSeconds = 0.0;
  double sampleSeconds = 0.0;  ///< choosing the next observation along a trial
  double pointPruneSeconds = 0.0;
  std::size_t upperBackups = 0, lowerBackups = 0, prunes = 0, alphasAdded = 0, pointsAdded = 0;
  std::size_t pointPrunes = 0, pointsPruned = 0;
  std::size_t depthSum = 0, maxDepth = 0;  ///< over all trials
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
  std::size_t bytes = 0;     ///< bytes held by the bounds (see SolverOptions::memoryLimit)
  double gap() const { return upper - lower; }
  /// @brief Both bounds finite and lower <= upper (up to rounding): the only bounds a program
  /// may report as valid. Always true for a Model (|R| <= Model::kMaxAbsReward); checked where
  /// bounds are printed or stored so that no path reports inf or nan as a bound.
  bool valid() const {
    return std::isfinite(lower) && std::isfinite(upper) &&
           lower <= upper + 1e-9 * std::max(1.0, std::abs(upper));
  }
};

/// @brief HSVI2-style anytime solver; construct, then call runUntil() repeatedly or solve().
class PointBasedSolver {
 public:
  /// @throws ConfigError if the discount is not below 1 or b0 is not a belief over S.
  PointBasedSolver(const Model& model, const Belief& b0, SolverOptions options = {});

  /// @brief Run trials until the solver has used untilSeconds in total or has converged.
  /// @return true when the root gap is <= precision.
  /// A trial that is under way at untilSeconds is finished, unless it reaches cutSeconds
  /// (default: untilSeconds), where it stops and skips its remaining backups. A caller that
  /// reports at checkpoints (pomdp_solve) passes its final deadline as cutSeconds, so that the
  /// checkpoints do not change the result: with a trial budget the run is then deterministic.
  bool runUntil(double untilSeconds, double cutSeconds = -1.0);
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
  /// @brief Time per kind of work in the search so far.
  const SearchProfile& profile() const { return profile_; }
  /// @brief True when the memory limit stopped the search (the bounds stay valid).
  bool memoryLimited() const { return memoryStop_; }
  /// @brief Remove every sawtooth point whose value is no better than what the other points,
  /// the corners and the FIB vectors give at its belief; returns how many were removed.
  /// Such a point is dominated everywhere: the one function that beats it at its own belief is
  /// convex and at most the corner values, so it is below the point's sawtooth (the
  /// interpolation between the point and the corners) at every belief. Removing it therefore
  /// changes the upper bound nowhere. Points are checked oldest first against those still kept,
  /// so two points that dominate each other are not both removed. The search calls this when
  /// the point set has doubled since the last pruning (SolverOptions::pointPruning).
  std::size_t prunePoints() { return prunePointsUntil(false); }

  /// @brief Models with at most this many states get exact dense (LU) evaluations in the
  /// set-up; larger ones sparse sweeps that stop at the set-up deadline (an O(S^3) LU of a
  /// 3000-state model took 7 s and could not be interrupted).
  static constexpr std::size_t kDenseSetupStates = 500;

 private:
  /// @brief A belief or unnormalised successor as sorted (state, probability) pairs: beliefs
  /// of RockSample or Tag have a few hundred non-zero entries out of thousands of states, so
  /// every bound evaluation and backup costs the support, not S.
  struct SparseBelief {
    std::vector<std::uint32_t> idx;
    std::vector<double> val;
    std::size_t size() const { return idx.size(); }
    void clear() {
      idx.clear();
      val.clear();
    }
  };
  void initLower(double deadline);
  void initUpper(double mdpDeadline, double setupEnd);
  // initUpper's steps; late(d): whether the constructor's clock has reached d seconds.
  /// Q_MDP by policy iteration (small models).
  Eigen::MatrixXd mdpQExact();
  /// Q = R + gamma T V after Gauss-Seidel sweeps down to V_MDP until mdpDeadline (large
  /// models): an upper bound wherever they stop.
  Eigen::MatrixXd mdpQSweeps(const std::function<bool(double)>& late, double mdpDeadline);
  /// Rounding margin; the trivial bound Rmax / (1 - gamma) if q is not an upper fixed point.
  void checkUpperFixedPoint(Eigen::MatrixXd& q) const;
  /// The fast informed bound iterated down from q until fibDeadline: whether it converged.
  bool fastInformedBound(Eigen::MatrixXd& q, const std::function<bool(double)>& late,
                         double fibDeadline);
  /// fib_: the columns of q no other column dominates pointwise.
  void keepUndominatedFib(const Eigen::MatrixXd& q);
  void trial();
  /// Per trial node: Q_U per action, and P(o | b, a) and U(b_ao) per (action, observation).
  struct NodeCache {
    std::vector<double> q, p, u;
    std::size_t action = 0;  ///< greedy w.r.t. the upper bound
  };
  SparseBelief toSparse(const Belief& b) const;
  /// kids_[k] = unnormalised successor for observation slot k of a; probs_[k] its mass.
  void expand(const SparseBelief& b, std::size_t a);
  /// Full upper-bound backup at b (fills c, adds a point when it improves).
  void upperBackup(const SparseBelief& b, NodeCache& c);
  /// Re-evaluate one child (action a, observation slot k) and redo the max.
  void refreshUpper(const SparseBelief& b, NodeCache& c, std::size_t a, std::size_t k,
                    const SparseBelief& child);
  void finishUpper(const SparseBelief& b, NodeCache& c);
  /// Point-based backup of the lower bound at b (adds a vector when it improves).
  void lowerBackup(const SparseBelief& b);
  /// max_i alpha_i . b; `arg` receives the maximiser.
  double lowerAt(const SparseBelief& b, std::size_t* arg = nullptr) const;
  double upperAt(const SparseBelief& b) const;
  /// The upper bound at b minus the corner interpolation `*base` (<= 0): the best of the FIB
  /// vectors and the sawtooth points, skipping points i with skip[i] != 0 (skip may be null).
  double upperBelowCorners(const SparseBelief& b, double* base, const char* skip) const;
  /// prunePoints(); with `interruptible`, it stops (keeping what it removed) once the trial
  /// under way must be cut.
  std::size_t prunePointsUntil(bool interruptible);
  double rewardAt(const SparseBelief& b, std::size_t a) const;
  /// children[k]: the vector the plan of `alpha` follows after observation slot k of action.
  /// Returns false (and adds nothing) when the memory limit would be exceeded.
  bool addAlpha(const double* alpha, std::size_t action, std::vector<std::uint32_t> children);
  void addPoint(const SparseBelief& b, double v);
  void insertByImprovement(std::vector<std::uint32_t>& bucket, std::size_t i) const;
  void pruneAlphas();
  /// Bytes held by the bounds (alpha vectors, plans, belief points): what the memory limit caps.
  std::size_t boundBytes() const;
  std::uint64_t beliefKey(const SparseBelief& b) const;
  std::size_t findPoint(const SparseBelief& b) const;

  const Model& m_;
  SolverOptions options_;
  std::size_t s_, a_;
  double gamma_;
  SparseBelief b0_;
  std::vector<std::vector<std::uint32_t>> slotOf_;  // slotOf_[a][o]: slot of obs o after a
  // Lower bound: one buffer per alpha vector (S entries), action per vector. Not one flat
  // N x S array: growing that copied it, so that old and new arrays were resident together
  // (RockSample 11,11: 1025 vectors of 2 MB peaked at 4.5 GB, twice the bounds).
  std::vector<std::vector<double>> alpha_;
  std::vector<std::size_t> alphaAction_;
  // Per vector, the vectors its plan continues with (one per observation slot of its action).
  // Pruning keeps them (or a vector dominating them): then every vector is at most the backup
  // of the set at every belief, so the greedy policy of the set earns the lower bound.
  std::vector<std::vector<std::uint32_t>> alphaChildren_;
  // Vectors that were the best at some belief the search evaluated since the last pruning:
  // the witnesses that pruning keeps (SARSOP keeps the vectors that are best somewhere in its
  // belief tree; re-scoring every stored belief at each pruning cost more than the search).
  mutable std::vector<char> witness_;
  std::size_t prunedAt_ = 0;
  // Upper bound: corner values, FIB action vectors and sawtooth points.
  Eigen::VectorXd corner_;
  std::vector<double> fib_;       // S x K, state-major: the kept FIB vectors
  std::size_t fibK_ = 0;
  mutable std::vector<double> fibScratch_;
  std::vector<std::size_t> pointStart_{0};  // point i: entries [start[i], start[i + 1])
  std::vector<std::uint32_t> pointIdx_;
  std::vector<double> pointInv_;  // 1 / b_i(s) on the support
  std::vector<double> improve_;   // v_i - corner . b_i (<= 0)
  std::size_t pointsPrunedAt_ = 0;  // points kept by the last point pruning
  std::vector<std::vector<std::uint32_t>> firstOf_;  // [s]: points whose support starts at s
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> pointIndex_;
  static constexpr std::size_t kNoPoint = static_cast<std::size_t>(-1);
  mutable std::vector<double> scatter_;  // scratch: a belief scattered to S entries (else 0)
  double rootUpper_ = 0.0;
  double rootLower_ = 0.0;
  std::size_t trials_ = 0;
  std::size_t backups_ = 0;
  bool memoryStop_ = false;       // the memory limit stopped the search
  double cutoffScale_ = 1.0;    // multiplies options_.trialWeightCutoff (halved on stalls)
  std::size_t stalled_ = 0;     // consecutive trials without progress at the root
  std::size_t lowerStalled_ = 0;  // consecutive trials without progress of the root's lower bound
  // Scratch buffers (no per-step allocation in the hot loop).
  std::vector<SparseBelief> kids_;
  struct PooledChild {
    SparseBelief kid;
    std::size_t slot = 0;
  };
  std::vector<PooledChild> pool_;  // lowerBackup: the children of every action
  std::vector<std::size_t> groupOf_, groupHeads_, args_, members_;
  std::vector<double> gather_, scores_;
  /// A belief the search backed up or evaluated, with the best vector at it and at each of its
  /// unnormalised children (slot order), over vectors [0, checked) of pruning epoch `epoch`.
  struct LowerNode {
    SparseBelief b;
    std::size_t epoch = 0, checked = 0, selfArg = 0;
    double self = 0.0;
    std::vector<double> best;
    std::vector<std::uint32_t> arg;
  };
  std::vector<LowerNode> lowerNodes_;
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> lowerIndex_;
  std::size_t epoch_ = 0, lowerNodeBytes_ = 0;
  /// The up-to-date LowerNode of b (created when new); returns its index.
  std::size_t lowerNode(const SparseBelief& b);
  std::vector<double> probs_;
  SparseBelief pred_;
  std::vector<double> acc_;
  std::vector<char> mark_;
  std::vector<std::uint32_t> touched_;
  Eigen::VectorXd accVec_, nextVec_, candidate_;
  std::vector<std::uint32_t> bestChildren_, candChildren_;
  SetupReport setup_;
  SolverClock clock_;
  double cutAt_ = 0.0;  // solver seconds at which a trial under way is cut (runUntil)
  bool cut() const { return clock_.now() >= cutAt_; }
  std::vector<SparseBelief> path_;
  std::vector<NodeCache> cache_;
  std::vector<std::size_t> chosenObs_;
  std::vector<std::size_t> obsOffset_;  // obsOffset_[a] = first slot of action a
  std::vector<char> toTerminal_;        // action leads only to terminal states (serve)
  SearchProfile profile_;
};

}  // namespace pomdp
}  // namespace krr
