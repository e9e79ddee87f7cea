// Small navigation domains and paths shared by the delivery tests (not a test itself).
#pragma once

#include <unistd.h>

#include <memory>
#include <string>

#include "krr_core/common/files.h"
#include "krr_core/kb/nav_domain.h"
#include "krr_core/mdp/sparse_model.h"
#include "krr_core/nav/occupancy_grid.h"

namespace delivery_test {

inline std::string repo(const std::string& rel) {
  return std::string(KRR_TEST_DATA_DIR) + "/../../../../" + rel;
}
inline std::string data(const std::string& rel) {
  return std::string(KRR_TEST_DATA_DIR) + "/dialog/" + rel;
}

inline std::string tempDir(const char* tag) {
  std::string t = std::string("/tmp/krr_") + tag + "_XXXXXX";
  return ::mkdtemp(&t[0]);
}

/**
 * A 7 x 3 corridor of 1 m cells:
 *   row 2: room1 (0,2)                  blocking area ba1: columns 3..3, all rows
 *   row 1: shop (0,1) . . [ba1] . . room2 (6,1)
 *   row 0: free
 * room1 is one move from the shop and never blocked; room2 is six moves away across ba1.
 */
inline krr::kb::NavDomain corridor(int step_limit = 40,
                                   const krr::nav::SimulatorConfig& sim = krr::nav::SimulatorConfig()) {
  krr::nav::OccupancyGrid map;
  map.width = 7;
  map.height = 3;
  map.resolution = 1.0;
  map.data.assign(21, krr::nav::kFree);
  krr::nav::PlacesFile places;
  places.places.push_back({"shop", {0.5, 1.5}, false, {}});
  places.places.push_back({"room1", {0.5, 2.5}, false, {}});
  places.places.push_back({"room2", {6.5, 1.5}, false, {}});
  places.areas.push_back({"ba1", {3.0, 0.0, 4.0, 3.0}});
  krr::nav::NavGridOptions opt;
  opt.cols = 7;
  opt.rows = 3;
  krr::kb::NavDomain d;
  d.domain.name = "corridor";
  d.domain.step_limit = step_limit;
  d.config.simulator = sim;
  d.grid = std::make_shared<krr::nav::NavGrid>(krr::nav::NavGrid::fromMap(map, places, opt));
  d.space = std::make_shared<krr::kb::NavStateSpace>(*d.grid);
  d.simulator = std::make_shared<krr::nav::BlockageSimulator>(*d.grid, d.config.simulator);
  const std::string geometry = tempDir("delivery_geo") + "/geometry.plog";
  krr::writeFileAtomic(geometry, d.grid->toPlog("corridor"));
  d.knowledge_files = {geometry, repo("config/navigation.plog")};
  return d;
}

/// Moves always succeed, nothing slips: navigation outcomes depend only on blocking.
inline krr::nav::SimulatorConfig exactMoves() {
  krr::nav::SimulatorConfig s;
  s.move_success = 1.0;
  s.slip_stay = 0.0;
  s.slip_lateral = 0.0;
  return s;
}

/// 4 x 1 chain of 1 m cells: shop (cell 0), room1 (cell 1), room2 (cell 3).
inline krr::nav::NavGrid chain() {
  krr::nav::OccupancyGrid map;
  map.width = 4;
  map.height = 1;
  map.resolution = 1.0;
  map.data.assign(4, krr::nav::kFree);
  krr::nav::PlacesFile places;
  places.places.push_back({"shop", {0.5, 0.5}, false, {}});
  places.places.push_back({"room1", {1.5, 0.5}, false, {}});
  places.places.push_back({"room2", {3.5, 0.5}, false, {}});
  krr::nav::NavGridOptions opt;
  opt.cols = 4;
  opt.rows = 1;
  return krr::nav::NavGrid::fromMap(map, places, opt);
}

/// Every move along the chain arrives with probability p and traps the robot otherwise;
/// moves into a wall stay.
inline krr::mdp::SparseModel chainModel(const krr::kb::NavStateSpace& sp, double p) {
  krr::mdp::SparseModelBuilder b(sp.numStates(), 4, 0.95);
  for (krr::mdp::StateId s = 0; s < sp.trappedState(); ++s) {
    const int cell = sp.cellOf(s);
    for (int m = 0; m < 4; ++m) {
      const int to = sp.grid().neighbour(cell, m);
      if (to < 0) {
        b.addTransition(s, static_cast<krr::mdp::ActionId>(m), s, 1.0);
      } else {
        b.addTransition(s, static_cast<krr::mdp::ActionId>(m), sp.stateOf(to), p);
        b.addTransition(s, static_cast<krr::mdp::ActionId>(m), sp.trappedState(), 1.0 - p);
      }
    }
  }
  b.setTerminal(sp.trappedState());
  return b.build();
}

}  // namespace delivery_test
