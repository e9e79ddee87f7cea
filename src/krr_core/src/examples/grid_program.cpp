#include "krr_core/examples/grid_program.h"

#include <set>
#include <sstream>

#include "krr_core/common/errors.h"

namespace krr {
namespace examples {

namespace {
std::string num(double v) {
  std::ostringstream os;
  os.precision(12);
  os << v;
  std::string s = os.str();
  if (s.find('.') == std::string::npos && s.find('e') == std::string::npos) s += ".0";
  return s;
}
}  // namespace

std::string makeGridNavigationProgram(const GridNavigationSpec& s) {
  if (s.width <= 0 || s.height <= 0)
    throw ConfigError("grid program: width and height must be positive (got " +
                      std::to_string(s.width) + "x" + std::to_string(s.height) + ")");
  std::set<int> walls;
  for (const auto& w : s.walls) walls.insert(gridCell(s, w.first, w.second));
  auto free = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < s.width && y < s.height && !walls.count(gridCell(s, x, y));
  };
  std::ostringstream os;
  os << "% grid navigation program " << s.width << "x" << s.height << " (generated)\n";
  if (walls.empty()) {
    os << "cell = {0.." << s.width * s.height - 1 << "}.\n";
  } else {
    os << "cell = {";
    bool first = true;
    for (int y = 0; y < s.height; ++y)
      for (int x = 0; x < s.width; ++x)
        if (free(x, y)) {
          os << (first ? "" : ", ") << gridCell(s, x, y);
          first = false;
        }
    os << "}.\n";
  }
  os << "move = {up, down, left, right}.\n";
  os << "time = {morning, noon, afternoon}.\n";
  if (!s.areas.empty()) {
    os << "area = {";
    for (size_t i = 0; i < s.areas.size(); ++i) os << (i ? ", " : "") << s.areas[i].name;
    os << "}.\n";
  }
  os << "#domain cell(C;C1).\n";
  os << "curr_cell : cell.\nnext_cell : cell.\nact_move : move.\ncurr_time : time.\n";
  os << "leftof : cell, cell -> boolean.\nbelowof : cell, cell -> boolean.\n";
  os << "reachable : cell, cell -> boolean.\nblocked : boolean.\n";
  if (!s.areas.empty()) {
    os << "walkers : area -> boolean.\n";
    os << "in_area : cell, area -> boolean.\n";
  }
  // geometry
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x) {
      if (!free(x, y)) continue;
      if (free(x + 1, y)) os << "leftof(" << gridCell(s, x, y) << "," << gridCell(s, x + 1, y) << ").\n";
      if (free(x, y + 1)) os << "belowof(" << gridCell(s, x, y) << "," << gridCell(s, x, y + 1) << ").\n";
    }
  std::set<int> in_some_area;
  for (const auto& a : s.areas)
    for (int y = a.y0; y <= a.y1; ++y)
      for (int x = a.x0; x <= a.x1; ++x) {
        if (!free(x, y)) continue;
        if (!in_some_area.insert(gridCell(s, x, y)).second)
          throw ConfigError("grid program: blocking areas overlap at cell (" + std::to_string(x) +
                            "," + std::to_string(y) + ")");
        os << "in_area(" << gridCell(s, x, y) << "," << a.name << ").\n";
      }
  os << "reachable(C,C).\n"
        "reachable(C,C1) :- leftof(C,C1).\n"
        "reachable(C,C1) :- leftof(C1,C).\n"
        "reachable(C,C1) :- belowof(C,C1).\n"
        "reachable(C,C1) :- belowof(C1,C).\n";
  // random attributes
  os << "random(curr_cell).\nrandom(act_move).\nrandom(curr_time).\n";
  if (!s.areas.empty()) os << "random(walkers(A)).\n";
  os << "random(next_cell : {C1 : reachable(C,C1)}) :- curr_cell = C.\n";
  // exogenous priors
  os << "pr(curr_time = morning) = " << num(s.p_morning) << ".\n";
  os << "pr(curr_time = noon) = " << num(s.p_noon) << ".\n";
  for (const auto& a : s.areas)
    os << "pr(walkers(" << a.name << ") = true) = " << num(a.walkers_probability) << ".\n";
  // blocking
  if (!s.areas.empty()) {
    os << "blocked :- curr_cell = C, in_area(C,A), walkers(A) = true.\n";
    for (const auto& a : s.areas)
      os << "pr(next_cell = C | curr_cell = C, in_area(C," << a.name << "), walkers(" << a.name
         << ") = true) = " << num(a.blocking_rate) << ".\n";
  }
  // moves
  struct Mv {
    const char* name;
    const char* rel;
  } moves[] = {{"right", "leftof(C,C1)"},
               {"left", "leftof(C1,C)"},
               {"up", "belowof(C,C1)"},
               {"down", "belowof(C1,C)"}};
  std::pair<const char*, double> times[] = {
      {"morning", s.success_morning}, {"noon", s.success_noon}, {"afternoon", s.success_afternoon}};
  for (const auto& m : moves)
    for (const auto& t : times)
      os << "pr(next_cell = C1 | curr_cell = C, " << m.rel << ", act_move = " << m.name
         << ", curr_time = " << t.first << ", not blocked) = " << num(t.second) << ".\n";
  return os.str();
}

}  // namespace examples
}  // namespace krr
