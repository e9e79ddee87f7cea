/**
 * @file ompl_planner.h
 * @brief Continuous motion planning on the occupancy grid with OMPL: what the robot actually
 * drives for a grid move (planCellMove) or a whole shop -> room route (planRoute).
 *
 * The state space is 2D (x, y) over the map bounds; a state is valid iff every non-free map cell
 * (occupied or unknown, and everything outside the map) is at least robot_radius away from it.
 * Motions are checked every resolution/4, and the validity check adds half that spacing to the
 * radius, so every point of a returned path - not only the checked ones - keeps the full radius
 * clearance: paths never cut corners.
 *
 * Seeding: OMPL has one process-wide seed that can be set only once, before OMPL creates its
 * first random generator. The constructor calls seedOmpl(root_seed); construct every planner
 * of a process with the same root seed (a different one throws ConfigError), and create
 * planners in a fixed order for reproducible runs.
 */
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "krr_core/nav/nav_grid.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_core/nav/occupancy_grid.h"

namespace krr {
namespace nav {

/**
 * @brief Seed OMPL's process-wide RNG from the root seed (a derived, non-zero 32-bit seed) and
 * silence OMPL's console output. Must run before any OMPL random generator exists.
 * @return true if this call set the seed, false if the same root seed was already set.
 * @throws ConfigError if OMPL was already seeded from a different root seed, or if an OMPL
 * planner (which creates OMPL generators) was constructed before OMPL was seeded.
 */
bool seedOmpl(std::uint64_t root_seed);

/// @brief Planner that reuses one OMPL setup across queries. Not thread-safe (one per thread).
class OmplPlanner {
 public:
  /// @throws ConfigError for an invalid configuration or seeding conflict (see seedOmpl).
  OmplPlanner(const OccupancyGrid& map, const PlannerConfig& config, std::uint64_t root_seed);
  ~OmplPlanner();
  OmplPlanner(const OmplPlanner&) = delete;
  OmplPlanner& operator=(const OmplPlanner&) = delete;

  /// @brief A collision-free path from start to goal, interpolated every interpolation_step.
  /// A straight motion is returned without running the planner when it is valid.
  /// @param timeout seconds; <= 0 uses the configured timeout.
  /// @throws NoPathError naming an invalid start or goal state, or no path within the timeout.
  std::vector<Point2> plan(const Point2& start, const Point2& goal, double timeout = 0.0);

  /// @brief Path for one executed grid move, between the valid points of the two cells nearest
  /// to their centres. @throws NoPathError (also when a cell has no valid point).
  std::vector<Point2> planCellMove(const NavGrid& grid, int from_cell, int to_cell,
                                   double timeout = 0.0);

  /// @brief Path between two named places (their points), e.g. from the shop to a room.
  std::vector<Point2> planRoute(const NavGrid& grid, const std::string& from,
                                const std::string& to, double timeout = 0.0);

  /// @brief Validity of a robot position (radius + checking margin, see the file comment).
  bool isValid(const Point2& p) const;
  /// @brief Distance (m) from p to the nearest non-free map cell (0 inside one), exact.
  double clearance(const Point2& p) const;
  /// @brief The valid point of a nav cell nearest to its centre; false if there is none.
  bool cellAnchor(const NavGrid& grid, int cell, Point2* out) const;

  const PlannerConfig& config() const { return config_; }
  /// @brief Calls to the OMPL planner (queries not answered by a straight motion).
  long plannerCalls() const { return planner_calls_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  PlannerConfig config_;
  long planner_calls_ = 0;
};

}  // namespace nav
}  // namespace krr
