/**
 * @file occupancy_grid.h
 * @brief Occupancy-grid maps in ROS map_server format (YAML + PGM or PNG), loaded without ROS.
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

/**
 * @brief A map image as map_server's image loader (SDL_image) hands it over, before thresholds.
 *
 * pixels[(row * width + col) * channels + c], row 0 at the TOP. channels is 1 (grey), 3 (RGB) or
 * 4 (RGB + alpha). Grey + alpha PNGs become (g, g, g, a), as SDL_image expands them, because
 * map_server averages all four bytes in trinary mode. PGM samples range over 0..maxval; PNG
 * samples are 8 bit (16-bit PNGs keep their high byte, as SDL_image's png_set_strip_16 does).
 */
struct MapImage {
  int width = 0;
  int height = 0;
  int channels = 1;
  bool has_alpha = false;  ///< the last channel is alpha (channels == 4)
  int maxval = 255;
  std::vector<std::uint16_t> pixels;
};

/// @brief Parse PGM bytes (P5 binary 8/16-bit or P2 ASCII); `name` is used in error messages.
MapImage parsePgm(const std::string& bytes, const std::string& name);

/**
 * @brief Decode PNG bytes with libpng: grey, grey + alpha, RGB, RGBA and palette, 1 to 16 bit.
 *
 * Palette images are expanded to their colours (map_server's documented "colour values are
 * averaged"; SDL_image 1.2 would hand map_server the palette index instead), a palette tRNS
 * chunk becomes alpha, and a tRNS colour key of a grey or RGB image is ignored (SDL_image makes
 * it a colour key, which map_server never reads). The declared size is checked against the
 * memory budget before anything is allocated; corrupt or truncated data is a MapError.
 */
MapImage parsePng(const std::string& bytes, const std::string& name);

/// @brief Parse a PGM or PNG image, told apart by its magic bytes (not by the file name).
MapImage parseImage(const std::string& bytes, const std::string& name);

/// @brief Read a PGM or PNG image file (regular files only); MapError names the file.
MapImage readImage(const std::string& path);

/// @brief Parse and validate a map_server YAML file's fields; MapError names file and field.
MapMetadata loadMapMetadata(const std::string& yaml_path);

/**
 * @brief Convert an image to occupancy values exactly as map_server's loadMapFromFile does.
 *
 * Each sample is rescaled to [0,255] by maxval and the channels are averaged to x (in trinary
 * mode alpha is averaged in too; in scale and raw mode it is left out). With negate x becomes
 * 255 - x. raw: x itself, truncated to a byte and wrapped into int8 like the message field.
 * Otherwise p = (255 - x) / 255; p > occupied_thresh -> 100, p < free_thresh -> 0, else -1 in
 * trinary; in scale mode a fully transparent pixel (alpha 0) -> -1 and the rest
 * 1 + 98 * (p - free) / (occ - free), truncated (map_server's code; its wiki writes 99 * ...).
 * Image row 0 (the top) becomes grid row height - 1.
 */
OccupancyGrid imageToGrid(const MapImage& image, const MapMetadata& meta);

/// @brief Load a map_server YAML + PGM/PNG image pair. Throws MapError naming the file and field.
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
