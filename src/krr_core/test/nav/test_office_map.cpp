#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>
#include <string>

#include "krr_core/common/files.h"
#include "krr_core/common/random.h"
#include "krr_core/nav/blockage_simulator.h"
#include "krr_core/nav/grid_astar.h"
#include "krr_core/nav/navigation_config.h"
#include "../support/office_map.h"

using namespace krr;
using namespace krr::nav;

namespace {

const std::string kRepo = std::string(KRR_TEST_DATA_DIR) + "/../../../..";

NavigationConfig config() { return loadNavigationConfig(kRepo + "/config/navigation.yaml"); }

NavGrid domain(const NavigationConfig& cfg, const std::string& name) {
  const DomainConfig& d = cfg.domain(name);
  NavGridOptions opt;
  opt.cols = d.cols;
  opt.rows = d.rows;
  opt.max_blocked_fraction = cfg.max_blocked_fraction;
  return NavGrid::fromMap(loadMap(cfg.map), loadPlaces(cfg.places), opt);
}

// Names of the blocking areas a route crosses, e.g. "ba1+ba2", and how many BA cells it visits.
std::string crossed(const NavGrid& g, const GridRoute& r, int* ba_cells) {
  std::uint32_t mask = 0;
  *ba_cells = 0;
  for (int c : r.cells) {
    mask |= g.areaMask(c);
    if (g.areaMask(c)) ++*ba_cells;
  }
  std::string s;
  for (size_t a = 0; a < g.areas().size(); ++a) {
    if (mask & (1u << a)) s += (s.empty() ? "" : "+") + g.areas()[a].name;
  }
  return s;
}

}  // namespace

// The committed map files are exactly the drawing (test/support/office_map.h). With
// KRR_WRITE_OFFICE_MAP=1 the test first rewrites them from the drawing (maps/README.md); the
// domains are then re-cut with make_nav_domain.
TEST(OfficeMap, CommittedFilesMatchGenerator) {
  NavigationConfig cfg = config();
  const krr_test::OfficeMap office = krr_test::makeOfficeMap();
  const char* write = std::getenv("KRR_WRITE_OFFICE_MAP");
  if (write && std::string(write) == "1") {
    saveMap(office.grid, cfg.map, "office.pgm");
    writeFileAtomic(cfg.places,
                    "# Named places and blocking areas of the office map (metres, map frame).\n"
                    "# Drawn by src/krr_core/test/support/office_map.h (maps/README.md). Do not "
                    "edit.\n" +
                        placesToYaml(office.places));
    std::cerr << "wrote " << cfg.map << ", " << cfg.places << "\n";
  }
  OccupancyGrid loaded = loadMap(cfg.map);
  EXPECT_EQ(loaded.width, 300);
  EXPECT_EQ(loaded.height, 300);
  EXPECT_DOUBLE_EQ(loaded.resolution, 0.05);
  EXPECT_EQ(loaded.data, office.grid.data);
  EXPECT_EQ(readFile(cfg.map.substr(0, cfg.map.size() - 5) + ".pgm"), encodePgm(office.grid));
  PlacesFile pf = loadPlaces(cfg.places);
  ASSERT_EQ(pf.places.size(), 6u);
  ASSERT_EQ(pf.areas.size(), 4u);
  // Committed domain descriptions match a fresh derivation.
  for (const char* name : {"office_30x30", "office_50x50"}) {
    NavGrid g = domain(cfg, name);
    EXPECT_EQ(readFile(kRepo + "/maps/" + name + ".yaml"), g.toYaml(name, "office.yaml")) << name;
    EXPECT_EQ(readFile(kRepo + "/maps/" + name + "_geometry.plog"), g.toPlog(name)) << name;
  }
}

// The design of Figure 3: room1/room4 need no BA crossing, room3 crosses BA3, room2 crosses one
// BA (BA1), room5 two (BA1+BA2 on the shortest route; BA3+BA4 the other way round the ring).
// BA depths along the routes: BA1 3 m, BA2 1.5 m, BA3 1.5 m -> 6/3/3 cells of 0.5 m, 10/5/5 of
// 0.3 m.
TEST(OfficeMap, BlockingAreasWhereTheDesignSays) {
  NavigationConfig cfg = config();
  struct Want {
    const char* room;
    const char* areas;
    int cells30, cells50;
  } wants[] = {{"room1", "", 0, 0},       {"room4", "", 0, 0},       {"room3", "ba3", 3, 5},
               {"room2", "ba1", 6, 10},   {"room5", "ba1+ba2", 9, 15}};
  for (const char* name : {"office_30x30", "office_50x50"}) {
    NavGrid g = domain(cfg, name);
    GridAStar astar(g);
    const int shop = g.placeCell("shop");
    // Every place reachable from the shop.
    std::vector<int> reach = g.reachableFrom(shop);
    for (const Place& p : g.places()) {
      EXPECT_TRUE(std::binary_search(reach.begin(), reach.end(), g.placeCell(p.name))) << p.name;
      EXPECT_EQ(g.roomOf(g.placeCell(p.name)), g.placeIndex(p.name)) << p.name;
    }
    // No blocking area reaches into a room.
    for (size_t a = 0; a < g.areas().size(); ++a) {
      for (int c : g.areaCells(static_cast<int>(a))) EXPECT_EQ(g.roomOf(c), -1) << c;
    }
    for (const Want& w : wants) {
      GridRoute r = astar.plan(shop, g.placeCell(w.room));
      int cells = 0;
      EXPECT_EQ(crossed(g, r, &cells), w.areas) << name << " " << w.room;
      EXPECT_EQ(cells, std::string(name) == "office_30x30" ? w.cells30 : w.cells50)
          << name << " " << w.room;
    }
    // The other way round the ring to room5 crosses the two other BAs: shop -> north-east
    // corner crosses BA3, north-east corner -> room5 crosses BA4 (so room5 always needs two).
    const int ne_corner = g.cellAt(Point2{11.25, 11.25});
    GridRoute north = astar.plan(ne_corner, g.placeCell("room5"));
    int cells = 0;
    EXPECT_EQ(crossed(g, north, &cells), "ba4") << name;
    GridRoute west = astar.plan(shop, ne_corner);
    EXPECT_EQ(crossed(g, west, &cells), "ba3") << name;
  }
}

// Calibration of config/navigation.yaml: shortest-path policy, br = 0.3, seeded MC with the
// paper's step limits. Target (paper, commented paragraph): room2 0.643, room5 0.519, room1
// close to 1. Tolerance: 4.5 binomial standard errors (n = 4000) plus 0.03 calibration slack.
TEST(OfficeMap, CalibratedSuccessRatesAtBr03) {
  NavigationConfig cfg = config();
  for (const char* name : {"office_30x30", "office_50x50"}) {
    NavGrid g = domain(cfg, name);
    BlockageSimulator sim(g, cfg.simulator);
    GridAStar astar(g);
    Rng rng = makeRng(7, "office_calibration");
    const int shop = g.placeCell("shop");
    const long n = 4000;
    const int limit = cfg.domain(name).step_limit;
    auto rate = [&](const char* room) {
      const int goal = g.placeCell(room);
      return runPolicy(sim, astar.policyTo(goal), shop, goal, limit, Context{}, n, rng)
          .successRate();
    };
    const double tol = 4.5 * std::sqrt(0.25 / n) + 0.03;
    EXPECT_GT(rate("room1"), 0.99) << name;
    EXPECT_GT(rate("room4"), 0.99) << name;
    EXPECT_NEAR(rate("room2"), 0.643, tol) << name;
    EXPECT_NEAR(rate("room5"), 0.519, tol) << name;
  }
}
