#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <map>
#include <new>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/random.h"
#include "krr_core/nav/blockage_simulator.h"

// Count heap allocations to check that step() allocates nothing. (GCC cannot see that the
// replaced operator new and delete pair malloc with free.)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
namespace {
std::atomic<long> g_allocations{0};
}
void* operator new(std::size_t n) {
  ++g_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

using namespace krr;
using namespace krr::nav;

namespace {

const std::string kDir = std::string(KRR_TEST_DATA_DIR) + "/nav/";

// astar_wall.pgm, one cell per 1 m pixel: 5x5, column 2 blocked in rows 0..3. One blocking area
// "bz" covering columns 3..4 (x in [3,5)), all rows.
NavGrid testGrid() {
  PlacesFile pf;
  pf.areas.push_back(BlockingArea{"bz", Rect{3.0, 0.0, 5.0, 5.0}});
  NavGridOptions opt;
  opt.cols = 5;
  opt.rows = 5;
  return NavGrid::fromMap(loadMap(kDir + "astar_wall.yaml"), pf, opt);
}

SimulatorConfig testConfig() {
  SimulatorConfig c;
  c.move_success = 0.9;
  c.slip_stay = 0.04;
  c.slip_lateral = 0.06;
  c.blocking_rate = 0.3;
  c.trap_probability = 0.2;
  c.trap_reference_cell_size = 0.0;  // no rescaling: q = 0.2 on this 1 m grid
  c.times_of_day = {"morning", "noon"};
  c.time_factors = {1.0, 2.0};
  return c;
}

std::map<int, double> dist(const BlockageSimulator& s, int cell, int move, const Context& ctx) {
  std::map<int, double> m;
  for (const auto& p : s.trueDistribution(cell, move, ctx)) m[p.first] = p.second;
  return m;
}

}  // namespace

// From (1,1) moving up (free target (1,2), lateral neighbours (0,1) free, (2,1) occupied):
//   (1,2): 0.9;  (0,1): 0.06/2 = 0.03;  stay (1,1): 0.04 + 0.03 (blocked lateral) = 0.07.
TEST(BlockageSimulator, FreeSpaceDistribution) {
  NavGrid g = testGrid();
  BlockageSimulator sim(g, testConfig());
  std::map<int, double> d = dist(sim, g.cellId(1, 1), kUp, Context{});
  ASSERT_EQ(d.size(), 3u);
  EXPECT_NEAR(d[g.cellId(1, 2)], 0.9, 1e-12);
  EXPECT_NEAR(d[g.cellId(0, 1)], 0.03, 1e-12);
  EXPECT_NEAR(d[g.cellId(1, 1)], 0.07, 1e-12);
  // Into the wall column or off the grid: stays with probability 1.
  d = dist(sim, g.cellId(1, 1), kRight, Context{});
  ASSERT_EQ(d.size(), 1u);
  EXPECT_DOUBLE_EQ(d[g.cellId(1, 1)], 1.0);
  d = dist(sim, g.cellId(0, 0), kDown, Context{});
  EXPECT_DOUBLE_EQ(d[0], 1.0);
}

// From (3,1) moving up into the blocking area (br 0.3, q 0.2), laterals (2,1) occupied, (4,1):
//   (3,2): 0.7*0.9 = 0.63; (4,1): 0.7*0.03 = 0.021; trapped: 0.3*0.2 = 0.06;
//   stay: 0.7*(0.04+0.03) + 0.3*0.8 = 0.049 + 0.24 = 0.289.
TEST(BlockageSimulator, BlockingAreaDistribution) {
  NavGrid g = testGrid();
  BlockageSimulator sim(g, testConfig());
  std::map<int, double> d = dist(sim, g.cellId(3, 1), kUp, Context{});
  ASSERT_EQ(d.size(), 4u);
  EXPECT_NEAR(d[g.cellId(3, 2)], 0.63, 1e-12);
  EXPECT_NEAR(d[g.cellId(4, 1)], 0.021, 1e-12);
  EXPECT_NEAR(d[sim.trappedState()], 0.06, 1e-12);
  EXPECT_NEAR(d[g.cellId(3, 1)], 0.289, 1e-12);
  EXPECT_EQ(sim.trappedState(), 25);
}

TEST(BlockageSimulator, DistributionsSumToOne) {
  NavGrid g = testGrid();
  BlockageSimulator sim(g, testConfig());
  for (int c = 0; c < g.numCells(); ++c) {
    for (int m = 0; m < kNumMoves; ++m) {
      for (Context ctx : {Context{}, Context{1}, Context{0, 0.7}, Context{1, 1.0}}) {
        double sum = 0.0;
        int prev = -1;
        for (const auto& p : sim.trueDistribution(c, m, ctx)) {
          EXPECT_GT(p.second, 0.0);
          EXPECT_GT(p.first, prev);  // sorted, distinct
          prev = p.first;
          sum += p.second;
        }
        EXPECT_NEAR(sum, 1.0, 1e-12) << c << " " << m;
      }
    }
  }
}

// Sampled frequencies match trueDistribution: N = 200000 samples per (cell, move, context),
// tolerance 4.5 binomial standard errors sqrt(p(1-p)/N) (+1e-9 for p = 0 / 1).
TEST(BlockageSimulator, SamplesMatchTrueDistribution) {
  NavGrid g = testGrid();
  BlockageSimulator sim(g, testConfig());
  Rng rng = makeRng(12345, "sim_test");
  const long n = 200000;
  struct Q {
    int cell, move;
    Context ctx;
  } qs[] = {{g.cellId(1, 1), kUp, Context{}},
            {g.cellId(3, 1), kUp, Context{}},
            {g.cellId(3, 1), kRight, Context{1}},   // noon: rate 0.6
            {g.cellId(1, 4), kRight, Context{-1, 0.7}}};  // into (2,4): not in the area
  for (const Q& q : qs) {
    std::map<int, long> count;
    long blocked = 0;
    for (long k = 0; k < n; ++k) {
      Outcome o = sim.step(q.cell, q.move, q.ctx, rng);
      ++count[o.trapped ? sim.trappedState() : o.cell];
      blocked += o.blocked;
      if (o.trapped) {
        EXPECT_TRUE(o.blocked);
      }
    }
    for (const auto& p : sim.trueDistribution(q.cell, q.move, q.ctx)) {
      const double f = static_cast<double>(count[p.first]) / n;
      const double se = std::sqrt(p.second * (1 - p.second) / n);
      EXPECT_NEAR(f, p.second, 4.5 * se + 1e-9) << "cell " << q.cell << " -> " << p.first;
      count.erase(p.first);
    }
    EXPECT_TRUE(count.empty()) << "outcome outside the true distribution";
    const int target = g.neighbour(q.cell, q.move);
    const double br = target >= 0 ? sim.blockingRate(target, q.ctx) : 0.0;
    EXPECT_NEAR(static_cast<double>(blocked) / n, br, 4.5 * std::sqrt(br * (1 - br) / n) + 1e-9);
  }
}

// Rates: default 0.3; noon factor 2 -> 0.6; override br 0.7 at noon -> min(1, 1.4) = 1;
// per-area override rate 0.1 with noon factor 3 -> 0.3; unspecified time -> factor 1.
TEST(BlockageSimulator, ContextChangesRates) {
  NavGrid g = testGrid();
  const int in_area = g.cellId(3, 2), outside = g.cellId(1, 2);
  BlockageSimulator sim(g, testConfig());
  EXPECT_DOUBLE_EQ(sim.blockingRate(in_area, Context{}), 0.3);
  EXPECT_DOUBLE_EQ(sim.blockingRate(in_area, Context{0}), 0.3);
  EXPECT_DOUBLE_EQ(sim.blockingRate(in_area, Context{1}), 0.6);
  EXPECT_DOUBLE_EQ(sim.blockingRate(in_area, Context{-1, 0.1}), 0.1);
  EXPECT_DOUBLE_EQ(sim.blockingRate(in_area, Context{1, 0.7}), 1.0);
  EXPECT_DOUBLE_EQ(sim.blockingRate(outside, Context{1, 0.7}), 0.0);
  EXPECT_EQ(sim.timeOfDayIndex("noon"), 1);
  EXPECT_THROW(sim.timeOfDayIndex("night"), ConfigError);
  EXPECT_THROW(sim.blockingRate(in_area, Context{2}), ConfigError);  // the simulator's times
  // Refused where the context is made (the one rule's message, nav/blocking_rate.h), not at
  // every step: a rate outside [0, 1], NaN, a time below -1; a setting's negative rate
  // (Context::withRate) means the configured rates.
  EXPECT_THROW(Context(-1, 1.5), ConfigError);
  EXPECT_THROW(Context(-2), ConfigError);
  try {
    Context(-1, std::nan(""));
    ADD_FAILURE() << "a NaN context rate was accepted";
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "blockage simulator: field 'context.blocking_rate': value nan must be "
                           "in [0, 1]");
  }
  try {
    Context::withRate(-1, std::nan(""));
    ADD_FAILURE() << "a NaN setting rate was accepted";
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "blockage simulator: field 'context.blocking_rate': value nan must be "
                           "in [0, 1] (negative: not set)");
  }
  EXPECT_FALSE(Context::withRate(0, -1.0).blockingRate().has_value());
  EXPECT_EQ(Context::withRate(1, 0.25).blockingRate().value(), 0.25);
  EXPECT_EQ(Context::withRate(1, 0.25).timeOfDay(), 1);
  SimulatorConfig c = testConfig();
  c.areas["bz"].rate = 0.1;
  c.areas["bz"].time_factor["noon"] = 3.0;
  BlockageSimulator sim2(g, c);
  EXPECT_DOUBLE_EQ(sim2.blockingRate(in_area, Context{}), 0.1);
  EXPECT_NEAR(sim2.blockingRate(in_area, Context{1}), 0.3, 1e-15);
  EXPECT_DOUBLE_EQ(sim2.blockingRate(in_area, Context{0}), 0.1);
  // The true distribution follows the context: at br 0 nobody is ever blocked or trapped.
  std::map<int, double> d = dist(sim, g.cellId(3, 1), kUp, Context{-1, 0.0});
  EXPECT_EQ(d.count(sim.trappedState()), 0u);
  EXPECT_NEAR(d[g.cellId(3, 2)], 0.9, 1e-12);
}

