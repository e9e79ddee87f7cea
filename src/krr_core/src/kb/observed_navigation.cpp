#include "krr_core/kb/observed_navigation.h"

#include <algorithm>
#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/nav/nav_grid.h"

namespace krr {
namespace kb {

namespace {

/// Moves seen in `counts` whose target exists and lies outside every blocking area: what the
/// move noise is estimated from (estimateAreaKnowledge needs at least one).
std::uint64_t freeMoves(const mdp::VisitCounts& counts, const NavStateSpace& space) {
  const nav::NavGrid& grid = space.grid();
  std::uint64_t n = 0;
  for (mdp::StateId s = 0; s < space.trappedState(); ++s)
    for (int m = 0; m < nav::kNumMoves; ++m) {
      const int target = grid.neighbour(space.cellOf(s), m);
      if (target >= 0 && grid.areaMask(target) == 0)
        n += counts.count(s, static_cast<mdp::ActionId>(m));
    }
  return n;
}

}  // namespace

std::string toString(MoveOutcome o) {
  switch (o) {
    case MoveOutcome::kReached: return "reached";
    case MoveOutcome::kStayed: return "stayed";
    case MoveOutcome::kElsewhere: return "elsewhere";
    case MoveOutcome::kAborted: return "aborted";
  }
  return "aborted";
}

MoveOutcome moveOutcomeFromString(const std::string& name) {
  for (MoveOutcome o : {MoveOutcome::kReached, MoveOutcome::kStayed, MoveOutcome::kElsewhere,
                        MoveOutcome::kAborted})
    if (toString(o) == name) return o;
  throw ConfigError("move outcome '" + name + "' must be reached, stayed, elsewhere or aborted");
}

MoveOutcome classifyMove(const nav::NavGrid& grid, int cell, int move, int observed,
                         bool aborted) {
  if (aborted) return MoveOutcome::kAborted;
  if (observed == cell) return MoveOutcome::kStayed;
  return observed == grid.neighbour(cell, move) ? MoveOutcome::kReached : MoveOutcome::kElsewhere;
}

ObservedNavigation::ObservedNavigation(const NavStateSpace& space) : space_(space) {}

void ObservedNavigation::share(const std::string& time, std::shared_ptr<mdp::VisitCounts> pool) {
  if (!pool || pool->getS() != space_.numStates() || pool->getA() != space_.numActions())
    throw ConfigError("observed navigation: the pool of time '" + time +
                      "' is not over the navigation space's " +
                      std::to_string(space_.numStates()) + " states and 4 moves");
  pools_[time] = std::move(pool);
}

std::shared_ptr<mdp::VisitCounts> ObservedNavigation::pool(const std::string& time) {
  auto& p = pools_[time];
  if (!p) p = std::make_shared<mdp::VisitCounts>(space_.numStates(), space_.numActions());
  return p;
}

void ObservedNavigation::add(const ObservedMove& m) {
  if (m.time.empty()) throw UnknownSymbolError("observed move: no time of day");
  if (m.move < 0 || m.move >= nav::kNumMoves)
    throw UnknownSymbolError("observed move: move " + std::to_string(m.move) +
                             " is not one of up, down, left, right (0-3)");
  // stateOf throws UnknownSymbolError naming a cell that is not free.
  const mdp::StateId s = space_.stateOf(m.cell);
  const mdp::StateId s1 = m.next_cell < 0 ? space_.trappedState() : space_.stateOf(m.next_cell);
  pool(m.time)->add(s, static_cast<mdp::ActionId>(m.move), s1);
  ++moves_[m.time];
}

std::uint64_t ObservedNavigation::moves(const std::string& time) const {
  const auto it = moves_.find(time);
  return it == moves_.end() ? 0 : it->second;
}

std::optional<AreaKnowledge> ObservedNavigation::estimate(const std::string& time) const {
  const auto it = pools_.find(time);
  if (it == pools_.end() || freeMoves(*it->second, space_) == 0) return std::nullopt;
  return estimateAreaKnowledge(*it->second, space_, time);
}

std::optional<AreaKnowledge> ObservedNavigation::extract(NavigationKnowledge& knowledge,
                                                         const std::string& time) const {
  std::optional<AreaKnowledge> k = estimate(time);
  if (k) knowledge.setLearnedAreas(time, areaKnowledgeText(*k));
  return k;
}

double largestChange(const std::optional<AreaKnowledge>& before, const AreaKnowledge& after) {
  if (!before || before->noise.moves == 0) return 1.0;
  const MoveNoiseEstimate &a = before->noise, &b = after.noise;
  double worst = std::max({std::fabs(a.success - b.success), std::fabs(a.lateral - b.lateral),
                           std::fabs(a.wall_stay - b.wall_stay)});
  for (const AreaEstimate& e : after.areas) {
    const auto f = std::find_if(before->areas.begin(), before->areas.end(),
                                [&](const AreaEstimate& x) { return x.area == e.area; });
    worst = f == before->areas.end()
                ? 1.0
                : std::max({worst, std::fabs(f->blocking - e.blocking),
                            std::fabs(f->trap - e.trap)});
  }
  return worst;
}

}  // namespace kb
}  // namespace krr
