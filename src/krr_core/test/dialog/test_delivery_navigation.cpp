// DeliveryNavigation: P^N, expected moves and trip costs against hand computation on a chain,
// trips driven in the simulator, option checks.
#include <gtest/gtest.h>

#include <cmath>

#include "krr_core/common/errors.h"
#include "krr_core/dialog/delivery_navigation.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/nav/occupancy_grid.h"
#include "delivery_test_support.h"

namespace {

using namespace krr;
using krr::dialog::DeliveryNavigation;
using krr::dialog::DeliveryNavigationOptions;
using krr::dialog::TripTable;
using delivery_test::chain;
using delivery_test::chainModel;

DeliveryNavigationOptions options() {
  DeliveryNavigationOptions o;
  o.shop = "shop";  // the test grids' place names
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
  // The trip table the dialog model is built from carries the same figures.
  const TripTable trips = nav.trips();
  EXPECT_EQ(trips.rooms, (std::vector<std::string>{"room1", "room2"}));
  ASSERT_EQ(trips.to_room.size(), 2u);
  ASSERT_EQ(trips.to_shop.size(), 2u);
  ASSERT_EQ(trips.reachFromShop().size(), 2);
  ASSERT_EQ(trips.reachBack().size(), 2);
  EXPECT_NEAR(trips.reachFromShop()(0), 0.9, 1e-12);
  EXPECT_NEAR(trips.reachFromShop()(1), 0.729, 1e-12);
  EXPECT_NEAR(trips.reachBack()(0), 0.9, 1e-12);
  EXPECT_NEAR(trips.reachBack()(1), 0.729, 1e-12);
  for (std::size_t r = 0; r < 2; ++r) {
    EXPECT_DOUBLE_EQ(trips.to_room[r].reach, nav.toRoom(r).reach);
    EXPECT_DOUBLE_EQ(trips.to_room[r].moves, nav.toRoom(r).moves);
    EXPECT_DOUBLE_EQ(trips.to_room[r].cost, nav.toRoom(r).cost);
    EXPECT_DOUBLE_EQ(trips.to_shop[r].reach, nav.toShop(r).reach);
    EXPECT_DOUBLE_EQ(trips.to_shop[r].moves, nav.toShop(r).moves);
    EXPECT_DOUBLE_EQ(trips.to_shop[r].cost, nav.toShop(r).cost);
  }
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

TEST(TripTable, FromReachProbabilities) {
  const TripTable t = TripTable::fromReach({"room1", "room2"}, {0.9, 0.5}, {0.8, 1.0}, 40.0);
  EXPECT_EQ(t.rooms, (std::vector<std::string>{"room1", "room2"}));
  ASSERT_EQ(t.to_room.size(), 2u);
  ASSERT_EQ(t.to_shop.size(), 2u);
  EXPECT_DOUBLE_EQ(t.to_room[0].reach, 0.9);
  EXPECT_DOUBLE_EQ(t.to_room[1].reach, 0.5);
  EXPECT_DOUBLE_EQ(t.to_shop[0].reach, 0.8);
  EXPECT_DOUBLE_EQ(t.to_shop[1].reach, 1.0);
  // Moves are unknown without a navigation model; cost = failure_penalty (1 - P^N).
  for (std::size_t r = 0; r < 2; ++r) {
    EXPECT_EQ(t.to_room[r].moves, 0.0);
    EXPECT_EQ(t.to_shop[r].moves, 0.0);
  }
  EXPECT_NEAR(t.to_room[0].cost, 40.0 * 0.1, 1e-12);
  EXPECT_NEAR(t.to_room[1].cost, 40.0 * 0.5, 1e-12);
  EXPECT_NEAR(t.to_shop[0].cost, 40.0 * 0.2, 1e-12);
  EXPECT_DOUBLE_EQ(t.to_shop[1].cost, 0.0);
  EXPECT_TRUE(t.reachFromShop().isApprox(Eigen::Vector2d(0.9, 0.5)));
  EXPECT_TRUE(t.reachBack().isApprox(Eigen::Vector2d(0.8, 1.0)));

  // Without P^N(room, shop) the way back is as hard as the way there.
  const TripTable same = TripTable::fromReach({"room1", "room2"}, {0.9, 0.5}, {}, 10.0);
  EXPECT_DOUBLE_EQ(same.to_shop[1].reach, 0.5);
  EXPECT_NEAR(same.to_shop[1].cost, 10.0 * 0.5, 1e-12);
  EXPECT_TRUE(same.reachBack().isApprox(same.reachFromShop()));
  // No penalty: every trip is free.
  const TripTable free = TripTable::fromReach({"room1"}, {0.3}, {}, 0.0);
  EXPECT_EQ(free.to_room[0].cost, 0.0);

  // Sizes, probabilities and the penalty are checked.
  EXPECT_THROW(TripTable::fromReach({"room1", "room2"}, {0.9}, {}, 40.0), ConfigError);
  EXPECT_THROW(TripTable::fromReach({"room1"}, {0.9, 0.5}, {}, 40.0), ConfigError);
  EXPECT_THROW(TripTable::fromReach({"room1", "room2"}, {0.9, 0.5}, {0.8}, 40.0), ConfigError);
  EXPECT_THROW(TripTable::fromReach({"room1", "room2"}, {0.9, 1.5}, {}, 40.0), ConfigError);
  EXPECT_THROW(TripTable::fromReach({"room1", "room2"}, {-0.1, 0.5}, {}, 40.0), ConfigError);
  EXPECT_THROW(TripTable::fromReach({"room1", "room2"}, {0.9, 0.5}, {0.8, 1.01}, 40.0), ConfigError);
  EXPECT_THROW(TripTable::fromReach({"room1"}, {std::nan("")}, {}, 40.0), ConfigError);
  EXPECT_THROW(TripTable::fromReach({"room1"}, {0.9}, {}, -1.0), ConfigError);
  try {
    TripTable::fromReach({"room1", "room2"}, {0.9, 2.0}, {}, 40.0);
    ADD_FAILURE() << "accepted P^N = 2";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("room2"), std::string::npos) << e.what();
  }
}

TEST(DeliveryNavigation, OptionsFromTheDialogConfig) {
  dialog::DialogConfig c;
  c.shop = "shop";
  c.step_cost = 2.0;
  c.rmax = 50.0;
  c.nav_discount = 0.9;
  c.failure_penalty = 25.0;
  const DeliveryNavigationOptions o = DeliveryNavigationOptions::fromConfig(c, {"room1", "room2"}, 17);
  EXPECT_EQ(o.shop, "shop");
  EXPECT_EQ(o.rooms, (std::vector<std::string>{"room1", "room2"}));
  EXPECT_DOUBLE_EQ(o.reward.step_cost, 2.0);
  EXPECT_DOUBLE_EQ(o.reward.rmax, 50.0);
  EXPECT_DOUBLE_EQ(o.discount, 0.9);
  EXPECT_EQ(o.step_limit, 17u);
  EXPECT_DOUBLE_EQ(o.failure_penalty, 25.0);
  EXPECT_NO_THROW(o.validate());

  // From the knowledge base of a small domain: the room next to the shop is reached in one
  // move, the room across the blocking area needs six.
  const kb::NavDomain d = delivery_test::corridor(40);
  kb::NavigationKnowledge knowledge(*d.grid, d.knowledge_files);
  dialog::DialogConfig config;
  config.shop = "shop";
  const auto nav = dialog::deliveryNavigationFromKnowledge(d, knowledge, config,
                                                           {"room1", "room2"});
  ASSERT_EQ(nav->numRooms(), 2u);
  EXPECT_EQ(nav->options().step_limit, 40u);
  EXPECT_GT(nav->toRoom(0).reach, nav->toRoom(1).reach);
  EXPECT_GT(nav->toRoom(1).moves, nav->toRoom(0).moves);
  EXPECT_THROW(dialog::deliveryNavigationFromKnowledge(d, knowledge, config,
                                                       {"room1", "room9"}),
               UnknownSymbolError);
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
