/**
 * @file check_site.cpp
 * @brief Check that a site's configuration files agree on its names (site/site_check.h).
 *
 *   check_site [--root DIR] [--navigation-config FILE] [--dialog-config FILE]
 *              [--language FILE] [--reasoner-config FILE] [--site DIR] [-h | --help]
 *
 * --site DIR checks a site folder (site/site.h) instead: its files, and ROOT/config's generic
 * settings under them.
 *
 * The files are those under ROOT/config the stack reads, each replaceable by its option. A
 * consistent site: one summary line on stdout, exit 0. Otherwise every finding, one per line
 * naming the file, the field and the value, on stderr and exit 1: a user fixing a building
 * sees all that is wrong at once, before anything is generated or started.
 */
#include <iostream>
#include <string>

#include "krr_core/common/cli.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/resource_locator.h"
#include "krr_core/common/errors.h"
#include "krr_core/site/site.h"
#include "krr_core/site/site_check.h"

/// @brief The program; main() runs it under guardedMain, which reports the findings' error.
static int mainBody(int argc, char** argv) {
  std::string root, navigation, dialog, language, reasoner, site_dir;
  krr::OptionParser parser(
      "check_site",
      "Check that the site's files agree: every room of the knowledge has a place, the shop\n"
      "is a place, simulator.areas are blocking areas of the map, every synonym names an\n"
      "item, room or person, and the reasoner loads the dialog's knowledge. Prints one line\n"
      "when they do; otherwise every finding (file, field, value) and exits 1.");
  parser.add("--root", "DIR", krr::kRepositoryRootHelp, &root);
  parser.add("--navigation-config", "FILE", "navigation config naming the map and the places",
             &navigation)
      .defaultText("ROOT/config/navigation.yaml");
  parser.add("--dialog-config", "FILE", "dialog config: navigation.shop, knowledge.office",
             &dialog)
      .defaultText("ROOT/config/dialog.yaml");
  parser.add("--language", "FILE", "language front end: synonyms", &language)
      .defaultText("ROOT/config/language.yaml");
  parser.add("--reasoner-config", "FILE",
             "reasoner node config: domain_files, relative to ROOT", &reasoner)
      .defaultText("ROOT/config/reasoner_node.yaml");
  parser.add("--site", "DIR",
             "a site folder (site.yaml, map, places, knowledge, language) over ROOT/config's "
             "generic settings, instead of the files above", &site_dir);
  if (const auto status = parser.parse(argc, argv, [&] {
        if (!site_dir.empty() &&
            !(navigation + dialog + language + reasoner).empty())
          throw krr::ConfigError("--site names every file of the site: no --navigation-config, "
                                 "--dialog-config, --language or --reasoner-config with it");
      }))
    return *status;
  const std::string dir = krr::findRepositoryRoot(root);
  if (!site_dir.empty()) {
    const krr::site::Site site = krr::site::Site::read(site_dir, dir + "/config");
    const std::string summary = krr::site::requireConsistentSite(site.files()).summary();
    std::cout << site.name() << ": " << summary << "\n";
    return 0;
  }
  krr::site::SiteFiles files = krr::site::SiteFiles::inConfigDir(dir + "/config");
  files.root = dir;
  if (!navigation.empty()) files.navigation_config = navigation;
  if (!dialog.empty()) files.dialog_config = dialog;
  if (!language.empty()) files.language_config = language;
  if (!reasoner.empty()) files.reasoner_config = reasoner;
  std::cout << krr::site::requireConsistentSite(files).summary() << "\n";
  return 0;
}

int main(int argc, char** argv) { return krr::guardedMain("check_site", mainBody, argc, argv); }
