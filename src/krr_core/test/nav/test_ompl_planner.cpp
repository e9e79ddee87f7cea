#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/nav/grid_astar.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_core/nav/ompl_planner.h"

using namespace krr;
using namespace krr::nav;

namespace {

const std::string kRepo = std::string(KRR_TEST_DATA_DIR) + "/../../../..";
constexpr std::uint64_t kSeed = 2024;  // one root seed for every planner of this process

// Independent check: distance from p to the nearest non-free map cell square, by brute force
// over the cells within `radius` + 2 cells; cells outside the map count as non-free.
double bruteClearance(const OccupancyGrid& m, const Point2& p, double radius) {
  double u = 0, v = 0;
  m.worldToMap(p, &u, &v);
  const int w = static_cast<int>(std::ceil(radius / m.resolution)) + 2;
  double best = 1e9;
  for (int j = static_cast<int>(v) - w; j <= static_cast<int>(v) + w; ++j) {
    for (int i = static_cast<int>(u) - w; i <= static_cast<int>(u) + w; ++i) {
      if (m.at(i, j) == kFree) continue;
      const double dx = std::max({i - u, 0.0, u - (i + 1)});
      const double dy = std::max({j - v, 0.0, v - (j + 1)});
      best = std::min(best, std::hypot(dx, dy) * m.resolution);
    }
  }
  return best;
}

// Every waypoint and every point between consecutive waypoints (every resolution/10) keeps the
// robot radius from occupied / unknown cells.
void expectCollisionFree(const OccupancyGrid& m, const std::vector<Point2>& path, double r) {
  ASSERT_GE(path.size(), 2u);
  for (size_t k = 0; k + 1 < path.size(); ++k) {
    const double len = std::hypot(path[k + 1].x - path[k].x, path[k + 1].y - path[k].y);
    const int n = std::max(1, static_cast<int>(std::ceil(len / (m.resolution / 10))));
    for (int s = 0; s <= n; ++s) {
      const double t = static_cast<double>(s) / n;
      const Point2 p{path[k].x + t * (path[k + 1].x - path[k].x),
                     path[k].y + t * (path[k + 1].y - path[k].y)};
      ASSERT_GE(bruteClearance(m, p, r), r - 1e-9) << "at (" << p.x << ", " << p.y << ")";
    }
  }
}

class OmplPlannerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    cfg_ = new NavigationConfig(loadNavigationConfig(kRepo + "/config/navigation.yaml"));
    map_ = new OccupancyGrid(loadMap(cfg_->map));
    planner_ = new OmplPlanner(*map_, cfg_->planner, kSeed);
  }
  static void TearDownTestSuite() {
    delete planner_;
    delete map_;
    delete cfg_;
  }
  static NavigationConfig* cfg_;
  static OccupancyGrid* map_;
  static OmplPlanner* planner_;
};
NavigationConfig* OmplPlannerTest::cfg_ = nullptr;
OccupancyGrid* OmplPlannerTest::map_ = nullptr;
OmplPlanner* OmplPlannerTest::planner_ = nullptr;

}  // namespace

TEST_F(OmplPlannerTest, RoutesFromShopAreCollisionFree) {
  NavGridOptions opt;
  opt.cols = 50;
  opt.rows = 50;
  NavGrid grid = NavGrid::fromMap(*map_, loadPlaces(cfg_->places), opt);
  for (const char* room : {"room1", "room2", "room3", "room4", "room5"}) {
    for (int rep = 0; rep < 3; ++rep) {
      std::vector<Point2> path = planner_->planRoute(grid, "shop", room);
      const Point2 goal = grid.places()[static_cast<size_t>(grid.placeIndex(room))].point;
      EXPECT_NEAR(path.back().x, goal.x, 1e-9);
      EXPECT_NEAR(path.back().y, goal.y, 1e-9);
      EXPECT_NEAR(path.front().x, 1.6, 1e-9);
      for (size_t k = 0; k + 1 < path.size(); ++k) {
        EXPECT_LE(std::hypot(path[k + 1].x - path[k].x, path[k + 1].y - path[k].y),
                  cfg_->planner.interpolation_step + 1e-9);
      }
      expectCollisionFree(*map_, path, cfg_->planner.robot_radius);
    }
  }
}

TEST_F(OmplPlannerTest, CellMovesAlongGridRoutes) {
  NavGridOptions opt;
  opt.cols = 30;
  opt.rows = 30;
  NavGrid grid = NavGrid::fromMap(*map_, loadPlaces(cfg_->places), opt);
  GridAStar astar(grid);
  GridRoute r = astar.plan(grid.placeCell("shop"), grid.placeCell("room5"));
  for (size_t i = 0; i + 1 < r.cells.size(); ++i) {
    std::vector<Point2> path = planner_->planCellMove(grid, r.cells[i], r.cells[i + 1]);
    EXPECT_EQ(grid.cellAt(path.front()), r.cells[i]);
    EXPECT_EQ(grid.cellAt(path.back()), r.cells[i + 1]);
    expectCollisionFree(*map_, path, cfg_->planner.robot_radius);
  }
}

