// The site consistency check: a small site (a mailroom, two rooms, one blocking area) that is
// consistent, then one broken copy per rule; each finding must name the file, the field and the
// value, and all findings of a site come in one error. The bundled configuration passes.
#include <gtest/gtest.h>

#include <cctype>
#include <cstdio>
#include <map>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/site/site_check.h"
#include "../support/nav_fixtures.h"

namespace {

using krr::site::Finding;
using krr::site::SiteFiles;
using krr::site::SiteReport;

/// @brief The simulator settings navigation.yaml requires, before its `areas:`.
const char* const kSimulator =
    "simulator:\n  move_success: 0.9\n  slip_stay: 0.05\n  slip_lateral: 0.05\n"
    "  blocking_rate: 0.3\n  trap_probability: 0.1\n";

/// @brief The files of a small consistent site, by path under its root; a test edits one.
std::map<std::string, std::string> smallSite() {
  return {
      {"config/navigation.yaml",
       "map: ../maps/site.yaml\n"
       "places: ../maps/site_places.yaml\n"
       "domains:\n  site_10x6: {cols: 10, rows: 6, step_limit: 60}\n" +
           std::string(kSimulator) + "  areas:\n    hall: {time_of_day: {noon: 2.0}}\n"},
      {"maps/site_places.yaml",
       "places:\n"
       "  mailroom: {point: [0.5, 0.5]}\n"
       "  lab: {point: [8.5, 0.5]}\n"
       "  studio: {point: [8.5, 5.5]}\n"
       "blocking_areas:\n  hall: {rect: [4, 0, 6, 6]}\n"},
      {"config/site.plog",
       "boolean = {true, false}.\n"
       "person = {ada, max}.\n"
       "item = {tea, mail}.\n"
       "room = {lab, studio}.\n"},
      {"config/dialog.yaml",
       "navigation: {shop: mailroom}\n"
       "knowledge: {office: site.plog, speech: speech.plog}\n"},
      {"config/language.yaml",
       "synonyms:\n  laboratory: lab\n  \"ada's office\": lab\n  Chai: TEA\n"},
      {"config/reasoner_node.yaml", "seed: 1\ndomain_files: [config/site.plog]\n"},
  };
}

/// @brief The site written under a fresh root, with `edits` (path -> content) applied.
std::string writeSite(const std::map<std::string, std::string>& edits = {}) {
  const std::string root = krr_test::tempDir("site_check");
  std::map<std::string, std::string> files = smallSite();
  for (const auto& [path, text] : edits) files[path] = text;
  krr::makeDirectories(root + "/config");
  krr::makeDirectories(root + "/maps");
  for (const auto& [path, text] : files)
    if (!text.empty()) krr::writeFileAtomic(root + "/" + path, text);
  return root;
}

SiteReport check(const std::string& root) {
  return krr::site::checkSite(SiteFiles::inConfigDir(root + "/config"));
}

/// @brief The one finding of `report` (a test that breaks one thing expects one).
Finding only(const SiteReport& report) {
  std::string all;
  for (const Finding& f : report.findings) all += "\n  " + f.str();
  EXPECT_EQ(report.findings.size(), 1u) << all;
  return report.findings.empty() ? Finding{} : report.findings.front();
}

/// @brief The finding names file, field and value, in its fields and in its text.
void expectNames(const Finding& f, const std::string& file, const std::string& field,
                 const std::string& value) {
  EXPECT_EQ(f.file, file);
  EXPECT_EQ(f.field, field);
  EXPECT_EQ(f.value, value);
  const std::string text = f.str();
  EXPECT_EQ(text.rfind(file + ": field '" + field + "': ", 0), 0u) << text;
  EXPECT_NE(text.find("'" + value + "'"), std::string::npos) << text;
}

TEST(SiteCheck, TheSmallSiteIsConsistent) {
  const std::string root = writeSite();
  const SiteReport r = check(root);
  EXPECT_TRUE(r.consistent()) << (r.findings.empty() ? "" : r.findings[0].str());
  EXPECT_EQ(r.rooms, (std::vector<std::string>{"lab", "studio"}));
  EXPECT_EQ(r.shop, "mailroom");
  EXPECT_EQ(r.areas, std::vector<std::string>{"hall"});
  EXPECT_EQ(r.synonyms, 3u);
  EXPECT_NE(r.summary().find("2 rooms with places (lab, studio), shop 'mailroom', 1 blocking "
                             "areas (hall), 3 synonyms"),
            std::string::npos)
      << r.summary();
  EXPECT_NO_THROW(krr::site::requireConsistentSite(SiteFiles::inConfigDir(root + "/config")));
}

TEST(SiteCheck, ARoomWithoutAPlaceNamesThePlacesFileAndThePlacesThatAreNoRooms) {
  // "studio" renamed to "atelier" in the places file only.
  const std::string root = writeSite({{"maps/site_places.yaml",
                                       "places:\n"
                                       "  mailroom: {point: [0.5, 0.5]}\n"
                                       "  lab: {point: [8.5, 0.5]}\n"
                                       "  atelier: {point: [8.5, 5.5]}\n"
                                       "blocking_areas:\n  hall: {rect: [4, 0, 6, 6]}\n"}});
  const Finding f = only(check(root));
  expectNames(f, root + "/config/../maps/site_places.yaml", "places", "studio");
  EXPECT_NE(f.message.find(root + "/config/site.plog (sort room)"), std::string::npos)
      << f.message;
  EXPECT_NE(f.message.find("places that are no room: atelier"), std::string::npos) << f.message;
  EXPECT_EQ(f.message.find("mailroom"), std::string::npos) << "the shop is no room by design";
}

TEST(SiteCheck, ASortOfOneValueNamesTheKnowledgeAndTheSort) {
  // The speech model hears a wrong answer as another value: one item leaves it none.
  std::string knowledge = smallSite().at("config/site.plog");
  knowledge.replace(knowledge.find("item = {tea, mail}."), 19, "item = {tea}.");
  const std::string root = writeSite({{"config/site.plog", knowledge}});
  const Finding f = only(check(root));
  expectNames(f, root + "/config/site.plog", "sort item", "tea");
  EXPECT_NE(f.message.find("at least two values of each of item, room and person"),
            std::string::npos)
      << f.message;
}

TEST(SiteCheck, AShopThatIsNoPlaceNamesTheDialogConfig) {
  const std::string root = writeSite({{"config/dialog.yaml",
                                       "navigation: {shop: shop}\n"
                                       "knowledge: {office: site.plog, speech: speech.plog}\n"}});
  const Finding f = only(check(root));
  expectNames(f, root + "/config/dialog.yaml", "navigation.shop", "shop");
  EXPECT_NE(f.message.find("(places: mailroom, lab, studio)"), std::string::npos) << f.message;
}

TEST(SiteCheck, AShopGivenOnTheCommandLineNamesTheOption) {
  const std::string root = writeSite();
  SiteFiles files = SiteFiles::inConfigDir(root + "/config");
  files.shop = "kiosk";
  files.shop_source = "option --shop";
  const Finding f = only(krr::site::checkSite(files));
  EXPECT_EQ(f.str().rfind("option --shop: 'kiosk' is not a place of ", 0), 0u) << f.str();
  EXPECT_EQ(f.value, "kiosk");
}

TEST(SiteCheck, AStaleSimulatorAreaNamesTheNavigationConfigField) {
  // The office's ba1 override left in another building's navigation config.
  const std::string root = writeSite(
      {{"config/navigation.yaml",
        "map: ../maps/site.yaml\n"
        "places: ../maps/site_places.yaml\n"
        "domains:\n  site_10x6: {cols: 10, rows: 6, step_limit: 60}\n" + std::string(kSimulator) +
            "  areas:\n    hall: {rate: 0.2}\n    ba1: {time_of_day: {noon: 8.0}}\n"}});
  const Finding f = only(check(root));
  expectNames(f, root + "/config/navigation.yaml", "simulator.areas.ba1", "ba1");
  EXPECT_NE(f.message.find("(blocking areas: hall)"), std::string::npos) << f.message;
}

TEST(SiteCheck, EveryStaleSynonymIsListedInOneError) {
  const std::string root = writeSite({{"config/language.yaml",
                                       "synonyms:\n  laboratory: lab\n  office2: room2\n"
                                       "  cola: coke\n  robert: bob\n"}});
  const SiteReport r = check(root);
  ASSERT_EQ(r.findings.size(), 3u);
  const std::string file = root + "/config/language.yaml";
  // In phrase order (the language config's synonyms are a map by phrase).
  expectNames(r.findings[0], file, "synonyms.cola", "coke");
  expectNames(r.findings[1], file, "synonyms.office2", "room2");
  expectNames(r.findings[2], file, "synonyms.robert", "bob");
  EXPECT_NE(r.findings[0].message.find("(its names: tea, mail, lab, studio, ada, max)"),
            std::string::npos)
      << r.findings[0].message;
  try {
    krr::site::requireConsistentSite(SiteFiles::inConfigDir(root + "/config"));
    FAIL() << "no error for three stale synonyms";
  } catch (const krr::ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("(3 findings)"), std::string::npos) << what;
    for (const Finding& f : r.findings) EXPECT_NE(what.find(f.str()), std::string::npos) << what;
  }
}

