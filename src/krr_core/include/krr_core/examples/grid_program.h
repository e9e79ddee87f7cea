/**
 * @file grid_program.h
 * @brief Generator of the grid-navigation P-log program of the paper (Section III), a toy
 * problem for the benchmark and the tests (examples library; the robot's own programs are the
 * knowledge base, kb/).
 */
#pragma once

#include <string>
#include <vector>

namespace krr {
namespace examples {

/// @brief A rectangular blocking area (inclusive cell coordinates) where walkers may appear.
struct BlockingArea {
  std::string name;          ///< constant naming the area in the program, e.g. "a0"
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  double walkers_probability = 0.3;  ///< prior P(walkers(area) = true)
  double blocking_rate = 0.7;        ///< P(robot stays in place | walkers, cell in area)
};

/// @brief Grid and probabilities of the generated program.
struct GridNavigationSpec {
  int width = 5, height = 5;
  std::vector<std::pair<int, int>> walls;  ///< (x, y) cells excluded from sort `cell`
  std::vector<BlockingArea> areas;         ///< must not overlap
  /// @brief Success rate of a move by time of day (morning, noon, afternoon).
  double success_morning = 0.95, success_noon = 0.8, success_afternoon = 0.9;
  /// @brief Prior of curr_time (afternoon gets the rest by P-log's default rule).
  double p_morning = 0.4, p_noon = 0.3;
};

/// @brief Cell number of (x, y): y * width + x (walls keep their numbers, they are just absent).
inline int gridCell(const GridNavigationSpec& s, int x, int y) { return y * s.width + x; }

/// @brief The classic-dialect P-log program: sorts cell/move/time/area, leftof/belowof facts,
/// in_area facts, reachable (self and the four neighbours), random curr_cell, act_move,
/// curr_time, walkers(A), next_cell with dynamic range {C1 : reachable(C,C1)}, the derived
/// predicate blocked, and pr-atoms: time and walkers priors, move success by time when not
/// blocked, staying in place with the area's blocking rate when blocked.
std::string makeGridNavigationProgram(const GridNavigationSpec& spec);

}  // namespace examples
}  // namespace krr
