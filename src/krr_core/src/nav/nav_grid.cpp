#include "krr_core/nav/nav_grid.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/limits.h"
#include "krr_core/common/yaml_section.h"

namespace krr {
namespace nav {

const char* moveName(int move) {
  static const char* names[] = {"up", "down", "left", "right"};
  return move >= 0 && move < kNumMoves ? names[move] : "?";
}

namespace {

std::string dump(const YAML::Node& n) {
  std::string s = YAML::Dump(n);
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}

/// @brief The rectangle [x0, y0, x1, y1] under `key`, with x1 > x0 and y1 > y0.
Rect rectFrom(const YamlSection& s, const std::string& key) {
  const std::vector<double> v = s.requiredNumbers(key, 4, "[x0, y0, x1, y1]");
  const Rect r{v[0], v[1], v[2], v[3]};
  if (!(r.x1 > r.x0 && r.y1 > r.y0)) s.fail(key, "must be [x0, y0, x1, y1] with x1>x0, y1>y0");
  return r;
}

bool validName(const std::string& s) {
  if (s.empty() || !std::islower(static_cast<unsigned char>(s[0]))) return false;
  for (char c : s) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
  }
  return true;
}

std::string fmt(double v) {
  std::ostringstream o;
  o.precision(10);
  o << v;
  return o.str();
}

}  // namespace

namespace {

PlacesFile loadPlacesImpl(const std::string& path) {
  YAML::Node root = loadYamlMapFile(path, "places file");
  if (!root.IsMap()) throw MapError(path + ": broken YAML: top level is not a mapping");
  using Format = YamlSection::Format;
  const YamlSection top(root, path, "", {"places", "blocking_areas"}, Format::kMap);
  PlacesFile pf;
  std::set<std::string> names;
  if (!top.has("places")) throw MapError(path + ": missing field 'places'");
  const YAML::Node places = top.get("places");
  if (!places.IsMap()) throw MapError(path + ": field 'places' must be a mapping name -> place");
  for (auto it = places.begin(); it != places.end(); ++it) {
    Place p;
    p.name = it->first.as<std::string>();
    const std::string field = "places." + p.name, where = path + ": " + field;
    if (!validName(p.name)) throw MapError(where + ": bad name (lower-case identifier expected)");
    if (!names.insert(p.name).second) throw MapError(where + ": duplicate name");
    if (!it->second.IsMap()) throw MapError(where + ": must be a mapping with 'point'");
    const YamlSection s(it->second, path, field, {"point", "room"}, Format::kMap);
    const std::vector<double> pt = s.requiredNumbers("point", 2, "[x, y]");
    p.point = Point2{pt[0], pt[1]};
    if (s.has("room")) {
      p.has_room = true;
      p.room = rectFrom(s, "room");
      if (!p.room.contains(p.point)) {
        throw MapError(where + ".point: value [" + fmt(pt[0]) + ", " + fmt(pt[1]) +
                       "] lies outside its room rectangle");
      }
    }
    pf.places.push_back(p);
  }
  if (top.has("blocking_areas")) {
    const YAML::Node areas = top.get("blocking_areas");
    if (!areas.IsMap()) throw MapError(path + ": field 'blocking_areas' must be a mapping");
    for (auto it = areas.begin(); it != areas.end(); ++it) {
      BlockingArea a;
      a.name = it->first.as<std::string>();
      const std::string field = "blocking_areas." + a.name, where = path + ": " + field;
      if (!validName(a.name)) throw MapError(where + ": bad name (lower-case identifier expected)");
      if (!names.insert(a.name).second) throw MapError(where + ": duplicate name");
      // {rect: [...]} or the rectangle itself.
      YAML::Node area = it->second;
      if (!area.IsMap()) {
        area = YAML::Node(YAML::NodeType::Map);
        area["rect"] = it->second;
      }
      a.rect = rectFrom(YamlSection(area, path, field, {"rect"}, Format::kMap), "rect");
      pf.areas.push_back(a);
    }
    if (pf.areas.size() > 32) throw MapError(path + ": blocking_areas: at most 32 areas");
  }
  return pf;
}

}  // namespace

PlacesFile loadPlaces(const std::string& path) {
  try {
    return loadPlacesImpl(path);
  } catch (const YAML::Exception& e) {
    throw MapError(path + ":" + std::to_string(e.mark.line + 1) + ": malformed places file: " +
                   e.msg);
  }
}

std::string placesToYaml(const PlacesFile& pf) {
  std::ostringstream o;
  o << "places:\n";
  for (const Place& p : pf.places) {
    o << "  " << p.name << ": {point: [" << fmt(p.point.x) << ", " << fmt(p.point.y) << "]";
    if (p.has_room) {
      o << ", room: [" << fmt(p.room.x0) << ", " << fmt(p.room.y0) << ", " << fmt(p.room.x1)
        << ", " << fmt(p.room.y1) << "]";
    }
    o << "}\n";
  }
  o << "blocking_areas:\n";
  for (const BlockingArea& a : pf.areas) {
    o << "  " << a.name << ": {rect: [" << fmt(a.rect.x0) << ", " << fmt(a.rect.y0) << ", "
      << fmt(a.rect.x1) << ", " << fmt(a.rect.y1) << "]}\n";
  }
  return o.str();
}

NavGrid NavGrid::fromMap(const OccupancyGrid& map, const PlacesFile& pf,
                         const NavGridOptions& opt) {
  if (opt.cols < 1 || opt.cols > map.width) {
    throw MapError("navigation grid: cols " + std::to_string(opt.cols) + " must be in [1, " +
                   std::to_string(map.width) + "] (map width in pixels)");
  }
  if (opt.rows < 1 || opt.rows > map.height) {
    throw MapError("navigation grid: rows " + std::to_string(opt.rows) + " must be in [1, " +
                   std::to_string(map.height) + "] (map height in pixels)");
  }
  if (!(opt.max_blocked_fraction > 0.0 && opt.max_blocked_fraction <= 1.0)) {
    throw MapError("navigation grid: max_blocked_fraction " + fmt(opt.max_blocked_fraction) +
                   " must be in (0, 1]");
  }
  // About 64 bytes per cell (flags, blocked fraction, neighbours, area and room indices and the
  // counts used while cutting): refuse a grid above the memory budget before building it.
  const size_t cells = saturatingMul(static_cast<size_t>(opt.cols), static_cast<size_t>(opt.rows));
  const size_t budget = memoryBudget();
  if (saturatingMul(cells, 64) > budget) {
    throw MapError("navigation grid: " + std::to_string(opt.cols) + "x" + std::to_string(opt.rows) +
                   " cells need about " + formatBytes(saturatingMul(cells, 64)) +
                   ", above the memory budget of " + formatBytes(budget) +
                   " (KRR_MEMORY_BUDGET_MIB)");
  }
  NavGrid g;
  g.cols_ = opt.cols;
  g.rows_ = opt.rows;
  g.cell_w_ = map.width * map.resolution / opt.cols;
  g.cell_h_ = map.height * map.resolution / opt.rows;
  g.origin_x_ = map.origin_x;
  g.origin_y_ = map.origin_y;
  g.yaw_ = map.origin_yaw;
  const size_t n = static_cast<size_t>(g.numCells());
  std::vector<int> blocked(n, 0), total(n, 0);
  for (int j = 0; j < map.height; ++j) {
    const int r = static_cast<int>(static_cast<long>(j) * opt.rows / map.height);
    for (int i = 0; i < map.width; ++i) {
      const int c = static_cast<int>(static_cast<long>(i) * opt.cols / map.width);
      const size_t id = static_cast<size_t>(g.cellId(c, r));
      ++total[id];
      if (map.data[static_cast<size_t>(map.index(i, j))] != kFree) ++blocked[id];
    }
  }
  g.free_.assign(n, 0);
  g.blocked_fraction_.assign(n, 1.0);
  for (size_t id = 0; id < n; ++id) {
    g.blocked_fraction_[id] = static_cast<double>(blocked[id]) / total[id];
    g.free_[id] = g.blocked_fraction_[id] < opt.max_blocked_fraction ? 1 : 0;
  }
  // A move between two free cells is possible iff the segment between their centres, sampled
  // every quarter pixel in map coordinates, crosses only free pixels.
  const double pw = static_cast<double>(map.width) / opt.cols;   // pixels per cell
  const double ph = static_cast<double>(map.height) / opt.rows;
  auto segmentFree = [&](double u0, double v0, double u1, double v1) {
    const double len = std::max(std::fabs(u1 - u0), std::fabs(v1 - v0));
    const int steps = std::max(1, static_cast<int>(std::ceil(len * 4.0)));
    for (int k = 0; k <= steps; ++k) {
      const double t = static_cast<double>(k) / steps;
      const int i = static_cast<int>(std::floor(u0 + t * (u1 - u0)));
      const int j = static_cast<int>(std::floor(v0 + t * (v1 - v0)));
      if (map.at(i, j) != kFree) return false;
    }
    return true;
  };
  g.wall_right_.assign(n, 0);
  g.wall_up_.assign(n, 0);
  for (int r = 0; r < g.rows_; ++r) {
    for (int c = 0; c < g.cols_; ++c) {
      const int id = g.cellId(c, r);
      if (!g.free_[static_cast<size_t>(id)]) continue;
      const double u = (c + 0.5) * pw;
      const double v = (r + 0.5) * ph;
      if (c + 1 < g.cols_ && g.free_[static_cast<size_t>(id + 1)] &&
          !segmentFree(u, v, u + pw, v)) {
        g.wall_right_[static_cast<size_t>(id)] = 1;
      }
      if (r + 1 < g.rows_ && g.free_[static_cast<size_t>(id + g.cols_)] &&
          !segmentFree(u, v, u, v + ph)) {
        g.wall_up_[static_cast<size_t>(id)] = 1;
      }
    }
  }
  g.places_ = pf.places;
  g.areas_ = pf.areas;
  g.finish();
  return g;
}

void NavGrid::finish() {
  const size_t n = static_cast<size_t>(numCells());
  nbr_.assign(n * 4, -1);
  for (int id = 0; id < numCells(); ++id) {
    if (!isFree(id)) continue;
    for (int m = 0; m < kNumMoves; ++m) {
      const int t = geometricNeighbour(id, m);
      if (t < 0 || !isFree(t)) continue;
      bool wall = false;
      if (m == kRight) wall = wall_right_[static_cast<size_t>(id)];
      if (m == kLeft) wall = wall_right_[static_cast<size_t>(t)];
      if (m == kUp) wall = wall_up_[static_cast<size_t>(id)];
      if (m == kDown) wall = wall_up_[static_cast<size_t>(t)];
      if (!wall) nbr_[static_cast<size_t>(id) * 4 + m] = t;
    }
  }
  place_cells_.clear();
  room_cells_.assign(places_.size(), {});
  room_of_.assign(n, -1);
  for (size_t p = 0; p < places_.size(); ++p) {
    const Place& pl = places_[p];
    const int c = cellAt(pl.point);
    if (c < 0) {
      throw MapError("place '" + pl.name + "' at (" + fmt(pl.point.x) + ", " + fmt(pl.point.y) +
                     ") lies outside the map");
    }
    if (!isFree(c)) {
      throw MapError("place '" + pl.name + "' at (" + fmt(pl.point.x) + ", " + fmt(pl.point.y) +
                     ") lies in cell " + std::to_string(c) + ", which is not free");
    }
    place_cells_.push_back(c);
    if (pl.has_room) {
      for (int id = 0; id < numCells(); ++id) {
        if (isFree(id) && pl.room.contains(cellCentre(id))) {
          room_cells_[p].push_back(id);
          int& room = room_of_[static_cast<size_t>(id)];
          if (room < 0) room = static_cast<int>(p);
        }
      }
    }
  }
  area_cells_.assign(areas_.size(), {});
  area_mask_.assign(n, 0u);
  for (size_t a = 0; a < areas_.size(); ++a) {
    for (int id = 0; id < numCells(); ++id) {
      if (isFree(id) && areas_[a].rect.contains(cellCentre(id))) {
        area_cells_[a].push_back(id);
        area_mask_[static_cast<size_t>(id)] |= (1u << a);
      }
    }
  }
}

int NavGrid::geometricNeighbour(int cell, int move) const {
  const int c = colOf(cell);
  const int r = rowOf(cell);
  switch (move) {
    case kUp: return r + 1 < rows_ ? cell + cols_ : -1;
    case kDown: return r > 0 ? cell - cols_ : -1;
    case kLeft: return c > 0 ? cell - 1 : -1;
    case kRight: return c + 1 < cols_ ? cell + 1 : -1;
    default: return -1;
  }
}

std::vector<int> NavGrid::freeCells() const {
  std::vector<int> out;
  for (int id = 0; id < numCells(); ++id) {
    if (isFree(id)) out.push_back(id);
  }
  return out;
}

int NavGrid::numFreeCells() const {
  return static_cast<int>(std::count(free_.begin(), free_.end(), 1));
}

Point2 NavGrid::cellCentre(int cell) const {
  const double lx = (colOf(cell) + 0.5) * cell_w_;
  const double ly = (rowOf(cell) + 0.5) * cell_h_;
  const double c = std::cos(yaw_), s = std::sin(yaw_);
  return Point2{origin_x_ + c * lx - s * ly, origin_y_ + s * lx + c * ly};
}

int NavGrid::cellAt(const Point2& p) const {
  const double dx = p.x - origin_x_, dy = p.y - origin_y_;
  const double c = std::cos(yaw_), s = std::sin(yaw_);
  const double u = (c * dx + s * dy) / cell_w_;
  const double v = (-s * dx + c * dy) / cell_h_;
  if (!(u >= 0.0 && v >= 0.0 && u < cols_ && v < rows_)) return -1;
  return cellId(static_cast<int>(u), static_cast<int>(v));
}

int NavGrid::placeIndex(const std::string& name) const {
  for (size_t p = 0; p < places_.size(); ++p) {
    if (places_[p].name == name) return static_cast<int>(p);
  }
  throw UnknownSymbolError("navigation grid: unknown place '" + name + "'");
}

int NavGrid::placeCell(const std::string& name) const {
  return place_cells_[static_cast<size_t>(placeIndex(name))];
}

int NavGrid::areaIndex(const std::string& name) const {
  for (size_t a = 0; a < areas_.size(); ++a) {
    if (areas_[a].name == name) return static_cast<int>(a);
  }
  throw UnknownSymbolError("navigation grid: unknown blocking area '" + name + "'");
}

std::vector<std::pair<int, int>> NavGrid::wallEdges() const {
  std::vector<std::pair<int, int>> out;
  for (int id = 0; id < numCells(); ++id) {
    if (wall_up_[static_cast<size_t>(id)]) out.emplace_back(id, id + cols_);
    if (wall_right_[static_cast<size_t>(id)]) out.emplace_back(id, id + 1);
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<int> NavGrid::reachableFrom(int start) const {
  std::vector<int> out;
  if (!valid(start) || !isFree(start)) return out;
  std::vector<std::uint8_t> seen(static_cast<size_t>(numCells()), 0);
  std::vector<int> queue{start};
  seen[static_cast<size_t>(start)] = 1;
  for (size_t h = 0; h < queue.size(); ++h) {
    for (int m = 0; m < kNumMoves; ++m) {
      const int t = neighbour(queue[h], m);
      if (t >= 0 && !seen[static_cast<size_t>(t)]) {
        seen[static_cast<size_t>(t)] = 1;
        queue.push_back(t);
      }
    }
  }
  std::sort(queue.begin(), queue.end());
  return queue;
}

std::string NavGrid::toYaml(const std::string& name, const std::string& map_file) const {
  std::ostringstream o;
  o << "# Navigation domain " << name << ": generated by make_nav_domain from " << map_file
    << ". Do not edit.\n"
    << "name: " << name << "\n"
    << "map: " << map_file << "\n"
    << "cols: " << cols_ << "\nrows: " << rows_ << "\n"
    << "cell_width: " << fmt(cell_w_) << "\ncell_height: " << fmt(cell_h_) << "\n"
    << "origin: [" << fmt(origin_x_) << ", " << fmt(origin_y_) << ", " << fmt(yaw_) << "]\n"
    << "num_cells: " << numCells() << "\n"
    << "num_free_cells: " << numFreeCells() << "\n"
    << "# cell id = row * cols + col, row 0 at the bottom\n"
    << "free_cells: [";
  bool first = true;
  for (int id : freeCells()) {
    o << (first ? "" : ", ") << id;
    first = false;
  }
  o << "]\n# pairs of free neighbouring cells separated by a wall\nwalls: [";
  first = true;
  for (const auto& e : wallEdges()) {
    o << (first ? "" : ", ") << "[" << e.first << ", " << e.second << "]";
    first = false;
  }
  o << "]\nplaces:\n";
  for (size_t p = 0; p < places_.size(); ++p) {
    const Place& pl = places_[p];
    o << "  " << pl.name << ": {cell: " << place_cells_[p] << ", point: [" << fmt(pl.point.x)
      << ", " << fmt(pl.point.y) << "]";
    if (pl.has_room) {
      o << ", room: [" << fmt(pl.room.x0) << ", " << fmt(pl.room.y0) << ", " << fmt(pl.room.x1)
        << ", " << fmt(pl.room.y1) << "], room_cells: [";
      for (size_t k = 0; k < room_cells_[p].size(); ++k) o << (k ? ", " : "") << room_cells_[p][k];
      o << "]";
    }
    o << "}\n";
  }
  o << "blocking_areas:\n";
  for (size_t a = 0; a < areas_.size(); ++a) {
    const BlockingArea& ba = areas_[a];
    o << "  " << ba.name << ": {rect: [" << fmt(ba.rect.x0) << ", " << fmt(ba.rect.y0) << ", "
      << fmt(ba.rect.x1) << ", " << fmt(ba.rect.y1) << "], cells: [";
    for (size_t k = 0; k < area_cells_[a].size(); ++k) o << (k ? ", " : "") << area_cells_[a][k];
    o << "]}\n";
  }
  return o.str();
}

std::string NavGrid::toPlog(const std::string& name) const {
  std::ostringstream o;
  o << "% Geometry of navigation domain " << name << " (" << cols_ << " x " << rows_
    << " cells of " << fmt(cell_w_) << " m x " << fmt(cell_h_) << " m).\n"
    << "% Generated by make_nav_domain. Do not edit.\n"
    << "% cell id = row * " << cols_ << " + col, row 0 at the bottom; only free cells.\n"
    << "% leftof(C,C1): C1 is immediately right of C and the robot can move between them.\n"
    << "% belowof(C,C1): C1 is immediately above C and the robot can move between them.\n\n"
    << "cell = {";
  int k = 0;
  for (int id : freeCells()) o << ((k++ % 16 == 0 && k > 1) ? ",\n  " : (k > 1 ? ", " : "")) << id;
  o << "}.\n";
  // Where a move can end: a free cell, or trapped by walkers (the failure state of the MDPs).
  o << "loc = {";
  k = 0;
  for (int id : freeCells()) o << ((k++ % 16 == 0 && k > 1) ? ",\n  " : (k > 1 ? ", " : "")) << id;
  o << (k > 0 ? ", " : "") << "trapped}.\n";
  o << "ba = {";
  for (size_t a = 0; a < areas_.size(); ++a) o << (a ? ", " : "") << areas_[a].name;
  o << "}.\n";
  o << "place = {";
  for (size_t p = 0; p < places_.size(); ++p) o << (p ? ", " : "") << places_[p].name;
  o << "}.\n\n";
  for (int id = 0; id < numCells(); ++id) {
    const int t = neighbour(id, kRight);
    if (isFree(id) && t >= 0) o << "leftof(" << id << ", " << t << ").\n";
  }
  o << "\n";
  for (int id = 0; id < numCells(); ++id) {
    const int t = neighbour(id, kUp);
    if (isFree(id) && t >= 0) o << "belowof(" << id << ", " << t << ").\n";
  }
  o << "\n";
  for (size_t p = 0; p < places_.size(); ++p) {
    o << "place_cell(" << places_[p].name << ", " << place_cells_[p] << ").\n";
  }
  o << "\n";
  for (size_t a = 0; a < areas_.size(); ++a) {
    for (int c : area_cells_[a]) o << "in_ba(" << c << ", " << areas_[a].name << ").\n";
  }
  return o.str();
}

NavGrid NavGrid::fromYaml(const std::string& path) {
  YAML::Node root = loadYamlMapFile(path, "navigation domain");
  if (!root.IsMap()) throw MapError(path + ": broken YAML: top level is not a mapping");
  // The generated domain file: keys it does not read are ignored (map_server's semantics).
  const YamlSection top(root, path, "", {}, YamlSection::Format::kMapServer);
  NavGrid g;
  g.cols_ = static_cast<int>(top.requiredInteger("cols", 1, 10000));
  g.rows_ = static_cast<int>(top.requiredInteger("rows", 1, 10000));
  g.cell_w_ = top.requiredNumber("cell_width", 0.0, std::numeric_limits<double>::max(),
                                 YamlSection::kLowerOpen);
  g.cell_h_ = top.requiredNumber("cell_height", 0.0, std::numeric_limits<double>::max(),
                                 YamlSection::kLowerOpen);
  const std::vector<double> origin = top.requiredNumbers("origin", 3, "[x, y, yaw]");
  g.origin_x_ = origin[0];
  g.origin_y_ = origin[1];
  g.yaw_ = origin[2];
  const size_t n = static_cast<size_t>(g.numCells());
  g.free_.assign(n, 0);
  g.blocked_fraction_.assign(n, 1.0);
  g.wall_right_.assign(n, 0);
  g.wall_up_.assign(n, 0);
  try {
    for (const auto& c : root["free_cells"]) {
      const int id = c.as<int>();
      if (!g.valid(id)) throw MapError(path + ": field 'free_cells': cell " + dump(c) + " out of range");
      g.free_[static_cast<size_t>(id)] = 1;
      g.blocked_fraction_[static_cast<size_t>(id)] = 0.0;
    }
    for (const auto& e : root["walls"]) {
      const int a = e[0].as<int>(), b = e[1].as<int>();
      if (!g.valid(a) || !g.valid(b)) throw MapError(path + ": field 'walls': bad pair " + dump(e));
      if (b == a + 1) {
        g.wall_right_[static_cast<size_t>(a)] = 1;
      } else if (b == a + g.cols_) {
        g.wall_up_[static_cast<size_t>(a)] = 1;
      } else {
        throw MapError(path + ": field 'walls': cells " + dump(e) + " are not neighbours");
      }
    }
    PlacesFile pf;
    using Format = YamlSection::Format;
    for (auto it = root["places"].begin(); it != root["places"].end(); ++it) {
      Place p;
      p.name = it->first.as<std::string>();
      const YamlSection s(it->second, path, "places." + p.name, {}, Format::kMapServer);
      const std::vector<double> pt = s.requiredNumbers("point", 2, "[x, y]");
      p.point = Point2{pt[0], pt[1]};
      if (s.has("room")) {
        p.has_room = true;
        p.room = rectFrom(s, "room");
      }
      g.places_.push_back(p);
    }
    for (auto it = root["blocking_areas"].begin(); it != root["blocking_areas"].end(); ++it) {
      BlockingArea a;
      a.name = it->first.as<std::string>();
      a.rect = rectFrom(YamlSection(it->second, path, "blocking_areas." + a.name, {},
                                    Format::kMapServer),
                        "rect");
      g.areas_.push_back(a);
    }
  } catch (const YAML::Exception& e) {
    throw MapError(path + ": malformed navigation domain: " + e.msg);
  }
  if (g.areas_.size() > 32) throw MapError(path + ": blocking_areas: at most 32 areas");
  try {
    g.finish();
  } catch (const MapError& e) {
    throw MapError(path + ": " + e.what());
  }
  return g;
}

}  // namespace nav
}  // namespace krr
