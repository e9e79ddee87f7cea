/**
 * @file scaffold.h
 * @brief A starter site folder (site.h) generated from a map, a places file and the building's
 * names, so that a new building starts from files that already agree instead of a renamed copy.
 *
 * Input (the options of the make_site program, whose names the errors use):
 *   --map FILE        map_server YAML (+ its PGM or PNG image)
 *   --places FILE     places and blocking areas (the lab's places.yaml format)
 *   --people, --items the knowledge's persons and items
 *   --offices         PERSON:ROOM, where each person works (at most one room per person)
 *   --shop PLACE      where deliveries start: a place that is no room
 *   --rooms           the rooms (default: every place but the shop)
 *   --domain NAME:COLSxROWS[:STEP_LIMIT]  a navigation domain (repeatable), or
 *   --cell METRES     one domain of square cells of that size (the map must divide evenly)
 *   --rooms-from-text FILE  instead of --map and --places: a map drawn from a room / corridor
 *                     description (floor_plan.h)
 *
 * Output, the files of a site folder: site.yaml (shop, domains, the navigation experiments'
 * places), map.yaml + map.<ext> and places.yaml (copies, or the drawn map as map.pgm),
 * knowledge.plog (the lab's structure: sorts, offices as place(P, R), the request prior
 * pr(curr_room(P)=R | place(P,R)=true) = 8/10, the request and serve attributes) and
 * language.yaml (the lab's word lists, minus any word that is a name of the building, and
 * synonyms built from the names, see Scaffold::synonyms()).
 *
 * Everything is validated before a file is written; an error is a ConfigError naming the
 * option and the value. A step limit not given is derived: 5 x the longest shortest route
 * from the shop at that grid, rounded up to ten (the README's "a few times the longest
 * route"), and every room must be reachable from the shop on every domain's grid. write()
 * builds the folder in a temporary sibling directory, checks it with the site consistency check
 * (site_check.h), cuts its domains as make_nav_domain does (site::writeDomain), and renames it
 * into place, so that a refused or failed run leaves nothing and a written folder runs as it is.
 */
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "krr_core/nav/nav_grid.h"
#include "krr_core/nav/occupancy_grid.h"
#include "krr_core/site/site_check.h"

namespace krr {
namespace site {

/// @brief One navigation domain of the scaffold; step_limit 0 = derive it from the routes.
struct ScaffoldDomain {
  std::string name;
  int cols = 0;
  int rows = 0;
  int step_limit = 0;
};

/// @brief What the scaffold is made from (the make_site options, see the file comment).
struct ScaffoldOptions {
  std::string map;
  std::string places;
  std::string rooms_from_text;  ///< a floor_plan.h description instead of map and places
  std::vector<std::string> people;
  std::vector<std::string> items;
  std::vector<std::pair<std::string, std::string>> offices;  ///< person -> room, in order
  std::string shop;
  std::vector<std::string> rooms;        ///< empty: every place but the shop
  std::vector<ScaffoldDomain> domains;   ///< or `cell`
  double cell = 0;                       ///< > 0: one domain of cell x cell metres
  std::string out;                       ///< the site folder to write
  bool force = false;                    ///< replace a non-empty `out`
};

/// @brief "NAME:COLSxROWS[:STEP_LIMIT]" of option `option`. @throws ConfigError naming it.
ScaffoldDomain parseScaffoldDomain(const std::string& option, const std::string& value);
/// @brief "PERSON:ROOM,..." of option `option`. @throws ConfigError naming it.
std::vector<std::pair<std::string, std::string>> parseOffices(const std::string& option,
                                                              const std::string& value);
/// @brief Whether `name` can be a constant of the generated knowledge: [a-z][a-z0-9_]*, no
/// P-log keyword and no symbol of the knowledge's own structure (person, room, true, ...).
bool isSiteConstant(const std::string& name);

/// @brief The validated scaffold of one site folder; see the file comment.
class Scaffold {
 public:
  /**
   * @brief Read the map and the places and validate every option (before anything is
   * written). @throws ConfigError naming the option and the value.
   */
  explicit Scaffold(ScaffoldOptions options);

  /// @brief The rooms (from --rooms or the places) and the resolved domains.
  const std::vector<std::string>& rooms() const { return rooms_; }
  const std::vector<ScaffoldDomain>& domains() const { return domains_; }
  /// @brief Moves of the shortest route from the shop to each room on the first domain.
  const std::map<std::string, int>& routeMoves() const { return moves_; }

  /// @brief The generated files' text.
  std::string siteYaml() const;
  std::string knowledgePlog() const;
  std::string languageYaml() const;
  /**
   * @brief The synonyms of language.yaml, phrase -> name: "<person>'s office" and
   * "<person>'s room" -> that person's room; for a room named office_a / room_a / room12 /
   * office_7 the other of office / room ("room a", "office12") and numbers up to twenty in
   * words ("room twelve"); the plural of each item ("teas"). A phrase that would mean
   * something else (a name, a word of the lists, an earlier synonym) is left out. Capitalised
   * forms are not needed: the language front end lower-cases the text.
   */
  std::vector<std::pair<std::string, std::string>> synonyms() const;

  /**
   * @brief Write the site folder atomically (see the file comment) and check it over the
   * generic settings of `base_config_dir` (the repository's config/).
   * @return the consistency check's report of the written folder.
   * @throws ConfigError / IoError naming the folder; nothing is left behind then.
   */
  SiteReport write(const std::string& base_config_dir) const;

 private:
  void validate();
  void validateNames();
  void validateRoomsAndOffices();
  void resolveDomains();
  std::vector<std::string> wordList(const std::vector<std::string>& words) const;

  ScaffoldOptions o_;
  nav::OccupancyGrid map_;
  nav::PlacesFile places_;
  std::string image_;  ///< the map's image file (resolved; "" for a drawn map)
  std::string places_file_;  ///< where the places come from (--places or --rooms-from-text)
  std::vector<std::string> rooms_;
  std::vector<ScaffoldDomain> domains_;
  std::map<std::string, int> moves_;
  std::string farthest_, nearest_;  ///< rooms for site.yaml's experiments
};

}  // namespace site
}  // namespace krr
