/**
 * @file nav_grid.h
 * @brief Navigation domains: a coarse W x H grid of cells derived from an occupancy-grid map.
 *
 * The MDP / P-log navigation models of the paper reason over grid cells (`cell={0..N-1}`,
 * `leftof`, `belowof`), not over map pixels. NavGrid is that abstraction: it decides which cells
 * the robot fits in, which neighbouring cells it can move between (thin walls block moves), and
 * which named places and blocking areas (BAs) each cell belongs to. Cell id = row * W + col with
 * row 0 at the bottom, the same for every consumer (simulator, A*, P-log facts, R-Max).
 */
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "krr_core/nav/occupancy_grid.h"

namespace krr {
namespace nav {

/// @brief The four navigation actions, in the order of the P-log sort move={up,down,left,right}.
enum Move : int { kUp = 0, kDown = 1, kLeft = 2, kRight = 3 };
constexpr int kNumMoves = 4;

/// @brief "up", "down", "left", "right".
const char* moveName(int move);

/// @brief Axis-aligned rectangle in world coordinates [x0,x1) x [y0,y1).
struct Rect {
  double x0 = 0.0, y0 = 0.0, x1 = 0.0, y1 = 0.0;
  bool contains(const Point2& p) const { return p.x >= x0 && p.x < x1 && p.y >= y0 && p.y < y1; }
};

/// @brief A named goal location (the shop, a room): a point the robot drives to, and its room.
struct Place {
  std::string name;
  Point2 point;
  bool has_room = false;  ///< whether `room` is set
  Rect room;
};

/// @brief A named blocking area where walkers may obstruct the robot.
struct BlockingArea {
  std::string name;
  Rect rect;
};

/// @brief The side file of a map: named places and blocking areas (office_places.yaml).
struct PlacesFile {
  std::vector<Place> places;
  std::vector<BlockingArea> areas;
};

/// @brief Load places / BAs from YAML; MapError naming file, entry and field on any problem.
PlacesFile loadPlaces(const std::string& path);

/// @brief Serialise places / BAs to the YAML format loadPlaces reads.
std::string placesToYaml(const PlacesFile& places);

/// @brief How a navigation domain is cut out of a map.
struct NavGridOptions {
  int cols = 30;  ///< W
  int rows = 30;  ///< H
  /// A cell is free iff the fraction of its map pixels that are occupied or unknown is below this.
  double max_blocked_fraction = 0.25;
};

/**
 * @brief A W x H navigation grid over a map, with places and blocking areas attached.
 *
 * Map pixel (i,j) belongs to cell (i*W/width, j*H/height), so the grid always covers the whole
 * map. Two 4-neighbouring free cells are connected iff the straight segment between their
 * centres crosses only free map pixels (a wall thinner than a cell still separates them).
 */
class NavGrid {
 public:
  NavGrid() = default;

  /// @brief Derive a domain from a map. MapError if a place is outside the map or in a non-free
  /// cell, or if options are out of range (cols/rows < 1 or more than the map's pixels).
  static NavGrid fromMap(const OccupancyGrid& map, const PlacesFile& places,
                         const NavGridOptions& options);

  int cols() const { return cols_; }
  int rows() const { return rows_; }
  int numCells() const { return cols_ * rows_; }
  int cellId(int col, int row) const { return row * cols_ + col; }
  int colOf(int cell) const { return cell % cols_; }
  int rowOf(int cell) const { return cell / cols_; }
  bool valid(int cell) const { return cell >= 0 && cell < numCells(); }
  bool isFree(int cell) const { return free_[static_cast<size_t>(cell)] != 0; }
  /// @brief Fraction of occupied/unknown map pixels in the cell (why it is free or not).
  double blockedFraction(int cell) const { return blocked_fraction_[static_cast<size_t>(cell)]; }
  /// @brief Ids of all free cells, ascending.
  std::vector<int> freeCells() const;
  int numFreeCells() const;

  /// @brief The cell reached by `move` from `cell` if that move is possible, else -1.
  int neighbour(int cell, int move) const { return nbr_[static_cast<size_t>(cell) * 4 + move]; }
  /// @brief The adjacent cell in direction `move` regardless of walls (-1 off the grid).
  int geometricNeighbour(int cell, int move) const;

  /// @brief World coordinates of the centre of a cell.
  Point2 cellCentre(int cell) const;
  /// @brief The cell containing a world point, -1 outside the grid.
  int cellAt(const Point2& p) const;
  /// @brief Cell width / height in metres.
  double cellWidth() const { return cell_w_; }
  double cellHeight() const { return cell_h_; }

  const std::vector<Place>& places() const { return places_; }
  const std::vector<BlockingArea>& areas() const { return areas_; }
  /// @brief Cell of a named place; UnknownSymbolError if there is no such place.
  int placeCell(const std::string& name) const;
  /// @brief Index of a named place / area; UnknownSymbolError if absent.
  int placeIndex(const std::string& name) const;
  int areaIndex(const std::string& name) const;
  /// @brief Free cells whose centre lies in area `a` (by index), ascending.
  const std::vector<int>& areaCells(int a) const { return area_cells_[static_cast<size_t>(a)]; }
  /// @brief Bit a set iff the cell lies in area a (at most 32 areas).
  std::uint32_t areaMask(int cell) const { return area_mask_[static_cast<size_t>(cell)]; }
  /// @brief Free cells whose centre lies in place p's room rectangle (empty without a room).
  const std::vector<int>& roomCells(int p) const { return room_cells_[static_cast<size_t>(p)]; }

  /// @brief Index of the place whose room rectangle contains the cell's centre (the first such
  /// place), -1 if none: which room the robot is in.
  int roomOf(int cell) const { return room_of_[static_cast<size_t>(cell)]; }

  /// @brief Pairs (a,b), a < b, of free 4-neighbours that a wall separates.
  std::vector<std::pair<int, int>> wallEdges() const;
  /// @brief Cells reachable from `start` through connected moves (BFS), ascending.
  std::vector<int> reachableFrom(int start) const;

  /// @brief Domain description (grid size, cell size, free cells, places, BAs, walls) as YAML.
  std::string toYaml(const std::string& name, const std::string& map_file) const;
  /// @brief The P-log geometry facts of this domain (cell sort, leftof, belowof, places, BAs).
  std::string toPlog(const std::string& name) const;
  /// @brief Rebuild a grid from a domain description written by toYaml (map not needed).
  static NavGrid fromYaml(const std::string& path);

 private:
  void finish();  // neighbours, area/room membership from free_, walls_, places_, areas_

  int cols_ = 0, rows_ = 0;
  double cell_w_ = 0.0, cell_h_ = 0.0;
  double origin_x_ = 0.0, origin_y_ = 0.0, yaw_ = 0.0;
  std::vector<std::uint8_t> free_;
  std::vector<double> blocked_fraction_;
  // wall_right_[c]: move c -> right is blocked by a wall; wall_up_[c]: c -> up blocked.
  std::vector<std::uint8_t> wall_right_, wall_up_;
  std::vector<int> nbr_;
  std::vector<Place> places_;
  std::vector<int> place_cells_;
  std::vector<BlockingArea> areas_;
  std::vector<std::vector<int>> area_cells_;
  std::vector<std::vector<int>> room_cells_;
  std::vector<std::uint32_t> area_mask_;
  std::vector<int> room_of_;
};

}  // namespace nav
}  // namespace krr
