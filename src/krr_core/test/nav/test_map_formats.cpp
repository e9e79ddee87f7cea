// Map images as map_server reads them (issue 14): PGM and PNG in every colour type and bit depth,
// trinary / scale / raw, negate, checked cell for cell against map_server's documented rules on
// a real TurtleBot3 map and on map_server's own test maps (test/data/nav/README.md names them).
//
// The expected values never come from the loader: the pixels come from PAM files written by
// make_png_maps.py (an independent zlib-only PNG decoder) or from the PGM bytes, and the
// occupancy values from the map_server documentation, coded again below.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/nav/occupancy_grid.h"

using namespace krr;
using namespace krr::nav;

namespace {

const std::string kDir = std::string(KRR_TEST_DATA_DIR) + "/nav/";

/// @brief 8-bit samples as SDL_image hands them to map_server, read from a PAM (P7) or P5 file.
struct Samples {
  int width = 0;
  int height = 0;
  int depth = 0;
  std::vector<std::uint8_t> bytes;  // row 0 at the top
};

Samples readSamples(const std::string& path) {
  const std::string data = readFile(path);
  Samples s;
  std::istringstream in(data);
  std::string magic;
  in >> magic;
  std::size_t header_end = 0;
  if (magic == "P7") {
    std::string key;
    int maxval = 0;
    while (in >> key && key != "ENDHDR") {
      if (key == "WIDTH") in >> s.width;
      if (key == "HEIGHT") in >> s.height;
      if (key == "DEPTH") in >> s.depth;
      if (key == "MAXVAL") in >> maxval;
    }
    EXPECT_EQ(maxval, 255) << path;
    header_end = static_cast<std::size_t>(in.tellg()) + 1;
  } else {
    EXPECT_EQ(magic, "P5") << path;
    std::string line;
    std::getline(in, line);
    while (in.peek() == '#') std::getline(in, line);
    int maxval = 0;
    in >> s.width >> s.height >> maxval;
    EXPECT_EQ(maxval, 255) << path;
    s.depth = 1;
    header_end = static_cast<std::size_t>(in.tellg()) + 1;
  }
  s.bytes.assign(data.begin() + static_cast<std::ptrdiff_t>(header_end), data.end());
  EXPECT_EQ(s.bytes.size(), static_cast<std::size_t>(s.width) * s.height * s.depth) << path;
  return s;
}

/**
 * @brief The occupancy value map_server gives a pixel, from its documentation (wiki and
 * image_loader.h) and its loadMapFromFile: x is the mean of the colour channels (alpha is
 * averaged in only in trinary mode), x -> 255 - x with negate; raw: x as a byte; otherwise
 * p = (255 - x) / 255, p > occupied -> 100, p < free -> 0, trinary -> -1; scale: alpha 0 -> -1,
 * else 1 + 98 * (p - free) / (occupied - free) truncated (the wiki's "99 * ..." differs from the
 * code by at most one and map_server's own tests only check the range 1..99).
 */
int expectedValue(const std::uint8_t* px, int depth, const MapMetadata& m) {
  const bool has_alpha = depth == 4;
  const int n = (m.mode == MapMode::kTrinary || !has_alpha) ? depth : depth - 1;
  int sum = 0;
  for (int c = 0; c < n; ++c) sum += px[c];
  double x = static_cast<double>(sum) / n;
  if (m.negate) x = 255.0 - x;
  if (m.mode == MapMode::kRaw) return static_cast<std::int8_t>(static_cast<std::uint8_t>(x));
  const double p = (255.0 - x) / 255.0;
  if (p > m.occupied_thresh) return 100;
  if (p < m.free_thresh) return 0;
  if (m.mode == MapMode::kTrinary || (has_alpha && px[3] == 0)) return -1;
  return static_cast<int>(1 + 98 * (p - m.free_thresh) / (m.occupied_thresh - m.free_thresh));
}

/// @brief Compares every cell of `g` with expectedValue over `s` (grid row 0 = image bottom).
/// Returns the number of cells checked.
std::size_t expectCells(const OccupancyGrid& g, const Samples& s, const MapMetadata& m,
                        const std::string& what) {
  EXPECT_EQ(g.width, s.width) << what;
  EXPECT_EQ(g.height, s.height) << what;
  if (g.width != s.width || g.height != s.height) return 0;
  std::size_t mismatches = 0;
  for (int j = 0; j < s.height; ++j) {
    for (int i = 0; i < s.width; ++i) {
      const std::uint8_t* px = &s.bytes[(static_cast<std::size_t>(j) * s.width + i) * s.depth];
      const int want = expectedValue(px, s.depth, m);
      const int got = g.at(i, s.height - 1 - j);
      if (got != want && ++mismatches <= 5) {
        ADD_FAILURE() << what << ": image pixel (" << i << "," << j << ") gives " << got
                      << ", map_server gives " << want;
      }
    }
  }
  EXPECT_EQ(mismatches, 0u) << what;
  return static_cast<std::size_t>(s.width) * s.height;
}

MapMetadata meta(MapMode mode, bool negate, double occ, double free_thresh) {
  MapMetadata m;
  m.mode = mode;
  m.negate = negate;
  m.occupied_thresh = occ;
  m.free_thresh = free_thresh;
  return m;
}

std::map<int, int> histogram(const OccupancyGrid& g) {
  std::map<int, int> h;
  for (std::int8_t v : g.data) ++h[v];
  return h;
}

// map_server/test/test_constants.cpp (ros-planning/navigation, BSD): the grid expected from
// testmap.png, row 0 = bottom of the image, with thresholds 0.65 / 0.1 (utest) or 0.65 / 0.196
// (rtest, testmap.yaml).
const std::vector<int> kTestmapContent = {
    0,   0,   0,   0,   0, 0, 0,   0,   0,   0,  100, 100, 100, 100, 0, 0, 100, 100, 100, 0,
    100, 100, 100, 100, 0, 0, 100, 100, 100, 0,  100, 0,   0,   0,   0, 0, 0,   0,   0,   0,
    100, 0,   0,   0,   0, 0, 0,   0,   0,   0,  100, 0,   0,   0,   0, 0, 100, 100, 0,   0,
    100, 0,   0,   0,   0, 0, 100, 100, 0,   0,  100, 0,   0,   0,   0, 0, 100, 100, 0,   0,
    100, 0,   0,   0,   0, 0, 100, 100, 0,   0,  100, 0,   0,   0,   0, 0, 0,   0,   0,   0};

// The same file's tmap2::g_valid_image_content: testmap2.yaml (negate 1, 0.5 / 0.2).
const std::vector<int> kTestmap2Content = {
    100, 100, 100, 100, 100, 100, 100, 100, 100, 100, 100, 100,  //
    100, 0,   0,   0,   0,   0,   0,   0,   0,   0,   0,   100,  //
    100, 0,   100, 100, 100, 100, 100, 100, 100, 100, 0,   100,  //
    100, 0,   100, 0,   0,   0,   0,   0,   0,   100, 0,   100,  //
    100, 0,   0,   0,   0,   0,   0,   0,   0,   0,   0,   100,  //
    100, 0,   0,   0,   0,   0,   0,   0,   0,   0,   0,   100,  //
    100, 0,   0,   0,   0,   0,   0,   0,   0,   0,   0,   100,  //
    100, 0,   0,   0,   0,   0,   0,   0,   0,   0,   0,   100,  //
    100, 0,   0,   0,   0,   0,   0,   0,   0,   0,   0,   100,  //
    100, 0,   100, 0,   0,   0,   0,   0,   0,   100, 0,   100,  //
    100, 0,   0,   0,   0,   0,   0,   0,   0,   0,   0,   100,  //
    100, 100, 100, 100, 100, 100, 100, 100, 100, 100, 100, 100};

std::vector<int> asInts(const OccupancyGrid& g) {
  return std::vector<int>(g.data.begin(), g.data.end());
}

}  // namespace

