#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/nav/grid_astar.h"
#include "krr_core/nav/navigation_config.h"

using namespace krr;
using namespace krr::nav;

namespace {

const std::string kDir = std::string(KRR_TEST_DATA_DIR) + "/nav/";

NavGrid pixelGrid(const std::string& yaml) {
  OccupancyGrid m = loadMap(kDir + yaml);
  NavGridOptions opt;
  opt.cols = m.width;
  opt.rows = m.height;
  return NavGrid::fromMap(m, PlacesFile{}, opt);
}

// Follow moves from start and return the end cell (checks every move is possible).
int follow(const NavGrid& g, int start, const std::vector<int>& moves) {
  int c = start;
  for (int m : moves) {
    c = g.neighbour(c, m);
    if (c < 0) return -1;
  }
  return c;
}

}  // namespace

// astar_wall: 5x5, column 2 blocked in grid rows 0..3, free in row 4 (the top).
// (0,0) -> (4,0): up 4 rows, right 4 columns, down 4 rows = 12 moves (Manhattan bound is 4).
// (1,0) -> (3,0): up 4, right 2, down 4 = 10 moves. (0,0) -> (1,3): 4 moves.
TEST(GridAStar, OptimalLengthsAroundWall) {
  NavGrid g = pixelGrid("astar_wall.yaml");
  GridAStar astar(g);
  struct Q {
    int c0, r0, c1, r1, len;
  } qs[] = {{0, 0, 4, 0, 12}, {1, 0, 3, 0, 10}, {0, 0, 1, 3, 4}, {3, 3, 3, 3, 0}, {1, 4, 3, 4, 2}};
  for (const Q& q : qs) {
    const int s = g.cellId(q.c0, q.r0), t = g.cellId(q.c1, q.r1);
    GridRoute r = astar.plan(s, t);
    EXPECT_EQ(static_cast<int>(r.moves.size()), q.len);
    ASSERT_EQ(r.cells.size(), r.moves.size() + 1);
    EXPECT_EQ(r.cells.front(), s);
    EXPECT_EQ(r.cells.back(), t);
    EXPECT_EQ(follow(g, s, r.moves), t);
    EXPECT_EQ(astar.distancesTo(t)[static_cast<size_t>(s)], q.len);
  }
  // Any 12-move route is 4 ups, 4 rights and 4 downs (no left: it would need a 14th move).
  GridRoute r = astar.plan(g.cellId(0, 0), g.cellId(4, 0));
  int count[kNumMoves] = {0, 0, 0, 0};
  for (int m : r.moves) ++count[m];
  EXPECT_EQ(count[kUp], 4);
  EXPECT_EQ(count[kRight], 4);
  EXPECT_EQ(count[kDown], 4);
  EXPECT_EQ(count[kLeft], 0);
}

// astar_pocket: the centre cell (2,2) is free but enclosed by a ring of occupied cells.
TEST(GridAStar, UnreachableAndInvalidCellsThrow) {
  NavGrid g = pixelGrid("astar_pocket.yaml");
  GridAStar astar(g);
  const int centre = g.cellId(2, 2);
  ASSERT_TRUE(g.isFree(centre));
  try {
    astar.plan(g.cellId(0, 0), centre);
    FAIL();
  } catch (const NoPathError& e) {
    EXPECT_NE(std::string(e.what()).find("no path from cell 0 to cell 12"), std::string::npos)
        << e.what();
  }
  try {
    astar.plan(g.cellId(1, 1), centre);
    FAIL();
  } catch (const NoPathError& e) {
    EXPECT_NE(std::string(e.what()).find("invalid start cell 6"), std::string::npos) << e.what();
  }
  EXPECT_THROW(astar.plan(0, 99), NoPathError);
  EXPECT_EQ(astar.distancesTo(centre)[0], -1);
  // Going round the ring: (0,0) -> (4,4) is 8 moves.
  EXPECT_EQ(astar.plan(0, g.cellId(4, 4)).moves.size(), 8u);
}

// On the office domains, A* lengths equal BFS distances for every place pair, and the
// shortest-path policy reaches the goal from every reachable cell in exactly that many moves.
TEST(GridAStar, MatchesBfsOnOffice) {
  NavigationConfig cfg =
      loadNavigationConfig(std::string(KRR_TEST_DATA_DIR) + "/../../../../config/navigation.yaml");
  NavGridOptions opt;
  opt.cols = 30;
  opt.rows = 30;
  NavGrid g = NavGrid::fromMap(loadMap(cfg.map), loadPlaces(cfg.places), opt);
  GridAStar astar(g);
  for (const Place& a : g.places()) {
    for (const Place& b : g.places()) {
      const int s = g.placeCell(a.name), t = g.placeCell(b.name);
      EXPECT_EQ(static_cast<int>(astar.plan(s, t).moves.size()),
                astar.distancesTo(t)[static_cast<size_t>(s)]);
    }
  }
  const int goal = g.placeCell("room5");
  std::vector<int> dist = astar.distancesTo(goal);
  std::vector<std::int8_t> pol = astar.policyTo(goal);
  for (int c = 0; c < g.numCells(); ++c) {
    if (dist[static_cast<size_t>(c)] <= 0) continue;
    int x = c, n = 0;
    while (x != goal && n < 1000) {
      x = g.neighbour(x, pol[static_cast<size_t>(x)]);
      ++n;
    }
    EXPECT_EQ(n, dist[static_cast<size_t>(c)]);
  }
}