TEST(SiteCheck, APhraseWithTwoMeaningsIsRefusedAsTheFrontEndWould) {
  const std::string root =
      writeSite({{"config/language.yaml", "yes: [yes, sure]\nsynonyms:\n  sure: lab\n"}});
  const Finding f = only(check(root));
  EXPECT_EQ(f.file, root + "/config/language.yaml");
  EXPECT_NE(f.message.find("sure"), std::string::npos) << f.message;
}

TEST(SiteCheck, AReasonerLoadingOtherKnowledgeNamesDomainFiles) {
  const std::string root = writeSite({{"config/reasoner_node.yaml",
                                       "domain_files: [config/office.plog]\n"},
                                      {"config/office.plog", "room = {room1}.\n"}});
  const Finding f = only(check(root));
  expectNames(f, root + "/config/reasoner_node.yaml", "domain_files", "[config/office.plog]");
  EXPECT_NE(f.message.find("knowledge.office " + root + "/config/site.plog"), std::string::npos)
      << f.message;
  EXPECT_NE(f.message.find("resolved against " + root), std::string::npos) << f.message;
}

TEST(SiteCheck, TheSameKnowledgeByAnotherPathIsTheSame) {
  const std::string root = writeSite(
      {{"config/reasoner_node.yaml",
        "domain_files: [config/geometry.plog, maps/../config/./site.plog]\n"}});
  EXPECT_TRUE(check(root).consistent());
  // A running reasoner hands over its parameters instead of the file.
  SiteFiles files = SiteFiles::inConfigDir(root + "/config");
  files.reasoner_config.clear();
  files.reasoner_domain_files = std::vector<std::string>{root + "/config/site.plog"};
  EXPECT_TRUE(krr::site::checkSite(files).consistent());
  files.reasoner_domain_files = std::vector<std::string>{root + "/maps/site.plog"};
  const Finding f = only(krr::site::checkSite(files));
  EXPECT_EQ(f.file, "reasoner parameters");
  EXPECT_EQ(f.field, "domain_files");
}

