// Test support for the turn-limited solver: a one-shot Tiger problem (opening a door ends the
// episode) and an exact finite-horizon value by enumerating every observation history.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "krr_core/pomdp/belief.h"
#include "krr_core/pomdp/model.h"

namespace krr {
namespace pomdp {
namespace test {

/// States tiger-left, tiger-right, done; actions listen (cost 1, heard right with 0.85),
/// open-left, open-right (+10 / -100, then done); observations hear-left, hear-right, none.
inline Model oneShotTiger(double discount = 1.0) {
  const Eigen::Index S = 3, O = 3;
  std::vector<Eigen::MatrixXd> t(3), z(3);
  Eigen::MatrixXd r(S, 3);
  t[0] = Eigen::MatrixXd::Identity(S, S);
  z[0] = Eigen::MatrixXd::Zero(S, O);
  z[0] << 0.85, 0.15, 0, 0.15, 0.85, 0, 0, 0, 1;
  for (int a = 1; a < 3; ++a) {
    t[a] = Eigen::MatrixXd::Zero(S, S);
    t[a].col(2).setOnes();
    z[a] = Eigen::MatrixXd::Zero(S, O);
    z[a].col(2).setOnes();
  }
  r << -1, -100, 10, -1, 10, -100, 0, 0, 0;
  Model m(std::move(t), std::move(z), std::move(r), discount);
  m.setNames({"tiger-left", "tiger-right", "done"}, {"listen", "open-left", "open-right"},
             {"hear-left", "hear-right", "none"});
  Belief b0(3);
  b0 << 0.5, 0.5, 0.0;
  m.setInitialBelief(b0);
  return m;
}

/// Exact V_t(b) of the turn-limited problem: expectimax over every observation history.
/// Ending actions are those leading only to terminal states. Exponential: tiny problems only.
inline double exactTurnLimitedValue(const Model& m, const Belief& b, int t, int limit) {
  double best = -std::numeric_limits<double>::infinity();
  for (std::size_t a = 0; a < m.getA(); ++a) {
    bool ends = true;
    for (std::size_t s = 0; s < m.getS(); ++s)
      for (const auto& e : m.successors(s, a)) ends = ends && m.isTerminal(e.first);
    double q = expectedReward(m, b, a);
    if (!ends) {
      if (t >= limit) continue;
      for (std::size_t o = 0; o < m.getO(); ++o) {
        Belief next;
        double p = 0.0;
        if (tryUpdateBelief(m, b, a, o, next, &p) && p > 0.0)
          q += m.getDiscount() * p * exactTurnLimitedValue(m, next, t + 1, limit);
      }
    }
    best = std::max(best, q);
  }
  return best;
}

}  // namespace test
}  // namespace pomdp
}  // namespace krr
