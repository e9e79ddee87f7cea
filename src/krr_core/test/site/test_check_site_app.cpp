// check_site as a user runs it: the bundled configuration gives one summary line and status 0;
// a site whose files disagree gives every finding on stderr and status 1, nothing on stdout.
#include <gtest/gtest.h>

#include <string>

#include "krr_core/common/files.h"
#include "../support/nav_fixtures.h"
#include "../support/run_command.h"

namespace {

krr::test::CommandOutcome checkSite(const std::string& args, const std::string& tag) {
  return krr::test::runCommand("'" + std::string(KRR_CHECK_SITE) + "' " + args + " </dev/null",
                               ::testing::TempDir() + "/check_site_" + tag);
}

TEST(CheckSiteApp, TheBundledSiteGivesOneLineAndStatus0) {
  const auto r = checkSite("--root '" + krr_test::repoPath("") + "'", "bundled");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out.rfind("site consistent: ", 0), 0u) << r.out;
  EXPECT_EQ(r.out.find('\n'), r.out.size() - 1) << "one line: " << r.out;
  EXPECT_EQ(r.err, "");
}

TEST(CheckSiteApp, ABrokenSiteGivesEveryFindingAndStatus1) {
  // The bundled site with a stale synonym pair and a reasoner loading another file, in a copy.
  const std::string root = krr_test::tempDir("check_site_app");
  krr::makeDirectories(root + "/config");
  for (const char* f : {"navigation.yaml", "dialog.yaml", "office.plog"})
    krr::writeFileAtomic(root + "/config/" + f, krr::readFile(krr_test::repoPath("config/") + f));
  krr::writeFileAtomic(root + "/config/language.yaml",
                       "synonyms: {kitchen: galley, espresso: coffee, lobby: foyer}\n");
  krr::writeFileAtomic(root + "/config/reasoner_node.yaml", "domain_files: [config/x.plog]\n");
  // The places and the map stay the repository's.
  const std::string navigation = root + "/config/navigation.yaml";
  std::string text = krr::readFile(navigation);
  for (const std::string key : {"map: ", "places: "}) {
    const auto at = text.find("\n" + key) + 1 + key.size();
    text.insert(at, krr_test::repoPath("config") + "/");
  }
  krr::writeFileAtomic(navigation, text);

  const auto r = checkSite("--root '" + root + "'", "broken");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err.rfind("check_site: the site's files disagree (3 findings):", 0), 0u) << r.err;
  const std::string language = root + "/config/language.yaml";
  EXPECT_NE(r.err.find(language + ": field 'synonyms.kitchen': 'galley' is no item, room or "
                                  "person of "),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find(language + ": field 'synonyms.lobby': 'foyer'"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find(root + "/config/reasoner_node.yaml: field 'domain_files': value "
                              "'[config/x.plog]'"),
            std::string::npos)
      << r.err;
}

TEST(CheckSiteApp, ASiteFolderGivesItsNameAndSummaryOrEveryFinding) {
  const std::string root = "--root '" + krr_test::repoPath("") + "' ";
  const auto lab = checkSite(root + "--site '" + krr_test::repoPath("config/sites/lab") + "'", "lab");
  EXPECT_EQ(lab.status, 0) << lab.err;
  EXPECT_EQ(lab.out.rfind("lab: site consistent: 4 rooms with places (lab, kitchen, library, "
                          "studio), shop 'mailroom', 3 blocking areas",
                          0),
            0u)
      << lab.out;
  // A copy of the lab whose places file renamed the library: refused, nothing on stdout.
  const std::string dir = krr_test::tempDir("check_site_lab") + "/lab";
  krr::makeDirectories(dir);
  for (const char* f : {"site.yaml", "map.yaml", "map.pgm", "knowledge.plog", "language.yaml"})
    krr::writeFileAtomic(dir + "/" + f, krr::readFile(krr_test::repoPath("config/sites/lab/") + f));
  std::string places = krr::readFile(krr_test::repoPath("config/sites/lab/places.yaml"));
  places.replace(places.find("  library:"), 10, "  reading:");
  krr::writeFileAtomic(dir + "/places.yaml", places);
  const auto r = checkSite(root + "--site '" + dir + "'", "lab_broken");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_EQ(r.out, "");
  EXPECT_NE(r.err.find(dir + "/places.yaml: field 'places': no place 'library' for the room of "
                             "that name in " + dir + "/knowledge.plog (sort room); places that "
                             "are no room: reading"),
            std::string::npos)
      << r.err;
  // --site names every file: no file options with it (a usage error).
  EXPECT_EQ(checkSite(root + "--site x --language y", "lab_usage").status, 2);
}

}  // namespace
