// Seeded, bounded fuzzing of the map loaders (issue 12): a few thousand mutants of the test
// PGM and PNG images, map YAML and places files must each load or fail with a typed krr::Error,
// with no signal, no hang past the time budget and no allocation beyond the memory cap
// (RLIMIT_AS in a forked child).
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "../common/fuzz_support.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/nav/nav_grid.h"
#include "krr_core/nav/occupancy_grid.h"

using namespace krr;
using namespace krr::nav;

namespace {

const std::string kDir = std::string(KRR_TEST_DATA_DIR) + "/nav/";
constexpr std::size_t kMutants = 5000;
constexpr std::uint64_t kSeed = 20261202;

enum Target { kPgm = 0, kMapYaml = 1, kPlaces = 2 };

struct Mutant {
  Target target;
  std::string text;
};

std::vector<Mutant> mutants() {
  const std::vector<std::string> pgms = {readFile(kDir + "tiny_3x2.pgm"),
                                         readFile(kDir + "tiny_3x2_max15.pgm"),
                                         readFile(kDir + "astar_wall.pgm"),
                                         readFile(kDir + "navgrid_door.pgm"),
                                         readFile(kDir + "tiny_3x2_p5.pgm")};
  // Absolute image path: the mutant YAML is written to a temporary directory.
  std::string yaml = readFile(kDir + "tiny_3x2.yaml");
  yaml.replace(yaml.find("tiny_3x2.pgm"), 12, kDir + "tiny_3x2.pgm");
  const std::vector<std::string> places = {
      readFile(kDir + "navgrid_places.yaml"),
      readFile(std::string(KRR_TEST_DATA_DIR) + "/../../../../maps/office_places.yaml")};
  const std::vector<std::string> pgm_dict = {"P5\n", "P2\n", "#c\n", " 65535 ", " 0 ", "\n"};
  const std::vector<std::string> yaml_dict = {
      "image: /dev/zero\n", "image: ", "{", "}", "[", "]", ": ", "- ", "\n", "mode: raw\n",
      "negate: 1\n", "places:", "blocking_areas:", "point:", "room:", "rect:", "&a ", "*a",
      "blocking_areas_typo:", "!!binary ", "\"", "'"};
  std::mt19937_64 rng(kSeed);
  std::vector<Mutant> out;
  for (std::size_t i = 0; i < kMutants; ++i) {
    const Target t = static_cast<Target>(i % 3);
    if (t == kPgm) {
      out.push_back({t, fuzz::mutate(pgms[(i / 3) % pgms.size()], rng, pgm_dict)});
    } else if (t == kMapYaml) {
      out.push_back({t, fuzz::mutate(yaml, rng, yaml_dict)});
    } else {
      out.push_back({t, fuzz::mutate(places[(i / 3) % places.size()], rng, yaml_dict)});
    }
  }
  return out;
}

/// @brief Load one mutant the way make_nav_domain would; typed errors are fine.
void loadQuietly(const Mutant& m, const std::string& scratch) {
  try {
    if (m.target == kPgm) {
      imageToGrid(parsePgm(m.text, "mutant.pgm"), MapMetadata());
      return;
    }
    {
      std::ofstream out(scratch, std::ios::binary | std::ios::trunc);
      out << m.text;
    }
    if (m.target == kMapYaml) {
      loadMap(scratch);
    } else {
      placesToYaml(loadPlaces(scratch));
    }
  } catch (const Error&) {
  }
}

TEST(MapFuzz, MutantsLoadOrGiveTypedErrors) {
  const std::vector<Mutant> inputs = mutants();
  const std::string scratch = ::testing::TempDir() + "/map_fuzz_" + std::to_string(::getpid());
  ::setenv("KRR_MEMORY_BUDGET_MIB", "64", 1);  // the loaders' own budget, below the RLIMIT_AS cap
  const auto t0 = std::chrono::steady_clock::now();
  const fuzz::Report r = fuzz::runIsolated(
      inputs.size(), [&](std::size_t i) { loadQuietly(inputs[i], scratch); },
      std::size_t(512) << 20, 10.0);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ::unsetenv("KRR_MEMORY_BUDGET_MIB");
  std::remove(scratch.c_str());
  std::printf("[ fuzz     ] %zu map mutants in %.2f s (seed %llu)\n", r.mutants, secs,
              static_cast<unsigned long long>(kSeed));
  if (r.failed_index >= 0) {
    const std::string path = ::testing::TempDir() + "/map_fuzz_failure_target" +
                             std::to_string(r.failed_index % 3);
    std::ofstream(path, std::ios::binary) << inputs[static_cast<std::size_t>(r.failed_index)].text;
    FAIL() << "mutant " << r.failed_index << ": " << r.failure << "; input saved to " << path;
  }
  EXPECT_EQ(r.mutants, inputs.size());
  EXPECT_LT(secs, 60.0);
}

// ---- PNG (issue 14) ----

/// @brief Big-endian 32-bit number at s[at].
std::uint32_t be32(const std::string& s, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t k = 0; k < 4; ++k) v = (v << 8) | static_cast<unsigned char>(s[at + k]);
  return v;
}

