#include "krr_core/nav/blockage_simulator.h"
#include "krr_core/nav/blocking_rate.h"

#include <algorithm>
#include <cmath>

#include "krr_core/common/errors.h"

namespace krr {
namespace nav {

namespace {

// The two moves perpendicular to `move` (where a lateral slip can take the robot).
inline void lateralMoves(int move, int* a, int* b) {
  if (move == kUp || move == kDown) {
    *a = kLeft;
    *b = kRight;
  } else {
    *a = kUp;
    *b = kDown;
  }
}

}  // namespace

BlockageSimulator::BlockageSimulator(const NavGrid& grid, const SimulatorConfig& config)
    : grid_(grid), config_(config) {
  validate(config_);
  const double ref = config_.trap_reference_cell_size;
  const double cell = 0.5 * (grid_.cellWidth() + grid_.cellHeight());
  trap_ = config_.trap_probability;
  if (ref > 0.0 && trap_ < 1.0) trap_ = 1.0 - std::pow(1.0 - trap_, cell / ref);
  num_times_ = static_cast<int>(config_.times_of_day.size());
  const size_t na = grid_.areas().size();
  base_rate_.assign(na, config_.blocking_rate);
  factor_.assign(na * static_cast<size_t>(num_times_ + 1), 1.0);
  for (size_t a = 0; a < na; ++a) {
    for (int t = 0; t < num_times_; ++t) {
      factor_[a * (num_times_ + 1) + t + 1] = config_.time_factors[static_cast<size_t>(t)];
    }
  }
  for (const auto& kv : config_.areas) {
    const size_t a = static_cast<size_t>(areaOfOverride(kv.first));
    if (kv.second.rate >= 0.0) base_rate_[a] = kv.second.rate;
    for (const auto& tf : kv.second.time_factor) {
      factor_[a * (num_times_ + 1) + timeOfDayIndex(tf.first) + 1] = tf.second;
    }
  }
}

int BlockageSimulator::areaOfOverride(const std::string& name) const {
  for (size_t a = 0; a < grid_.areas().size(); ++a) {
    if (grid_.areas()[a].name == name) return static_cast<int>(a);
  }
  std::string known;
  for (const auto& area : grid_.areas()) known += (known.empty() ? "" : ", ") + area.name;
  throw ConfigError((config_.source.empty() ? std::string("simulator config") : config_.source) +
                    ": field 'simulator.areas." + name + "': unknown blocking area '" + name +
                    "' (the places file's blocking areas: " + (known.empty() ? "none" : known) +
                    ")");
}

int BlockageSimulator::timeOfDayIndex(const std::string& name) const {
  for (int t = 0; t < num_times_; ++t) {
    if (config_.times_of_day[static_cast<size_t>(t)] == name) return t;
  }
  throw ConfigError("blockage simulator: unknown time of day '" + name + "'");
}

Context::Context(int time_of_day, std::optional<double> blocking_rate)
    : time_of_day_(time_of_day), blocking_rate_(blocking_rate) {
  if (time_of_day < -1)
    throw ConfigError("blockage simulator: context time_of_day " + std::to_string(time_of_day) +
                      " below -1 (unspecified)");
  if (blocking_rate) checkBlockingRate(*blocking_rate, "blockage simulator", "context.blocking_rate");
}

Context Context::withRate(int time_of_day, double rate_or_unset) {
  if (!isBlockingRate(rate_or_unset, RateUnset::kAllowed))
    refuseBlockingRate(rate_or_unset, "blockage simulator", "context.blocking_rate",
                       RateUnset::kAllowed);
  return Context(time_of_day, rate_or_unset < 0.0 ? std::nullopt : std::optional<double>(rate_or_unset));
}

double BlockageSimulator::areaRate(int a, const Context& ctx) const {
  if (ctx.timeOfDay() >= num_times_) {
    throw ConfigError("blockage simulator: context time_of_day " +
                      std::to_string(ctx.timeOfDay()) + " out of range [-1, " +
                      std::to_string(num_times_ - 1) + "]");
  }
  const double base = ctx.blockingRate() ? *ctx.blockingRate() : base_rate_[static_cast<size_t>(a)];
  const double f = factor_[static_cast<size_t>(a) * (num_times_ + 1) + ctx.timeOfDay() + 1];
  return std::min(1.0, base * f);
}

double BlockageSimulator::moveBlockingRate(int from, int to, const Context& ctx) const {
  std::uint32_t mask = grid_.areaMask(to);
  if (config_.blocking_mode == BlockingMode::kOnEntry) mask &= ~grid_.areaMask(from);
  double rate = 0.0;
  for (int a = 0; mask != 0; ++a, mask >>= 1) {
    if (mask & 1u) rate = std::max(rate, areaRate(a, ctx));
  }
  return rate;
}

double BlockageSimulator::blockingRate(int cell, const Context& ctx) const {
  std::uint32_t mask = grid_.areaMask(cell);
  double rate = 0.0;
  for (int a = 0; mask != 0; ++a, mask >>= 1) {
    if (mask & 1u) rate = std::max(rate, areaRate(a, ctx));
  }
  return rate;
}

Outcome BlockageSimulator::step(int cell, int move, const Context& ctx, Rng& rng) const {
  Outcome out;
  out.cell = cell;
  if (!grid_.valid(cell) || !grid_.isFree(cell) || move < 0 || move >= kNumMoves) return out;
  const int target = grid_.neighbour(cell, move);
  if (target < 0) return out;  // bumped into a wall: stays
  const double b = moveBlockingRate(cell, target, ctx);
  if (b > 0.0 && uniform01(rng) < b) {
    out.blocked = true;
    out.trapped = uniform01(rng) < trap_;
    return out;
  }
  const double u = uniform01(rng);
  if (u < config_.move_success) {
    out.cell = target;
  } else if (u < config_.move_success + config_.slip_stay) {
    // stays
  } else {
    int la = 0, lb = 0;
    lateralMoves(move, &la, &lb);
    const double half = config_.move_success + config_.slip_stay + 0.5 * config_.slip_lateral;
    const int side = grid_.neighbour(cell, u < half ? la : lb);
    if (side >= 0) out.cell = side;
  }
  return out;
}

std::vector<std::pair<int, double>> BlockageSimulator::trueDistribution(
    int cell, int move, const Context& ctx) const {
  std::vector<std::pair<int, double>> out;
  if (!grid_.valid(cell)) {
    throw UnknownSymbolError("blockage simulator: cell " + std::to_string(cell) +
                             " is not a cell of the grid");
  }
  if (move < 0 || move >= kNumMoves) {
    throw UnknownSymbolError("blockage simulator: move " + std::to_string(move) +
                             " is not up/down/left/right");
  }
  const int target = grid_.isFree(cell) ? grid_.neighbour(cell, move) : -1;
  if (target < 0) {
    out.emplace_back(cell, 1.0);
    return out;
  }
  const double b = moveBlockingRate(cell, target, ctx);
  const double go = 1.0 - b;
  int la = 0, lb = 0;
  lateralMoves(move, &la, &lb);
  const int side_a = grid_.neighbour(cell, la);
  const int side_b = grid_.neighbour(cell, lb);
  const double half = 0.5 * config_.slip_lateral * go;
  std::pair<int, double> parts[5] = {
      {target, go * config_.move_success},
      {cell, go * config_.slip_stay + b * (1.0 - trap_)},
      {side_a < 0 ? cell : side_a, half},
      {side_b < 0 ? cell : side_b, half},
      {trappedState(), b * trap_}};
  for (const auto& p : parts) {
    if (p.second <= 0.0) continue;
    auto it = std::find_if(out.begin(), out.end(),
                           [&](const std::pair<int, double>& q) { return q.first == p.first; });
    if (it == out.end()) {
      out.push_back(p);
    } else {
      it->second += p.second;
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

EpisodeStats runPolicy(const BlockageSimulator& sim, const std::vector<std::int8_t>& policy,
                       int start, int goal, int step_limit, const Context& context, long episodes,
                       Rng& rng) {
  if (policy.size() != static_cast<size_t>(sim.grid().numCells())) {
    throw ConfigError("runPolicy: policy has " + std::to_string(policy.size()) +
                      " entries, grid has " + std::to_string(sim.grid().numCells()) + " cells");
  }
  EpisodeStats st;
  double steps_sum = 0.0;
  for (long e = 0; e < episodes; ++e) {
    int cell = start;
    int steps = 0;
    bool done = false;
    while (!done) {
      if (cell == goal) {
        ++st.successes;
        steps_sum += steps;
        break;
      }
      const int m = policy[static_cast<size_t>(cell)];
      if (steps >= step_limit || m < 0) {
        ++st.timeouts;
        break;
      }
      const Outcome o = sim.step(cell, m, context, rng);
      ++steps;
      if (o.trapped) {
        ++st.trapped;
        done = true;
      }
      cell = o.cell;
    }
  }
  st.episodes = episodes;
  st.mean_steps_success = st.successes ? steps_sum / st.successes : 0.0;
  return st;
}

}  // namespace nav
}  // namespace krr
