/**
 * @file turn_limited_policy.h
 * @brief The policy of a POMDP with a turn limit: alpha vectors tagged with the latest turn
 * at which their plan may start.
 *
 * A dialog manager may ask at most `turnLimit` questions, then it must end the dialog (serve).
 * The turn count is known to the robot, so the optimal value depends on it: V_t(b) for t
 * questions asked. A vector tagged with stage k is the value of a conditional plan that asks
 * at most turnLimit - k more questions, so it may start at any turn t <= k (fewer questions
 * asked leave at least as many to spare); vectors tagged turnLimit are plans that end at
 * once. At turn t the policy takes the action of the best vector among those with stage >= t:
 * executed greedily this way, the policy earns at least that vector's value (the solver
 * exports only vectors of plans that stay available, see dialog::CertifiedDialogSolver).
 *
 * Plans (optional): each vector may also name, per observation, the vector of the plan that
 * continues it after that answer (next()). A robot that follows them earns exactly the
 * vector's value in O(1) per turn, instead of a scan of every vector at every turn (a
 * certified dialog policy has about 150,000); it scans only when it leaves the plan.
 */
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "krr_core/pomdp/model.h"

namespace krr {
namespace pomdp {

/// @brief Alpha vectors with actions and stages (see the file comment).
class TurnLimitedPolicy {
 public:
  /// @brief An empty policy. @throws ConfigError for a negative turn limit.
  explicit TurnLimitedPolicy(std::size_t numStates = 0, int turnLimit = 0);

  /// @brief Add a vector usable at turns 0..stage. @throws ConfigError on a size mismatch,
  /// a non-finite entry or a stage outside [0, turnLimit].
  void add(const Eigen::VectorXd& alpha, std::size_t action, int stage);

  /**
   * @brief Attach the plans' continuations: next[i * numObservations + o] is the vector that
   * continues vector i after observation o, -1 for none. @throws ConfigError for a wrong size,
   * an index out of range, or a continuation not usable one turn later (stage below
   * min(stage(i) + 1, turnLimit)).
   */
  void setPlans(std::size_t numObservations, std::vector<long> next);
  bool hasPlans() const { return obs_ > 0; }
  std::size_t numObservations() const { return obs_; }
  /// @brief The vector continuing vector i after observation o, -1 for none (or no plans).
  long next(std::size_t i, std::size_t o) const {
    return obs_ == 0 || o >= obs_ ? -1 : next_[i * obs_ + o];
  }

  std::size_t numStates() const { return s_; }
  int turnLimit() const { return limit_; }
  std::size_t size() const { return actions_.size(); }
  const Eigen::VectorXd& alpha(std::size_t i) const { return alphas_[i]; }
  std::size_t action(std::size_t i) const { return actions_[i]; }
  int stage(std::size_t i) const { return stages_[i]; }

  /// @brief Index of the best vector at b among those usable after `turns` questions (turns
  /// beyond the limit count as the limit; lowest index on ties).
  /// @throws ConfigError on a belief of the wrong size or when no vector is usable.
  std::size_t bestIndex(const Belief& b, int turns) const;
  std::size_t bestAction(const Belief& b, int turns) const { return actions_[bestIndex(b, turns)]; }
  /// @brief The value the policy guarantees at (b, turns).
  double value(const Belief& b, int turns) const;
  /**
   * @brief One-step lookahead on the policy's values: R(b, a) + gamma sum_o P(o | b, a)
   * value(b_ao, turns + 1) for an action that continues (R(b, a) alone for one that ends the
   * episode: `ends`). Acting by it and then by the policy is worth at least this.
   */
  double lookahead(const Model& m, const Belief& b, std::size_t a, int turns, bool ends) const;
  /// @brief lookahead() of several continuing actions at once (one pass over the vectors for
  /// all their successor beliefs; what a decision between questions needs).
  std::vector<double> lookahead(const Model& m, const Belief& b,
                                const std::vector<std::size_t>& actions, int turns) const;
  /// @brief value() of every column of `beliefs` (S x k).
  Eigen::VectorXd values(const Eigen::MatrixXd& beliefs, int turns) const;

  /// @brief Text format: "krr-turn-limited-policy 1", "states S", "turn_limit L",
  /// "vectors N", then N lines "stage action v1 ... vS" (exact round trip). With plans,
  /// version 2 and after the vectors "plans O" and N lines of O entries, next + 1 (0: none).
  std::string toText() const;
  /// @throws ParseError with file:line:col, ConfigError for values add() refuses.
  static TurnLimitedPolicy fromText(const std::string& text, const std::string& file = "<string>");
  void save(const std::string& path) const;
  static TurnLimitedPolicy load(const std::string& path);

 private:
  std::size_t s_;
  int limit_;
  std::vector<Eigen::VectorXd> alphas_;
  std::vector<std::size_t> actions_;
  std::vector<int> stages_;
  std::size_t obs_ = 0;
  std::vector<long> next_;
  /// @brief The vectors of one stage, row-major and contiguous, with their indices: bestIndex
  /// is then one matrix-vector product per stage (it runs at every lookahead of every trial).
  struct StageGroup {
    std::vector<double> rows;
    std::vector<std::size_t> ids;
  };
  std::vector<StageGroup> by_stage_;
};

}  // namespace pomdp
}  // namespace krr
