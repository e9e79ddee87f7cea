#include "krr_core/pomdp/belief.h"

#include <cmath>

#include "krr_core/common/errors.h"

namespace krr {
namespace pomdp {

namespace {
void checkArgs(const Model& m, const Belief& b, std::size_t a, std::size_t o) {
  if (static_cast<std::size_t>(b.size()) != m.getS())
    throw ConfigError("belief has " + std::to_string(b.size()) + " entries, model has " +
                      std::to_string(m.getS()) + " states");
  if (a >= m.getA())
    throw ConfigError("action index " + std::to_string(a) + " out of range (" +
                      std::to_string(m.getA()) + " actions)");
  if (o >= m.getO())
    throw ConfigError("observation index " + std::to_string(o) + " out of range (" +
                      std::to_string(m.getO()) + " observations)");
}
}  // namespace

double observationProbability(const Model& m, const Belief& b, std::size_t a, std::size_t o) {
  checkArgs(m, b, a, o);
  if (m.hasDenseObservations() && m.hasDenseTransitions()) {  // the historical dense path
    if (m.isIdentityTransition(a)) return m.observationMatrix(a).col(o).dot(b);
    return m.observationMatrix(a).col(o).dot(m.transitionMatrixTransposed(a) * b);
  }
  Belief next;
  m.predict(a, b, next);
  m.weightByObservation(a, o, next);
  return next.sum();
}

bool tryUpdateBelief(const Model& m, const Belief& b, std::size_t a, std::size_t o, Belief& out,
                     double* prob) {
  checkArgs(m, b, a, o);
  // predict then weight: the same products as O_o .* (T^T b) in either storage.
  Belief next;
  m.predict(a, b, next);
  m.weightByObservation(a, o, next);
  double p = next.sum();
  if (prob) *prob = p;
  if (!(p > 0.0)) return false;
  out = next / p;
  return true;
}

Belief updateBelief(const Model& m, const Belief& b, std::size_t a, std::size_t o) {
  Belief out;
  if (!tryUpdateBelief(m, b, a, o, out))
    throw IncoherentError("belief update: observation '" + m.observationNames()[o] +
                          "' has probability 0 after action '" + m.actionNames()[a] +
                          "' under the current belief");
  return out;
}

double entropy(const Belief& b, EntropyUnit unit) {
  double h = 0.0;
  for (Eigen::Index i = 0; i < b.size(); ++i)
    if (b(i) > 0.0) h -= b(i) * std::log(b(i));
  return unit == EntropyUnit::kBits ? h / std::log(2.0) : h;
}

Eigen::VectorXd marginal(const Belief& b, const std::vector<int>& groupOf, std::size_t groups) {
  if (groupOf.size() != static_cast<std::size_t>(b.size()))
    throw ConfigError("marginal: " + std::to_string(groupOf.size()) + " group labels for " +
                      std::to_string(b.size()) + " states");
  Eigen::VectorXd out = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(groups));
  for (std::size_t s = 0; s < groupOf.size(); ++s) {
    int g = groupOf[s];
    if (g < 0) continue;
    if (static_cast<std::size_t>(g) >= groups)
      throw ConfigError("marginal: group " + std::to_string(g) + " of state " +
                        std::to_string(s) + " out of range (" + std::to_string(groups) + ")");
    out(g) += b(static_cast<Eigen::Index>(s));
  }
  return out;
}

std::size_t argmaxState(const Belief& b) {
  Eigen::Index best = 0;
  b.maxCoeff(&best);
  return static_cast<std::size_t>(best);
}

double expectedReward(const Model& m, const Belief& b, std::size_t a) {
  return m.rewardMatrix().col(static_cast<Eigen::Index>(a)).dot(b);
}

}  // namespace pomdp
}  // namespace krr
