#include "krr_core/mdp/reach_probability.h"

#include <Eigen/Sparse>
#include <Eigen/SparseLU>

#include <algorithm>
#include <string>

#include "krr_core/common/errors.h"

namespace krr {
namespace mdp {

namespace {

std::vector<std::uint8_t> targetMask(const SparseModel& m, const std::vector<ActionId>& policy,
                                     const std::vector<StateId>& target) {
  if (policy.size() != m.getS()) {
    throw ConfigError("reachProbability: policy has " + std::to_string(policy.size()) +
                      " entries, the model has " + std::to_string(m.getS()) + " states");
  }
  for (StateId s = 0; s < m.getS(); ++s) {
    if (!m.isTerminal(s) && policy[s] >= m.getA()) {
      throw ConfigError("reachProbability: action " + std::to_string(policy[s]) + " of state " +
                        std::to_string(s) + " out of range [0, " + std::to_string(m.getA()) +
                        ")");
    }
  }
  std::vector<std::uint8_t> mask(m.getS(), 0);
  for (StateId t : target) {
    if (t >= m.getS()) {
      throw ConfigError("reachProbability: target " + std::to_string(t) + " out of range [0, " +
                        std::to_string(m.getS()) + ")");
    }
    mask[t] = 1;
  }
  return mask;
}

}  // namespace

std::vector<double> reachProbability(const SparseModel& m, const std::vector<ActionId>& policy,
                                     const std::vector<StateId>& target, std::size_t horizon) {
  const std::vector<std::uint8_t> tgt = targetMask(m, policy, target);
  const std::size_t n = m.getS();
  // A state is "open" (transient, unknown probability) if it is neither target nor terminal.
  auto open = [&](StateId s) { return !tgt[s] && !m.isTerminal(s); };

  if (horizon != kInfiniteHorizon) {
    std::vector<double> x(n, 0.0), y(n, 0.0);
    for (std::size_t s = 0; s < n; ++s) x[s] = tgt[s] ? 1.0 : 0.0;
    y = x;
    for (std::size_t k = 0; k < horizon; ++k) {
      for (StateId s = 0; s < n; ++s) {
        if (!open(s)) continue;
        double acc = 0.0;
        for (Outcome o : m.successors(s, policy[s])) acc += o.probability * x[o.state];
        y[s] = acc;
      }
      x.swap(y);
    }
    return x;
  }

  // States that can reach a target: reverse search over the policy's transition graph.
  std::vector<std::vector<StateId>> pred(n);
  for (StateId s = 0; s < n; ++s) {
    if (!open(s)) continue;
    for (Outcome o : m.successors(s, policy[s])) {
      if (o.probability > 0.0) pred[o.state].push_back(s);
    }
  }
  std::vector<std::uint8_t> can(n, 0);
  std::vector<StateId> stack;
  for (StateId s = 0; s < n; ++s) {
    if (tgt[s]) {
      can[s] = 1;
      stack.push_back(s);
    }
  }
  while (!stack.empty()) {
    const StateId s = stack.back();
    stack.pop_back();
    for (StateId p : pred[s]) {
      if (!can[p]) {
        can[p] = 1;
        stack.push_back(p);
      }
    }
  }
  // Unknowns: open states that can reach the target. Every one of them has a path out of the
  // unknown set with positive probability, so I - Q is non-singular.
  std::vector<int> idx(n, -1);
  int nu = 0;
  for (StateId s = 0; s < n; ++s) {
    if (open(s) && can[s]) idx[s] = nu++;
  }
  std::vector<double> x(n, 0.0);
  for (StateId s = 0; s < n; ++s) x[s] = tgt[s] ? 1.0 : 0.0;
  if (nu == 0) return x;
  std::vector<Eigen::Triplet<double>> trip;
  Eigen::VectorXd b = Eigen::VectorXd::Zero(nu);
  for (StateId s = 0; s < n; ++s) {
    if (idx[s] < 0) continue;
    trip.emplace_back(idx[s], idx[s], 1.0);
    for (Outcome o : m.successors(s, policy[s])) {
      if (tgt[o.state]) {
        b[idx[s]] += o.probability;
      } else if (idx[o.state] >= 0) {
        trip.emplace_back(idx[s], idx[o.state], -o.probability);
      }
    }
  }
  Eigen::SparseMatrix<double> a(nu, nu);
  a.setFromTriplets(trip.begin(), trip.end());
  a.makeCompressed();
  Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
  lu.analyzePattern(a);
  lu.factorize(a);
  if (lu.info() != Eigen::Success) {
    throw ConfigError("reachProbability: absorbing-chain system is singular");
  }
  Eigen::VectorXd sol = lu.solve(b);
  for (StateId s = 0; s < n; ++s) {
    if (idx[s] >= 0) x[s] = std::min(1.0, std::max(0.0, sol[idx[s]]));
  }
  return x;
}

double monteCarloReachProbability(const SparseModel& m, const std::vector<ActionId>& policy,
                                  const std::vector<StateId>& target, StateId start,
                                  std::size_t horizon, std::size_t episodes, Rng& rng,
                                  std::size_t max_steps) {
  const std::vector<std::uint8_t> tgt = targetMask(m, policy, target);
  if (start >= m.getS()) {
    throw ConfigError("monteCarloReachProbability: start " + std::to_string(start) +
                      " out of range");
  }
  if (episodes == 0) throw ConfigError("monteCarloReachProbability: episodes must be > 0");
  const std::size_t limit = horizon == kInfiniteHorizon ? max_steps : horizon;
  std::size_t hits = 0;
  for (std::size_t e = 0; e < episodes; ++e) {
    StateId s = start;
    for (std::size_t k = 0; !tgt[s] && !m.isTerminal(s) && k < limit; ++k) {
      s = m.sampleSR(s, policy[s], rng).first;
    }
    hits += tgt[s];
  }
  return static_cast<double>(hits) / static_cast<double>(episodes);
}

}  // namespace mdp
}  // namespace krr
