#include "krr_core/common/format.h"
#include "krr_core/mdp/grid_model.h"

#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "krr_core/common/errors.h"

namespace krr {
namespace mdp {

namespace {

std::string num(double v) { return formatNumber(v, 17); }

}  // namespace

template <class P>
BasicGridModel<P>::BasicGridModel(std::uint32_t width, std::uint32_t height, double discount)
    : w_(width), h_(height), wb_(0), discount_(discount) {
  if (w_ == 0 || h_ == 0) {
    throw ConfigError("GridModel: width and height must be positive, got " +
                      std::to_string(w_) + "x" + std::to_string(h_));
  }
  if (static_cast<std::uint64_t>(w_) * h_ * kNumActions >=
      std::numeric_limits<std::uint32_t>::max()) {
    throw ConfigError("GridModel: grid too large: " + std::to_string(w_) + "x" +
                      std::to_string(h_));
  }
  if (!(discount >= 0.0 && discount <= 1.0)) {
    throw ConfigError("GridModel: discount must be in [0, 1], got " + num(discount));
  }
  wb_ = (w_ + kLanes - 1) / kLanes;
  prob_.assign(static_cast<std::size_t>(h_) * wb_ * kBlockSize, P(0));
  fail_.assign(numCells() * kNumActions, P(0));
  reward_.assign(static_cast<std::size_t>(h_) * wb_ * kNumActions * kLanes, P(0));
  live_.assign(static_cast<std::size_t>(h_) * paddedWidth(), P(0));  // padding: inert
  for (StateId c = 0; c < numCells(); ++c) {
    live_[liveIndex(c)] = P(1);
    for (ActionId a = 0; a < kNumActions; ++a) prob_[probIndex(c, a, kStay)] = P(1);
  }
}

template <class P>
void BasicGridModel<P>::setOutcomes(StateId cell, ActionId a, const Probabilities& p,
                                    double reward) {
  const std::string where =
      "GridModel::setOutcomes(cell=" + std::to_string(cell) + ", a=" + std::to_string(a) + ")";
  if (cell >= numCells()) throw ConfigError(where + ": cell out of range");
  if (a >= kNumActions) throw ConfigError(where + ": action out of range");
  if (!std::isfinite(reward)) throw ConfigError(where + ": reward is " + num(reward));
  double sum = 0.0;
  for (unsigned k = 0; k < kNumOutcomes; ++k) {
    if (!(p[k] >= 0.0 && p[k] <= 1.0)) {
      throw ConfigError(where + ": probability of outcome " + std::to_string(k) + " is " +
                        num(p[k]) + ", outside [0, 1]");
    }
    sum += p[k];
  }
  if (std::fabs(sum - 1.0) > kRowSumTolerance) {
    throw ConfigError(where + ": outcome probabilities sum to " + num(sum) +
                      " (expected 1 within 1e-9)");
  }
  Probabilities q = p;
  const std::uint32_t x = cell % w_, y = cell / w_;
  const bool off[5] = {false, y == 0, y + 1 == h_, x == 0, x + 1 == w_};
  for (unsigned k = kUp; k <= kRight; ++k) {
    if (off[k]) {
      q[kStay] += q[k];
      q[k] = 0.0;
    }
  }
  for (unsigned k = 0; k < kSweepOutcomes; ++k) prob_[probIndex(cell, a, k)] = static_cast<P>(q[k]);
  fail_[static_cast<std::size_t>(cell) * kNumActions + a] = static_cast<P>(q[kFail]);
  reward_[rewardIndex(cell, a)] = static_cast<P>(reward);
}

template <class P>
void BasicGridModel<P>::setTerminal(StateId cell, bool terminal) {
  if (cell >= numCells()) {
    throw ConfigError("GridModel::setTerminal: cell " + std::to_string(cell) +
                      " out of range [0, " + std::to_string(numCells()) + ")");
  }
  live_[liveIndex(cell)] = terminal ? P(0) : P(1);
}

template <class P>
double BasicGridModel<P>::outcomeProbability(StateId cell, ActionId a, unsigned k) const {
  if (cell >= numCells() || a >= kNumActions || k >= kNumOutcomes) return 0.0;
  if (k == kFail) return static_cast<double>(fail_[static_cast<std::size_t>(cell) * kNumActions + a]);
  return static_cast<double>(prob_[probIndex(cell, a, k)]);
}

template <class P>
StateId BasicGridModel<P>::outcomeState(StateId cell, unsigned k) const {
  switch (k) {
    case kUp: return cell >= w_ ? cell - w_ : cell;
    case kDown: return cell + w_ < numCells() ? cell + w_ : cell;
    case kLeft: return cell % w_ != 0 ? cell - 1 : cell;
    case kRight: return cell % w_ + 1 != w_ ? cell + 1 : cell;
    case kFail: return failureState();
    default: return cell;
  }
}

template <class P>
double BasicGridModel<P>::getTransitionProbability(StateId s, ActionId a, StateId s1) const {
  if (isTerminal(s)) return s1 == s ? 1.0 : 0.0;
  double p = 0.0;
  for (unsigned k = 0; k < kNumOutcomes; ++k) {
    if (outcomeState(s, k) == s1) p += outcomeProbability(s, a, k);
  }
  return p;
}

template <class P>
double BasicGridModel<P>::getExpectedReward(StateId s, ActionId a) const {
  if (isTerminal(s)) return 0.0;
  return static_cast<double>(reward_[rewardIndex(s, a)]);
}

template <class P>
std::pair<StateId, double> BasicGridModel<P>::sampleSR(StateId s, ActionId a, Rng& rng) const {
  if (isTerminal(s)) return {s, 0.0};
  double u = uniform01(rng);
  unsigned last = kStay;
  for (unsigned k = 0; k < kNumOutcomes; ++k) {
    const double p = outcomeProbability(s, a, k);
    if (p <= 0.0) continue;
    last = k;
    u -= p;
    if (u < 0.0) break;
  }
  return {outcomeState(s, last), getExpectedReward(s, a)};
}

template <class P>
SparseModel BasicGridModel<P>::toSparse() const {
  SparseModelBuilder b(getS(), kNumActions, discount_);
  b.setTerminal(failureState());
  for (StateId c = 0; c < numCells(); ++c) {
    if (isTerminal(c)) {
      b.setTerminal(c);
      continue;
    }
    for (ActionId a = 0; a < kNumActions; ++a) {
      double sum = 0.0;
      for (unsigned k = 0; k < kNumOutcomes; ++k) sum += outcomeProbability(c, a, k);
      // Float storage rounds each probability; renormalise so the row sums to 1 exactly.
      for (unsigned k = 0; k < kNumOutcomes; ++k) {
        const double p = outcomeProbability(c, a, k);
        if (p > 0.0) b.addTransition(c, a, outcomeState(c, k), p / sum);
      }
      b.addReward(c, a, getExpectedReward(c, a));
    }
  }
  return b.build();
}

template class BasicGridModel<double>;
template class BasicGridModel<float>;

}  // namespace mdp
}  // namespace krr
