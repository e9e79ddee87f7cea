/**
 * @file grid_astar.h
 * @brief Shortest paths on the navigation grid, ignoring blocking risk: the baseline planner,
 * and the "shortest-path policy" the blockage calibration and the lead's baselines follow.
 */
#pragma once

#include <cstdint>
#include <vector>

#include "krr_core/nav/nav_grid.h"

namespace krr {
namespace nav {

/// @brief A cell path and the moves that follow it (moves.size() == cells.size() - 1).
struct GridRoute {
  std::vector<int> cells;
  std::vector<int> moves;
};

/**
 * @brief 4-connected A* with the Manhattan heuristic over the grid's connected moves.
 *
 * Ties are broken deterministically (lower f, then higher g, then lower cell id), so the same
 * query always returns the same path. Search buffers are reused across queries: an instance
 * must not be shared between threads. The grid must outlive the planner (it is referenced);
 * grids of up to 2^21 - 1 cells are supported (ConfigError beyond).
 */
class GridAStar {
 public:
  explicit GridAStar(const NavGrid& grid);

  /// @brief A shortest route from start to goal.
  /// @throws NoPathError naming both cells if goal is unreachable, or if start / goal is not a
  /// free cell of the grid (named as the invalid start / goal).
  GridRoute plan(int start, int goal);

  /// @brief Number of moves of a shortest path from every cell to goal (BFS); -1 if unreachable.
  std::vector<int> distancesTo(int goal) const;

  /// @brief A deterministic shortest-path policy towards goal: for every cell, a move that
  /// decreases the distance to goal (first in up, down, left, right order); -1 at the goal and
  /// where goal is unreachable.
  std::vector<std::int8_t> policyTo(int goal) const;

  /// @brief Number of nodes expanded by the last plan() call (for benchmarks).
  int lastExpansions() const { return expansions_; }

 private:
  const NavGrid& grid_;
  std::vector<int> g_;
  std::vector<int> parent_;
  std::vector<std::uint32_t> stamp_;
  std::uint32_t query_ = 0;
  std::vector<std::uint64_t> heap_;
  int expansions_ = 0;
};

}  // namespace nav
}  // namespace krr
