// site::Site, the one loader of a site folder: the bundled sites load with their own names over
// the base configuration, and a broken folder (no folder, no manifest, a missing file, a bad
// field, a stale name) is refused with a ConfigError naming the file, the field and the value.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_core/site/site.h"
#include "../support/nav_fixtures.h"

namespace {

namespace fs = std::filesystem;
using krr::site::Site;

std::string config() { return fs::weakly_canonical(krr_test::repoPath("config")).string(); }

/// @brief A copy of the bundled lab site in a fresh directory, for a test to break.
std::string labCopy(const std::string& tag) {
  const std::string dir = krr_test::tempDir("site_" + tag) + "/lab";
  fs::copy(config() + "/sites/lab", dir, fs::copy_options::recursive);
  return dir;
}

void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

std::string readText(const std::string& path) { return krr::readFile(path); }

/// @brief The ConfigError message of loading `dir` ("" and a test failure when it loads).
std::string refusal(const std::string& dir) {
  try {
    Site::load(dir, config());
  } catch (const krr::ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << dir << " loaded";
  return "";
}

void expectNames(const std::string& message, const std::vector<std::string>& parts) {
  for (const std::string& p : parts)
    EXPECT_NE(message.find(p), std::string::npos) << "'" << p << "' not in: " << message;
}

TEST(Site, TheLabLoadsWithItsOwnNamesOverTheBaseSettings) {
  const Site lab = Site::load(config() + "/sites/lab", config());
  const krr::nav::NavigationConfig base = krr::nav::loadNavigationConfig(config() + "/navigation.yaml");
  EXPECT_EQ(lab.name(), "lab");
  EXPECT_EQ(lab.shop(), "mailroom");
  EXPECT_EQ(lab.map(), lab.dir() + "/map.yaml");
  EXPECT_EQ(lab.places(), lab.dir() + "/places.yaml");
  EXPECT_EQ(lab.knowledge(), lab.dir() + "/knowledge.plog");
  EXPECT_EQ(lab.dialog().office_plog, lab.knowledge());
  EXPECT_EQ(lab.language(), lab.dir() + "/language.yaml");
  ASSERT_EQ(lab.navigation().domains.size(), 1u);
  EXPECT_EQ(lab.navigation().defaultDomain().name, "lab_24x16");
  EXPECT_EQ(lab.geometry("lab_24x16"), lab.dir() + "/lab_24x16_geometry.plog");
  EXPECT_EQ(lab.domainFile("lab_24x16"), lab.dir() + "/lab_24x16.yaml");
  EXPECT_THROW(lab.geometry("office_30x30"), krr::UnknownSymbolError);
  // The base's per-area overrides are the office's areas: only the lab's own remain.
  ASSERT_EQ(lab.navigation().simulator.areas.size(), 1u);
  EXPECT_EQ(lab.navigation().simulator.areas.begin()->first, "hall_mid");
  // Everything generic is the base's.
  EXPECT_EQ(lab.navigation().simulator.blocking_rate, base.simulator.blocking_rate);
  EXPECT_EQ(lab.navigation().planning.step_cost, base.planning.step_cost);
  EXPECT_EQ(lab.experimentPlace("nav_transfer", "target"), "library");
  EXPECT_EQ(lab.experimentPlace("new_circumstances", "start"), "");
  // The reasoner loads the site's knowledge: the check's rule 5 holds by construction.
  ASSERT_TRUE(lab.files().reasoner_domain_files);
  EXPECT_EQ(lab.files().reasoner_domain_files->front(), lab.knowledge());
}

TEST(Site, TheOfficeSiteIsTheBaseConfiguration) {
  const Site office = Site::load(config() + "/sites/office", config());
  const krr::nav::NavigationConfig base = krr::nav::loadNavigationConfig(config() + "/navigation.yaml");
  const krr::dialog::DialogConfig dialog = krr::dialog::loadDialogConfig(config() + "/dialog.yaml");
  EXPECT_EQ(office.map(), fs::weakly_canonical(base.map).string());
  EXPECT_EQ(office.shop(), dialog.shop);
  EXPECT_EQ(office.knowledge(), fs::weakly_canonical(dialog.office_plog).string());
  ASSERT_EQ(office.navigation().domains.size(), base.domains.size());
  EXPECT_EQ(office.navigation().defaultDomain().name, base.defaultDomain().name);
  EXPECT_EQ(office.navigation().simulator.areas.size(), base.simulator.areas.size());
  EXPECT_EQ(office.geometry(base.defaultDomain().name),
            fs::weakly_canonical(krr_test::repoPath("maps")).string() + "/" +
                base.defaultDomain().name + "_geometry.plog");
}

TEST(Site, AFolderWithoutAManifestIsRefused) {
  expectNames(refusal(krr_test::tempDir("site_none") + "/nowhere"), {"nowhere", "no such directory"});
  const std::string empty = krr_test::tempDir("site_empty");
  expectNames(refusal(empty), {empty, "no site.yaml"});
}

TEST(Site, AMissingFileNamesTheFieldAndThePath) {
  const std::string dir = labCopy("missing");
  fs::remove(dir + "/knowledge.plog");
  expectNames(refusal(dir), {dir + "/site.yaml", "field 'knowledge'", "knowledge.plog",
                             "no file"});
  write(dir + "/site.yaml", readText(dir + "/site.yaml") + "knowledge: people.plog\n");
  expectNames(refusal(dir), {"field 'knowledge'", "value 'people.plog'"});
  // The map's image: the map loader's error names the map file and the image.
  const std::string lab = labCopy("image");
  fs::remove(lab + "/map.pgm");
  try {
    Site::load(lab, config());
    ADD_FAILURE() << "loaded without its image";
  } catch (const krr::MapError& e) {
    expectNames(e.what(), {"map.pgm"});
  }
}

TEST(Site, AnUnknownOrMalformedFieldIsRefused) {
  const std::string dir = labCopy("fields");
  const std::string good = readText(dir + "/site.yaml");
  write(dir + "/site.yaml", good + "rooms: [lab]\n");
  expectNames(refusal(dir), {"site.yaml", "rooms"});
  std::string tours = good;
  tours.replace(tours.find("nav_transfer:"), 13, "tours:");
  write(dir + "/site.yaml", tours);
  expectNames(refusal(dir), {"experiments.tours", "unknown experiment"});
  std::string text = good;
  text.replace(text.find("cols: 24"), 8, "cols: -3");
  write(dir + "/site.yaml", text);
  expectNames(refusal(dir), {"site.yaml", "domains.lab_24x16", "cols", "-3"});
}

TEST(Site, AnotherMapNeedsItsShopAndDomains) {
  const std::string dir = labCopy("inherit");
  const std::string good = readText(dir + "/site.yaml");
  std::string text = good;
  text.erase(text.find("shop: mailroom"), std::string("shop: mailroom").size());
  write(dir + "/site.yaml", text);
  expectNames(refusal(dir), {"site.yaml", "missing field 'shop'"});
  text = good;
  text.erase(text.find("domains:"), text.find("# Per-area") - text.find("domains:"));
  write(dir + "/site.yaml", text);
  expectNames(refusal(dir), {"site.yaml", "missing field 'domains'", "map.yaml"});
}

TEST(Site, AStaleNameIsRefusedWithEveryFinding) {
  const std::string dir = labCopy("stale");
  // A room renamed in the knowledge only, a stale synonym, a shop that is no place, an area
  // override of an area the map lacks, an experiment place the map lacks.
  std::string plog = readText(dir + "/knowledge.plog");
  plog.replace(plog.find("room = {lab,"), 12, "room = {lab2,");
  plog.replace(plog.find("place(carol, lab)"), 17, "place(carol, lab2)");
  write(dir + "/knowledge.plog", plog);
  std::string manifest = readText(dir + "/site.yaml");
  manifest.replace(manifest.find("shop: mailroom"), 14, "shop: postroom");
  manifest.replace(manifest.find("hall_mid:"), 9, "ba1:");
  write(dir + "/site.yaml", manifest);
  const std::string message = refusal(dir);
  expectNames(message, {"places.yaml: field 'places': no place 'lab2'",
                        "field 'shop': 'postroom' is not a place",
                        "field 'areas.ba1'", "'ba1' is not a blocking area",
                        "language.yaml: field 'synonyms.laboratory': 'lab' is no item, room or "
                        "person"});
  // With the names fixed, an experiment place the map lacks is named too.
  const std::string lab = labCopy("experiment");
  std::string m = readText(lab + "/site.yaml");
  m.replace(m.find("target: library"), 15, "target: attic");
  write(lab + "/site.yaml", m);
  expectNames(refusal(lab), {"field 'experiments.nav_transfer.target'", "value 'attic'"});
}

}  // namespace

// site::writeDomain, the one writer of a domain's files: the bundled lab's committed files are
// exactly what it writes, and a name that is no file name is refused before anything is written.
TEST(Site, WriteDomainWritesTheCommittedFilesAndRefusesABadName) {
  const std::string dir = labCopy("write_domain");
  const Site site = Site::load(dir, config());
  const krr::nav::NavigationConfig& nav = site.navigation();
  const krr::nav::OccupancyGrid map = krr::nav::loadMap(nav.map);
  const krr::nav::PlacesFile places = krr::nav::loadPlaces(nav.places);
  fs::remove(site.geometry("lab_24x16"));
  fs::remove(site.domainFile("lab_24x16"));
  krr::site::writeDomain(nav, nav.domain("lab_24x16"), map, places);
  const std::string lab = config() + "/sites/lab/";
  EXPECT_EQ(readText(site.geometry("lab_24x16")), readText(lab + "lab_24x16_geometry.plog"));
  EXPECT_EQ(readText(site.domainFile("lab_24x16")), readText(lab + "lab_24x16.yaml"));

  krr::nav::DomainConfig bad = nav.domain("lab_24x16");
  bad.name = "../escape";
  EXPECT_THROW(krr::site::writeDomain(nav, bad, map, places), krr::ConfigError);
  EXPECT_FALSE(fs::exists(fs::path(dir).parent_path() / "escape.yaml"));
  EXPECT_FALSE(fs::exists(fs::path(dir).parent_path() / "escape_geometry.plog"));
}
