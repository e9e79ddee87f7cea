#include "krr_core/common/parallel.h"
#include "krr_core/experiments/belief_entropy_survey.h"
#include "krr_core/dialog/dialog_policy.h"
#include "krr_core/dialog/dialog_session.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <random>

#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"
#include "krr_core/pomdp/belief.h"

namespace krr {
namespace experiments {

using dialog::DialogPomdp;

void BeliefSamplerOptions::validate() const {
  if (!(alpha_min > 0) || !std::isfinite(alpha_min))
    throw ConfigError("belief sampler: alpha_min = " + std::to_string(alpha_min) + " must be > 0");
  if (!(alpha_max >= alpha_min) || !std::isfinite(alpha_max))
    throw ConfigError("belief sampler: alpha_max = " + std::to_string(alpha_max) +
                      " must be finite and >= alpha_min");
}

BeliefEntropySurvey::BeliefEntropySurvey(const DialogPomdp& dialog,
                                         const pomdp::TurnLimitedPolicy& policy,
                                         const BeliefSamplerOptions& options, std::uint64_t seed)
    : dialog_(dialog), policy_(policy), options_(options), seed_(seed) {
  options_.validate();
  const std::string mismatch = dialog::policyMismatch(policy, dialog);
  if (!mismatch.empty()) throw ConfigError("belief entropy survey: " + mismatch);
}

pomdp::Belief BeliefEntropySurvey::belief(std::size_t index) const {
  Rng rng = makeRng(seed_, "entropy/belief", index);
  const double lo = std::log(options_.alpha_min), hi = std::log(options_.alpha_max);
  const double alpha = std::exp(lo + (hi - lo) * uniform01(rng));
  // Dirichlet(alpha) in log space: G(alpha) = G(alpha + 1) U^(1/alpha), so tiny alphas do not
  // underflow to an all-zero vector.
  const std::size_t n = dialog_.numRequests();
  std::vector<double> logw(n);
  std::gamma_distribution<double> gamma(alpha + 1.0, 1.0);
  for (std::size_t k = 0; k < n; ++k) {
    double u = uniform01(rng);
    if (u <= 0) u = 1e-300;
    logw[k] = std::log(std::max(gamma(rng), 1e-300)) + std::log(u) / alpha;
  }
  const double mx = *std::max_element(logw.begin(), logw.end());
  pomdp::Belief b = pomdp::Belief::Zero(static_cast<Eigen::Index>(dialog_.model().getS()));
  double sum = 0;
  for (std::size_t k = 0; k < n; ++k) sum += (b(static_cast<Eigen::Index>(k)) = std::exp(logw[k] - mx));
  b /= sum;
  return b;
}

EntropySample BeliefEntropySurvey::sample(std::size_t index) const {
  const pomdp::Belief b = belief(index);
  EntropySample s;
  s.index = index;
  s.action = dialog::decideAction(dialog_, policy_, b, 0);  // the robot at the start of a dialog
  s.serve = dialog_.isServe(s.action);
  if (s.serve) s.request = dialog_.requestOfServe(s.action);
  s.entropy = pomdp::entropy(b, pomdp::EntropyUnit::kNats);
  s.entropy_bits = pomdp::entropy(b, pomdp::EntropyUnit::kBits);
  s.max_probability = b.maxCoeff();
  return s;
}

std::vector<EntropySample> BeliefEntropySurvey::run(std::size_t begin, std::size_t count,
                                                    std::size_t threads) const {
  return runParallelTrials<EntropySample>(count, threads, [&]() {
    return [&](std::size_t k) { return sample(begin + k); };
  });
}

std::string BeliefEntropySurvey::csvHeader() {
  return "trial,action,room,entropy,entropy_bits,max_probability,served";
}

std::string BeliefEntropySurvey::csvRow(const EntropySample& s) const {
  const std::string action = dialog_.model().actionNames()[s.action];
  std::string room, served;
  if (s.serve) {
    room = dialog_.spec().rooms[dialog_.requestParts(s.request)[1]];
    served = dialog_.requestName(s.request);
  }
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%zu,%s,%s,%.6g,%.6g,%.6g,%s", s.index, action.c_str(),
                room.c_str(), s.entropy, s.entropy_bits, s.max_probability, served.c_str());
  return buf;
}

}  // namespace experiments
}  // namespace krr
