// site::Scaffold, the starter site folder of make_site: scaffolded from the lab's map and
// places with other people and items, the folder passes the site check, loads as a Site and
// cuts into its domain with every room reachable; the request prior is the lab's 8/10; the
// synonyms are built from the names; every bad option is refused naming the option and the
// value, and a refused run leaves no folder behind.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/dialog/language.h"
#include "krr_core/nav/grid_astar.h"
#include "krr_core/nav/nav_grid.h"
#include "krr_core/nav/occupancy_grid.h"
#include "krr_core/plog/reasoner.h"
#include "krr_core/site/scaffold.h"
#include "krr_core/site/site.h"
#include "../support/nav_fixtures.h"

namespace {

namespace fs = std::filesystem;
using krr::site::Scaffold;
using krr::site::ScaffoldOptions;

std::string config() { return fs::weakly_canonical(krr_test::repoPath("config")).string(); }
std::string lab() { return config() + "/sites/lab"; }

/// @brief The lab's map and places with other names, written to a fresh folder's "site".
ScaffoldOptions labOptions(const std::string& tag) {
  ScaffoldOptions o;
  o.map = lab() + "/map.yaml";
  o.places = lab() + "/places.yaml";
  o.people = {"ann", "ben_li"};
  o.items = {"juice", "cup", "glass"};  // cup, glass: ignored words of the lab's language file
  o.offices = {{"ann", "kitchen"}, {"ben_li", "studio"}};
  o.shop = "mailroom";
  o.cell = 0.5;
  o.out = krr_test::tempDir("scaffold_" + tag) + "/site";
  return o;
}

/// @brief The ConfigError message of scaffolding `o` ("" and a failure when it succeeds).
std::string refusal(const ScaffoldOptions& o) {
  try {
    Scaffold(o).write(config());
  } catch (const krr::ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "scaffolded " << o.out;
  return "";
}

/// @brief Nothing was left in the output's parent folder (no site, no temporary).
void expectNothingWritten(const ScaffoldOptions& o) {
  EXPECT_FALSE(fs::exists(o.out)) << o.out;
  EXPECT_TRUE(fs::is_empty(fs::path(o.out).parent_path())) << fs::path(o.out).parent_path();
}

void expectContains(const std::string& text, const std::string& part) {
  EXPECT_NE(text.find(part), std::string::npos) << "'" << part << "' not in: " << text;
}

TEST(Scaffold, TheLabsMapWithOtherNamesMakesAConsistentSite) {
  const ScaffoldOptions o = labOptions("ok");
  const Scaffold scaffold(o);
  EXPECT_EQ(scaffold.rooms(), (std::vector<std::string>{"studio", "lab", "kitchen", "library"}));
  ASSERT_EQ(scaffold.domains().size(), 1u);
  const krr::site::ScaffoldDomain d = scaffold.domains().front();
  EXPECT_EQ(d.name, "site_24x16");
  EXPECT_EQ(d.cols, 24);
  EXPECT_EQ(d.rows, 16);
  EXPECT_EQ(scaffold.routeMoves().at("library"), 27);  // the README's longest route
  EXPECT_EQ(d.step_limit, 140);                        // 5 x 27, rounded up to ten

  const krr::site::SiteReport report = scaffold.write(config());
  EXPECT_TRUE(report.consistent());
  EXPECT_EQ(report.shop, "mailroom");
  EXPECT_EQ(report.rooms.size(), 4u);
  for (const char* f : {"site.yaml", "map.yaml", "map.pgm", "places.yaml", "knowledge.plog",
                        "language.yaml"})
    EXPECT_TRUE(fs::is_regular_file(o.out + "/" + f)) << f;

  // What make_nav_domain --site does: the site loads, its map cuts into its domain, and every
  // room is reachable from the shop.
  const krr::site::Site site = krr::site::Site::load(o.out, config());
  EXPECT_EQ(site.shop(), "mailroom");
  EXPECT_EQ(site.experimentPlace("nav_transfer", "target"), "library");
  const krr::nav::DomainConfig& dc = site.navigation().domain("site_24x16");
  EXPECT_EQ(dc.step_limit, 140);
  krr::nav::NavGridOptions opt;
  opt.cols = dc.cols;
  opt.rows = dc.rows;
  const krr::nav::NavGrid grid = krr::nav::NavGrid::fromMap(
      krr::nav::loadMap(site.map()), krr::nav::loadPlaces(site.places()), opt);
  krr::nav::GridAStar astar(grid);
  for (const std::string& room : scaffold.rooms())
    EXPECT_NO_THROW(astar.plan(grid.placeCell("mailroom"), grid.placeCell(room))) << room;

  // make_site cut the domain already, exactly as make_nav_domain --site writes it
  // (site::writeDomain), so the folder runs as it is.
  ASSERT_TRUE(fs::is_regular_file(site.domainFile("site_24x16")));
  ASSERT_TRUE(fs::is_regular_file(site.geometry("site_24x16")));
  EXPECT_EQ(krr::readFile(site.domainFile("site_24x16")), grid.toYaml("site_24x16", "map.yaml"));
  EXPECT_EQ(krr::readFile(site.geometry("site_24x16")), grid.toPlog("site_24x16"));
  EXPECT_EQ(site.domainFile("site_24x16"), o.out + "/site_24x16.yaml");
  const std::string before = krr::readFile(site.geometry("site_24x16"));
  krr::site::writeDomain(site.navigation(), dc, krr::nav::loadMap(site.map()),
                         krr::nav::loadPlaces(site.places()));
  EXPECT_EQ(krr::readFile(site.geometry("site_24x16")), before);

  // The lab's request prior, with the site's names.
  krr::plog::Reasoner reasoner;
  reasoner.loadFile(site.knowledge());
  EXPECT_NEAR(reasoner.probability("?{curr_room(ann)=kitchen} | do(curr_person=ann)"), 0.8, 1e-9);
  EXPECT_NEAR(reasoner.probability("?{curr_room(ann)=lab} | do(curr_person=ann)"), 0.2 / 3, 1e-9);
}

TEST(Scaffold, SynonymsAreBuiltFromTheNames) {
  ScaffoldOptions o = labOptions("synonyms");
  // The lab's places renamed office_a-style: studio -> office_a, kitchen -> room2.
  std::string places = krr::readFile(o.places);
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"studio", "office_a"},
                                 {"kitchen", "room2"}}) {
    for (std::size_t at; (at = places.find(from)) != std::string::npos;)
      places.replace(at, from.size(), to);
  }
  o.places = krr_test::tempDir("scaffold_places") + "/places.yaml";
  std::ofstream(o.places) << places;
  o.offices = {{"ann", "room2"}, {"ben_li", "office_a"}};
  const Scaffold scaffold(o);
  const auto synonyms = scaffold.synonyms();
  const std::map<std::string, std::string> s(synonyms.begin(), synonyms.end());
  EXPECT_EQ(s.at("ann's office"), "room2");
  EXPECT_EQ(s.at("ben li's room"), "office_a");
  EXPECT_EQ(s.at("room a"), "office_a");
  EXPECT_EQ(s.count("office a"), 0u);  // the name itself, read with '_' as a space
  EXPECT_EQ(s.at("office2"), "room2");
  EXPECT_EQ(s.at("office two"), "room2");
  EXPECT_EQ(s.at("room two"), "room2");
  EXPECT_EQ(s.at("juices"), "juice");
  EXPECT_EQ(s.at("glasses"), "glass");
  // The language file loads with the knowledge: no phrase has two meanings (cup and glass, the
  // items, are no longer ignored words).
  const krr::dialog::LanguageConfig language =
      krr::dialog::parseLanguageConfig(scaffold.languageYaml(), "language.yaml");
  EXPECT_EQ(std::count(language.ignoreWords.begin(), language.ignoreWords.end(), "cup"), 0);
  const krr::dialog::LanguageFrontEnd front(
      {"juice", "cup", "glass"}, scaffold.rooms(), {"ann", "ben_li"}, language, "language.yaml");
  const krr::dialog::ParsedUtterance p = front.parse("Juices to Ben Li's office, or room two");
  EXPECT_TRUE(p.unknownWords.size() == 1 && p.unknownWords[0] == "or");
  ASSERT_EQ(p.mentions.size(), 3u);  // juice, office_a, room2
  EXPECT_EQ(p.mentions[1].phrase, "ben li office");
  EXPECT_EQ(scaffold.rooms()[p.mentions[1].index], "office_a");
  EXPECT_EQ(scaffold.rooms()[p.mentions[2].index], "room2");
  EXPECT_TRUE(scaffold.write(config()).consistent());
}

