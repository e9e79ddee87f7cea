#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/nav/occupancy_grid.h"

using namespace krr;
using namespace krr::nav;

namespace {

const std::string kDir = std::string(KRR_TEST_DATA_DIR) + "/nav/";

// Expect loadMap(file) to throw MapError whose message names the file and contains `what`.
void expectMapError(const std::string& file, const std::string& what) {
  try {
    loadMap(kDir + file);
    FAIL() << "no MapError for " << file;
  } catch (const MapError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(file.substr(0, file.find('.'))), std::string::npos) << msg;
    EXPECT_NE(msg.find(what), std::string::npos) << "expected '" << what << "' in: " << msg;
  }
}

}  // namespace

// Image (top row first):  0 128 255 / 205 89 90, thresholds occ 0.65 free 0.196.
// p = (255 - v) / 255:   1.0 .498 0   / .19608 .651 .647
// trinary:               100  -1   0  /  -1    100   -1   (.19608 > .196 so not free)
// Image row 0 is the top, so grid row 1 = [100, -1, 0] and grid row 0 = [-1, 100, -1].
TEST(OccupancyGrid, TrinaryValuesAndRowFlip) {
  OccupancyGrid g = loadMap(kDir + "tiny_3x2.yaml");
  ASSERT_EQ(g.width, 3);
  ASSERT_EQ(g.height, 2);
  EXPECT_DOUBLE_EQ(g.resolution, 0.5);
  EXPECT_DOUBLE_EQ(g.origin_x, 1.0);
  EXPECT_DOUBLE_EQ(g.origin_y, -2.0);
  EXPECT_EQ(g.at(0, 1), 100);
  EXPECT_EQ(g.at(1, 1), -1);
  EXPECT_EQ(g.at(2, 1), 0);
  EXPECT_EQ(g.at(0, 0), -1);
  EXPECT_EQ(g.at(1, 0), 100);
  EXPECT_EQ(g.at(2, 0), -1);
}

TEST(OccupancyGrid, BinaryP5MatchesAscii) {
  OccupancyGrid a = loadMap(kDir + "tiny_3x2.yaml");
  OccupancyGrid b = loadMap(kDir + "tiny_3x2_p5.yaml");
  EXPECT_EQ(a.data, b.data);
}

// negate: p = v / 255: 0 .502 1 / .804 .349 .353 -> 0 -1 100 / 100 -1 -1.
TEST(OccupancyGrid, Negate) {
  OccupancyGrid g = loadMap(kDir + "tiny_3x2_negate.yaml");
  EXPECT_EQ(g.at(0, 1), 0);
  EXPECT_EQ(g.at(1, 1), -1);
  EXPECT_EQ(g.at(2, 1), 100);
  EXPECT_EQ(g.at(0, 0), 100);
  EXPECT_EQ(g.at(1, 0), -1);
  EXPECT_EQ(g.at(2, 0), -1);
}

// scale: between the thresholds value = 1 + 98 * (p - free) / (occ - free), truncated:
//   v=128: p=127/255=.498039, ratio=.302039/.454=.665284 -> 1+65.198 -> 66
//   v=205: p=50/255=.196078, ratio=.000078/.454=.000173 -> 1.017 -> 1
//   v=90:  p=165/255=.647059, ratio=.451059/.454=.993522 -> 1+97.365 -> 98
TEST(OccupancyGrid, ScaleMode) {
  OccupancyGrid g = loadMap(kDir + "tiny_3x2_scale.yaml");
  EXPECT_EQ(g.at(0, 1), 100);
  EXPECT_EQ(g.at(1, 1), 66);
  EXPECT_EQ(g.at(2, 1), 0);
  EXPECT_EQ(g.at(0, 0), 1);
  EXPECT_EQ(g.at(1, 0), 100);
  EXPECT_EQ(g.at(2, 0), 98);
}

// raw: the grey value itself, wrapped into int8 like the ROS message field: 255 -> -1,
// 205 -> 205 - 256 = -51, 128 -> -128.
TEST(OccupancyGrid, RawMode) {
  OccupancyGrid g = loadMap(kDir + "tiny_3x2_raw.yaml");
  EXPECT_EQ(g.at(0, 1), 0);
  EXPECT_EQ(g.at(1, 1), -128);
  EXPECT_EQ(g.at(2, 1), -1);
  EXPECT_EQ(g.at(0, 0), -51);
  EXPECT_EQ(g.at(1, 0), 89);
  EXPECT_EQ(g.at(2, 0), 90);
}