// TurtleBot3's own map (turtlebot3_navigation/maps, Apache-2.0), 384 x 384 cells from
// map_saver: 0 occupied, 254 free, 205 unknown.
TEST(MapFormats, TurtleBot3MapCellForCell) {
  const OccupancyGrid g = loadMap(kDir + "turtlebot3_map.yaml");
  EXPECT_DOUBLE_EQ(g.resolution, 0.05);
  EXPECT_DOUBLE_EQ(g.origin_x, -10.0);
  EXPECT_DOUBLE_EQ(g.origin_y, -10.0);
  EXPECT_DOUBLE_EQ(g.origin_yaw, 0.0);
  const Samples s = readSamples(kDir + "turtlebot3_map.pgm");
  EXPECT_EQ(expectCells(g, s, meta(MapMode::kTrinary, false, 0.65, 0.196), "turtlebot3 pgm"),
            384u * 384u);
  const std::map<int, int> h = histogram(g);
  EXPECT_EQ(h.at(100), 870);
  EXPECT_EQ(h.at(0), 7903);
  EXPECT_EQ(h.at(-1), 138683);
  // Every mode and negate on the same real map.
  MapImage img = readImage(kDir + "turtlebot3_map.pgm");
  for (MapMode mode : {MapMode::kTrinary, MapMode::kScale, MapMode::kRaw}) {
    for (bool negate : {false, true}) {
      const MapMetadata m = meta(mode, negate, 0.65, 0.196);
      expectCells(imageToGrid(img, m), s, m, "turtlebot3 mode " + std::to_string(int(mode)));
    }
  }
}