TEST(Scaffold, ABadOfficeRoomIsRefusedAndLeavesNoFolder) {
  ScaffoldOptions o = labOptions("bad_office");
  o.offices = {{"ann", "garage"}};
  const std::string m = refusal(o);
  expectContains(m, "--offices");
  expectContains(m, "ann:garage");
  expectContains(m, "not a room");
  expectNothingWritten(o);
}

TEST(Scaffold, EveryBadOptionIsRefusedNamingTheOptionAndTheValue) {
  const auto refused = [](const std::string& tag, auto change, const std::string& option,
                          const std::string& value) {
    ScaffoldOptions o = labOptions(tag);
    change(o);
    const std::string m = refusal(o);
    expectContains(m, option);
    expectContains(m, value);
    expectNothingWritten(o);
  };
  refused("shop", [](ScaffoldOptions& o) { o.shop = "garage"; }, "--shop", "'garage'");
  refused("shop_room", [](ScaffoldOptions& o) { o.rooms = {"lab", "mailroom"}; }, "--rooms",
          "'mailroom' is the shop");
  refused("office_shop", [](ScaffoldOptions& o) { o.offices = {{"ann", "mailroom"}}; },
          "--offices", "'mailroom' is the shop");
  refused("person", [](ScaffoldOptions& o) { o.offices = {{"zoe", "lab"}}; }, "--offices",
          "'zoe' is not a person");
  refused("two_offices",
          [](ScaffoldOptions& o) { o.offices = {{"ann", "lab"}, {"ann", "studio"}}; },
          "--offices", "already has an office");
  refused("dup", [](ScaffoldOptions& o) { o.items = {"juice", "ann"}; }, "--items",
          "'ann' is a duplicate name");
  refused("dup_place", [](ScaffoldOptions& o) { o.people = {"kitchen"}; }, "place",
          "'kitchen' is a duplicate name");
  refused("upper", [](ScaffoldOptions& o) { o.people = {"Ann"}; }, "--people",
          "'Ann' must be a P-log constant");
  refused("reserved", [](ScaffoldOptions& o) { o.items = {"room"}; }, "--items",
          "'room' is a symbol");
  refused("one_item", [](ScaffoldOptions& o) { o.items = {"juice"}; }, "--items",
          "'juice': 1 item: the dialog needs at least two");
  refused("one_person", [](ScaffoldOptions& o) {
    o.people = {"ann"};
    o.offices = {{"ann", "kitchen"}};
  }, "--people", "'ann': 1 person: the dialog needs at least two");
  refused("one_room", [](ScaffoldOptions& o) {
    o.rooms = {"lab"};
    o.offices = {};
  }, "--rooms", "'lab': 1 room(s) besides the shop 'mailroom': the dialog needs at least two");
  refused("cell", [](ScaffoldOptions& o) { o.cell = 0.7; }, "--cell", "does not divide the map");
  refused("no_domain", [](ScaffoldOptions& o) { o.cell = 0; }, "--domain", "--cell");
  refused("domain", [](ScaffoldOptions& o) {
    o.cell = 0;
    o.domains = {{"big", 100000, 16, 0}};
  }, "--domain", "'big'");
}

