/**
 * @file nav_fixtures.h
 * @brief The one factory of the small navigation domains the tests build in code (not a test
 * itself), so that a change to NavDomain or NavGrid is made once for every fixture.
 */
#pragma once

#include <unistd.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "krr_core/common/files.h"
#include "krr_core/kb/nav_domain.h"
#include "krr_core/nav/occupancy_grid.h"

namespace krr_test {

/// @brief A file of the repository (config/navigation.plog, ...).
inline std::string repoPath(const std::string& rel) {
  return std::string(KRR_TEST_DATA_DIR) + "/../../../../" + rel;
}

/// @brief A fresh directory /tmp/krr_<tag>_XXXXXX.
inline std::string tempDir(const std::string& tag) {
  std::string t = "/tmp/krr_" + tag + "_XXXXXX";
  return ::mkdtemp(&t[0]);
}

/// @brief A place at the centre of the 1 m cell (col, row).
inline krr::nav::Place place(const std::string& name, int col, int row) {
  return {name, {col + 0.5, row + 0.5}, false, {}};
}

/// @brief Places and blocking areas (rectangles in metres: x0, y0, x1, y1).
inline krr::nav::PlacesFile places(std::vector<krr::nav::Place> named,
                                   std::vector<krr::nav::BlockingArea> areas = {}) {
  krr::nav::PlacesFile p;
  p.places = std::move(named);
  p.areas = std::move(areas);
  return p;
}

/**
 * @brief A width x height map of 1 m cells, free but for the `walls` (col, row), cut into a
 * NavGrid of one cell per map cell.
 */
inline krr::nav::NavGrid makeGrid(int width, int height, const krr::nav::PlacesFile& places,
                                  const std::vector<std::pair<int, int>>& walls = {}) {
  krr::nav::OccupancyGrid map;
  map.width = width;
  map.height = height;
  map.resolution = 1.0;
  map.data.assign(static_cast<std::size_t>(width * height), krr::nav::kFree);
  for (const auto& [c, r] : walls)
    map.data[static_cast<std::size_t>(map.index(c, r))] = krr::nav::kOccupied;
  krr::nav::NavGridOptions opt;
  opt.cols = width;
  opt.rows = height;
  return krr::nav::NavGrid::fromMap(map, places, opt);
}

/**
 * @brief A NavDomain named `name` on `grid`: its state space, a blockage simulator with `sim`,
 * and as knowledge files the grid's geometry (written to a fresh temporary directory) and the
 * repository's human navigation knowledge (config/navigation.plog).
 */
inline krr::kb::NavDomain makeNavDomain(krr::nav::NavGrid grid, const std::string& name,
                                        int step_limit,
                                        const krr::nav::SimulatorConfig& sim = {}) {
  krr::kb::NavDomain d;
  d.domain.name = name;
  d.domain.cols = grid.cols();
  d.domain.rows = grid.rows();
  d.domain.step_limit = step_limit;
  d.config.simulator = sim;
  d.grid = std::make_shared<krr::nav::NavGrid>(std::move(grid));
  d.space = std::make_shared<krr::kb::NavStateSpace>(*d.grid);
  d.simulator = std::make_shared<krr::nav::BlockageSimulator>(*d.grid, d.config.simulator);
  const std::string geometry = tempDir("fixture_" + name) + "/" + name + "_geometry.plog";
  krr::writeFileAtomic(geometry, d.grid->toPlog(name));
  d.knowledge_files = {geometry, repoPath("config/navigation.plog")};
  return d;
}

/**
 * @brief The 3 x 2 grid of test/data/kb/tiny_geometry.plog: all cells free, cell 4 is blocking
 * area ba1, shop = cell 0, room1 = cell 5.
 *   3 4 5
 *   0 1 2
 */
inline krr::nav::NavGrid tinyGrid() {
  return makeGrid(3, 2, places({place("shop", 0, 0), place("room1", 2, 1)},
                               {{"ba1", {1.0, 1.0, 2.0, 2.0}}}));
}

/**
 * @brief An 8 x 3 corridor: the route to room1 (top right) is free, the one to room2 (bottom
 * right) crosses blocking area ba1.
 *   row 2:  . . . . . . . room1
 *   row 1:  shop . . . . . . .
 *   row 0:  . . . B B . . room2        B = ba1
 */
inline krr::kb::NavDomain corridor8x3(const std::string& name, int step_limit = 60) {
  return makeNavDomain(
      makeGrid(8, 3, places({place("shop", 0, 1), place("room1", 7, 2), place("room2", 7, 0)},
                            {{"ba1", {3.0, 0.0, 5.0, 1.0}}})),
      name, step_limit);
}

}  // namespace krr_test