std::string putBe32(std::uint32_t v) {
  std::string out(4, '\0');
  for (int k = 0; k < 4; ++k) out[k] = static_cast<char>((v >> (24 - 8 * k)) & 0xff);
  return out;
}

/// @brief One PNG chunk with its CRC.
std::string pngChunk(const std::string& type, const std::string& data) {
  const std::string body = type + data;
  const uLong crc = crc32(0L, reinterpret_cast<const Bytef*>(body.data()),
                          static_cast<uInt>(body.size()));
  return putBe32(static_cast<std::uint32_t>(data.size())) + body +
         putBe32(static_cast<std::uint32_t>(crc));
}

/// @brief Recompute the CRC of every complete chunk, so that a mutant gets past the CRC check
/// into libpng's header, palette and pixel handling.
std::string fixCrcs(std::string png) {
  std::size_t pos = 8;
  while (pos + 12 <= png.size()) {
    const std::uint32_t n = be32(png, pos);
    if (n > png.size() - pos - 12) break;
    const std::string body = png.substr(pos + 4, 4 + n);
    const uLong crc = crc32(0L, reinterpret_cast<const Bytef*>(body.data()),
                            static_cast<uInt>(body.size()));
    png.replace(pos + 8 + n, 4, putBe32(static_cast<std::uint32_t>(crc)));
    pos += 12 + n;
  }
  return png;
}

/// @brief Mutate the decompressed scanlines (filter bytes, lengths) and compress them again into
/// a well-formed PNG: this reaches the row decoding that byte flips in deflate data rarely do.
std::string mutateRaster(const std::string& png, std::mt19937_64& rng) {
  std::string head;
  std::string idat;
  std::size_t pos = 8;
  while (pos + 12 <= png.size()) {
    const std::uint32_t n = be32(png, pos);
    const std::string type = png.substr(pos + 4, 4);
    if (type == "IDAT") {
      idat += png.substr(pos + 8, n);
    } else if (type != "IEND") {
      head += png.substr(pos, 12 + n);
    }
    pos += 12 + n;
  }
  std::string raw(1 << 20, '\0');
  uLongf raw_len = raw.size();
  if (uncompress(reinterpret_cast<Bytef*>(&raw[0]), &raw_len,
                 reinterpret_cast<const Bytef*>(idat.data()), idat.size()) != Z_OK) {
    return png;
  }
  raw.resize(raw_len);
  if (rng() % 4 == 0) {  // lengths and filter bytes
    raw = fuzz::mutate(raw, rng, {std::string(1, '\x05'), std::string(1, '\xff'), "\x04\x04"});
  } else if (!raw.empty()) {  // pixel values only (mostly): the image still decodes
    for (int k = 1 + static_cast<int>(rng() % 4); k > 0; --k) {
      raw[rng() % raw.size()] = static_cast<char>(rng() & 0xff);
    }
  }
  std::string packed(compressBound(raw.size()), '\0');
  uLongf packed_len = packed.size();
  compress(reinterpret_cast<Bytef*>(&packed[0]), &packed_len,
           reinterpret_cast<const Bytef*>(raw.data()), raw.size());
  packed.resize(packed_len);
  return png.substr(0, 8) + head + pngChunk("IDAT", packed) + pngChunk("IEND", "");
}