TEST(Scaffold, AnExistingFolderIsKeptUnlessForced) {
  ScaffoldOptions o = labOptions("force");
  fs::create_directories(o.out);
  std::ofstream(o.out + "/notes.txt") << "mine\n";
  const std::string m = refusal(o);
  expectContains(m, "--out");
  expectContains(m, "not empty (--force replaces it)");
  EXPECT_TRUE(fs::exists(o.out + "/notes.txt"));
  o.force = true;
  EXPECT_TRUE(Scaffold(o).write(config()).consistent());
  EXPECT_FALSE(fs::exists(o.out + "/notes.txt"));
  EXPECT_TRUE(fs::exists(o.out + "/site.yaml"));
  // Only the site is left beside it (no temporary, no old copy).
  EXPECT_EQ(std::distance(fs::directory_iterator(fs::path(o.out).parent_path()),
                          fs::directory_iterator()), 1);
}

TEST(Scaffold, AMapDrawnFromTextMakesAConsistentSite) {
  ScaffoldOptions o = labOptions("text");
  o.map = o.places = "";
  o.rooms_from_text = krr_test::tempDir("scaffold_text") + "/rooms.txt";
  std::ofstream(o.rooms_from_text) << "size 12 8\ncorridor 0 3 12 5\n"
                                      "room mailroom 0 0 4 3 door 1.1 2.4\n"
                                      "room studio 4 0 8 3 door 5.1 6.4\n"
                                      "room kitchen 4 5 8 8 door 5.1 6.4\n"
                                      "area hall 3 3 4.5 5\n";
  o.offices = {{"ann", "kitchen"}};
  const Scaffold scaffold(o);
  EXPECT_EQ(scaffold.rooms(), (std::vector<std::string>{"studio", "kitchen"}));
  EXPECT_TRUE(scaffold.write(config()).consistent());
  EXPECT_TRUE(fs::is_regular_file(o.out + "/map.pgm"));
  const krr::site::Site site = krr::site::Site::load(o.out, config());
  EXPECT_EQ(krr::nav::loadMap(site.map()).width, 240);
  EXPECT_EQ(krr::nav::loadPlaces(site.places()).areas.size(), 1u);

  // Either the text or a map and places; a door the corridor lacks names the text's line.
  ScaffoldOptions both = labOptions("both");
  both.rooms_from_text = o.rooms_from_text;
  expectContains(refusal(both), "--rooms-from-text");
  expectNothingWritten(both);
  ScaffoldOptions bad = labOptions("bad_text");
  bad.map = bad.places = "";
  bad.rooms_from_text = o.rooms_from_text + ".bad";
  std::ofstream(bad.rooms_from_text) << "size 12 8\nroom mailroom 0 0 4 3 door 1 2\n";
  const std::string m = refusal(bad);
  expectContains(m, "--rooms-from-text: " + bad.rooms_from_text + ":2:1: room mailroom: door");
  expectNothingWritten(bad);
}

