#include "krr_core/nav/grid_astar.h"

#include <algorithm>
#include <cstdlib>
#include <functional>

#include "krr_core/common/errors.h"

namespace krr {
namespace nav {

GridAStar::GridAStar(const NavGrid& grid) : grid_(grid) {
  if (grid_.numCells() >= (1 << 21)) {  // the heap key packs cell ids into 21 bits
    throw ConfigError("grid A*: grid of " + std::to_string(grid_.numCells()) +
                      " cells exceeds the supported 2097151");
  }
  const size_t n = static_cast<size_t>(grid_.numCells());
  g_.assign(n, 0);
  parent_.assign(n, -1);
  stamp_.assign(n, 0);
  heap_.reserve(n);
}

GridRoute GridAStar::plan(int start, int goal) {
  if (!grid_.valid(start) || !grid_.isFree(start)) {
    throw NoPathError("grid A*: invalid start cell " + std::to_string(start) +
                      " (not a free cell of the grid)");
  }
  if (!grid_.valid(goal) || !grid_.isFree(goal)) {
    throw NoPathError("grid A*: invalid goal cell " + std::to_string(goal) +
                      " (not a free cell of the grid)");
  }
  if (++query_ == 0) {  // stamp wrap-around: reset
    std::fill(stamp_.begin(), stamp_.end(), 0u);
    query_ = 1;
  }
  const int gc = grid_.colOf(goal), gr = grid_.rowOf(goal);
  auto h = [&](int c) { return std::abs(grid_.colOf(c) - gc) + std::abs(grid_.rowOf(c) - gr); };
  // Heap key: f (high bits), then -g (prefer deeper nodes), then cell id; min-heap via greater.
  auto key = [](int f, int g, int cell) {
    return (static_cast<std::uint64_t>(f) << 42) |
           (static_cast<std::uint64_t>((1u << 21) - 1 - static_cast<unsigned>(g)) << 21) |
           static_cast<std::uint64_t>(cell);
  };
  heap_.clear();
  expansions_ = 0;
  stamp_[static_cast<size_t>(start)] = query_;
  g_[static_cast<size_t>(start)] = 0;
  parent_[static_cast<size_t>(start)] = -1;
  heap_.push_back(key(h(start), 0, start));
  const std::uint64_t mask21 = (1u << 21) - 1;
  bool found = false;
  while (!heap_.empty()) {
    std::pop_heap(heap_.begin(), heap_.end(), std::greater<std::uint64_t>());
    const std::uint64_t k = heap_.back();
    heap_.pop_back();
    const int cell = static_cast<int>(k & mask21);
    const int g = static_cast<int>(mask21 - ((k >> 21) & mask21));
    if (g != g_[static_cast<size_t>(cell)]) continue;  // stale entry
    ++expansions_;
    if (cell == goal) {
      found = true;
      break;
    }
    for (int m = 0; m < kNumMoves; ++m) {
      const int t = grid_.neighbour(cell, m);
      if (t < 0) continue;
      const size_t ti = static_cast<size_t>(t);
      if (stamp_[ti] != query_ || g + 1 < g_[ti]) {
        stamp_[ti] = query_;
        g_[ti] = g + 1;
        parent_[ti] = cell;
        heap_.push_back(key(g + 1 + h(t), g + 1, t));
        std::push_heap(heap_.begin(), heap_.end(), std::greater<std::uint64_t>());
      }
    }
  }
  if (!found) {
    throw NoPathError("grid A*: no path from cell " + std::to_string(start) + " to cell " +
                      std::to_string(goal));
  }
  GridRoute route;
  for (int c = goal; c >= 0; c = parent_[static_cast<size_t>(c)]) route.cells.push_back(c);
  std::reverse(route.cells.begin(), route.cells.end());
  for (size_t i = 0; i + 1 < route.cells.size(); ++i) {
    for (int m = 0; m < kNumMoves; ++m) {
      if (grid_.neighbour(route.cells[i], m) == route.cells[i + 1]) {
        route.moves.push_back(m);
        break;
      }
    }
  }
  return route;
}

std::vector<int> GridAStar::distancesTo(int goal) const {
  std::vector<int> dist(static_cast<size_t>(grid_.numCells()), -1);
  if (!grid_.valid(goal) || !grid_.isFree(goal)) return dist;
  // Moves are symmetric (a wall blocks both directions), so BFS from the goal suffices.
  std::vector<int> queue{goal};
  dist[static_cast<size_t>(goal)] = 0;
  for (size_t i = 0; i < queue.size(); ++i) {
    const int c = queue[i];
    for (int m = 0; m < kNumMoves; ++m) {
      const int t = grid_.neighbour(c, m);
      if (t >= 0 && dist[static_cast<size_t>(t)] < 0) {
        dist[static_cast<size_t>(t)] = dist[static_cast<size_t>(c)] + 1;
        queue.push_back(t);
      }
    }
  }
  return dist;
}

std::vector<std::int8_t> GridAStar::policyTo(int goal) const {
  const std::vector<int> dist = distancesTo(goal);
  std::vector<std::int8_t> policy(dist.size(), -1);
  for (int c = 0; c < grid_.numCells(); ++c) {
    const int d = dist[static_cast<size_t>(c)];
    if (d <= 0) continue;
    for (int m = 0; m < kNumMoves; ++m) {
      const int t = grid_.neighbour(c, m);
      if (t >= 0 && dist[static_cast<size_t>(t)] == d - 1) {
        policy[static_cast<size_t>(c)] = static_cast<std::int8_t>(m);
        break;
      }
    }
  }
  return policy;
}

}  // namespace nav
}  // namespace krr