// maxval 15: grey = v * 255 / 15. Top row 0 8 15 -> 0, 136, 255 -> p 1, .467, 0 -> 100 -1 0;
// bottom row 3 15 0 -> 51, 255, 0 -> p .8, 0, 1 -> 100 0 100.
TEST(OccupancyGrid, MaxvalRescaled) {
  OccupancyGrid g = loadMap(kDir + "tiny_3x2_max15.yaml");
  EXPECT_EQ(g.at(0, 1), 100);
  EXPECT_EQ(g.at(1, 1), -1);
  EXPECT_EQ(g.at(2, 1), 0);
  EXPECT_EQ(g.at(0, 0), 100);
  EXPECT_EQ(g.at(1, 0), 0);
  EXPECT_EQ(g.at(2, 0), 100);
}

TEST(OccupancyGrid, WorldCellConversions) {
  OccupancyGrid g = loadMap(kDir + "tiny_3x2.yaml");  // origin (1,-2), 0.5 m cells
  Point2 c = g.cellCentre(2, 1);                       // (1 + 2.5*0.5, -2 + 1.5*0.5)
  EXPECT_DOUBLE_EQ(c.x, 2.25);
  EXPECT_DOUBLE_EQ(c.y, -1.25);
  int col = -1, row = -1;
  ASSERT_TRUE(g.worldToCell(Point2{2.4, -1.01}, &col, &row));
  EXPECT_EQ(col, 2);
  EXPECT_EQ(row, 1);
  EXPECT_FALSE(g.worldToCell(Point2{0.99, -1.5}, &col, &row));
  EXPECT_FALSE(g.worldToCell(Point2{1.2, -1.0}, &col, &row));  // y = top edge: outside
  EXPECT_EQ(g.at(-1, 0), kUnknown);
  // Rotated origin: yaw 90 deg maps the map's x axis onto world y.
  g.origin_yaw = std::acos(-1.0) / 2;
  Point2 r = g.cellCentre(0, 0);
  EXPECT_NEAR(r.x, 1.0 - 0.25, 1e-12);
  EXPECT_NEAR(r.y, -2.0 + 0.25, 1e-12);
  ASSERT_TRUE(g.worldToCell(Point2{0.9, -1.1}, &col, &row));  // local (0.9, 0.1)
  EXPECT_EQ(col, 1);
  EXPECT_EQ(row, 0);
}

TEST(OccupancyGrid, SaveLoadRoundTrip) {
  OccupancyGrid g = loadMap(kDir + "tiny_3x2.yaml");
  const std::string dir = ::testing::TempDir();
  saveMap(g, dir + "/rt.yaml", "rt.pgm");
  OccupancyGrid h = loadMap(dir + "/rt.yaml");
  EXPECT_EQ(h.width, 3);
  EXPECT_EQ(h.height, 2);
  EXPECT_DOUBLE_EQ(h.resolution, 0.5);
  EXPECT_DOUBLE_EQ(h.origin_y, -2.0);
  EXPECT_EQ(h.data, g.data);
  std::remove((dir + "/rt.yaml").c_str());
  std::remove((dir + "/rt.pgm").c_str());
}

