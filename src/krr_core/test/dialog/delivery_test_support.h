// Small navigation domains and paths shared by the delivery tests (not a test itself).
#pragma once

#include <unistd.h>

#include <memory>
#include <string>

#include "../support/nav_fixtures.h"
#include "krr_core/mdp/sparse_model.h"

namespace delivery_test {

inline std::string repo(const std::string& rel) { return krr_test::repoPath(rel); }
inline std::string data(const std::string& rel) {
  return std::string(KRR_TEST_DATA_DIR) + "/dialog/" + rel;
}

inline std::string tempDir(const char* tag) { return krr_test::tempDir(tag); }

/**
 * A 7 x 3 corridor of 1 m cells:
 *   row 2: room1 (0,2)                  blocking area ba1: columns 3..3, all rows
 *   row 1: shop (0,1) . . [ba1] . . room2 (6,1)
 *   row 0: free
 * room1 is one move from the shop and never blocked; room2 is six moves away across ba1.
 */
inline krr::kb::NavDomain corridor(int step_limit = 40,
                                   const krr::nav::SimulatorConfig& sim = krr::nav::SimulatorConfig()) {
  using krr_test::place;
  return krr_test::makeNavDomain(
      krr_test::makeGrid(7, 3, krr_test::places({place("shop", 0, 1), place("room1", 0, 2),
                                                 place("room2", 6, 1)},
                                                {{"ba1", {3.0, 0.0, 4.0, 3.0}}})),
      "corridor", step_limit, sim);
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
  using krr_test::place;
  return krr_test::makeGrid(
      4, 1, krr_test::places({place("shop", 0, 0), place("room1", 1, 0), place("room2", 3, 0)}));
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
