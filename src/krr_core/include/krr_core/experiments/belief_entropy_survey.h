/**
 * @file belief_entropy_survey.h
 * @brief The paper's Table II experiment: "In each trial, we randomly generate a belief
 * distribution over all possible service requests, evaluate the entropy of this belief, and
 * record the suggested action given this belief. We then statistically analyze the entropy
 * values of beliefs, under which delivery actions are suggested."
 *
 * The paper does not say how the random beliefs are drawn. Uniform Dirichlet(1) beliefs over
 * 30 requests have entropies around 2.9 nats, where no sensible policy delivers, so here a
 * sample is a Dirichlet(alpha, ..., alpha) belief with alpha log-uniform in
 * [alpha_min, alpha_max] (default [0.005, 0.5]): from nearly certain to diffuse beliefs, so the
 * entropies under which the policy delivers span the whole range up to its delivery threshold.
 * Entropy is in nats (natural log); Table II's magnitudes (means 0.10 to 0.27, maxima up to
 * 0.42) are consistent with either unit, and nats is belief.h's documented default. The
 * belief is over the requests only (no terminal mass). The suggested action is the policy's
 * at the start of a dialog (no question asked yet: all turns left). Sample i uses stream
 * makeRng(seed, "entropy/belief", i) only.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "krr_core/pomdp/turn_limited_policy.h"
#include "krr_core/dialog/dialog_pomdp.h"

namespace krr {
namespace experiments {

/// @brief How random beliefs are drawn.
struct BeliefSamplerOptions {
  double alpha_min = 0.005;
  double alpha_max = 0.5;
  /// @throws ConfigError unless 0 < alpha_min <= alpha_max (finite).
  void validate() const;
};

/// @brief One random belief and the policy's suggestion.
struct EntropySample {
  std::size_t index = 0;
  std::size_t action = 0;      ///< the policy's action at the belief
  bool serve = false;          ///< a delivery action
  std::size_t request = 0;     ///< served request (serve only)
  double entropy = 0.0;        ///< nats
  double entropy_bits = 0.0;
  double max_probability = 0.0;  ///< largest belief entry
};

/// @brief Draws beliefs and asks the policy (both referenced; they must outlive the survey).
class BeliefEntropySurvey {
 public:
  /// @throws ConfigError on bad options or a policy of the wrong size.
  BeliefEntropySurvey(const dialog::DialogPomdp& dialog, const pomdp::TurnLimitedPolicy& policy,
                      const BeliefSamplerOptions& options, std::uint64_t seed);
  /// @brief The random belief of sample i (over all states; terminal mass 0).
  pomdp::Belief belief(std::size_t index) const;
  EntropySample sample(std::size_t index) const;
  /// @brief Samples begin..begin+count-1, in order, on `threads` threads.
  std::vector<EntropySample> run(std::size_t begin, std::size_t count, std::size_t threads) const;

  /// @brief CSV header (sample index first, column "trial").
  static std::string csvHeader();
  std::string csvRow(const EntropySample& s) const;

 private:
  const dialog::DialogPomdp& dialog_;
  const pomdp::TurnLimitedPolicy& policy_;
  BeliefSamplerOptions options_;
  std::uint64_t seed_;
};

}  // namespace experiments
}  // namespace krr