// trap probability given at 0.5 m cells, on 1 m cells: 1 - (1 - 0.2)^(1/0.5) = 0.36.
TEST(BlockageSimulator, TrapProbabilityScalesWithCellSize) {
  NavGrid g = testGrid();
  SimulatorConfig c = testConfig();
  c.trap_reference_cell_size = 0.5;
  BlockageSimulator sim(g, c);
  EXPECT_NEAR(sim.trapProbability(), 0.36, 1e-12);
}

TEST(BlockageSimulator, ConfigErrors) {
  NavGrid g = testGrid();
  SimulatorConfig c = testConfig();
  c.slip_stay = 0.1;  // sum 1.06
  try {
    BlockageSimulator s(g, c);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("move_success"), std::string::npos) << e.what();
  }
  c = testConfig();
  c.blocking_rate = 1.2;
  try {
    BlockageSimulator s(g, c);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("'blocking_rate': value 1.2"), std::string::npos)
        << e.what();
  }
  c = testConfig();
  c.areas["ba9"].rate = 0.5;
  c.source = "site/navigation.yaml";
  try {  // an override of an area the map lacks says which file and field to fix
    BlockageSimulator s(g, c);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("site/navigation.yaml: field 'simulator.areas.ba9': "
                                         "unknown blocking area 'ba9'"),
              std::string::npos)
        << e.what();
  }
  c = testConfig();
  c.areas["bz"].time_factor["midnight"] = 1.0;
  EXPECT_THROW(BlockageSimulator(g, c), ConfigError);
  c = testConfig();
  c.time_factors = {1.0};
  EXPECT_THROW(BlockageSimulator(g, c), ConfigError);
  BlockageSimulator ok(g, testConfig());
  EXPECT_THROW(ok.trueDistribution(-1, kUp, Context{}), UnknownSymbolError);
  EXPECT_THROW(ok.trueDistribution(0, 7, Context{}), UnknownSymbolError);
}