TEST(Scaffold, OptionValuesParse) {
  const krr::site::ScaffoldDomain d =
      krr::site::parseScaffoldDomain("--domain", "b_40x24:40x24:300");
  EXPECT_EQ(d.name, "b_40x24");
  EXPECT_EQ(d.cols, 40);
  EXPECT_EQ(d.rows, 24);
  EXPECT_EQ(d.step_limit, 300);
  EXPECT_EQ(krr::site::parseScaffoldDomain("--domain", "b:4x2").step_limit, 0);
  for (const char* bad : {"b", "b:40", "b:40x", "b:x2", "b:4x2:0", "b/c:4x2", "b:4x2:1:2"})
    EXPECT_THROW(krr::site::parseScaffoldDomain("--domain", bad), krr::ConfigError) << bad;
  const auto offices = krr::site::parseOffices("--offices", "ann:lab,ben:studio");
  ASSERT_EQ(offices.size(), 2u);
  EXPECT_EQ(offices[1], (std::pair<std::string, std::string>{"ben", "studio"}));
  for (const char* bad : {"ann", "ann:", ":lab", "ann:lab:x", "ann:lab,"})
    EXPECT_THROW(krr::site::parseOffices("--offices", bad), krr::ConfigError) << bad;
  EXPECT_TRUE(krr::site::isSiteConstant("ben_li2"));
  for (const char* bad : {"", "Ann", "_x", "2b", "a-b", "not", "person", "true"})
    EXPECT_FALSE(krr::site::isSiteConstant(bad)) << bad;
}

}  // namespace