TEST(OccupancyGridErrors, BrokenYaml) { expectMapError("err_broken.yaml", "broken YAML"); }
TEST(OccupancyGridErrors, MissingFields) {
  expectMapError("err_missing_resolution.yaml", "'resolution'");
  expectMapError("err_missing_image_field.yaml", "missing field 'image'");
  expectMapError("err_missing_negate.yaml", "missing field 'negate'");
}
TEST(OccupancyGridErrors, MissingImageFile) {
  try {
    loadMap(kDir + "err_no_image_file.yaml");
    FAIL();
  } catch (const MapError& e) {
    EXPECT_NE(std::string(e.what()).find("does_not_exist.pgm"), std::string::npos) << e.what();
  }
}
TEST(OccupancyGridErrors, BadMagic) { expectMapError("err_bad_magic.yaml", "bad magic 'P6'"); }
TEST(OccupancyGridErrors, Truncated) {
  expectMapError("err_truncated.yaml", "truncated PGM data");
  expectMapError("err_truncated_p2.yaml", "truncated PGM data");
  expectMapError("err_truncated_header.yaml", "truncated PGM header");
}
TEST(OccupancyGridErrors, Resolution) {
  expectMapError("err_resolution.yaml", "field 'resolution': value -0.05");
  expectMapError("err_resolution_zero.yaml", "field 'resolution': value 0");
  expectMapError("err_resolution_text.yaml", "field 'resolution': value 'fine'");
}
TEST(OccupancyGridErrors, Thresholds) {
  expectMapError("err_occupied_thresh.yaml", "field 'occupied_thresh': value 1.5");
  expectMapError("err_free_thresh.yaml", "field 'free_thresh': value -0.1");
  expectMapError("err_thresh_order.yaml", "must be > free_thresh");
}
TEST(OccupancyGridErrors, ModeAndOrigin) {
  expectMapError("err_mode.yaml", "field 'mode': unknown value 'fancy'");
  expectMapError("err_origin.yaml", "field 'origin'");
}
// map_server's semantics through the one YAML section reader: keys it does not read are
// ignored; a bad field is a MapError naming file and field.
TEST(OccupancyGrid, MapYamlIgnoresUnknownKeys) {
  const std::string yaml = ::testing::TempDir() + "/extra_keys_map.yaml";
  {
    std::ofstream out(yaml);
    out << "image: " << kDir << "tiny_3x2.pgm\nresolution: 0.5\norigin: [1.0, -2.0, 0.0]\n"
        << "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nsampler: uniform\n"
        << "made_by: some_tool\n";
  }
  const MapMetadata m = loadMapMetadata(yaml);
  EXPECT_DOUBLE_EQ(m.resolution, 0.5);
  EXPECT_DOUBLE_EQ(m.origin[1], -2.0);
  EXPECT_FALSE(m.negate);
  {
    std::ofstream out(yaml);
    out << "image: x.pgm\nresolution: 0.5\norigin: [1.0, -2.0]\nnegate: 0\n"
        << "occupied_thresh: 0.65\nfree_thresh: 0.196\n";
  }
  try {
    loadMapMetadata(yaml);
    ADD_FAILURE() << "no error";
  } catch (const MapError& e) {
    EXPECT_NE(std::string(e.what()).find("field 'origin': value '[1.0, -2.0]' must be [x, y, yaw]"),
              std::string::npos)
        << e.what();
  }
}
TEST(OccupancyGridErrors, MissingYamlFile) { expectMapError("nonexistent.yaml", "cannot read"); }
TEST(OccupancyGridErrors, PgmValueAboveMaxval) {
  EXPECT_THROW(parsePgm("P2\n2 1\n10\n3 11\n", "mem.pgm"), MapError);
  EXPECT_THROW(parsePgm("P2\n2 1\n0\n0 0\n", "mem.pgm"), MapError);   // maxval 0
  EXPECT_THROW(parsePgm("P5\n0 1\n255\n", "mem.pgm"), MapError);      // empty image
  EXPECT_THROW(parsePgm("", "mem.pgm"), MapError);
  MapImage ok = parsePgm("P2 # c\n2 1 # comment\n10\n3 10\n", "mem.pgm");
  EXPECT_EQ(ok.pixels[1], 10);
}

// `image: /dev/zero` made make_nav_domain read until it held 2 GB (issue 12).
TEST(OccupancyGridErrors, SpecialFileImageIsRefused) {
  const std::string yaml = ::testing::TempDir() + "/devzero_map.yaml";
  {
    std::ofstream out(yaml);
    out << "image: /dev/zero\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
           "occupied_thresh: 0.65\nfree_thresh: 0.196\n";
  }
  try {
    loadMap(yaml);
    ADD_FAILURE() << "no error";
  } catch (const MapError& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/zero"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("expected a regular file"), std::string::npos)
        << e.what();
  }
  std::remove(yaml.c_str());
}

// The header decides the allocation, so it is checked against the budget first.
TEST(OccupancyGridErrors, ImageAboveMemoryBudgetIsRefused) {
  ::setenv("KRR_MEMORY_BUDGET_MIB", "1", 1);
  try {
    parsePgm("P5\n2000 2000\n255\n", "huge.pgm");
    ADD_FAILURE() << "no error";
  } catch (const MapError& e) {
    EXPECT_NE(std::string(e.what()).find("huge.pgm: PGM image 2000x2000 needs about 11.4 MiB"),
              std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("memory budget of 1 MiB"), std::string::npos) << e.what();
  }
  ::unsetenv("KRR_MEMORY_BUDGET_MIB");
  // Under the default budget the same header gets as far as the (missing) raster.
  EXPECT_THROW(parsePgm("P5\n2000 2000\n255\n", "huge.pgm"), MapError);
}
