/**
 * @file turn_limited_solver.h
 * @brief Point-based solver (HSVI family) for POMDPs with a turn limit: after `turnLimit`
 * continuing actions (questions) the agent must take an action that ends the episode.
 *
 * The dialog manager may ask at most 20 questions, then it is forced to serve (paper,
 * Sec. IV). A policy that does not know the limit plans to keep confirming forever and is
 * cut off by it; one that knows it plans its last questions. The turn count is observed, so
 * the problem is a finite-horizon POMDP over the model's states with one value function per
 * turn count t:
 *   V_L(b) = max over ending actions a of b . R_a            (exact: nothing follows)
 *   V_t(b) = max( max_ending b . R_a,
 *                 max_continuing [ b . R_a + gamma sum_o P(o | b, a) V_{t+1}(b_ao) ] ).
 * An action "ends" the episode when it leads only to terminal states (absorbing, zero
 * reward: Model::isTerminal), like serve; every other action counts a turn. No state is
 * added to the model: the turn count indexes the bounds.
 *
 * Bounds, per turn count t < L:
 *  - lower: alpha vectors from point-based backups, each tagged with the turn it was built
 *    for (TurnLimitedPolicy). A vector built for turn t is also valid at every earlier turn
 *    (more questions to spare never hurt), so the lower bound at t is the max over vectors
 *    tagged t..L; the ending actions' reward vectors (tag L) are exact plans "end now".
 *    Vectors are never pruned unless pointwise dominated by one usable at least as long, so
 *    the greedy policy always earns at least the certified lower bound;
 *  - upper: the finite-horizon fast informed bound (computed backwards from the exact V_L)
 *    and belief points with sawtooth interpolation, improved by Bellman backups.
 * Trials start at (b0, 0), follow the action of the best upper bound and the observation
 * with the largest weighted excess gap, stop at turn L (exact) or on an ending action, and
 * back up both bounds on the way back. Any discount in (0, 1] is allowed (the horizon is
 * finite). Runs stopped by the precision or the trial budget are reproducible.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

#include "krr_core/common/resources.h"
#include "krr_core/pomdp/model.h"
#include "krr_core/pomdp/point_based_solver.h"
#include "krr_core/pomdp/solver_clock.h"
#include "krr_core/pomdp/turn_limited_policy.h"

namespace krr {
namespace pomdp {

/// @brief Solver parameters.
struct TurnLimitedSolverOptions {
  double precision = 0.5;       ///< stop when upper - lower <= precision at (b0, turn 0)
  double timeout = 10.0;        ///< seconds of solver time for solve()
  std::size_t maxTrials = 0;    ///< stop after this many trials (0: no limit); reproducible
  double trialGapFactor = 0.95; ///< trial precision = max(precision, factor * root gap)
  /// Every k-th trial follows the lower bound's greedy action instead of the upper bound's
  /// (0: never). The upper bound alone explores where it is loosest, which in information
  /// gathering is everywhere; trials along the current policy improve the policy itself.
  std::size_t lowerGuidedEvery = 3;
};

/// @brief HSVI over (belief, turn count); construct, then runUntil() repeatedly or solve().
class TurnLimitedSolver {
 public:
  /**
   * @throws ConfigError for a negative turn limit, a discount outside (0, 1], an initial
   * belief that is not a distribution over S, bad options, or a model without an action that
   * ends the episode.
   */
  TurnLimitedSolver(const Model& model, const Belief& b0, int turnLimit,
                    TurnLimitedSolverOptions options = {});

  /// @brief Run trials until untilSeconds of solver time in total, the precision or the trial
  /// budget. @return true when the root gap is <= precision.
  bool runUntil(double untilSeconds);
  bool solve() { return runUntil(options_.timeout); }
  /// @brief Change the trial budget (0: none) for later runUntil() calls.
  void setMaxTrials(std::size_t n) { options_.maxTrials = n; }

  /// @brief Run trials rooted at (b, turns) until its gap is <= precision or maxTrials trials
  /// ran; the bounds everywhere stay valid. @return the gap at (b, turns).
  double improveAt(const Belief& b, int turns, double precision, std::size_t maxTrials);

  bool converged() const { return rootUpper_ - rootLower_ <= options_.precision; }
  /// @brief Bounds at (b0, turn 0), solver time, vectors, points, trials.
  BoundsReport report() const;
  int turnLimit() const { return limit_; }
  /// @brief True for the actions that end the episode (all successors terminal).
  bool isEnding(std::size_t a) const { return ending_[a] != 0; }

  /// @brief Lower bound at b after `turns` continuing actions (clamped to the limit).
  double lowerBound(const Belief& b, int turns) const;
  /// @brief Upper bound at b after `turns` continuing actions.
  double upperBound(const Belief& b, int turns) const;
  /// @brief The greedy policy of the lower bound (every vector with its action and stage).
  TurnLimitedPolicy policy() const;

  /// @brief An extra upper bound U(b, t) >= V_t(b) (e.g. an information relaxation), used
  /// with the solver's own (the minimum of all). Set before solving.
  using ExtraUpper = std::function<double(const Eigen::VectorXd& b, int turns)>;
  void setExtraUpper(ExtraUpper f);
  /// @brief Called for every child (b, t) of a trial node before its upper bound is read, so
  /// that the extra bound can be tightened there.
  void setRefiner(std::function<void(const Eigen::VectorXd& b, int turns)> f) { refine_ = std::move(f); }

 private:
  struct Stage {                 // bounds for one turn count
    std::vector<double> alpha;   // lower: n x S, flat
    std::vector<std::size_t> action;
    Eigen::VectorXd corner;      // upper: FIB value of each state
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> fib;  // K x S
    std::vector<double> point, inv, improve;  // sawtooth points (n x S), 1 / b_i on the support
    std::vector<std::size_t> order;           // point indices by increasing improvement
    std::unordered_map<std::uint64_t, std::vector<std::size_t>> index;  // belief hash -> points
  };
  struct NodeCache {             // per trial depth: Q_U per action, P(o) and U per slot
    std::vector<double> q, p, u;
    std::size_t action = 0;
  };

  void initBounds();
  double lowerRaw(const double* b, int t) const;
  double upperRaw(const double* b, int t) const;
  void addAlpha(int t, const Eigen::VectorXd& alpha, std::size_t action);
  void addPoint(int t, const Eigen::VectorXd& b, double v);
  std::size_t findPoint(const Stage& st, std::uint64_t key, const double* b) const;
  std::uint64_t beliefKey(const double* b) const;
  void predict(const Eigen::VectorXd& b, std::size_t a, Eigen::VectorXd& out) const;
  void upperBackup(const Eigen::VectorXd& b, int t, NodeCache& c);
  void refreshUpper(const Eigen::VectorXd& b, int t, NodeCache& c, std::size_t k,
                    const Eigen::VectorXd& child);
  void finishUpper(const Eigen::VectorXd& b, int t, NodeCache& c);
  void lowerBackup(const Eigen::VectorXd& b, int t);
  void trial();
  /// One trial rooted at (root, t0) with trial precision thr at the root.
  void trialFrom(const Eigen::VectorXd& root, int t0, double thr, bool lowerGuided = false);
  /// The action greedy w.r.t. the lower bound at b (one-step lookahead), using c's P(o).
  std::size_t lowerGreedy(const Eigen::VectorXd& b, int t, const NodeCache& c);

  const Model& m_;
  TurnLimitedSolverOptions options_;
  std::size_t s_, a_;
  int limit_;
  double gamma_;
  Eigen::VectorXd b0_;
  std::vector<char> ending_;
  std::vector<std::size_t> continuing_;               // actions that count a turn
  std::vector<std::vector<Eigen::VectorXd>> obsCol_;  // [a][k]: column of the k-th possible obs
  std::vector<std::size_t> slotOffset_;               // [a]: first slot of a's observations
  std::vector<Stage> stages_;                         // 0..L
  double rootLower_ = 0.0, rootUpper_ = 0.0;
  std::size_t trials_ = 0;
  SolverClock clock_;
  std::vector<Eigen::VectorXd> path_;
  std::vector<NodeCache> cache_;
  std::vector<std::size_t> chosen_;
  Eigen::VectorXd pred_, child_, acc_, candidate_, best_;
  Eigen::MatrixXd children_;
  ExtraUpper extra_;
  std::function<void(const Eigen::VectorXd&, int)> refine_;
};

}  // namespace pomdp
}  // namespace krr