TEST(SiteCheck, AReasonerConfigWithoutDomainFilesLoadsTheDialogsKnowledge) {
  // Not set, the reasoner loads the dialog config's knowledge.office: one home of its name.
  const std::string root = writeSite({{"config/reasoner_node.yaml", "seed: 1\n"}});
  EXPECT_TRUE(check(root).consistent());
}

TEST(SiteCheck, EveryRuleReportsInOneRunAndAnUnreadableFileIsAFinding) {
  const std::string root = writeSite(
      {{"config/dialog.yaml", "navigation: {shop: shop}\nknowledge: {office: site.plog}\n"},
       {"config/language.yaml", "synonyms: {office5: room5, cola: coke}\n"},
       {"config/reasoner_node.yaml", "domain_files: [config/office.plog]\n"},
       {"maps/site_places.yaml", "places:\n  mailroom: {point: [0.5, 0.5]}\n"}});
  const SiteReport r = check(root);
  // shop, lab and studio without places, the stale hall override, 2 synonyms, the reasoner.
  std::string all;
  for (const Finding& f : r.findings) all += "\n  " + f.str();
  EXPECT_EQ(r.findings.size(), 7u) << all;
  // An unreadable language file: one finding naming it, the other rules still run.
  std::remove((root + "/config/language.yaml").c_str());
  const SiteReport r2 = check(root);
  EXPECT_EQ(r2.findings.size(), 6u);
  bool named = false;
  for (const Finding& f : r2.findings) named = named || f.file == root + "/config/language.yaml";
  EXPECT_TRUE(named);
}

TEST(SiteCheck, BrokenKnowledgeIsAFindingAtItsLine) {
  const std::string root =
      writeSite({{"config/site.plog", "person = {ada, max}.\nroom = {lab, studio\n"}});
  const SiteReport r = check(root);
  ASSERT_FALSE(r.findings.empty());
  const std::string text = r.findings.front().str();
  const std::string file = root + "/config/site.plog:";
  ASSERT_EQ(text.rfind(file, 0), 0u) << text;
  EXPECT_TRUE(std::isdigit(static_cast<unsigned char>(text[file.size()]))) << text;  // its line
  EXPECT_EQ(text.find(file, 1), std::string::npos) << "the file named once: " << text;
}

TEST(SiteCheck, TheBundledConfigurationPasses) {
  const std::string config = krr_test::repoPath("config");
  const SiteReport r = krr::site::requireConsistentSite(SiteFiles::inConfigDir(config));
  EXPECT_FALSE(r.rooms.empty());
  EXPECT_EQ(r.shop, krr::dialog::loadDialogConfig(config + "/dialog.yaml").shop);
  EXPECT_GT(r.synonyms, 0u);
  EXPECT_EQ(r.summary().rfind("site consistent: ", 0), 0u);
}

}  // namespace
