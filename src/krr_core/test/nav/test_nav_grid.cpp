#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/nav/nav_grid.h"

using namespace krr;
using namespace krr::nav;

namespace {

const std::string kDir = std::string(KRR_TEST_DATA_DIR) + "/nav/";

NavGrid wallGrid(const std::string& map, double max_blocked = 0.3) {
  NavGridOptions opt;
  opt.cols = 2;
  opt.rows = 1;
  opt.max_blocked_fraction = max_blocked;
  return NavGrid::fromMap(loadMap(kDir + map), loadPlaces(kDir + "navgrid_places.yaml"), opt);
}

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string p = ::testing::TempDir() + "/" + name;
  writeFileAtomic(p, text);
  return p;
}

}  // namespace

// navgrid_wall.pgm: 8x4 px of 1 m, a 1-px wall column at x = 4 (no gap). Cut into 2x1 cells of
// 4x4 px: the left cell has 0/16 blocked pixels, the right one 4/16 = 0.25 (the wall).
TEST(NavGrid, ThinWallSeparatesFreeCells) {
  NavGrid g = wallGrid("navgrid_wall.yaml");
  ASSERT_EQ(g.numCells(), 2);
  EXPECT_TRUE(g.isFree(0));
  EXPECT_TRUE(g.isFree(1));
  EXPECT_DOUBLE_EQ(g.blockedFraction(0), 0.0);
  EXPECT_DOUBLE_EQ(g.blockedFraction(1), 0.25);
  EXPECT_EQ(g.neighbour(0, kRight), -1);  // the segment (2,2)-(6,2) crosses the wall pixel
  EXPECT_EQ(g.neighbour(1, kLeft), -1);
  EXPECT_EQ(g.geometricNeighbour(0, kRight), 1);
  ASSERT_EQ(g.wallEdges().size(), 1u);
  EXPECT_EQ(g.wallEdges()[0], std::make_pair(0, 1));
  EXPECT_EQ(g.reachableFrom(0), std::vector<int>{0});
  const std::string plog = g.toPlog("t");
  EXPECT_NE(plog.find("cell = {0, 1}."), std::string::npos) << plog;
  EXPECT_EQ(plog.find("leftof(0"), std::string::npos) << plog;
}

// Same map with a door in image row 1 (grid row 2, the row the centre segment v = 2 samples).
TEST(NavGrid, DoorConnectsCells) {
  NavGrid g = wallGrid("navgrid_door.yaml");
  EXPECT_EQ(g.neighbour(0, kRight), 1);
  EXPECT_EQ(g.neighbour(1, kLeft), 0);
  EXPECT_EQ(g.neighbour(0, kUp), -1);  // off the grid
  EXPECT_TRUE(g.wallEdges().empty());
  const std::string plog = g.toPlog("t");
  EXPECT_NE(plog.find("leftof(0, 1)."), std::string::npos);
  EXPECT_EQ(plog.find("belowof(0"), std::string::npos);
  EXPECT_NE(plog.find("place_cell(left, 0)."), std::string::npos);
  EXPECT_NE(plog.find("place_cell(right, 1)."), std::string::npos);
  EXPECT_NE(plog.find("in_ba(1, ba_right)."), std::string::npos);
  EXPECT_EQ(plog.find("in_ba(0,"), std::string::npos);
}

TEST(NavGrid, PlacesAreasAndThreshold) {
  NavGrid g = wallGrid("navgrid_door.yaml");
  EXPECT_EQ(g.placeCell("left"), 0);
  EXPECT_EQ(g.placeCell("right"), 1);
  EXPECT_THROW(g.placeCell("kitchen"), UnknownSymbolError);
  EXPECT_EQ(g.areaCells(g.areaIndex("ba_right")), std::vector<int>{1});
  EXPECT_EQ(g.areaMask(1), 1u);
  EXPECT_EQ(g.areaMask(0), 0u);
  EXPECT_EQ(g.roomCells(g.placeIndex("left")), std::vector<int>{0});
  EXPECT_TRUE(g.roomCells(g.placeIndex("right")).empty());
  EXPECT_EQ(g.roomOf(0), g.placeIndex("left"));
  EXPECT_EQ(g.roomOf(1), -1);
  // With the door, the right cell has 3/16 blocked pixels; without it 4/16 = 0.25, which is not
  // below a 0.25 threshold: that cell is not free, and the place in it is rejected by name.
  EXPECT_DOUBLE_EQ(g.blockedFraction(1), 3.0 / 16.0);
  try {
    wallGrid("navgrid_wall.yaml", 0.25);
    FAIL();
  } catch (const MapError& e) {
    EXPECT_NE(std::string(e.what()).find("'right'"), std::string::npos) << e.what();
  }
}

