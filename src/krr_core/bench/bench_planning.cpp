/**
 * @file bench_planning.cpp
 * @brief Speed of grid A* and OMPL planning on the site's domains, simulator throughput, and
 * the calibration table of navigation success rates (shortest-path policy) per blocking rate.
 *
 *   bench_planning [--config ROOT/config/navigation.yaml] [--dialog-config FILE] [--site DIR
 *                  [--root DIR]] [--seed N] [--episodes N]
 *
 * Routes start at the site's shop (the dialog config's navigation.shop, or site.yaml's shop with
 * --site, site/site_options.h) and go to every other place of the places file, in its order.
 *
 * Targets: A* and OMPL queries well under a millisecond each.
 */
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/random.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/resources.h"
#include "krr_core/nav/blockage_simulator.h"
#include "krr_core/nav/grid_astar.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_core/nav/ompl_planner.h"
#include "krr_core/site/site_options.h"

using namespace krr;
using namespace krr::nav;

/// @brief One domain's figures: A* and OMPL query times from the shop to every room, the
/// simulator's throughput and the shortest-path policy's success rates.
static void benchDomain(const NavigationConfig& cfg, const OccupancyGrid& map,
                        const PlacesFile& places, OmplPlanner& planner, const DomainConfig& d,
                        const std::string& shopName, const std::vector<std::string>& rooms,
                        std::uint64_t seed, std::size_t episodes) {
  NavGridOptions opt;
  opt.cols = d.cols;
  opt.rows = d.rows;
  opt.max_blocked_fraction = cfg.max_blocked_fraction;
  NavGrid grid = NavGrid::fromMap(map, places, opt);
  GridAStar astar(grid);
  const int shop = grid.placeCell(shopName);
  std::printf("== domain %s (%d free cells, step limit %d)\n", d.name.c_str(),
              grid.numFreeCells(), d.step_limit);
  // Grid A*: the shop -> each room.
  for (const std::string& room : rooms) {
    const int goal = grid.placeCell(room);
    const int reps = 2000;
    size_t len = 0;
    Stopwatch sw;
    for (int k = 0; k < reps; ++k) len = astar.plan(shop, goal).moves.size();
    std::printf("grid A*      %s->%s: %3zu moves, %8.2f us/query\n", shopName.c_str(),
                room.c_str(), len,
                1e6 * sw.seconds() / reps);
  }
  // OMPL: the shop -> each room.
  for (const std::string& room : rooms) {
    const int reps = 200;
    size_t pts = 0;
    long calls0 = planner.plannerCalls();
    Stopwatch sw;
    for (int k = 0; k < reps; ++k) pts = planner.planRoute(grid, shopName, room).size();
    std::printf("OMPL route   %s->%s: %3zu waypoints, %8.2f us/query (%ld planner calls)\n",
                shopName.c_str(), room.c_str(), pts, 1e6 * sw.seconds() / reps,
                planner.plannerCalls() - calls0);
  }
  // OMPL per executed grid move: every move along the A* routes from the shop to the rooms.
  {
    std::vector<std::pair<int, int>> moves;
    for (const std::string& room : rooms) {
      GridRoute r = astar.plan(shop, grid.placeCell(room));
      for (size_t i = 0; i + 1 < r.cells.size(); ++i) moves.emplace_back(r.cells[i], r.cells[i + 1]);
    }
    const int reps = 20;
    long calls0 = planner.plannerCalls();
    Stopwatch sw;
    for (int k = 0; k < reps; ++k) {
      for (const auto& m : moves) planner.planCellMove(grid, m.first, m.second);
    }
    std::printf("OMPL cell move (%zu moves on the routes): %8.2f us/query (%ld planner calls "
                "of %zu)\n", moves.size(), 1e6 * sw.seconds() / (reps * moves.size()),
                planner.plannerCalls() - calls0, reps * moves.size());
  }
  // Simulator throughput: random moves from random free cells.
  {
    BlockageSimulator sim(grid, cfg.simulator);
    std::vector<int> cells = grid.freeCells();
    Rng rng = makeRng(seed, "bench_sim");
    const long steps = 20000000;
    long moved = 0;
    int cell = shop;
    Stopwatch sw;
    for (long k = 0; k < steps; ++k) {
      const Outcome o = sim.step(cell, static_cast<int>(rng() & 3u), Context{}, rng);
      moved += o.cell != cell;
      cell = o.trapped ? shop : o.cell;
    }
    const double t = sw.seconds();
    std::printf("simulator: %.1f M steps/s (%ld of %ld steps moved)\n", steps / t / 1e6,
                moved, steps);
    // Success rates of the shortest-path policy per blocking rate.
    std::printf("shortest-path policy success (%zu episodes each, seed %llu, %s blocking, "
                "trap %.4f per blocked step):\n", episodes,
                static_cast<unsigned long long>(seed),
                cfg.simulator.blocking_mode == BlockingMode::kOnEntry ? "on_entry" : "per_cell",
                sim.trapProbability());
    std::printf("   br ");
    for (const std::string& room : rooms) std::printf("  %6s", room.c_str());
    std::printf("\n");
    for (double br : {0.1, 0.3, 0.5, 0.7}) {
      std::printf("  %.1f ", br);
      for (const std::string& room : rooms) {
        const int goal = grid.placeCell(room);
        const Context ctx(-1, br);
        Rng r2 = makeRng(seed, "bench_success", static_cast<std::uint64_t>(goal));
        EpisodeStats st = runPolicy(sim, astar.policyTo(goal), shop, goal, d.step_limit, ctx,
                                    static_cast<long>(episodes), r2);
        std::printf("  %6.3f", st.successRate());
      }
      std::printf("\n");
    }
  }
}

/// @brief The benchmark; main() runs it under guardedMain, which reports a bad option or file.
static int mainBody(int argc, char** argv) {
  site::SiteOptions options;
  std::uint64_t seed = 1;
  std::size_t episodes = 10000;
  OptionParser cli("bench_planning",
                   "Speed of grid A* and OMPL planning on the site's domains, simulator\n"
                   "throughput, and the success rates of the shortest-path policy per blocking\n"
                   "rate.");
  options.declare(cli);
  cli.add("--seed", "N", "seed of the planner and the simulator", &seed);
  cli.add("--episodes", "N", "episodes per success rate", &episodes);
  if (const auto status = cli.parse(argc, argv, [&] { options.check(); })) return *status;
  const site::ResolvedSite site = options.resolve();
  const NavigationConfig& cfg = site.navigation;
  OccupancyGrid map = loadMap(cfg.map);
  PlacesFile places = loadPlaces(cfg.places);
  OmplPlanner planner(map, cfg.planner, seed);
  // The site's shop and every other place (the rooms), in the places file's order.
  const std::string shopName = site.shop();
  std::vector<std::string> rooms;
  for (const Place& p : places.places)
    if (p.name != shopName) rooms.push_back(p.name);
  for (const DomainConfig& d : cfg.domains)
    benchDomain(cfg, map, places, planner, d, shopName, rooms, seed, episodes);
  std::printf("peak RSS %.1f MiB\n", peakRssMiB());
  return 0;
}

int main(int argc, char** argv) {
  return krr::guardedMain("bench_planning", mainBody, argc, argv);
}
