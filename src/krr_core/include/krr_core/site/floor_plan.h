/**
 * @file floor_plan.h
 * @brief A map drawn from a short room / corridor description (make_site --rooms-from-text),
 * so that a building can be tried before anyone has drawn or recorded its map.
 *
 * One statement a line, metres in the map frame (x right, y up), '#' starts a comment:
 * @code
 *   size 12 8                                 # the map: width, height (0.05 m per pixel)
 *   corridor 0 3 12 5                         # free space: x0 y0 x1 y1 (any number)
 *   room mailroom 0 0 4 3 door 1.1 2.4        # a place and its room, with a door
 *   room studio 4 0 8 3 door 5.1 6.4 at 6.1 1.6
 *   area hall_west 3 3 4.5 5                  # a blocking area
 * @endcode
 * Everything outside the corridors and rooms is occupied. Every room gets a 2-px wall centred
 * on each of its edges (the README's Grid: walls on cell edges); `door A B` opens the span
 * [A, B) along every edge the room shares with a corridor (x along a horizontal edge, y along a
 * vertical one); a door on no such edge is an error. `at X Y` is the place's point (default: the
 * room's centre). The shop is a room like the others (make_site --shop names it).
 *
 * Errors are ParseErrors "file:line:col: message": an unknown statement, a missing or malformed
 * number, a rectangle that is empty or leaves the map, a point outside its room, a door on no
 * wall shared with a corridor, a repeated name, `size` missing or given twice.
 */
#pragma once

#include <string>

#include "krr_core/nav/nav_grid.h"
#include "krr_core/nav/occupancy_grid.h"

namespace krr {
namespace site {

/// @brief A drawn map: the occupancy grid and its places (rooms) and blocking areas.
struct FloorPlan {
  nav::OccupancyGrid grid;
  nav::PlacesFile places;
};

/// @brief Draw the description `text`; `name` is the file named in errors.
/// @throws ParseError "name:line:col: message" (see the file comment).
FloorPlan parseFloorPlan(const std::string& text, const std::string& name = "<string>");
/// @brief parseFloorPlan of a file. @throws IoError / ParseError naming the file.
FloorPlan loadFloorPlan(const std::string& path);

}  // namespace site
}  // namespace krr
