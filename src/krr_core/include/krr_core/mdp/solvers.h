/**
 * @file solvers.h
 * @brief Value iteration and policy iteration for SparseModel and the grid layouts.
 *
 * Value iteration is Gauss-Seidel in place, alternating the sweep direction (forward, then
 * backward; per pass when several sweeps are pipelined in one pass, see below) so values
 * propagate both towards and away from the goal. It stops
 * when the largest change of a sweep (the residual) is below epsilon (1 - gamma) / (2 gamma),
 * the standard bound under which the greedy policy is epsilon-optimal; with gamma = 1 it stops
 * on residual < epsilon. A warm start (the previous value function) makes replanning after a
 * small model change cost a few sweeps instead of a full solve.
 *
 * On the grid layout a row is updated Jacobi-style from the values at the start of its update
 * (so the row vectorises across cells) and Gauss-Seidel across rows; this is still a
 * gamma-contraction, so the same bound applies. Grids larger than about 1 MiB run up to 8
 * sweeps per pass over memory, pipelined one row apart (identical results, a fraction of the
 * memory traffic).
 *
 * A SparseModel is solved through its sweep layout (BasicSweepModel: per state the union of
 * the successors of all actions and a dense successor x action block), built on each call
 * when it suits the model (CSR rows otherwise); build a SweepModel / SweepModelF once to
 * solve a model repeatedly. Its sweeps are Gauss-Seidel in state order with the actions of a
 * state evaluated together in SIMD lanes, 4 sweeps pipelined per pass (identical results)
 * when the model's bandwidth allows.
 *
 * The kernels are compiled for AVX2 + FMA and chosen at run time (portable C++ otherwise, or
 * when the environment variable KRR_MDP_ISA=generic is set), so the default -O3 build needs
 * no -march flag.
 */
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"

#include "krr_core/mdp/grid_model.h"
#include "krr_core/mdp/model_concept.h"
#include "krr_core/mdp/sparse_model.h"

namespace krr {
namespace mdp {

/// @brief Starting values of a cold (not warm-started) value iteration.
enum class InitialValues {
  kZero,           ///< V0 = 0
  /// V0(s) = min(0, max_a R(s,a)) / (1 - gamma): paying the best immediate cost forever. It is
  /// exact far from any goal in a navigation task, which removes the slow gamma^k build-up of
  /// the step costs (about half the sweeps on navigation grids); 0 where a reward is positive.
  kRewardHorizon,
};

/// @brief Stopping parameters shared by the solvers.
struct SolverOptions {
  double epsilon = 1e-6;              ///< target suboptimality of the greedy policy
  std::size_t max_iterations = 100000;  ///< sweeps (VI) or improvement steps (PI)
  InitialValues initial = InitialValues::kRewardHorizon;  ///< cold-start values (VI)
  /// @throws ConfigError naming the field when epsilon <= 0 or max_iterations == 0.
  void validate() const;
};

/// @brief Result of a solve: values, greedy policy, work done and final residual.
struct Solution {
  std::vector<double> values;      ///< V(s), 0 for terminal states
  std::vector<ActionId> policy;    ///< greedy action (lowest index among ties), 0 for terminals
  std::size_t iterations = 0;      ///< sweeps (VI) or policy improvements (PI)
  double residual = 0.0;           ///< last sweep's max |V_new - V_old| (VI) / Bellman residual (PI)
  bool converged = false;          ///< residual below the stopping threshold

