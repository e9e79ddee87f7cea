#include "krr_core/common/format.h"
#include "krr_core/mdp/navigation_task.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "krr_core/common/errors.h"

namespace krr {
namespace mdp {

namespace {

std::string num(double v) { return formatNumber(v, 17); }

std::vector<std::uint8_t> goalMask(std::size_t n, const std::vector<StateId>& goals,
                                   const char* who) {
  std::vector<std::uint8_t> mask(n, 0);
  for (StateId g : goals) {
    if (g >= n) {
      throw ConfigError(std::string(who) + ": goal " + std::to_string(g) + " out of range [0, " +
                        std::to_string(n) + ")");
    }
    mask[g] = 1;
  }
  return mask;
}

template <class P>
BasicGridModel<P> buildGrid(const GridDynamics& dyn, const std::vector<StateId>& goals,
                            const NavigationReward& reward, double discount) {
  dyn.validate();
  reward.validate();
  const std::vector<std::uint8_t> goal = goalMask(dyn.numCells(), goals, "makeNavigationGridModel");
  BasicGridModel<P> m(dyn.width, dyn.height, discount);
  for (StateId c = 0; c < dyn.numCells(); ++c) {
    if (goal[c] && dyn.blocked[c]) {
      throw ConfigError("makeNavigationGridModel: goal " + std::to_string(c) +
                        " is an obstacle");
    }
    if (goal[c] || dyn.blocked[c]) {
      m.setTerminal(c);
      continue;
    }
    for (ActionId a = 0; a < 4; ++a) {
      typename BasicGridModel<P>::Probabilities q{};
      double r = -reward.step_cost;
      for (unsigned k = 0; k < 6; ++k) {
        const double p = dyn.p(c, a, k);
        const StateId t = dyn.target(c, k);
        if (k == kFail) {
          q[kFail] += p;
          r -= p * reward.rmax;
        } else if (t == c) {
          q[kStay] += p;  // off the grid or into an obstacle: the robot stays
        } else {
          q[k] += p;
          if (goal[t]) r += p * reward.rmax;
        }
      }
      m.setOutcomes(c, a, q, r);
    }
  }
  return m;
}

}  // namespace

void NavigationReward::validate() const {
  if (!(step_cost >= 0.0) || !std::isfinite(step_cost)) {
    throw ConfigError("NavigationReward.step_cost must be >= 0, got " + num(step_cost));
  }
  if (!(rmax > 0.0) || !std::isfinite(rmax)) {
    throw ConfigError("NavigationReward.rmax must be > 0, got " + num(rmax));
  }
}

GridDynamics::GridDynamics(std::uint32_t w, std::uint32_t h) : width(w), height(h) {
  blocked.assign(numCells(), 0);
  outcomes.assign(numCells() * 24, 0.0);
  for (StateId c = 0; c < numCells(); ++c) {
    for (ActionId a = 0; a < 4; ++a) p(c, a, kStay) = 1.0;
  }
}

StateId GridDynamics::target(StateId c, unsigned k) const {
  const std::uint32_t x = c % width, y = c / width;
  StateId t = c;
  switch (k) {
    case kUp: t = y > 0 ? c - width : c; break;
    case kDown: t = y + 1 < height ? c + width : c; break;
    case kLeft: t = x > 0 ? c - 1 : c; break;
    case kRight: t = x + 1 < width ? c + 1 : c; break;
    case kFail: return static_cast<StateId>(numCells());
    default: break;
  }
  return blocked[t] ? c : t;
}

void GridDynamics::validate() const {
  if (width == 0 || height == 0) {
    throw ConfigError("GridDynamics: width and height must be positive, got " +
                      std::to_string(width) + "x" + std::to_string(height));
  }
  if (blocked.size() != numCells() || outcomes.size() != numCells() * 24) {
    throw ConfigError("GridDynamics: blocked has " + std::to_string(blocked.size()) +
                      " cells and outcomes " + std::to_string(outcomes.size()) +
                      " entries; expected " + std::to_string(numCells()) + " and " +
                      std::to_string(numCells() * 24));
  }
  for (StateId c = 0; c < numCells(); ++c) {
    for (ActionId a = 0; a < 4; ++a) {
      double sum = 0.0;
      for (unsigned k = 0; k < 6; ++k) {
        const double v = p(c, a, k);
        if (!(v >= 0.0 && v <= 1.0)) {
          throw ConfigError("GridDynamics: cell " + std::to_string(c) + " action " +
                            std::to_string(a) + " outcome " + std::to_string(k) +
                            " has probability " + num(v));
        }
        sum += v;
      }
      if (std::fabs(sum - 1.0) > kRowSumTolerance) {
        throw ConfigError("GridDynamics: cell " + std::to_string(c) + " action " +
                          std::to_string(a) + " sums to " + num(sum));
      }
    }
  }
}

GridDynamics makeRandomGridDynamics(std::uint32_t width, std::uint32_t height,
                                    const RandomGridOptions& o,
                                    const std::vector<StateId>& keep_free, Rng& rng) {
  const double p_stay = 1.0 - o.p_intended - 2.0 * o.p_side - o.p_back;
  if (!(o.p_intended >= 0 && o.p_side >= 0 && o.p_back >= 0 && p_stay >= -1e-12)) {
    throw ConfigError("RandomGridOptions: move probabilities must be >= 0 and sum to <= 1 "
                      "(p_intended=" + num(o.p_intended) + ", p_side=" + num(o.p_side) +
                      ", p_back=" + num(o.p_back) + ")");
  }
  if (!(o.obstacle_density >= 0.0 && o.obstacle_density < 1.0)) {
    throw ConfigError("RandomGridOptions.obstacle_density must be in [0, 1), got " +
                      num(o.obstacle_density));
  }
  if (!(o.p_trap >= 0.0 && o.p_trap <= o.p_intended)) {
    throw ConfigError("RandomGridOptions.p_trap must be in [0, p_intended], got " +
                      num(o.p_trap));
  }
  GridDynamics d(width, height);
  for (StateId c = 0; c < d.numCells(); ++c) d.blocked[c] = uniform01(rng) < o.obstacle_density;
  for (StateId c : keep_free) {
    if (c >= d.numCells()) {
      throw ConfigError("makeRandomGridDynamics: cell " + std::to_string(c) + " out of range");
    }
    d.blocked[c] = 0;
  }
  std::vector<std::uint8_t> trap(d.numCells(), 0);
  for (std::uint32_t t = 0; t < o.trap_areas; ++t) {
    const std::uint32_t x0 = static_cast<std::uint32_t>(uniform01(rng) * width);
    const std::uint32_t y0 = static_cast<std::uint32_t>(uniform01(rng) * height);
    for (std::uint32_t y = y0; y < std::min(height, y0 + o.trap_size); ++y) {
      for (std::uint32_t x = x0; x < std::min(width, x0 + o.trap_size); ++x) {
        trap[y * width + x] = 1;
      }
    }
  }
  // Slot of the intended, perpendicular and opposite moves of each action.
  static const unsigned kIntended[4] = {kUp, kDown, kLeft, kRight};
  static const unsigned kBack[4] = {kDown, kUp, kRight, kLeft};
  static const unsigned kSide[4][2] = {{kLeft, kRight}, {kLeft, kRight}, {kUp, kDown}, {kUp, kDown}};
  for (StateId c = 0; c < d.numCells(); ++c) {
    for (ActionId a = 0; a < 4; ++a) {
      const double fail = trap[c] ? o.p_trap : 0.0;
      d.p(c, a, kStay) = std::max(0.0, p_stay);
      d.p(c, a, kIntended[a]) = o.p_intended - fail;
      d.p(c, a, kBack[a]) = o.p_back;
      d.p(c, a, kSide[a][0]) = o.p_side;
      d.p(c, a, kSide[a][1]) = o.p_side;
      d.p(c, a, kFail) = fail;
      double sum = 0.0;
      for (unsigned k = 0; k < 6; ++k) sum += d.p(c, a, k);
      d.p(c, a, kStay) += 1.0 - sum;  // absorb rounding so the row sums to 1
    }
  }
  return d;
}

std::vector<std::uint8_t> reachable(const GridDynamics& dyn, StateId start) {
  std::vector<std::uint8_t> seen(dyn.numCells(), 0);
  if (start >= dyn.numCells() || dyn.blocked[start]) return seen;
  std::vector<StateId> stack{start};
  seen[start] = 1;
  while (!stack.empty()) {
    const StateId c = stack.back();
    stack.pop_back();
    for (ActionId a = 0; a < 4; ++a) {
      for (unsigned k = kUp; k <= kRight; ++k) {
        if (dyn.p(c, a, k) <= 0.0) continue;
        const StateId t = dyn.target(c, k);
        if (!seen[t]) {
          seen[t] = 1;
          stack.push_back(t);
        }
      }
    }
  }
  return seen;
}

GridModel makeNavigationGridModel(const GridDynamics& dyn, const std::vector<StateId>& goals,
                                  const NavigationReward& reward, double discount) {
  return buildGrid<double>(dyn, goals, reward, discount);
}

GridModelF makeNavigationGridModelF(const GridDynamics& dyn, const std::vector<StateId>& goals,
                                    const NavigationReward& reward, double discount) {
  return buildGrid<float>(dyn, goals, reward, discount);
}

SparseModel makeNavigationTask(const SparseModel& dyn, const std::vector<StateId>& goals,
                               const std::vector<StateId>& failure_states,
                               const NavigationReward& reward) {
  reward.validate();
  const std::vector<std::uint8_t> goal = goalMask(dyn.getS(), goals, "makeNavigationTask");
  const std::vector<std::uint8_t> fail =
      goalMask(dyn.getS(), failure_states, "makeNavigationTask (failure state)");
  SparseModelBuilder b(dyn.getS(), dyn.getA(), dyn.getDiscount());
  for (StateId s = 0; s < dyn.getS(); ++s) {
    if (goal[s] && fail[s]) {
      throw ConfigError("makeNavigationTask: state " + std::to_string(s) +
                        " is both a goal and a failure state");
    }
    if (goal[s] || fail[s] || dyn.isTerminal(s)) {
      b.setTerminal(s);
      continue;
    }
    for (ActionId a = 0; a < dyn.getA(); ++a) {
      b.addReward(s, a, -reward.step_cost);
      for (Outcome o : dyn.successors(s, a)) {
        b.addTransition(s, a, o.state, o.probability,
                        goal[o.state] ? reward.rmax : (fail[o.state] ? -reward.rmax : 0.0));
      }
    }
  }
  return b.build();
}

}  // namespace mdp
}  // namespace krr