// The same map saved as an 8-bit grey PNG (make_png_maps.py) loads to the same grid.
TEST(MapFormats, TurtleBot3MapAsPng) {
  const OccupancyGrid pgm = loadMap(kDir + "turtlebot3_map.yaml");
  const OccupancyGrid png = loadMap(kDir + "turtlebot3_map_png.yaml");
  EXPECT_EQ(png.width, 384);
  EXPECT_EQ(png.height, 384);
  EXPECT_EQ(png.data, pgm.data);
  EXPECT_DOUBLE_EQ(png.origin_x, pgm.origin_x);
}

// map_server/test/utest.cpp loadValidPNG: testmap.png (RGB) with 0.65 / 0.1, trinary.
TEST(MapFormats, MapServerTestmapPng) {
  const MapImage img = readImage(kDir + "ms_testmap.png");
  EXPECT_EQ(img.channels, 3);
  const MapMetadata utest = meta(MapMode::kTrinary, false, 0.65, 0.1);
  const OccupancyGrid g = imageToGrid(img, utest);
  ASSERT_EQ(g.width, 10);
  ASSERT_EQ(g.height, 10);
  EXPECT_EQ(asInts(g), kTestmapContent);
  expectCells(g, readSamples(kDir + "ms_testmap.pam"), utest, "testmap utest");
  // rtest.cpp: map_server started on testmap.yaml publishes the same content.
  const OccupancyGrid r = loadMap(kDir + "ms_testmap.yaml");
  EXPECT_EQ(asInts(r), kTestmapContent);
  EXPECT_FLOAT_EQ(r.resolution, 0.1f);
  EXPECT_DOUBLE_EQ(r.origin_x, 2.0);
  EXPECT_DOUBLE_EQ(r.origin_y, 3.0);
  EXPECT_DOUBLE_EQ(r.origin_yaw, 1.0);  // yaw kept: the lower-left corner is rotated by 1 rad
  const Point2 c = r.mapToWorld(10.0, 0.0);  // lower-right corner: 1 m along the rotated x axis
  EXPECT_NEAR(c.x, 2.0 + std::cos(1.0), 1e-12);
  EXPECT_NEAR(c.y, 3.0 + std::sin(1.0), 1e-12);
}

// rtest.cpp change_map to testmap2.yaml: negate 1, thresholds 0.5 / 0.2.
TEST(MapFormats, MapServerTestmap2Negate) {
  const OccupancyGrid g = loadMap(kDir + "ms_testmap2.yaml");
  ASSERT_EQ(g.width, 12);
  ASSERT_EQ(g.height, 12);
  EXPECT_EQ(asInts(g), kTestmap2Content);
  EXPECT_DOUBLE_EQ(g.origin_x, -2.0);
  EXPECT_DOUBLE_EQ(g.origin_yaw, -1.0);
  expectCells(g, readSamples(kDir + "ms_testmap2.pam"), meta(MapMode::kTrinary, true, 0.5, 0.2),
              "testmap2");
}