TEST(MapFuzz, PngMutantsLoadOrGiveTypedErrors) {
  constexpr std::size_t kPngMutants = 3000;
  std::vector<std::string> seeds;
  for (const char* f : {"png_rgb", "png_gray1", "png_gray16", "png_palette_trns", "png_palette4",
                        "png_interlaced", "png_gray_alpha16", "png_rgba", "ms_testmap",
                        "turtlebot3_map_png"}) {
    seeds.push_back(readFile(kDir + f + ".png"));
  }
  const std::vector<std::string> dict = {
      "IHDR", "PLTE", "tRNS", "IDAT", "IEND", "zTXt", "iCCP", std::string("\0\0\0\0", 4),
      std::string("\xff\xff\xff\xff", 4), std::string("\x10\x06\x01", 3), std::string(1, '\x03')};
  std::mt19937_64 rng(kSeed + 14);
  std::vector<std::string> inputs;
  for (std::size_t i = 0; i < kPngMutants; ++i) {
    const std::string& seed = seeds[i % seeds.size()];
    switch (i % 3) {
      case 0:
        inputs.push_back(fuzz::mutate(seed, rng, dict));  // most die at a CRC
        break;
      case 1:
        inputs.push_back(fixCrcs(fuzz::mutate(seed, rng, dict)));
        break;
      default:
        inputs.push_back(mutateRaster(seed, rng));
        break;
    }
  }
  auto decode = [&](std::size_t i) {
    MapMetadata m;
    m.mode = static_cast<MapMode>(i % 3);
    imageToGrid(parseImage(inputs[i], "mutant.png"), m);
  };
  ::setenv("KRR_MEMORY_BUDGET_MIB", "64", 1);
  const auto t0 = std::chrono::steady_clock::now();
  const fuzz::Report r = fuzz::runIsolated(
      inputs.size(),
      [&](std::size_t i) {
        try {
          decode(i);
        } catch (const Error&) {
        }
      },
      std::size_t(512) << 20, 10.0);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (r.failed_index >= 0) {
    const std::string path = ::testing::TempDir() + "/map_fuzz_failure.png";
    std::ofstream(path, std::ios::binary) << inputs[static_cast<std::size_t>(r.failed_index)];
    ::unsetenv("KRR_MEMORY_BUDGET_MIB");
    FAIL() << "PNG mutant " << r.failed_index << ": " << r.failure << "; input saved to " << path;
  }
  // No mutant crashed in the children, so count the outcomes here: the campaign is only worth
  // something if many mutants get past the signature and CRCs into pixel decoding.
  std::size_t loaded = 0;
  std::size_t in_pixels = 0;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    try {
      decode(i);
      ++loaded;
    } catch (const Error& e) {
      if (std::string(e.what()).find("corrupt PNG data") != std::string::npos) ++in_pixels;
    }
  }
  ::unsetenv("KRR_MEMORY_BUDGET_MIB");
  std::printf("[ fuzz     ] %zu PNG mutants in %.2f s (seed %llu): %zu load, %zu fail while "
              "decoding pixels, %zu earlier\n", r.mutants, secs,
              static_cast<unsigned long long>(kSeed + 14), loaded, in_pixels,
              inputs.size() - loaded - in_pixels);
  EXPECT_GT(loaded, inputs.size() / 10);
  EXPECT_GT(loaded + in_pixels, inputs.size() / 2);
  EXPECT_EQ(r.mutants, inputs.size());
  EXPECT_LT(secs, 60.0);
}

}  // namespace