  /// @brief Record sweep `it` with residual `res` (the one stopping rule of every sweep loop);
  /// true when it converged (res < threshold).
  bool recordSweep(std::size_t it, double res, double threshold) {
    iterations = it;
    residual = res;
    converged = res < threshold;
    return converged;
  }
};

/// @brief The residual threshold epsilon (1 - gamma) / (2 gamma) (epsilon when gamma = 1).
double stoppingThreshold(double epsilon, double discount);

/// @brief Cold-start value of a state whose best immediate reward is max_reward.
inline double initialValue(InitialValues init, double max_reward, double discount) {
  if (init == InitialValues::kZero || max_reward >= 0.0 || discount >= 1.0) return 0.0;
  return max_reward / (1.0 - discount);
}

/**
 * @brief Gauss-Seidel value iteration on a SparseModel.
 * @param warm_start initial values (size S), or nullptr for zeros.
 * @throws ConfigError when options are invalid or warm_start has the wrong size.
 */
Solution valueIteration(const SparseModel& model, const SolverOptions& options,
                        const std::vector<double>* warm_start = nullptr);
/**
 * @brief Value iteration on the sweep layout of a SparseModel (what valueIteration(const
 * SparseModel&) uses for models it suits). Build the layout once (float storage halves the
 * memory traffic of large models) and solve it many times. Same stopping rule and result.
 */
Solution valueIteration(const SweepModel& model, const SolverOptions& options,
                        const std::vector<double>* warm_start = nullptr);
/// @brief Value iteration on the float sweep layout.
Solution valueIteration(const SweepModelF& model, const SolverOptions& options,
                        const std::vector<double>* warm_start = nullptr);
/// @brief Value iteration on the grid layout (values of cells, then the failure state).
Solution valueIteration(const GridModel& model, const SolverOptions& options,
                        const std::vector<double>* warm_start = nullptr);
/// @brief Value iteration on the float grid layout.
Solution valueIteration(const GridModelF& model, const SolverOptions& options,
                        const std::vector<double>* warm_start = nullptr);

/**
 * @brief Policy iteration with exact policy evaluation (Eigen sparse LU). Improvement keeps the
 * current action unless another is better by more than 1e-10, so it cannot cycle.
 * @throws ConfigError if some policy's evaluation system is singular (gamma = 1 and the policy
 * never reaches a terminal state).
 */
Solution policyIteration(const SparseModel& model, const SolverOptions& options,
                         const std::vector<ActionId>* initial_policy = nullptr);

/// @brief V^pi solved exactly: (I - gamma P_pi) V = R_pi on non-terminal states.
std::vector<double> evaluatePolicy(const SparseModel& model, const std::vector<ActionId>& policy);

/// @brief Q(s, a) = R(s, a) + gamma sum_s' T(s, a, s') V(s').
double qValue(const SparseModel& model, const std::vector<double>& values, StateId s, ActionId a);

/// @brief Greedy policy of a value function (lowest action index among exact ties).
std::vector<ActionId> greedyPolicy(const SparseModel& model, const std::vector<double>& values);

/// @brief max_s |(B V)(s) - V(s)|, the Bellman residual of a value function.
double bellmanResidual(const SparseModel& model, const std::vector<double>& values);

/**
 * @brief Bellman backup max_a Q(s, a) on any model with the SparseModel interface; writes the
 * maximising action (lowest index among ties) to *best_action when given.
 */
template <class Model>
double bellmanBackup(const Model& model, const std::vector<double>& values, StateId s,
                     ActionId* best_action = nullptr) {
  static_assert(is_successor_model_v<Model>,
                "bellmanBackup: the model must satisfy mdp::SuccessorModel (getS, getA, "
                "getDiscount, getTransitionProbability, getExpectedReward, isTerminal, "
                "successors; see krr_core/mdp/model_concept.h)");
  double best = -std::numeric_limits<double>::infinity();
  ActionId arg = 0;
  const double g = model.getDiscount();
  for (ActionId a = 0; a < model.getA(); ++a) {
    double acc = 0.0;
    for (Outcome o : model.successors(s, a)) acc += o.probability * values[o.state];
    const double q = model.getExpectedReward(s, a) + g * acc;
    if (q > best) {
      best = q;
      arg = a;
    }
  }
  if (best_action != nullptr) *best_action = arg;
  return best;
}

/**
 * @brief Gauss-Seidel value iteration (alternating sweeps) on any model with the SparseModel
 * interface, e.g. the R-Max model view. Same stopping rule and result as valueIteration().
 */
template <class Model>
Solution valueIterationView(const Model& model, const SolverOptions& options,
                            const std::vector<double>* warm_start = nullptr) {
  static_assert(is_successor_model_v<Model>,
                "valueIterationView: the model must satisfy mdp::SuccessorModel (getS, getA, "
                "getDiscount, getTransitionProbability, getExpectedReward, isTerminal, "
                "successors; see krr_core/mdp/model_concept.h)");
  options.validate();
  const std::size_t ns = model.getS();
  if (warm_start != nullptr && warm_start->size() != ns) {
    throw ConfigError("valueIteration: warm start has " + std::to_string(warm_start->size()) +
                      " values, the model has " + std::to_string(ns) + " states");
  }
  Solution sol;
  sol.values = warm_start != nullptr ? *warm_start : std::vector<double>(ns, 0.0);
  sol.policy.assign(ns, 0);
  for (StateId s = 0; s < ns; ++s) {
    if (model.isTerminal(s)) {
      sol.values[s] = 0.0;
    } else if (warm_start == nullptr) {
      double best = -std::numeric_limits<double>::infinity();
      for (ActionId a = 0; a < model.getA(); ++a) {
        best = std::max(best, model.getExpectedReward(s, a));
      }
      sol.values[s] = initialValue(options.initial, best, model.getDiscount());
    }
  }
  const double threshold = stoppingThreshold(options.epsilon, model.getDiscount());
  for (std::size_t it = 1; it <= options.max_iterations; ++it) {
    double res = 0.0;
    for (std::size_t idx = 0; idx < ns; ++idx) {
      const StateId s = static_cast<StateId>(it % 2 == 1 ? idx : ns - 1 - idx);
      if (model.isTerminal(s)) continue;
      const double v = bellmanBackup(model, sol.values, s, &sol.policy[s]);
      res = std::max(res, std::fabs(v - sol.values[s]));
      sol.values[s] = v;
    }
    if (sol.recordSweep(it, res, threshold)) break;
  }
  for (StateId s = 0; s < ns; ++s) {
    if (!model.isTerminal(s)) bellmanBackup(model, sol.values, s, &sol.policy[s]);
  }
  return sol;
}

}  // namespace mdp
}  // namespace krr
