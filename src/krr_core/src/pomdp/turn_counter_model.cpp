#include "krr_core/pomdp/turn_counter_model.h"

#include "krr_core/common/errors.h"

namespace krr {
namespace pomdp {

Model withTurnCounter(const Model& m, const Belief& b0, int turnLimit) {
  if (turnLimit < 0) throw ConfigError("turn counter: turn limit " + std::to_string(turnLimit) + " < 0");
  const std::size_t S = m.getS(), A = m.getA(), O = m.getO(), L = static_cast<std::size_t>(turnLimit);
  if (static_cast<std::size_t>(b0.size()) != S)
    throw ConfigError("turn counter: initial belief has " + std::to_string(b0.size()) +
                      " entries, model has " + std::to_string(S) + " states");
  std::vector<char> ending(A, 1);
  double minEnding = 0.0;
  bool anyEnding = false;
  for (std::size_t a = 0; a < A; ++a) {
    for (std::size_t s = 0; s < S; ++s)
      for (const auto& e : m.successors(s, a)) ending[a] = ending[a] && m.isTerminal(e.first);
    if (ending[a]) {
      const double lo = m.rewardMatrix().col(static_cast<Eigen::Index>(a)).minCoeff();
      minEnding = anyEnding ? std::min(minEnding, lo) : lo;
      anyEnding = true;
    }
  }
  std::size_t terminal = S;
  for (std::size_t s = 0; s < S && terminal == S; ++s)
    if (m.isTerminal(s)) terminal = s;
  if (!anyEnding || terminal == S)
    throw ConfigError("turn counter: the model has no action that ends the episode");
  const double forbidden = minEnding - 1.0 - std::abs(minEnding);
  const std::size_t N = S * (L + 1);
  const auto n = static_cast<Eigen::Index>(N);
  auto idx = [S](std::size_t s, std::size_t t) { return static_cast<Eigen::Index>(t * S + s); };
  std::vector<Eigen::MatrixXd> tr(A, Eigen::MatrixXd::Zero(n, n)), z(A);
  Eigen::MatrixXd r(n, static_cast<Eigen::Index>(A));
  for (std::size_t a = 0; a < A; ++a) {
    z[a].setZero(n, static_cast<Eigen::Index>(O));
    for (std::size_t t = 0; t <= L; ++t)
      for (std::size_t s = 0; s < S; ++s) {
        const auto row = idx(s, t);
        for (const auto& e : m.observationRow(s, a)) z[a](row, static_cast<Eigen::Index>(e.first)) = e.second;
        r(row, static_cast<Eigen::Index>(a)) = m.getExpectedReward(s, a);
        if (m.isTerminal(s)) {
          tr[a](row, row) = 1.0;  // absorbing at its turn, zero reward
          continue;
        }
        if (ending[a]) {
          for (const auto& e : m.successors(s, a)) tr[a](row, idx(e.first, t)) += e.second;
        } else if (t < L) {
          for (const auto& e : m.successors(s, a)) tr[a](row, idx(e.first, t + 1)) += e.second;
        } else {
          tr[a](row, idx(terminal, t)) = 1.0;  // not allowed at the limit
          r(row, static_cast<Eigen::Index>(a)) = forbidden;
        }
      }
  }
  Model out(std::move(tr), std::move(z), std::move(r), m.getDiscount());
  std::vector<std::string> states;
  for (std::size_t t = 0; t <= L; ++t)
    for (std::size_t s = 0; s < S; ++s) states.push_back(m.stateNames()[s] + "_t" + std::to_string(t));
  out.setNames(states, m.actionNames(), m.observationNames());
  Belief b = Belief::Zero(n);
  b.head(static_cast<Eigen::Index>(S)) = b0;
  out.setInitialBelief(b);
  return out;
}

}  // namespace pomdp
}  // namespace krr
