/**
 * @file make_site.cpp
 * @brief Generate a starter site folder (site/scaffold.h) from a map, a places file and the
 * building's names, so that a new building starts from files that already agree.
 *
 *   make_site (--map FILE --places FILE | --rooms-from-text FILE) --people A,B --items X,Y
 *             --shop PLACE
 *             [--offices PERSON:ROOM,...] [--rooms R,...]
 *             (--domain NAME:COLSxROWS[:STEP_LIMIT] ... | --cell METRES)
 *             --out DIR [--force] [--root DIR] [-h | --help]
 *
 * Every option is validated before anything is written (an error names the option and the
 * value); the folder is written atomically and checked with the site consistency check, whose
 * one line is printed. Its domains are cut too (<domain>.yaml and <domain>_geometry.plog), so
 * the stack runs on it at once; after editing its map, places or domains, `make_nav_domain
 * --site DIR` cuts them again.
 */
#include <iostream>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/resource_locator.h"
#include "krr_core/site/scaffold.h"
#include "krr_core/site/site_check.h"

namespace {

/// @brief A comma-separated list option; every element non-empty.
krr::OptionParser::Setter listSetter(const std::string& option, std::vector<std::string>* out) {
  return [option, out](const std::string& value) {
    for (const std::string& v : krr::splitOption(value)) {
      if (v.empty())
        throw krr::ConfigError(option + ": value '" + value + "' has an empty name");
      out->push_back(v);
    }
  };
}

}  // namespace

/// @brief The program; main() runs it under guardedMain, which reports a refusal.
static int mainBody(int argc, char** argv) {
  krr::site::ScaffoldOptions o;
  std::string root;
  krr::OptionParser parser(
      "make_site",
      "Write a starter site folder: site.yaml, copies of the map and the places, knowledge.plog\n"
      "(people, items, rooms, offices, the request prior) and language.yaml (synonyms such as\n"
      "\"carol's office\"), then check it. Next: make_nav_domain --site DIR.");
  parser.add("--map", "FILE", "map_server YAML (its PGM or PNG image is copied too)", &o.map);
  parser.add("--places", "FILE", "places and blocking areas (config/sites/lab/places.yaml format)",
             &o.places);
  parser.add("--rooms-from-text", "FILE",
             "instead of --map and --places: draw them from a room / corridor description "
             "(size W H; corridor X0 Y0 X1 Y1; room NAME X0 Y0 X1 Y1 [door A B] [at X Y]; "
             "area NAME X0 Y0 X1 Y1)", &o.rooms_from_text);
  parser.add("--people", "NAME,...", "the people who order deliveries",
             listSetter("--people", &o.people))
      .required();
  parser.add("--items", "NAME,...", "the items delivered", listSetter("--items", &o.items))
      .required();
  parser.add("--offices", "PERSON:ROOM,...", "where each person works (one room each)",
             [&o](const std::string& v) {
               for (auto& p : krr::site::parseOffices("--offices", v)) o.offices.push_back(p);
             });
  parser.add("--shop", "PLACE", "the place every delivery starts from (no room)", &o.shop)
      .required();
  parser.add("--rooms", "NAME,...", "the rooms", listSetter("--rooms", &o.rooms))
      .defaultText("every place but the shop");
  parser.add("--domain", "NAME:COLSxROWS[:STEP_LIMIT]",
             "a navigation domain (repeatable); the step limit defaults to 5 x the longest "
             "route from the shop",
             [&o](const std::string& v) {
               o.domains.push_back(krr::site::parseScaffoldDomain("--domain", v));
             });
  parser.add("--cell", "METRES", "instead of --domain: one domain <DIR name>_<cols>x<rows> of "
             "square cells of this size (it must divide the map)", &o.cell)
      .defaultText("");
  parser.add("--out", "DIR", "the site folder to write (refused if it exists and is not empty)",
             &o.out)
      .required();
  parser.flag("--force", "replace a non-empty --out folder", &o.force);
  parser.add("--root", "DIR", krr::kRepositoryRootHelp, &root);
  if (const auto status = parser.parse(argc, argv)) return *status;
  const krr::site::Scaffold scaffold(o);
  const krr::site::SiteReport report = scaffold.write(krr::findRepositoryRoot(root) + "/config");
  std::cout << o.out << ": " << report.summary() << "\n";
  std::cout << "domains cut:";
  for (const krr::site::ScaffoldDomain& d : scaffold.domains())
    std::cout << " " << d.name << " (" << d.cols << "x" << d.rows << ", step limit "
              << d.step_limit << ")";
  std::cout << "\nnext: roslaunch krr_ros sim.launch site:=" << o.out
            << " (after editing its map, places or domains: make_nav_domain --site " << o.out
            << ")\n";
  return 0;
}

int main(int argc, char** argv) { return krr::guardedMain("make_site", mainBody, argc, argv); }
