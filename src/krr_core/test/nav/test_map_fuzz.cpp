// Seeded, bounded fuzzing of the map loaders (issue 12): a few thousand mutants of the test
// PGM images, map YAML files and places files must each load or fail with a typed krr::Error,
// with no signal, no hang past the time budget and no allocation beyond the memory cap
// (RLIMIT_AS in a forked child).
#include <gtest/gtest.h>
#include <unistd.h>

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

}  // namespace
