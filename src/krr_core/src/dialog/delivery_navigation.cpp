#include "krr_core/dialog/delivery_navigation.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "krr_core/common/errors.h"
#include "krr_core/mdp/reach_probability.h"
#include "krr_core/mdp/trip.h"
#include "krr_core/mdp/solvers.h"

namespace krr {
namespace dialog {

void DeliveryNavigationOptions::validate() const {
  auto bad = [](const std::string& field, const std::string& value) {
    throw ConfigError("delivery navigation: field '" + field + "' has invalid value " + value);
  };
  if (shop.empty()) bad("shop", "\"\"");
  if (rooms.empty()) bad("rooms", "(empty)");
  std::set<std::string> seen;
  for (const auto& r : rooms) {
    if (r == shop) bad("rooms", r + " (the shop)");
    if (!seen.insert(r).second) bad("rooms", r + " (duplicate)");
  }
  reward.validate();
  if (!(discount > 0.0 && discount <= 1.0)) bad("discount", std::to_string(discount));
  if (step_limit == 0) bad("step_limit", "0");
  if (!(epsilon > 0.0)) bad("epsilon", std::to_string(epsilon));
  if (!(failure_penalty >= 0.0) || !std::isfinite(failure_penalty))
    bad("failure_penalty", std::to_string(failure_penalty));
}

DeliveryNavigationOptions DeliveryNavigationOptions::fromConfig(const DialogConfig& c,
                                                                std::vector<std::string> rooms,
                                                                std::size_t step_limit) {
  DeliveryNavigationOptions o;
  o.shop = c.shop;
  o.rooms = std::move(rooms);
  o.reward = mdp::NavigationReward{c.step_cost, c.rmax};
  o.discount = c.nav_discount;
  o.step_limit = step_limit;
  o.failure_penalty = c.failure_penalty;
  return o;
}

DeliveryNavigation::DeliveryNavigation(const kb::NavStateSpace& space,
                                       const mdp::SparseModel& dynamics,
                                       const DeliveryNavigationOptions& options)
    : space_(space), options_(options) {
  options_.validate();
  if (dynamics.getS() != space.numStates() || dynamics.getA() != space.numActions())
    throw ConfigError("delivery navigation: the model has " + std::to_string(dynamics.getS()) +
                      " states and " + std::to_string(dynamics.getA()) +
                      " actions, the navigation space " + std::to_string(space.numStates()) +
                      " and " + std::to_string(space.numActions()));
  shop_cell_ = space.grid().placeCell(options_.shop);
  for (const auto& r : options_.rooms) room_cell_.push_back(space.grid().placeCell(r));

  // Re-discount the dynamics (the navigation task keeps the model's discount).
  const std::size_t S = dynamics.getS(), A = dynamics.getA();
  mdp::SparseModelBuilder b(S, A, options_.discount);
  for (mdp::StateId s = 0; s < S; ++s) {
    if (dynamics.isTerminal(s)) {
      b.setTerminal(s);
      continue;
    }
    for (mdp::ActionId a = 0; a < A; ++a)
      for (mdp::Outcome o : dynamics.successors(s, a)) b.addTransition(s, a, o.state, o.probability);
  }
  const mdp::SparseModel dyn = b.build();

  mdp::SolverOptions so;
  so.epsilon = options_.epsilon;
  so.initial = mdp::InitialValues::kZero;
  const mdp::StateId shop = space.stateOf(shop_cell_);
  auto solveFor = [&](mdp::StateId goal) {
    const mdp::SparseModel task =
        mdp::makeNavigationTask(dyn, {goal}, {space.trappedState()}, options_.reward);
    mdp::Solution sol = mdp::valueIteration(task, so);
    if (!sol.converged)
      throw ConfigError("delivery navigation: value iteration did not converge for goal cell " +
                        std::to_string(space.cellOf(goal)));
    return std::make_pair(task, sol.policy);
  };
  for (std::size_t r = 0; r < room_cell_.size(); ++r) {
    const mdp::StateId g = space.stateOf(room_cell_[r]);
    auto [task, policy] = solveFor(g);
    to_room_.push_back(estimate(task, policy, shop, g));
    policy_.push_back(std::move(policy));
  }
  {
    auto [task, policy] = solveFor(shop);
    for (std::size_t r = 0; r < room_cell_.size(); ++r)
      to_shop_.push_back(estimate(task, policy, space.stateOf(room_cell_[r]), shop));
    policy_.push_back(std::move(policy));
  }
}

TripEstimate DeliveryNavigation::estimate(const mdp::SparseModel& task,
                                          const std::vector<mdp::ActionId>& policy,
                                          mdp::StateId start, mdp::StateId goal) const {
  TripEstimate e;
  const std::size_t N = options_.step_limit;
  // Clamped: summing N steps of a stochastic matrix can overshoot 1 by rounding.
  e.reach = std::min(1.0, std::max(0.0, mdp::reachProbability(task, policy, {goal}, N)[start]));
  // Expected moves within N: m_k(s) = 1 + sum_s' P(s' | s, pi(s)) m_{k-1}(s') off the absorbing
  // states (goal, trapped), m_0 = 0.
  const std::size_t S = task.getS();
  std::vector<double> m(S, 0.0), next(S, 0.0);
  for (std::size_t k = 0; k < N; ++k) {
    for (mdp::StateId s = 0; s < S; ++s) {
      if (task.isTerminal(s)) {
        next[s] = 0.0;
        continue;
      }
      double acc = 1.0;
      for (mdp::Outcome o : task.successors(s, policy[s])) acc += o.probability * m[o.state];
      next[s] = acc;
    }
    m.swap(next);
  }
  e.moves = m[start];
  e.cost = options_.reward.step_cost * e.moves + options_.failure_penalty * (1.0 - e.reach);
  return e;
}

std::size_t DeliveryNavigation::roomIndex(const std::string& room) const {
  for (std::size_t r = 0; r < options_.rooms.size(); ++r)
    if (options_.rooms[r] == room) return r;
  throw UnknownSymbolError("delivery navigation: no room '" + room + "'");
}

TripTable DeliveryNavigation::trips() const { return {options_.rooms, to_room_, to_shop_}; }

TripTable DeliveryNavigation::evaluate(const mdp::SparseModel& dynamics) const {
  if (dynamics.getS() != space_.numStates() || dynamics.getA() != space_.numActions())
    throw ConfigError("delivery navigation: dynamics with " + std::to_string(dynamics.getS()) +
                      " states to evaluate on a space of " + std::to_string(space_.numStates()));
  TripTable t;
  t.rooms = options_.rooms;
  const mdp::StateId shop = space_.stateOf(shop_cell_);
  auto task = [&](mdp::StateId goal) {
    return mdp::makeNavigationTask(dynamics, {goal}, {space_.trappedState()}, options_.reward);
  };
  for (std::size_t r = 0; r < room_cell_.size(); ++r) {
    const mdp::StateId g = space_.stateOf(room_cell_[r]);
    t.to_room.push_back(estimate(task(g), policy_[r], shop, g));
  }
  const mdp::SparseModel back = task(shop);
  for (std::size_t r = 0; r < room_cell_.size(); ++r)
    t.to_shop.push_back(estimate(back, policy_.back(), space_.stateOf(room_cell_[r]), shop));
  return t;
}

Eigen::VectorXd TripTable::reachFromShop() const {
  Eigen::VectorXd v(static_cast<Eigen::Index>(to_room.size()));
  for (std::size_t r = 0; r < to_room.size(); ++r) v(static_cast<Eigen::Index>(r)) = to_room[r].reach;
  return v;
}

Eigen::VectorXd TripTable::reachBack() const {
  Eigen::VectorXd v(static_cast<Eigen::Index>(to_shop.size()));
  for (std::size_t r = 0; r < to_shop.size(); ++r) v(static_cast<Eigen::Index>(r)) = to_shop[r].reach;
  return v;
}

TripTable TripTable::fromReach(const std::vector<std::string>& rooms, const std::vector<double>& reach,
                               const std::vector<double>& back, double failure_penalty) {
  if (reach.size() != rooms.size() || (!back.empty() && back.size() != rooms.size()))
    throw ConfigError("trip table: need one P^N(shop, room) per room (" + std::to_string(rooms.size()) +
                      "), got " + std::to_string(reach.size()) +
                      (back.empty() ? "" : " and " + std::to_string(back.size()) + " P^N(room, shop)"));
  if (!(failure_penalty >= 0.0) || !std::isfinite(failure_penalty))
    throw ConfigError("trip table: failure penalty " + std::to_string(failure_penalty) + " must be >= 0");
  TripTable t;
  t.rooms = rooms;
  auto trip = [&](double p, const std::string& what) {
    if (!(p >= 0.0 && p <= 1.0))
      throw ConfigError("trip table: " + what + " = " + std::to_string(p) + " is not a probability");
    return TripEstimate{p, 0.0, failure_penalty * (1.0 - p)};
  };
  for (std::size_t r = 0; r < rooms.size(); ++r) {
    t.to_room.push_back(trip(reach[r], "P^N(shop, " + rooms[r] + ")"));
    t.to_shop.push_back(trip(back.empty() ? reach[r] : back[r], "P^N(" + rooms[r] + ", shop)"));
  }
  return t;
}

TripResult DeliveryNavigation::execute(const nav::BlockageSimulator& sim, std::size_t r,
                                       bool toRoom, const nav::Context& context, Rng& rng) const {
  if (r >= room_cell_.size())
    throw ConfigError("delivery navigation: room index " + std::to_string(r) + " out of range");
  if (sim.grid().numCells() != space_.grid().numCells())
    throw ConfigError("delivery navigation: the simulator's grid is not the model's grid");
  const std::vector<mdp::ActionId>& policy = toRoom ? policy_[r] : policy_.back();
  int cell = toRoom ? shop_cell_ : room_cell_[r];
  const int goal = toRoom ? room_cell_[r] : shop_cell_;
  const mdp::TripSummary trip = mdp::runTrip(cell == goal, options_.step_limit, [&](std::size_t) {
    const int move = static_cast<int>(policy[space_.stateOf(cell)]);
    const nav::Outcome o = sim.step(cell, move, context, rng);
    mdp::TripMove m;
    m.failed = o.trapped;
    if (!o.trapped) cell = o.cell;
    m.reached = !o.trapped && cell == goal;
    return m;
  });
  TripResult t;
  t.moves = trip.moves;
  t.reached = trip.end == mdp::TripEnd::kReached;
  t.trapped = trip.end == mdp::TripEnd::kFailed;
  return t;
}

std::unique_ptr<DeliveryNavigation> deliveryNavigationFromKnowledge(
    const kb::NavDomain& domain, kb::NavigationKnowledge& knowledge, const DialogConfig& config,
    const std::vector<std::string>& rooms) {
  if (!domain.space) throw ConfigError("delivery navigation: the navigation domain is not loaded");
  const kb::NavModel model = knowledge.buildModel({config.time}, config.nav_discount);
  return std::make_unique<DeliveryNavigation>(
      *domain.space, model.dynamics,
      DeliveryNavigationOptions::fromConfig(config, rooms,
                                            static_cast<std::size_t>(domain.domain.step_limit)));
}

}  // namespace dialog
}  // namespace krr
