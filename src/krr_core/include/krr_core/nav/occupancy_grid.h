/**
 * @file occupancy_grid.h
 * @brief Occupancy-grid maps in ROS map_server format (YAML + PGM), loaded without ROS.
 *
 * The navigation layer must run on the maps a real robot produced with map_server / map_saver,
 * so the loader follows map_server's rules exactly (thresholds, negate, trinary / scale / raw
 * modes, image row 0 at the top of the map). Every failure is a krr::MapError naming the file
 * and the offending field or value, so that a user can fix a broken map without a debugger.
 */
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace krr {
namespace nav {

/// @brief A point in the map frame (metres).
struct Point2 {
  double x = 0.0;
  double y = 0.0;
};

/// @brief How map_server turns pixel values into occupancy values.
enum class MapMode { kTrinary, kScale, kRaw };

/// @brief Occupancy values used by map_server (nav_msgs/OccupancyGrid conventions).
constexpr std::int8_t kUnknown = -1;
constexpr std::int8_t kFree = 0;
constexpr std::int8_t kOccupied = 100;

/**
 * @brief A 2D occupancy grid: data[row * width + col], row 0 at the BOTTOM of the map.
 *
 * Mirrors nav_msgs/OccupancyGrid so that maps can go to and from ROS unchanged. Cell (0,0)'s
 * lower-left corner is at the origin pose (x, y, yaw) in the world frame.
 */
struct OccupancyGrid {
  int width = 0;               ///< cells along x
  int height = 0;              ///< cells along y
  double resolution = 0.05;    ///< metres per cell
  double origin_x = 0.0;       ///< world pose of the lower-left corner of cell (0,0)
  double origin_y = 0.0;
  double origin_yaw = 0.0;
  std::vector<std::int8_t> data;  ///< -1 unknown, 0 free, 100 occupied (scale/raw: other values)

  /// @brief Index into data of cell (col,row); no bounds check (hot loops check once outside).
  int index(int col, int row) const { return row * width + col; }
  /// @brief True if (col,row) lies inside the grid.
  bool inBounds(int col, int row) const {
    return col >= 0 && row >= 0 && col < width && row < height;
  }
  /// @brief Value at (col,row), kUnknown outside the grid (unmapped space is never free).
  std::int8_t at(int col, int row) const {
    return inBounds(col, row) ? data[static_cast<size_t>(index(col, row))] : kUnknown;
  }
  /// @brief World coordinates of the centre of cell (col,row) (origin yaw applied).
  Point2 cellCentre(int col, int row) const { return mapToWorld(col + 0.5, row + 0.5); }
  /// @brief Map-frame continuous cell coordinates (u along x in cells) to world coordinates.
  Point2 mapToWorld(double u, double v) const;
  /// @brief World to continuous cell coordinates (u,v): cell (floor(u), floor(v)).
  void worldToMap(const Point2& p, double* u, double* v) const;
  /// @brief Cell containing a world point; false (and outputs untouched) outside the grid.
  bool worldToCell(const Point2& p, int* col, int* row) const;
};

/// @brief The metadata fields of a map_server YAML file.
struct MapMetadata {
  std::string image;  ///< as written in the YAML (relative to the YAML's directory or absolute)
  double resolution = 0.05;
  double origin[3] = {0.0, 0.0, 0.0};
  double occupied_thresh = 0.65;
  double free_thresh = 0.196;
  bool negate = false;
  MapMode mode = MapMode::kTrinary;
};

/// @brief A grey-level image as stored in a PGM file: pixels[row * width + col], row 0 at TOP.
struct PgmImage {
  int width = 0;
  int height = 0;
  int maxval = 255;
  std::vector<std::uint16_t> pixels;
};

/// @brief Read a PGM image (P5 binary 8/16-bit or P2 ASCII); MapError names the file and problem.
PgmImage readPgm(const std::string& path);

/// @brief Parse PGM bytes; `name` is used in error messages.
PgmImage parsePgm(const std::string& bytes, const std::string& name);

/// @brief Parse and validate a map_server YAML file's fields; MapError names file and field.
MapMetadata loadMapMetadata(const std::string& yaml_path);

/**
 * @brief Convert an image to occupancy values exactly as map_server does.
 *
 * Grey value v is rescaled to [0,255] by maxval; p = (255 - v) / 255, or v / 255 with negate.
 * trinary: p > occupied_thresh -> 100, p < free_thresh -> 0, else -1; scale: the same but values
 * in between become 1 + 98 * (p - free) / (occ - free); raw: the (negated) grey value itself.
 * Image row 0 (the top) becomes grid row height - 1.
 */
OccupancyGrid imageToGrid(const PgmImage& image, const MapMetadata& meta);

/// @brief Load a map_server YAML + image pair. Throws MapError naming the file and field.
OccupancyGrid loadMap(const std::string& yaml_path);

/// @brief Encode a grid as PGM P5 bytes the way map_saver does (0 occupied, 254 free, 205 unknown).
std::string encodePgm(const OccupancyGrid& grid);

/**
 * @brief Write grid as `<yaml_path>` + an image next to it (map_saver conventions).
 * @param image_name file name of the image, relative to the YAML's directory.
 * Files are written atomically; IoError on failure.
 */
void saveMap(const OccupancyGrid& grid, const std::string& yaml_path, const std::string& image_name);

}  // namespace nav
}  // namespace krr
