/**
 * @file belief.h
 * @brief Exact Bayesian belief tracking and belief statistics.
 *
 * The dialog manager keeps an exact distribution over the 30 service requests; these functions
 * are that filter. An observation that the model says is impossible under the current belief
 * is reported (IncoherentError or a false return), never silently renormalised to NaN.
 */
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "krr_core/pomdp/model.h"

namespace krr {
namespace pomdp {

/// @brief Unit of belief entropy.
enum class EntropyUnit {
  kNats,  ///< natural logarithm (default; scipy.stats.entropy's default, used for Table II)
  kBits   ///< base-2 logarithm
};

/// @brief P(o | b, a) = sum_s1 O(s1, a, o) sum_s T(s, a, s1) b(s).
double observationProbability(const Model& m, const Belief& b, std::size_t a, std::size_t o);

/**
 * @brief b'(s1) proportional to O(s1, a, o) sum_s T(s, a, s1) b(s), written to out.
 * @return false (out untouched) when P(o | b, a) is zero; prob receives P(o | b, a) if given.
 */
bool tryUpdateBelief(const Model& m, const Belief& b, std::size_t a, std::size_t o, Belief& out,
                     double* prob = nullptr);

/// @brief The updated belief. @throws IncoherentError naming action and observation when
/// the observation has probability zero under b.
Belief updateBelief(const Model& m, const Belief& b, std::size_t a, std::size_t o);

/// @brief Shannon entropy -sum b log b (0 log 0 = 0) in the given unit.
double entropy(const Belief& b, EntropyUnit unit = EntropyUnit::kNats);

/// @brief Marginal of a belief over a factor: out[groupOf[s]] += b[s] (states with
/// groupOf[s] < 0, e.g. terminals, are skipped). @throws ConfigError on size mismatch.
Eigen::VectorXd marginal(const Belief& b, const std::vector<int>& groupOf, std::size_t groups);

/// @brief Index of the most likely state (lowest index on ties).
std::size_t argmaxState(const Belief& b);

/// @brief Expected immediate reward sum_s b(s) R(s, a).
double expectedReward(const Model& m, const Belief& b, std::size_t a);

}  // namespace pomdp
}  // namespace krr
