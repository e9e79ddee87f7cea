/**
 * @file site.h
 * @brief A site folder: one building's map, places, knowledge and language in one directory,
 * and the one loader that resolves it into the configuration the stack runs on.
 *
 * A site folder holds `site.yaml` and the building's own files (names relative to the
 * folder; these are the defaults when site.yaml does not name them):
 *
 *   site.yaml        shop (the place deliveries start from), domains {name: {cols, rows, step_limit}}, areas
 *                    (per-area simulator overrides, navigation.yaml's simulator.areas format),
 *                    optional experiments {nav_transfer: {source, target}, new_circumstances:
 *                    {goal}} (places of this site), and the file names below when they differ
 *   map.yaml + image the map_server map (PGM or PNG)
 *   places.yaml      named places (the shop and every room) and blocking areas
 *   knowledge.plog   people, items, rooms, offices, the request prior (sorts person, item, room)
 *   language.yaml    the language front end's vocabulary and synonyms
 *
 * Everything else is derived: each domain's grid and P-log geometry (`make_nav_domain --site
 * DIR` writes <domain>.yaml and <domain>_geometry.plog next to the map), the navigation config
 * (the base config/navigation.yaml with the site's map, places, domains and areas), the dialog
 * config (config/dialog.yaml with the site's knowledge and shop), the reasoner's domain files
 * (the site's knowledge) and the simulated user's model (the same knowledge). The generic
 * settings (rewards, R-Max, simulator noise, solver) stay in the base config directory.
 *
 * A site that names the base config's own map may leave out `shop`, `domains` and `areas`: the
 * base's are that map's (the bundled office site, config/sites/office, does so: its files keep the
 * paths the paper's experiments cite). A site with another map must name its shop and list its domains.
 *
 * Site::load() checks that every file exists and that site.yaml is well-formed (unknown fields
 * are errors), then runs the site consistency check (site_check.h) on the resolved files:
 * errors are ConfigErrors naming the file, the field and the value.
 */
#pragma once

#include <map>
#include <string>
#include <vector>

#include "krr_core/dialog/dialog_config.h"
#include "krr_core/nav/nav_grid.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_core/nav/occupancy_grid.h"
#include "krr_core/site/site_check.h"

namespace krr {
namespace site {

/// @brief One loaded site folder (see the file comment).
class Site {
 public:
  /// @brief The manifest's name in a site folder.
  static constexpr const char* kManifest = "site.yaml";

  /**
   * @brief Load the site folder `dir` over the generic configuration in `base_config_dir`
   * (navigation.yaml and dialog.yaml there, the repository's config/), and check it.
   * @throws ConfigError naming the file, the field and the value: a missing folder, manifest or
   * file, a malformed or unknown field; InconsistentSiteError (a ConfigError) listing every
   * disagreement between the site's files (a stale name).
   */
  static Site load(const std::string& dir, const std::string& base_config_dir);

  /// @brief As load() without the consistency check (for check_site, which reports it).
  static Site read(const std::string& dir, const std::string& base_config_dir);

  const std::string& dir() const { return dir_; }            ///< the folder (absolute)
  const std::string& name() const { return name_; }          ///< the folder's name
  const std::string& manifest() const { return manifest_; }  ///< DIR/site.yaml
  const std::string& map() const { return map_; }              ///< map_server YAML
  const std::string& places() const { return places_; }        ///< places file
  const std::string& knowledge() const { return knowledge_; }  ///< the .plog
  const std::string& language() const { return language_; }  ///< the language file
  const std::string& shop() const { return dialog_.shop; }    ///< where deliveries start

  /// @brief The base navigation config with the site's map, places, domains and areas.
  const nav::NavigationConfig& navigation() const { return navigation_; }
  /// @brief The base dialog config with the site's knowledge and shop.
  const dialog::DialogConfig& dialog() const { return dialog_; }
  /// @brief `base` (a node's own navigation / dialog config, e.g. a test's) with the site's
  /// names put over it, as navigation() and dialog() are made from the base directory's.
  nav::NavigationConfig navigationOver(nav::NavigationConfig base) const;
  dialog::DialogConfig dialogOver(dialog::DialogConfig base) const;
  /// @brief The generated files of domain `name` (next to the map): <name>_geometry.plog and
  /// <name>.yaml. @throws UnknownSymbolError for a domain the site does not have.
  std::string geometry(const std::string& domain) const;
  std::string domainFile(const std::string& domain) const;
  /// @brief A place of the site's experiments, site.yaml's experiments.<experiment>.<field>;
  /// "" when the site names none.
  std::string experimentPlace(const std::string& experiment, const std::string& field) const;

  /// @brief The files and loaded configs for checkSite() (the reasoner loads the knowledge).
  SiteFiles files() const;

 private:
  std::string dir_, name_, manifest_, map_, places_, knowledge_, language_, shop_;
  bool same_map_ = false;   ///< the site's map is the base config's (office site)
  bool own_areas_ = false;  ///< site.yaml has `areas`
  std::vector<nav::DomainConfig> domains_;       ///< site.yaml's (empty: the base's)
  std::map<std::string, nav::AreaConfig> areas_;  ///< site.yaml's
  nav::NavigationConfig navigation_;
  dialog::DialogConfig dialog_;
  std::map<std::string, std::map<std::string, std::string>> experiments_;
};

/**
 * @brief Cut the map of `cfg` into domain `d` (NavGrid::fromMap with cfg's
 * max_blocked_fraction) and write it beside the map as <d.name>.yaml and
 * <d.name>_geometry.plog, the files Site::domainFile() and Site::geometry() name: the one
 * writer of a domain (make_nav_domain, and make_site, whose folder is then complete).
 * @return the grid. @throws ConfigError for a domain name that is no plain identifier;
 * MapError when the grid cannot be cut; IoError when a file cannot be written.
 */
nav::NavGrid writeDomain(const nav::NavigationConfig& cfg, const nav::DomainConfig& d,
                         const nav::OccupancyGrid& map, const nav::PlacesFile& places);

/// @brief The generated files of domain `name` beside the map file `map_yaml`, where every
/// program looks for them; canonical (config/../maps resolved as the file system does).
std::string domainFileBeside(const std::string& map_yaml, const std::string& name);
std::string geometryFileBeside(const std::string& map_yaml, const std::string& name);

}  // namespace site
}  // namespace krr