// utest.cpp testMapMode: spectrum.png holds each grey value once; thresholds 0.65 / 0.1.
TEST(MapFormats, MapServerSpectrumModes) {
  const MapImage img = readImage(kDir + "ms_spectrum.png");
  const Samples s = readSamples(kDir + "ms_spectrum.pam");
  const MapMetadata tri = meta(MapMode::kTrinary, false, 0.65, 0.1);
  std::map<int, int> h = histogram(imageToGrid(img, tri));
  EXPECT_EQ(h[100], 90);
  EXPECT_EQ(h[0], 26);
  EXPECT_EQ(h[-1], 140);
  expectCells(imageToGrid(img, tri), s, tri, "spectrum trinary");

  const MapMetadata scale = meta(MapMode::kScale, false, 0.65, 0.1);
  h = histogram(imageToGrid(img, scale));
  EXPECT_EQ(h[100], 90);
  EXPECT_EQ(h[0], 26);
  int between = 0;
  for (int v = 1; v < 100; ++v) between += h[v];
  EXPECT_EQ(between, 140);
  expectCells(imageToGrid(img, scale), s, scale, "spectrum scale");

  const MapMetadata raw = meta(MapMode::kRaw, false, 0.65, 0.1);
  const OccupancyGrid r = imageToGrid(img, raw);
  std::vector<int> counts(256, 0);
  for (std::int8_t v : r.data) ++counts[static_cast<std::uint8_t>(v)];
  for (int v = 0; v < 256; ++v) EXPECT_EQ(counts[v], 1) << v;
  expectCells(r, s, raw, "spectrum raw");
}

// Every PNG colour type and bit depth, every mode, with and without negate: 16 files x 6.
TEST(MapFormats, PngColourTypesCellForCell) {
  const std::vector<std::pair<std::string, int>> files = {
      {"png_gray16", 1},     {"png_gray4", 1},        {"png_gray2", 1},
      {"png_gray1", 1},      {"png_gray_trns", 1},    {"png_gray_alpha", 4},
      {"png_gray_alpha16", 4}, {"png_rgb", 3},        {"png_rgb16", 3},
      {"png_rgb_trns", 3},   {"png_rgba", 4},         {"png_rgba16", 4},
      {"png_palette", 3},    {"png_palette_trns", 4}, {"png_palette4", 3},
      {"png_interlaced", 3}};
  std::size_t cells = 0;
  for (const auto& f : files) {
    const MapImage img = readImage(kDir + f.first + ".png");
    EXPECT_EQ(img.channels, f.second) << f.first;
    EXPECT_EQ(img.has_alpha, f.second == 4) << f.first;
    const Samples s = readSamples(kDir + f.first + ".pam");
    ASSERT_EQ(s.depth, img.channels) << f.first;
    ASSERT_EQ(img.pixels.size(), s.bytes.size()) << f.first;
    for (std::size_t i = 0; i < s.bytes.size(); ++i) {
      ASSERT_EQ(img.pixels[i], s.bytes[i]) << f.first << " sample " << i;
    }
    for (MapMode mode : {MapMode::kTrinary, MapMode::kScale, MapMode::kRaw}) {
      for (bool negate : {false, true}) {
        const MapMetadata m = meta(mode, negate, 0.65, 0.196);
        cells += expectCells(imageToGrid(img, m), s, m,
                             f.first + " mode " + std::to_string(int(mode)) + " negate " +
                                 std::to_string(negate));
      }
    }
  }
  EXPECT_EQ(cells, 16u * 6u * 256u);
}

// The YAML path end to end on a PNG: mode scale, negate, other thresholds, rotated origin.
TEST(MapFormats, PngThroughYaml) {
  const OccupancyGrid g = loadMap(kDir + "png_rgba_scale.yaml");
  EXPECT_DOUBLE_EQ(g.resolution, 0.25);
  EXPECT_DOUBLE_EQ(g.origin_x, 0.5);
  EXPECT_DOUBLE_EQ(g.origin_y, -1.5);
  EXPECT_DOUBLE_EQ(g.origin_yaw, 0.3);
  EXPECT_EQ(expectCells(g, readSamples(kDir + "png_rgba.pam"),
                        meta(MapMode::kScale, true, 0.6, 0.25), "png_rgba_scale.yaml"),
            256u);
  // The image exercises every branch: occupied, free, transparent unknown and scaled values.
  const std::map<int, int> h = histogram(g);
  int scaled = 0;
  for (const auto& kv : h) scaled += (kv.first >= 1 && kv.first <= 99) ? kv.second : 0;
  EXPECT_GT(h.count(100), 0u);
  EXPECT_GT(h.count(0), 0u);
  EXPECT_GT(h.count(-1), 0u);
  EXPECT_GT(scaled, 20);
}

