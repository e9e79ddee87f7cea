#include "krr_core/kb/area_knowledge.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/nav/nav_grid.h"

namespace krr {
namespace kb {

namespace {

/// The two moves perpendicular to `move` (nav::Move order: up, down, left, right).
void lateralMoves(int move, int* a, int* b) {
  if (move == nav::kUp || move == nav::kDown) {
    *a = nav::kLeft;
    *b = nav::kRight;
  } else {
    *a = nav::kUp;
    *b = nav::kDown;
  }
}

/// Index of the first blocking area containing `cell`, -1 if none.
int areaOf(const nav::NavGrid& grid, int cell) {
  const std::uint32_t mask = grid.areaMask(cell);
  for (int a = 0; a < 32; ++a)
    if (mask & (1u << a)) return a;
  return -1;
}

/// Counts of moves into one area, the stays split by the number of lateral neighbours (the
/// free stay probability depends on it).
struct AreaCounts {
  std::uint64_t n = 0, trapped = 0, moved = 0;
  std::uint64_t stays[3] = {0, 0, 0}, movesByLaterals[3] = {0, 0, 0};
};

std::string fraction(double p) {
  const long k = std::lround(std::clamp(p, 0.0, 1.0) * 1e6);
  if (k == 0) return "0";
  if (k == 1000000) return "1";
  return std::to_string(k) + "/1000000";
}

}  // namespace

AreaKnowledge estimateAreaKnowledge(const mdp::VisitCounts& counts, const NavStateSpace& space,
                                    const std::string& time) {
  if (counts.getS() != space.numStates() || counts.getA() != space.numActions())
    throw ConfigError("area knowledge: visit counts over " + std::to_string(counts.getS()) +
                      " states, the navigation space has " + std::to_string(space.numStates()));
  const nav::NavGrid& grid = space.grid();
  const std::size_t numAreas = grid.areas().size();
  std::vector<AreaCounts> area(numAreas);
  std::uint64_t freeN = 0, freeTarget = 0, freeLateral = 0, lateralExposure = 0;
  std::uint64_t wallN = 0, wallStay = 0;
  const mdp::StateId trapped = space.trappedState();
  for (mdp::StateId s = 0; s < trapped; ++s) {
    const int cell = space.cellOf(s);
    for (int m = 0; m < 4; ++m) {
      const auto a = static_cast<mdp::ActionId>(m);
      if (counts.count(s, a) == 0) continue;
      const int target = grid.neighbour(cell, m);
      if (target < 0) {
        wallN += counts.count(s, a);
        wallStay += counts.count(s, a, s);
        continue;
      }
      int la = 0, lb = 0;
      lateralMoves(m, &la, &lb);
      const int sideA = grid.neighbour(cell, la), sideB = grid.neighbour(cell, lb);
      const int laterals = (sideA >= 0) + (sideB >= 0);
      const mdp::StateId t = space.stateOf(target);
      const std::uint64_t n = counts.count(s, a), nTarget = counts.count(s, a, t);
      std::uint64_t nLateral = 0;
      if (sideA >= 0) nLateral += counts.count(s, a, space.stateOf(sideA));
      if (sideB >= 0) nLateral += counts.count(s, a, space.stateOf(sideB));
      const int ar = areaOf(grid, target);
      if (ar < 0) {
        freeN += n;
        freeTarget += nTarget;
        freeLateral += nLateral;
        lateralExposure += n * static_cast<std::uint64_t>(laterals);
        continue;
      }
      AreaCounts& c = area[static_cast<std::size_t>(ar)];
      c.n += n;
      c.trapped += counts.count(s, a, trapped);
      c.moved += nTarget + nLateral;
      c.stays[laterals] += counts.count(s, a, s);
      c.movesByLaterals[laterals] += n;
    }
  }
  if (freeN == 0)
    throw ConfigError("area knowledge: no move outside the blocking areas was seen at time " +
                      time + ", so the move noise cannot be estimated");
  AreaKnowledge k;
  k.time = time;
  k.noise.moves = freeN;
  k.noise.success = static_cast<double>(freeTarget) / static_cast<double>(freeN);
  k.noise.lateral = lateralExposure ? static_cast<double>(freeLateral) / lateralExposure : 0.0;
  k.noise.wall_moves = wallN;
  k.noise.wall_stay = wallN ? static_cast<double>(wallStay) / static_cast<double>(wallN) : 1.0;
  // A cell has up to two lateral neighbours: keep success + 2 * lateral <= 1 (pooled counts from
  // cells with one lateral neighbour could otherwise overshoot) and round on the written grid so
  // the reasoner sees the very numbers it checks for coherence.
  {
    const long sk = std::lround(std::clamp(k.noise.success, 0.0, 1.0) * 1e6);
    const long lk = std::min(std::lround(std::clamp(k.noise.lateral, 0.0, 1.0) * 1e6),
                             (1000000 - sk) / 2);
    k.noise.success = static_cast<double>(sk) / 1e6;
    k.noise.lateral = static_cast<double>(lk) / 1e6;
  }
  const double s = k.noise.success, l = k.noise.lateral;
  for (std::size_t a = 0; a < numAreas; ++a) {
    const AreaCounts& c = area[a];
    if (c.n == 0) continue;
    AreaEstimate e;
    e.area = grid.areas()[a].name;
    e.moves = c.n;
    e.trapped = c.trapped;
    // P(stay | not blocked) for a move with k lateral neighbours.
    double freeStay[3];
    for (int j = 0; j < 3; ++j) freeStay[j] = std::max(0.0, 1.0 - s - l * j);
    // EM over the latent "blocked" of the stays: start from blocked = trapped + all stays.
    double stays = 0.0;
    for (int j = 0; j < 3; ++j) stays += static_cast<double>(c.stays[j]);
    double b = std::min(1.0, (static_cast<double>(c.trapped) + stays) / static_cast<double>(c.n));
    double t = b > 0 ? static_cast<double>(c.trapped) / (b * static_cast<double>(c.n)) : 0.0;
    for (int it = 0; it < 500; ++it) {
      double blockedStays = 0.0;
      for (int j = 0; j < 3; ++j) {
        if (c.stays[j] == 0) continue;
        const double pb = b * (1.0 - t), pf = (1.0 - b) * freeStay[j];
        blockedStays += pb + pf > 0 ? static_cast<double>(c.stays[j]) * pb / (pb + pf) : 0.0;
      }
      const double blocked = static_cast<double>(c.trapped) + blockedStays;
      const double nb = blocked / static_cast<double>(c.n);
      const double nt = blocked > 0 ? static_cast<double>(c.trapped) / blocked : 0.0;
      const bool done = std::fabs(nb - b) < 1e-12 && std::fabs(nt - t) < 1e-12;
      b = nb;
      t = nt;
      if (done) break;
    }
    e.blocking = b;
    e.trap = t;
    k.areas.push_back(e);
  }
  return k;
}

std::string areaKnowledgeText(const AreaKnowledge& k) {
  std::ostringstream o;
  const std::string& T = k.time;
  o << "% Learned at time " << T << ", pooled over the cells of each blocking area (" << k.noise.moves
    << " free moves, " << k.noise.wall_moves << " moves into walls).\n";
  const std::string cond = "not blocked(C, M), curr_time=" + T + ", not learned(C, M, " + T + ")";
  o << "pr(next_cell=C1 | curr_cell=C, act_move=M, target(C, M, C1), " << cond
    << ") = " << fraction(k.noise.success) << ".\n";
  // Slips happen only on moves that have a target (into a wall the robot stays).
  o << "pr(next_cell=C1 | curr_cell=C, act_move=M, has_target(C, M), lateral(C, M, C1), " << cond
    << ") = " << fraction(k.noise.lateral) << ".\n";
  o << "pr(next_cell=C1 | curr_cell=C, act_move=M, has_target(C, M), behind(C, M, C1), " << cond
    << ") = 0.\n";
  o << "pr(next_cell=C | curr_cell=C, act_move=M, not has_target(C, M), " << cond
    << ") = " << fraction(k.noise.wall_stay) << ".\n";
  o << "learned_noise(" << T << ").\n";
  for (const AreaEstimate& e : k.areas) {
    o << "% " << e.area << ": " << e.moves << " moves into it, " << e.trapped << " trapped.\n";
    o << "pr(walkers(" << e.area << ")=true | curr_time=" << T << ") = " << fraction(e.blocking)
      << ".\n";
    const std::string bc = "curr_cell=C, act_move=M, blocked_in(C, M, " + e.area + "), curr_time=" +
                           T + ", not learned(C, M, " + T + ")";
    // Exact complements: the two outcomes of a blocked move sum to 1.
    const long trap = std::lround(std::clamp(e.trap, 0.0, 1.0) * 1e6);
    o << "pr(next_cell=trapped | " << bc << ") = " << trap << "/1000000.\n";
    o << "pr(next_cell=C | " << bc << ") = " << 1000000 - trap << "/1000000.\n";
    o << "learned_area(" << e.area << ", " << T << ").\n";
  }
  return o.str();
}

}  // namespace kb
}  // namespace krr