TEST_F(OmplPlannerTest, ValidityMatchesBruteForce) {
  // Sample a lattice over the map: isValid iff brute clearance >= radius + check margin
  // (resolution / 8); points within 1e-6 of the boundary are skipped.
  const double r = cfg_->planner.robot_radius + map_->resolution / 8;
  int checked = 0;
  for (double x = 0.013; x < 15.0; x += 0.0371) {
    for (double y = 0.007; y < 15.0; y += 0.0413) {
      const double c = bruteClearance(*map_, Point2{x, y}, r);
      if (std::fabs(c - r) < 1e-6) continue;
      ASSERT_EQ(planner_->isValid(Point2{x, y}), c >= r) << x << " " << y << " " << c;
      ++checked;
    }
  }
  EXPECT_GT(checked, 100000);
  EXPECT_NEAR(planner_->clearance(Point2{3.75, 7.5}), 0.7, 1e-9);  // corridor centre, walls 0.7 m
}

TEST_F(OmplPlannerTest, ImpossibleQueriesThrowNoPathError) {
  // Goal inside the unknown lab in the centre of the ring.
  try {
    planner_->plan(Point2{1.6, 7.6}, Point2{7.5, 6.0});
    FAIL();
  } catch (const NoPathError& e) {
    EXPECT_NE(std::string(e.what()).find("invalid goal state"), std::string::npos) << e.what();
  }
  // Start in a wall.
  try {
    planner_->plan(Point2{3.0, 2.0}, Point2{1.6, 7.6});
    FAIL();
  } catch (const NoPathError& e) {
    EXPECT_NE(std::string(e.what()).find("invalid start state"), std::string::npos) << e.what();
  }
  // Outside the map.
  EXPECT_THROW(planner_->plan(Point2{-1.0, 2.0}, Point2{1.6, 7.6}), NoPathError);
}

// A map with two free regions separated by a wall: both states are valid, no path exists; the
// planner gives up after its timeout with NoPathError.
TEST_F(OmplPlannerTest, DisconnectedGoalTimesOut) {
  OccupancyGrid m;
  m.width = 40;
  m.height = 20;
  m.resolution = 0.05;
  m.data.assign(800, kFree);
  for (int j = 0; j < 20; ++j) {
    for (int i = 0; i < 40; ++i) {
      if (i < 2 || j < 2 || i >= 38 || j >= 18 || i == 19 || i == 20) {
        m.data[static_cast<size_t>(m.index(i, j))] = kOccupied;
      }
    }
  }
  PlannerConfig pc = cfg_->planner;
  pc.timeout = 0.02;
  OmplPlanner p(m, pc, kSeed);  // same root seed: fine
  ASSERT_TRUE(p.isValid(Point2{0.45, 0.5}));
  ASSERT_TRUE(p.isValid(Point2{1.55, 0.5}));
  try {
    p.plan(Point2{0.45, 0.5}, Point2{1.55, 0.5});
    FAIL();
  } catch (const NoPathError& e) {
    EXPECT_NE(std::string(e.what()).find("no path from"), std::string::npos) << e.what();
  }
  EXPECT_EQ(p.plannerCalls(), 1);
}

TEST_F(OmplPlannerTest, SeedingRules) {
  EXPECT_FALSE(seedOmpl(kSeed));                 // already seeded with the same root seed
  EXPECT_THROW(seedOmpl(kSeed + 1), ConfigError);  // OMPL cannot be reseeded
  EXPECT_THROW(OmplPlanner(*map_, cfg_->planner, kSeed + 1), ConfigError);
  PlannerConfig bad = cfg_->planner;
  bad.algorithm = "rrt*";
  EXPECT_THROW(OmplPlanner(*map_, bad, kSeed), ConfigError);
}

TEST_F(OmplPlannerTest, PrmAlsoPlans) {
  PlannerConfig pc = cfg_->planner;
  pc.algorithm = "prm";
  pc.timeout = 1.0;
  OmplPlanner p(*map_, pc, kSeed);
  std::vector<Point2> path = p.plan(Point2{1.6, 7.6}, Point2{8.35, 1.6});
  expectCollisionFree(*map_, path, pc.robot_radius);
  path = p.plan(Point2{1.6, 7.6}, Point2{13.6, 6.85});  // reuses the roadmap
  expectCollisionFree(*map_, path, pc.robot_radius);
}
