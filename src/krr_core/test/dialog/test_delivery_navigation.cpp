// DeliveryNavigation: P^N, expected moves and trip costs against hand computation on a chain,
// trips driven in the simulator, option checks.
#include <gtest/gtest.h>

#include "krr_core/common/errors.h"
#include "krr_core/dialog/delivery_navigation.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/nav/occupancy_grid.h"
#include "delivery_test_support.h"

namespace {

using namespace krr;
using krr::dialog::DeliveryNavigation;
using krr::dialog::DeliveryNavigationOptions;
using delivery_test::chain;
using delivery_test::chainModel;

DeliveryNavigationOptions options() {
  DeliveryNavigationOptions o;
  o.rooms = {"room1", "room2"};
  o.step_limit = 10;
  o.failure_penalty = 40.0;
  return o;
}

TEST(DeliveryNavigation, ReachMovesAndCostsMatchHandComputation) {
  const nav::NavGrid grid = chain();
  const kb::NavStateSpace sp(grid);
  const DeliveryNavigation nav(sp, chainModel(sp, 0.9), options());
  ASSERT_EQ(nav.numRooms(), 2u);
  // shop -> room1: one move. shop -> room2: three moves, each arriving with 0.9.
  EXPECT_NEAR(nav.toRoom(0).reach, 0.9, 1e-12);
  EXPECT_NEAR(nav.toRoom(0).moves, 1.0, 1e-12);
  EXPECT_NEAR(nav.toRoom(0).cost, 1.0 + 40.0 * 0.1, 1e-9);
  EXPECT_NEAR(nav.toRoom(1).reach, 0.729, 1e-12);
  EXPECT_NEAR(nav.toRoom(1).moves, 1.0 + 0.9 + 0.81, 1e-12);  // moves made until trapped or there
  EXPECT_NEAR(nav.toRoom(1).cost, 2.71 + 40.0 * 0.271, 1e-9);
  EXPECT_NEAR(nav.toShop(0).reach, 0.9, 1e-12);
  EXPECT_NEAR(nav.toShop(1).reach, 0.729, 1e-12);
  EXPECT_NEAR(nav.reachFromShop()(1), 0.729, 1e-12);
  EXPECT_NEAR(nav.reachBack()(0), 0.9, 1e-12);
  // The policies drive along the chain.
  EXPECT_EQ(nav.policyToRoom(1)[sp.stateOf(grid.placeCell("shop"))], nav::kRight);
  EXPECT_EQ(nav.policyToShop()[sp.stateOf(grid.placeCell("room2"))], nav::kLeft);
  EXPECT_EQ(nav.roomIndex("room2"), 1u);
  EXPECT_THROW(nav.roomIndex("room9"), UnknownSymbolError);
}

TEST(DeliveryNavigation, StepLimitCutsTheTrip) {
  const nav::NavGrid grid = chain();
  const kb::NavStateSpace sp(grid);
  auto o = options();
  o.step_limit = 2;  // room2 is three moves away
  const DeliveryNavigation nav(sp, chainModel(sp, 0.9), o);
  EXPECT_NEAR(nav.toRoom(1).reach, 0.0, 1e-12);
  EXPECT_NEAR(nav.toRoom(1).moves, 1.0 + 0.9, 1e-12);
  EXPECT_NEAR(nav.toRoom(1).cost, 1.9 + 40.0, 1e-9);
}

TEST(DeliveryNavigation, ExecutesTripsInTheSimulator) {
  const nav::NavGrid grid = chain();
  const kb::NavStateSpace sp(grid);
  nav::SimulatorConfig exact;
  exact.move_success = 1.0;
  exact.slip_stay = 0.0;
  exact.slip_lateral = 0.0;
  const nav::BlockageSimulator sim(grid, exact);
  const DeliveryNavigation nav(sp, chainModel(sp, 0.9), options());
  Rng rng = makeRng(1, "trip");
  const dialog::TripResult out = nav.execute(sim, 1, true, nav::Context(), rng);
  EXPECT_TRUE(out.reached);
  EXPECT_FALSE(out.trapped);
  EXPECT_EQ(out.moves, 3u);
  const dialog::TripResult back = nav.execute(sim, 0, false, nav::Context(), rng);
  EXPECT_TRUE(back.reached);
  EXPECT_EQ(back.moves, 1u);

  auto o = options();
  o.step_limit = 2;
  const DeliveryNavigation shortNav(sp, chainModel(sp, 0.9), o);
  const dialog::TripResult cut = shortNav.execute(sim, 1, true, nav::Context(), rng);
  EXPECT_FALSE(cut.reached);
  EXPECT_FALSE(cut.trapped);
  EXPECT_EQ(cut.moves, 2u);
  EXPECT_THROW(nav.execute(sim, 5, true, nav::Context(), rng), ConfigError);
}

TEST(DeliveryNavigation, RejectsBadOptionsAndModels) {
  const nav::NavGrid grid = chain();
  const kb::NavStateSpace sp(grid);
  const mdp::SparseModel m = chainModel(sp, 0.9);
  auto expectBad = [&](DeliveryNavigationOptions o, const std::string& field) {
    try {
      DeliveryNavigation nav(sp, m, o);
      ADD_FAILURE() << "no error for " << field;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  auto o = options();
  o.rooms.clear();
  expectBad(o, "rooms");
  o = options();
  o.rooms = {"room1", "shop"};
  expectBad(o, "rooms");
  o = options();
  o.rooms = {"room1", "room1"};
  expectBad(o, "rooms");
  o = options();
  o.discount = 0.0;
  expectBad(o, "discount");
  o = options();
  o.step_limit = 0;
  expectBad(o, "step_limit");
  o = options();
  o.failure_penalty = -1;
  expectBad(o, "failure_penalty");
  o = options();
  o.rooms = {"room7"};
  EXPECT_THROW(DeliveryNavigation(sp, m, o), UnknownSymbolError);
  mdp::SparseModelBuilder small(3, 4, 0.9);
  small.setTerminal(0);
  small.setTerminal(1);
  small.setTerminal(2);
  EXPECT_THROW(DeliveryNavigation(sp, small.build(), options()), ConfigError);
}

}  // namespace
