#include "krr_core/site/floor_plan.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"

namespace krr {
namespace site {

namespace {

constexpr double kResolution = 0.05;  // metres per pixel, as the bundled maps
constexpr double kMaxSide = 500.0;    // metres: 10,000 px a side

int px(double metres) { return static_cast<int>(std::lround(metres / kResolution)); }

/// @brief One statement: its words and where it starts, for errors.
struct Line {
  std::vector<std::string> words;
  SourceLocation at;
};

/// @brief A room as drawn: its place and its door spans.
struct Room {
  nav::Place place;
  double door0 = 0, door1 = 0;
  bool has_door = false;
  SourceLocation at;
};

class Drawer {
 public:
  explicit Drawer(std::string name) : name_(std::move(name)) {}

  FloorPlan draw(const std::string& text);

 private:
  [[noreturn]] void fail(const Line& l, const std::string& message) const {
    throw ParseError(l.at, message);
  }
  double number(const Line& l, std::size_t i) const;
  nav::Rect rect(const Line& l, std::size_t first) const;
  void statement(const Line& l);
  void room(const Line& l);
  void fill(const nav::Rect& r, std::int8_t v);
  void wall(bool horizontal, double at, double from, double to, double gap0, double gap1);
  void walls(const Room& r);

  std::string name_;
  bool sized_ = false;
  double width_ = 0, height_ = 0;
  std::vector<nav::Rect> corridors_;
  std::vector<Room> rooms_;
  FloorPlan plan_;
  std::set<std::string> names_;
};

double Drawer::number(const Line& l, std::size_t i) const {
  if (i >= l.words.size())
    fail(l, "'" + l.words[0] + "': a number is missing (" + std::to_string(i) + " words given)");
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(l.words[i], &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != l.words[i].size() || !std::isfinite(v))
    fail(l, "'" + l.words[i] + "' is not a number");
  return v;
}

nav::Rect Drawer::rect(const Line& l, std::size_t first) const {
  const nav::Rect r{number(l, first), number(l, first + 1), number(l, first + 2),
                    number(l, first + 3)};
  std::ostringstream m;
  m << "rectangle [" << r.x0 << ", " << r.y0 << ", " << r.x1 << ", " << r.y1 << "] ";
  if (!(r.x0 < r.x1 && r.y0 < r.y1)) fail(l, m.str() + "must have x0 < x1 and y0 < y1");
  if (r.x0 < 0 || r.y0 < 0 || r.x1 > width_ + 1e-9 || r.y1 > height_ + 1e-9) {
    m << "leaves the map [0, " << width_ << "] x [0, " << height_ << "]";
    fail(l, m.str());
  }
  return r;
}

void Drawer::room(const Line& l) {
  if (l.words.size() < 6) fail(l, "room NAME X0 Y0 X1 Y1 [door A B] [at X Y]");
  Room r;
  r.at = l.at;
  r.place.name = l.words[1];
  r.place.has_room = true;
  r.place.room = rect(l, 2);
  const nav::Rect& b = r.place.room;
  r.place.point = {(b.x0 + b.x1) / 2, (b.y0 + b.y1) / 2};
  for (std::size_t i = 6; i < l.words.size(); i += 3) {
    if (l.words[i] == "door") {
      r.door0 = number(l, i + 1);
      r.door1 = number(l, i + 2);
      r.has_door = true;
      if (!(r.door0 < r.door1)) fail(l, "door " + l.words[i + 1] + " " + l.words[i + 2] +
                                            ": the span must have A < B");
    } else if (l.words[i] == "at") {
      r.place.point = {number(l, i + 1), number(l, i + 2)};
      if (!r.place.room.contains(r.place.point))
        fail(l, "at " + l.words[i + 1] + " " + l.words[i + 2] + ": the point is outside the room");
    } else {
      fail(l, "'" + l.words[i] + "': expected 'door A B' or 'at X Y'");
    }
  }
  rooms_.push_back(r);
}

void Drawer::statement(const Line& l) {
  const std::string& w = l.words[0];
  if (w == "size") {
    if (sized_) fail(l, "'size' given twice");
    if (l.words.size() != 3) fail(l, "size WIDTH HEIGHT (metres)");
    width_ = number(l, 1);
    height_ = number(l, 2);
    if (!(width_ > 0 && height_ > 0 && width_ <= kMaxSide && height_ <= kMaxSide))
      fail(l, "size must be positive and at most " + std::to_string(kMaxSide) + " m a side");
    sized_ = true;
    return;
  }
  if (!sized_) fail(l, "'" + w + "' before 'size WIDTH HEIGHT' (the first statement)");
  if (w == "corridor") {
    if (l.words.size() != 5) fail(l, "corridor X0 Y0 X1 Y1");
    corridors_.push_back(rect(l, 1));
  } else if (w == "room") {
    room(l);
  } else if (w == "area") {
    if (l.words.size() != 6) fail(l, "area NAME X0 Y0 X1 Y1");
    plan_.places.areas.push_back({l.words[1], rect(l, 2)});
  } else {
    fail(l, "unknown statement '" + w + "' (size, corridor, room, area)");
  }
  if ((w == "room" || w == "area") && !names_.insert(l.words[1]).second)
    fail(l, "'" + l.words[1] + "' is named twice");
}

void Drawer::fill(const nav::Rect& r, std::int8_t v) {
  nav::OccupancyGrid& g = plan_.grid;
  for (int j = std::max(0, px(r.y0)); j < std::min(g.height, px(r.y1)); ++j)
    for (int i = std::max(0, px(r.x0)); i < std::min(g.width, px(r.x1)); ++i)
      g.data[static_cast<std::size_t>(g.index(i, j))] = v;
}

void Drawer::wall(bool horizontal, double at, double from, double to, double gap0, double gap1) {
  nav::OccupancyGrid& g = plan_.grid;
  for (int k = px(from) - 1; k < px(to) + 1; ++k) {
    if (k >= px(gap0) && k < px(gap1)) continue;
    for (int d = px(at) - 1; d <= px(at); ++d) {
      const int i = horizontal ? k : d, j = horizontal ? d : k;
      if (g.inBounds(i, j)) g.data[static_cast<std::size_t>(g.index(i, j))] = nav::kOccupied;
    }
  }
}

void Drawer::walls(const Room& r) {
  const nav::Rect& b = r.place.room;
  bool door_placed = false;
  // Each edge: horizontal?, its line, its extent; a corridor across it shares it.
  const struct { bool horizontal; double at, from, to; } edges[4] = {
      {true, b.y0, b.x0, b.x1}, {true, b.y1, b.x0, b.x1},
      {false, b.x0, b.y0, b.y1}, {false, b.x1, b.y0, b.y1}};
  for (const auto& e : edges) {
    bool shared = false;
    for (const nav::Rect& c : corridors_) {
      const double c_lo = e.horizontal ? c.y0 : c.x0, c_hi = e.horizontal ? c.y1 : c.x1;
      const double c_from = e.horizontal ? c.x0 : c.y0, c_to = e.horizontal ? c.x1 : c.y1;
      const bool touches = std::abs(c_lo - e.at) < 1e-9 || std::abs(c_hi - e.at) < 1e-9;
      if (touches && c_from <= r.door0 + 1e-9 && r.door1 <= c_to + 1e-9) shared = true;
    }
    const bool door = r.has_door && shared && e.from <= r.door0 + 1e-9 && r.door1 <= e.to + 1e-9;
    door_placed = door_placed || door;
    wall(e.horizontal, e.at, e.from, e.to, door ? r.door0 : 0, door ? r.door1 : 0);
  }
  if (r.has_door && !door_placed) {
    std::ostringstream m;
    m << "room " << r.place.name << ": door [" << r.door0 << ", " << r.door1
      << ") lies on no edge the room shares with a corridor";
    throw ParseError(r.at, m.str());
  }
}

FloorPlan Drawer::draw(const std::string& text) {
  std::istringstream in(text);
  int number = 0;
  for (std::string raw; std::getline(in, raw);) {
    ++number;
    Line l;
    l.at = SourceLocation{name_, number, 1};
    std::istringstream words(raw.substr(0, raw.find('#')));
    for (std::string w; words >> w;) l.words.push_back(w);
    if (!l.words.empty()) statement(l);
  }
  if (!sized_) throw ParseError(SourceLocation{name_, number + 1, 1}, "no 'size WIDTH HEIGHT'");
  if (rooms_.empty())
    throw ParseError(SourceLocation{name_, number + 1, 1}, "no room (room NAME X0 Y0 X1 Y1 ...)");
  nav::OccupancyGrid& g = plan_.grid;
  g.width = px(width_);
  g.height = px(height_);
  g.resolution = kResolution;
  g.data.assign(static_cast<std::size_t>(g.width) * static_cast<std::size_t>(g.height),
                nav::kOccupied);
  for (const nav::Rect& c : corridors_) fill(c, nav::kFree);
  for (const Room& r : rooms_) fill(r.place.room, nav::kFree);
  for (const Room& r : rooms_) {
    walls(r);
    plan_.places.places.push_back(r.place);
  }
  return plan_;
}

}  // namespace

FloorPlan parseFloorPlan(const std::string& text, const std::string& name) {
  return Drawer(name).draw(text);
}

FloorPlan loadFloorPlan(const std::string& path) { return parseFloorPlan(readFile(path), path); }

}  // namespace site
}  // namespace krr
