// site::parseFloorPlan, the map make_site --rooms-from-text draws: rooms and corridors become
// free space, every room is walled on its edges with its door open towards the corridor, the
// drawn lab-like building cuts into a grid on which every room is reachable from the shop, and
// every malformed statement is a ParseError naming the file and the line.
#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/nav/grid_astar.h"
#include "krr_core/nav/nav_grid.h"
#include "krr_core/site/floor_plan.h"

namespace {

using krr::site::FloorPlan;
using krr::site::parseFloorPlan;

const char* kBuilding =
    "# a corridor with two rooms south and three north\n"
    "size 12 8\n"
    "corridor 0 3 12 5\n"
    "room mailroom 0 0 4 3 door 1.1 2.4 at 1.6 1.6\n"
    "room studio 4 0 8 3 door 5.1 6.4\n"
    "room lab 0 5 4 8 door 1.1 2.4\n"
    "room kitchen 4 5 8 8 door 5.1 6.4\n"
    "room library 8 5 12 8 door 9.1 10.4   # the far end\n"
    "area hall_west 3 3 4.5 5\n"
    "area hall_east 9 3 10 5\n";

/// @brief Occupancy at a point (metres).
int at(const FloorPlan& p, double x, double y) {
  return p.grid.at(static_cast<int>(x / p.grid.resolution),
                   static_cast<int>(y / p.grid.resolution));
}

TEST(FloorPlan, DrawsRoomsCorridorsWallsAndDoors) {
  const FloorPlan p = parseFloorPlan(kBuilding, "b.txt");
  EXPECT_EQ(p.grid.width, 240);
  EXPECT_EQ(p.grid.height, 160);
  ASSERT_EQ(p.places.places.size(), 5u);
  ASSERT_EQ(p.places.areas.size(), 2u);
  EXPECT_EQ(p.places.places[0].name, "mailroom");
  EXPECT_DOUBLE_EQ(p.places.places[0].point.x, 1.6);
  EXPECT_DOUBLE_EQ(p.places.places[1].point.x, 6.0);  // the room's centre
  EXPECT_DOUBLE_EQ(p.places.places[1].point.y, 1.5);
  EXPECT_EQ(at(p, 2.0, 1.5), krr::nav::kFree);       // inside a room
  EXPECT_EQ(at(p, 6.0, 4.0), krr::nav::kFree);       // the corridor
  EXPECT_EQ(at(p, 3.0, 2.99), krr::nav::kOccupied);  // the mailroom's wall to the corridor
  EXPECT_EQ(at(p, 3.0, 3.01), krr::nav::kOccupied);
  EXPECT_EQ(at(p, 2.0, 2.99), krr::nav::kFree);      // its door
  EXPECT_EQ(at(p, 2.0, 3.01), krr::nav::kFree);
  EXPECT_EQ(at(p, 4.01, 1.5), krr::nav::kOccupied);  // the wall between mailroom and studio
  EXPECT_EQ(at(p, 3.99, 1.5), krr::nav::kOccupied);
}

TEST(FloorPlan, EveryRoomIsReachableOnAGridWithWallsOnCellEdges) {
  const FloorPlan p = parseFloorPlan(kBuilding, "b.txt");
  krr::nav::NavGridOptions opt;
  opt.cols = 24;
  opt.rows = 16;
  const krr::nav::NavGrid grid = krr::nav::NavGrid::fromMap(p.grid, p.places, opt);
  krr::nav::GridAStar astar(grid);
  for (const krr::nav::Place& place : p.places.places)
    EXPECT_NO_THROW(astar.plan(grid.placeCell("mailroom"), grid.placeCell(place.name)))
        << place.name;
  // The wall between the two southern rooms separates them: the route goes round.
  EXPECT_GT(astar.plan(grid.placeCell("mailroom"), grid.placeCell("studio")).moves.size(), 8u);
}

/// @brief The ParseError message of drawing `text` ("" and a failure when it draws).
std::string error(const std::string& text) {
  try {
    parseFloorPlan(text, "b.txt");
  } catch (const krr::ParseError& e) {
    return e.what();
  }
  ADD_FAILURE() << "drawn: " << text;
  return "";
}

TEST(FloorPlan, MalformedStatementsNameTheFileAndTheLine) {
  const std::string size = "size 12 8\n";
  const std::string room = "corridor 0 3 12 5\nroom a 0 0 4 3 door 1 2\n";
  const std::pair<std::string, std::string> cases[] = {
      {"", "b.txt:1:1: no 'size WIDTH HEIGHT'"},
      {size, "b.txt:2:1: no room"},
      {"room a 0 0 1 1\n", "b.txt:1:1: 'room' before 'size"},
      {size + "size 1 1\n", "b.txt:2:1: 'size' given twice"},
      {size + "wall 0 0 1 1\n", "b.txt:2:1: unknown statement 'wall'"},
      {size + "corridor 0 3 x 5\n", "b.txt:2:1: 'x' is not a number"},
      {size + "corridor 0 3 13 5\n", "leaves the map [0, 12] x [0, 8]"},
      {size + "corridor 0 5 12 3\n", "must have x0 < x1 and y0 < y1"},
      {size + "room a 0 0 4 3 door 5 6\n", "b.txt:2:1: room a: door [5, 6) lies on no edge"},
      {size + room + "room a 4 0 8 3\n", "b.txt:4:1: 'a' is named twice"},
      {size + room + "area a 4 0 8 3\n", "'a' is named twice"},
      {size + "room a 0 0 4 3 at 5 1\n", "the point is outside the room"},
      {size + "room a 0 0 4 3 window 1 2\n", "'window': expected 'door A B' or 'at X Y'"},
      {size + "room a 0 0 4 3 door 2\n", "a number is missing"},
  };
  for (const auto& [text, message] : cases)
    EXPECT_NE(error(text).find(message), std::string::npos)
        << "'" << message << "' not in: " << error(text);
}

}  // namespace