// 5x5 map of 1 m pixels, one cell per pixel: ids, centres and lookups.
TEST(NavGrid, CellIdsAndCentres) {
  NavGridOptions opt;
  opt.cols = 5;
  opt.rows = 5;
  NavGrid g = NavGrid::fromMap(loadMap(kDir + "astar_wall.yaml"), PlacesFile{}, opt);
  EXPECT_EQ(g.cellId(2, 1), 7);  // row * W + col
  EXPECT_EQ(g.colOf(7), 2);
  EXPECT_EQ(g.rowOf(7), 1);
  Point2 c = g.cellCentre(7);
  EXPECT_DOUBLE_EQ(c.x, 2.5);
  EXPECT_DOUBLE_EQ(c.y, 1.5);
  EXPECT_EQ(g.cellAt(Point2{2.9, 1.1}), 7);
  EXPECT_EQ(g.cellAt(Point2{5.0, 1.0}), -1);
  // Image column 2 is occupied in image rows 1..4 = grid rows 3..0; free at the top.
  for (int r = 0; r < 4; ++r) EXPECT_FALSE(g.isFree(g.cellId(2, r))) << r;
  EXPECT_TRUE(g.isFree(g.cellId(2, 4)));
  EXPECT_EQ(g.numFreeCells(), 21);
  EXPECT_EQ(g.neighbour(g.cellId(1, 0), kRight), -1);
  EXPECT_EQ(g.neighbour(g.cellId(1, 4), kRight), g.cellId(2, 4));
  EXPECT_EQ(g.neighbour(g.cellId(0, 0), kDown), -1);
  // Options out of range.
  opt.cols = 6;
  EXPECT_THROW(NavGrid::fromMap(loadMap(kDir + "astar_wall.yaml"), PlacesFile{}, opt), MapError);
}

TEST(NavGrid, YamlRoundTrip) {
  NavGrid g = wallGrid("navgrid_wall.yaml");
  const std::string p = writeTemp("domain_rt.yaml", g.toYaml("rt", "navgrid_wall.yaml"));
  NavGrid h = NavGrid::fromYaml(p);
  EXPECT_EQ(h.cols(), 2);
  EXPECT_EQ(h.rows(), 1);
  EXPECT_EQ(h.freeCells(), g.freeCells());
  EXPECT_EQ(h.wallEdges(), g.wallEdges());
  EXPECT_EQ(h.placeCell("right"), 1);
  EXPECT_EQ(h.areaCells(0), g.areaCells(0));
  EXPECT_EQ(h.toYaml("rt", "navgrid_wall.yaml"), g.toYaml("rt", "navgrid_wall.yaml"));
  EXPECT_EQ(h.toPlog("rt"), g.toPlog("rt"));
  std::remove(p.c_str());
}

TEST(NavGrid, PlacesFileErrors) {
  struct Case {
    const char* text;
    const char* what;
  } cases[] = {
      {"places: [1, 2\n", "broken YAML"},
      {"blocking_areas: {}\n", "missing field 'places'"},
      {"places:\n  shop: {room: [0, 0, 1, 1]}\n", "places.shop.point"},
      {"places:\n  Shop: {point: [0, 0]}\n", "places.Shop: bad name"},
      {"places:\n  shop: {point: [5, 5], room: [0, 0, 1, 1]}\n", "outside its room"},
      {"places:\n  shop: {point: [0.5, 0.5], room: [1, 0, 0, 1]}\n", "places.shop.room"},
      {"places:\n  shop: {point: [0, 0]}\nblocking_areas:\n  shop: {rect: [0, 0, 1, 1]}\n",
       "duplicate name"},
      {"places:\n  shop: {point: [0, 0]}\nblocking_areas:\n  ba1: {rect: [0, 0, 1]}\n",
       "blocking_areas.ba1.rect"},
      // Typo'd keys are errors naming the key, not silently missing sections (issue 12).
      {"places:\n  shop: {point: [0, 0]}\nblocking_areas_typo:\n  ba1: {rect: [0, 0, 1, 1]}\n",
       "unknown field 'blocking_areas_typo' (expected blocking_areas, places)"},
      {"places:\n  shop: {point: [0, 0], rooom: [0, 0, 1, 1]}\n",
       "unknown field 'places.shop.rooom' (expected point, room)"},
      {"places:\n  shop: {point: [0, 0]}\nblocking_areas:\n  ba1: {rect: [0, 0, 1, 1], rat: 1}\n",
       "unknown field 'blocking_areas.ba1.rat' (expected rect)"},
  };
  int k = 0;
  for (const Case& c : cases) {
    const std::string name = "places_err_" + std::to_string(k++) + ".yaml";
    const std::string p = writeTemp(name, c.text);
    try {
      loadPlaces(p);
      ADD_FAILURE() << "no error for " << c.text;
    } catch (const MapError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.what), std::string::npos) << e.what();
    }
    std::remove(p.c_str());
  }
}

// cols x rows come from the navigation config: a grid above the memory budget is refused.
TEST(NavGrid, GridAboveMemoryBudgetIsRefused) {
  ::setenv("KRR_MEMORY_BUDGET_MIB", "0.001", 1);  // about 1 kB: 2x1 cells fit, 8x4 do not
  NavGridOptions opt;
  opt.cols = 8;
  opt.rows = 4;
  try {
    NavGrid::fromMap(loadMap(kDir + "navgrid_wall.yaml"), loadPlaces(kDir + "navgrid_places.yaml"),
                     opt);
    ADD_FAILURE() << "no error";
  } catch (const MapError& e) {
    EXPECT_NE(std::string(e.what()).find("8x4 cells need about"), std::string::npos) << e.what();
  }
  ::unsetenv("KRR_MEMORY_BUDGET_MIB");
  EXPECT_EQ(wallGrid("navgrid_wall.yaml").numCells(), 2);
}