TEST(BlockageSimulator, StepDoesNotAllocateAndIgnoresBadInput) {
  NavGrid g = testGrid();
  BlockageSimulator sim(g, testConfig());
  Rng rng = makeRng(1, "alloc");
  const Context ctx{1};
  const long before = g_allocations.load();
  int cell = 0;
  for (int k = 0; k < 100000; ++k) {
    Outcome o = sim.step(cell, static_cast<int>(rng() % 4), ctx, rng);
    cell = o.trapped ? 0 : o.cell;
  }
  Outcome bad = sim.step(g.cellId(2, 0), kUp, ctx, rng);  // from an occupied cell
  Outcome bad_move = sim.step(0, 9, ctx, rng);
  EXPECT_EQ(g_allocations.load(), before);
  EXPECT_EQ(bad.cell, g.cellId(2, 0));
  EXPECT_EQ(bad_move.cell, 0);
  EXPECT_FALSE(bad.blocked || bad_move.blocked);
}

// runPolicy on column 0 (no blocking area): up the column, and back left after a lateral slip
// into column 1; failing to arrive within 200 moves has probability far below 1e-30. From
// column 2 (an occupied cell, no move defined) every episode times out.
TEST(BlockageSimulator, RunPolicyCounts) {
  NavGrid g = testGrid();
  SimulatorConfig c = testConfig();
  BlockageSimulator sim(g, c);
  std::vector<std::int8_t> policy(static_cast<size_t>(g.numCells()), -1);
  for (int r = 0; r < 5; ++r) {
    policy[static_cast<size_t>(g.cellId(0, r))] = kUp;
    policy[static_cast<size_t>(g.cellId(1, r))] = kLeft;
  }
  Rng rng = makeRng(3, "run");
  EpisodeStats st = runPolicy(sim, policy, g.cellId(0, 0), g.cellId(0, 4), 200, Context{}, 1000, rng);
  EXPECT_EQ(st.successes, 1000);
  EXPECT_GE(st.mean_steps_success, 4.0);
  st = runPolicy(sim, policy, g.cellId(2, 0), g.cellId(0, 4), 200, Context{}, 10, rng);
  EXPECT_EQ(st.timeouts, 10);
}