// Scale mode: a fully transparent pixel with an in-between grey is unknown; in trinary mode alpha
// is averaged in with the colours (map_server keeps this for compatibility).
TEST(MapFormats, AlphaRules) {
  MapImage img;
  img.width = 3;
  img.height = 1;
  img.channels = 4;
  img.has_alpha = true;
  img.pixels = {100, 100, 100, 0, 128, 128, 128, 255, 0, 0, 0, 0};
  const OccupancyGrid s = imageToGrid(img, meta(MapMode::kScale, false, 0.65, 0.196));
  EXPECT_EQ(s.at(0, 0), -1);   // transparent, p = 155 / 255 = .608 between the thresholds
  EXPECT_EQ(s.at(1, 0), 66);   // opaque: p = .498 -> 1 + 98 * (.498 - .196) / .454
  EXPECT_EQ(s.at(2, 0), 100);  // black wins over transparency: p > occupied comes first
  const OccupancyGrid t = imageToGrid(img, meta(MapMode::kTrinary, false, 0.65, 0.196));
  EXPECT_EQ(t.at(0, 0), 100);  // (3 * 100 + 0) / 4 = 75: p = .706 > .65
  EXPECT_EQ(t.at(1, 0), -1);   // (3 * 128 + 255) / 4 = 159.75: p = .374
  EXPECT_EQ(t.at(2, 0), 100);
}

TEST(MapFormats, PngErrorsNameTheFile) {
  const std::string png = readFile(kDir + "png_rgb.png");
  try {
    parseImage(png.substr(0, png.size() / 2), "half.png");
    ADD_FAILURE() << "no error";
  } catch (const MapError& e) {
    EXPECT_NE(std::string(e.what()).find("half.png: corrupt PNG data"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(parseImage(png.substr(0, 20), "short.png"), MapError);
  EXPECT_THROW(parsePng("P5\n1 1\n255\n\n", "not.png"), MapError);
  try {
    parseImage("GIF89a", "map.gif");
    ADD_FAILURE() << "no error";
  } catch (const MapError& e) {
    EXPECT_NE(std::string(e.what()).find("map.gif: bad magic 'GI'"), std::string::npos)
        << e.what();
  }
}

// The declared size is checked against the budget before any pixel memory is allocated.
TEST(MapFormats, PngAboveMemoryBudgetIsRefused) {
  std::string png = readFile(kDir + "png_rgba.png");
  // IHDR width and height (bytes 16..23) -> 8000 x 8000, CRC (bytes 29..32) recomputed.
  const unsigned char wh[8] = {0, 0, 0x1f, 0x40, 0, 0, 0x1f, 0x40};
  png.replace(16, 8, reinterpret_cast<const char*>(wh), 8);
  std::uint32_t crc = 0xffffffffu;
  for (std::size_t i = 12; i < 29; ++i) {
    crc ^= static_cast<unsigned char>(png[i]);
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  crc ^= 0xffffffffu;
  for (int k = 0; k < 4; ++k) png[29 + k] = static_cast<char>((crc >> (24 - 8 * k)) & 0xff);
  ::setenv("KRR_MEMORY_BUDGET_MIB", "64", 1);
  try {
    parsePng(png, "huge.png");
    ADD_FAILURE() << "no error";
  } catch (const MapError& e) {
    EXPECT_NE(std::string(e.what()).find("huge.png: PNG image 8000x8000 needs about 793"),
              std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("memory budget of 64 MiB"), std::string::npos)
        << e.what();
  }
  ::unsetenv("KRR_MEMORY_BUDGET_MIB");
}

TEST(MapFormats, SpecialFilePngIsRefused) {
  EXPECT_THROW(readImage("/dev/zero"), MapError);
  EXPECT_THROW(readImage(kDir + "does_not_exist.png"), MapError);
}
