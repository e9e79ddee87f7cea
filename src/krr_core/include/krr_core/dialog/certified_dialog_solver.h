/**
 * @file certified_dialog_solver.h
 * @brief The dialog POMDP solved through its own structure, with certified bounds at the
 * prior: the one dialog solver of the robot, the experiments and the benchmarks.
 *
 * Structure used (DialogPomdp): the request never changes during the dialog, each answer
 * depends only on the asked slot's true value, answers are independent given the request,
 * and serving ends the episode with a known reward. The belief after any dialog is therefore
 * b(s) ~ root(s) * prod_k lambda_k(v_k(s)), one likelihood vector per slot (item, room,
 * person), and lambda_k(v) = g_k^{a_v} h^{d_v}: a_v answers "v" to the general question,
 * d_v = yeses minus noes to "is it v?", g_k = p_general (n_k - 1) / (1 - p_general),
 * h = p_yesno / (1 - p_yesno). The integers (a_v, d_v) are a sufficient statistic, and when
 * log g_k / log h is a small rational p / q (8, 16, 4 and 4 for the office: 3/2, 2, 1) one
 * integer e_v = p a_v + q d_v is. A belief node is the turn count and these integers, shifted
 * so that each slot's minimum is 0, with the values of each slot that the root belief and the
 * rewards treat alike (the office's items) sorted: two dialogs with the same statistics reach
 * exactly the same belief, so the reachable beliefs form a finite DAG of depth turnLimit.
 * (Answer accuracies of exactly 0 or 1 exclude values instead; that is kept as a flag.)
 *
 * Search: HSVI-style trials over that DAG, with one scalar lower and upper bound per node
 * (no alpha vectors, no interpolation: nodes are exact beliefs). A trial follows the action
 * of the best upper bound and samples an answer with probability proportional to
 * P(answer) x (bound gap - epsilon) (a seeded stream: runs are reproducible), stops where the
 * gap is at most epsilon = trialTarget x precision, and backs up both bounds exactly on the
 * way back. At turnLimit the node's value is exact (serve the best request).
 *
 * Bounds at a node that has not been expanded:
 *  - lower: the best of three plans the robot can run, valued exactly: serve now; commit to
 *    one room r, i.e. never ask about the room again and follow the room-revealed
 *    sub-dialog's optimal plan for r (below) on the item and person; or ask one question
 *    about the room, then commit to the room best for its answer (roomLookahead: the commit
 *    plans one turn later). The sub-dialog stores each plan's value per true request (all of
 *    them: the plan's serve goes to r, and its answers depend only on the true item and
 *    person), so a commit value is one dot product per room. Once the room is nearly settled
 *    this bound is nearly the upper one, and the search stops there;
 *  - upper: the room revealed for free (generally: the slot with most values). The belief
 *    is the mixture sum_r b(room = r) b(. | room = r), the finite-horizon value V_t is
 *    convex (a maximum of linear functions of the belief), so V_t(b) <= sum_r b(r) V_t(b | r).
 *    V_t(b | r) is computed exactly: with the room known, room questions carry no information
 *    and the sub-dialog over the other slots is small (memoised exact dynamic programming
 *    over its own sufficient statistics). This is the information relaxation "room answered
 *    perfectly at no cost"; a more informative experiment is worth at least as much
 *    (Blackwell), so the bound is a proof, not an estimate. A sub-dialog that outgrows half
 *    of the memory budget or the timeout (much larger models than the office's) is cut off
 *    there with the full-information value, which is larger still: the bound stays a proof,
 *    only looser.
 *  - upper, the room paid for (roomPaidBound), the tighter of the two: a relaxation M in
 *    which the room r is revealed at the node, but serving earns the room-known serve
 *    serve_r(x') minus pen(x') = (1 - theta) Y+(x') (x': the other slots' statistics then),
 *    where theta bounds how likely any room can be by then. theta starts at theta(b) and
 *    each question about the room moves it on: an answer multiplies a room's odds by at
 *    most G (the question's largest ratio of one answer's likelihoods over the rooms), so
 *    theta' <= theta G / (theta G + 1 - theta) whatever the answer. theta's odds live on a
 *    grid of three steps per doubling (48 levels; G = 16 and 4 for the office move whole
 *    steps, other G are rounded down; theta(b) is rounded up: smaller penalties, valid
 *    too), and a question about the room costs its own cost. M's value is sum_r w_r T_r,
 *    T_r an exact dynamic programme over the sub-dialog's statistics and the level, solved
 *    with the sub-dialog.
 *    Why V <= value(M): a real policy runs in M (its room answers drawn from the revealed
 *    room) with the same costs, and the same rewards after a question about the room. When
 *    it serves without one, its expected reward given what it heard is the blind serve
 *    max_a sum_s b(s) R(s, a), while in M serving the best request of the revealed room
 *    earns, in expectation given the same information, sum_r w_r serve_r - pen. Their
 *    difference, the value of knowing the room at that serve, is
 *    VOI = min_{r*} sum_{r != r*} w_r (serve_r - Gmax(r, r*)) >= (1 - max_r w_r) Y, with
 *    Gmax(r, r*) = max over requests s of room r and a of room r* != r of R(s, a) (every
 *    wrong-room serve earns at most that) and Y = min_{r != r*} (serve_r - Gmax(r, r*)).
 *    Answers about the other slots only reweight them, so no room's posterior exceeds
 *    the max over the other slots' values (i, p) of b(r | i, p), which is theta(b) before
 *    any question about the room and at most the level's theta after (the bound above
 *    holds for each b(. | i, p)). Hence pen <= VOI: in M the policy loses nothing. The
 *    proof holds for any discount; tests: EveryNodeBracketsItsExactValue (brute force at
 *    every node), and CertifiedReport::crossings (an upper bound below a lower one) stays 0.
 * Expanded nodes take the Bellman backup of their children's bounds (upper: the minimum of
 * the backup and the relaxation; both stay valid).
 *
 * Storage: a child becomes a node only when a trial enters it (most never do); until then
 * its bounds are kept in its parent, as floats rounded outwards (keepLeaves: 8 bytes a
 * child instead of about 70 for a node).
 *
 * Shared upper bounds (CertifiedSolverOptions::shareUpperBounds):
 *  - fewer turns: a node takes the upper bound of the same statistics reached in fewer turns,
 *    since more questions left cannot be worth less (V_d <= V_d' for d' <= d);
 *  - the room simplex: nodes with the same turn and the same item and person statistics
 *    differ only in the room's likelihoods, so their beliefs are mixtures sum_r w_r b|r of
 *    the same corners, whose values are the exact sub-dialog values V_r. V_t is convex in w,
 *    so a node whose bound U' lies delta' below the line sum_r w'_r V_r lowers every node of
 *    its simplex by rho delta', rho = min_r w_r / w'_r (HSVI's sawtooth on that simplex).
 *
 * The policy: the greedy policy of the lower bound, exported as alpha vectors
 * (pomdp::TurnLimitedPolicy) by walking the policy's DAG from the root: each node's vector is
 * the value, per true request, of the plan the node starts (a frontier node's: serve, or its
 * commit plan with every node of that plan); the vector at the root is the certified lower
 * bound. The vectors serve every belief the language front end can produce
 * (max over vectors usable at that turn, each a plan's guaranteed value).
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "krr_core/dialog/dialog_pomdp.h"
#include "krr_core/pomdp/turn_limited_policy.h"

namespace krr {
namespace dialog {

/// @brief Solver parameters (config/dialog.yaml's `solver` block).
struct CertifiedSolverOptions {
  double precision = 1.0;        ///< stop when upper - lower <= precision at the root
  std::size_t maxTrials = 0;     ///< stop after this many trials (0: no limit); reproducible
  double timeout = 600.0;        ///< safety stop in seconds (not reproducible: reported)
  std::size_t memoryBudget = 0;  ///< bytes for the search's tables; 0: krr::memoryBudget()
  std::uint64_t seed = 1;        ///< the trials' answer sampling
  /// Every k-th trial follows the lower bound's greedy action instead of the upper bound's
  /// (0: never): trials along the policy improve the policy itself. With the commit plans
  /// few are needed, but some are: at k = 0 the lower bound at the root stays near 0.
  std::size_t lowerGuidedEvery = 8;
  /// A new node's lower bound is also the best "commit to one room" plan: follow the
  /// room-revealed sub-dialog's optimal plan for that room (never asking about the room
  /// again), valued exactly for every true request.
  bool commitLower = true;
  /// Nodes share upper bounds (proofs in certified_dialog_solver.cpp): a node takes the bound
  /// of the same statistics reached in fewer turns (more questions left cannot be worth
  /// less), and nodes that differ only in the room's statistics share one simplex of beliefs
  /// with exact corners, where a bound lowered at one node lowers the others (a sawtooth).
  bool shareUpperBounds = true;
  /// A new node's upper bound charges for the room (proof in the file comment): with the
  /// room revealed, serving before any question about it pays a penalty that the value of
  /// knowing the room at that serve provably exceeds.
  bool roomPaidBound = true;
  /// A new node's lower bound is also the best "ask one question about the room, then commit
  /// to the room best for its answer" plan (commitLower's plans, one turn later).
  bool roomLookahead = true;
  /// Children that no trial has entered are kept in their parent (8 bytes each: bounds as
  /// floats rounded outwards) instead of as nodes (about 70 bytes each): most never are.
  bool keepLeaves = true;
  /// A trial stops at a node whose gap is at most trialTarget x precision (HSVI's epsilon).
  /// At 1, the root's gap only approaches the precision: nodes just inside it are never
  /// entered again (br 0.1 learned: 1.015 after 300 s; at 0.1, <= 1 after 30 s).
  double trialTarget = 0.1;
};

/// @brief Why a solve stopped.
enum class SolveStop { kRunning, kPrecision, kTrials, kTimeout, kMemory };
const char* toString(SolveStop s);

/// @brief The bounds at the root and the size of the search.
struct CertifiedReport {
  double lower = 0.0;         ///< value the exported policy guarantees at the root belief
  double upper = 0.0;         ///< proven upper bound on the optimal value at the root
  double seconds = 0.0;       ///< wall time of the search
  std::size_t trials = 0;
  std::size_t nodes = 0;      ///< belief nodes stored
  std::size_t expanded = 0;   ///< nodes backed up from their children
  std::size_t subNodes = 0;   ///< nodes of the revealed-slot sub-dialogs (upper bound)
  std::size_t subCapped = 0;  ///< sub-dialog values cut off by the memory budget or timeout
  std::size_t sharedCuts = 0;  ///< new nodes whose upper bound another node's lowered
  /// Upper bounds found below lower ones (beyond rounding) and raised to them: 0 unless a
  /// bound is wrong (the tests and the benchmark check it).
  std::size_t crossings = 0;
  std::size_t bytes = 0;      ///< memory held by the tables
  SolveStop stop = SolveStop::kRunning;
  double gap() const { return upper - lower; }
  /// @brief Stopped by the precision or the trial budget, with no sub-dialog cut off: the same
  /// on every run. A cut depends on the memory budget (the machine's, limits.h) or the clock,
  /// so such a policy is not the same everywhere (solveDialogPolicy does not cache it).
  bool reproducible() const {
    return (stop == SolveStop::kPrecision || stop == SolveStop::kTrials) && subCapped == 0;
  }
};

/// @brief See the file comment.
class CertifiedDialogSolver {
 public:
  /**
   * @param dialog the model (referenced: it must outlive the solver)
   * @param root belief over requests (numRequests() entries, a distribution); empty: the
   *        model's prior
   * @param turnsUsed questions already asked at the root (the remaining horizon is
   *        turnLimit - turnsUsed)
   * @throws ConfigError for a root that is not a distribution, turnsUsed outside
   *         [0, turnLimit], bad options, or a turn limit whose statistics would not fit.
   */
  CertifiedDialogSolver(const DialogPomdp& dialog, const Eigen::VectorXd& root = {},
                        int turnsUsed = 0, CertifiedSolverOptions options = {});
  ~CertifiedDialogSolver();
  CertifiedDialogSolver(const CertifiedDialogSolver&) = delete;
  CertifiedDialogSolver& operator=(const CertifiedDialogSolver&) = delete;

  /// @brief Run trials until the precision, the trial budget, the timeout or the memory
  /// budget. @return true when the root gap is <= precision.
  bool solve();
  /// @brief Run at most `trials` more trials (then stop as solve() would).
  bool runTrials(std::size_t trials);
  CertifiedReport report() const;

  /// @brief The exported policy's action at the root (a model action index).
  std::size_t rootAction() const;
  /// @brief The lower bound's policy as alpha vectors tagged with their turns (see the file
  /// comment); its value at the root belief is report().lower.
  pomdp::TurnLimitedPolicy policy() const;

  /// @brief One stored belief node: its belief over requests (values of alike classes in
  /// canonical order), questions asked, and bounds; each must bracket its exact value.
  struct NodeBounds {
    Eigen::VectorXd belief;
    int turnsUsed = 0;
    double lower = 0.0, upper = 0.0;
  };
  /// @brief The first `maxNodes` stored nodes (tests and diagnostics).
  std::vector<NodeBounds> nodeBounds(std::size_t maxNodes) const;

  /// @brief Exact value V_t of the model at the root by exhaustive dynamic programming over
  /// the statistics (no bounds, no pruning): a reference for small models and tests.
  /// @throws ConfigError when more than maxNodes nodes would be needed.
  static double exactValue(const DialogPomdp& dialog, std::size_t maxNodes = 2000000);

  class Impl;  ///< the search (certified_dialog_solver.cpp)

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace dialog
}  // namespace krr