// on_entry mode: only a move from outside an area into it can be blocked. (2,4) -> (3,4) enters
// bz (rate 0.3); (3,1) -> (3,2) stays inside bz (rate 0: the distribution is the free-space
// one, 0.9 to the target); per_cell mode blocks both.
TEST(BlockageSimulator, OnEntryMode) {
  NavGrid g = testGrid();
  SimulatorConfig c = testConfig();
  c.blocking_mode = BlockingMode::kOnEntry;
  BlockageSimulator entry(g, c);
  BlockageSimulator per_cell(g, testConfig());
  EXPECT_DOUBLE_EQ(entry.moveBlockingRate(g.cellId(2, 4), g.cellId(3, 4), Context{}), 0.3);
  EXPECT_DOUBLE_EQ(entry.moveBlockingRate(g.cellId(3, 1), g.cellId(3, 2), Context{}), 0.0);
  EXPECT_DOUBLE_EQ(per_cell.moveBlockingRate(g.cellId(3, 1), g.cellId(3, 2), Context{}), 0.3);
  std::map<int, double> d = dist(entry, g.cellId(3, 1), kUp, Context{});
  EXPECT_EQ(d.count(entry.trappedState()), 0u);
  EXPECT_NEAR(d[g.cellId(3, 2)], 0.9, 1e-12);
  d = dist(entry, g.cellId(2, 4), kRight, Context{});
  EXPECT_NEAR(d[entry.trappedState()], 0.3 * 0.2, 1e-12);
  EXPECT_NEAR(d[g.cellId(3, 4)], 0.7 * 0.9, 1e-12);
}
