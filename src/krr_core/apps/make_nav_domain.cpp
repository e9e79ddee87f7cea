/**
 * @file make_nav_domain.cpp
 * @brief Cut a site's map into the navigation domains derived from it.
 *
 *   make_nav_domain [--config ROOT/config/navigation.yaml] [--dialog-config FILE] [--shop NAME]
 *                   [--site DIR [--root DIR]] [-h | --help]
 *
 * For every domain of the config (or of site.yaml), the map is loaded through the map_server
 * loader and cut into a NavGrid, written next to the map as <domain>.yaml and
 * <domain>_geometry.plog. A JSON summary line per domain is printed
 * (free cells, place cells, blocking-area cells, shortest routes from the shop and the blocking
 * areas they cross). The shop is the dialog config's navigation.shop (the dialog.yaml beside the
 * navigation config by default) or --shop.
 *
 * Before anything is written, the site consistency check (site/site_check.h) runs on the files
 * beside the navigation config (dialog.yaml, language.yaml, reasoner_node.yaml, the root their
 * parent) or of the site folder: a shop, room, blocking area or synonym that the files disagree
 * on stops the program with every finding.
 */
#include <cstdio>
#include <iostream>
#include <string>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/json.h"
#include "krr_core/common/limits.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/nav/grid_astar.h"
#include "krr_core/nav/nav_grid.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_core/nav/occupancy_grid.h"
#include "krr_core/site/site.h"
#include "krr_core/site/site_check.h"
#include "krr_core/site/site_options.h"

using namespace krr;
using namespace krr::nav;

/// @brief The program; main() runs it under guardedMain so that no exception aborts it.
static int mainBody(int argc, char** argv) {
  site::SiteOptions options;
  OptionParser parser("make_nav_domain",
                      "Cut the map named by the config (map_server YAML + PGM or PNG) into the\n"
                      "navigation domains it lists; write <domain>.yaml and\n"
                      "<domain>_geometry.plog next to the map.");
  options.declare(parser, /*with_shop=*/true);
  if (const auto status = parser.parse(argc, argv, [&] { options.check(); })) return *status;
  const site::ResolvedSite resolved = options.resolve();
  const NavigationConfig& cfg = resolved.navigation;
  const std::string shopName = site::requireConsistentSite(resolved.files).shop;
  OccupancyGrid map = loadMap(cfg.map);
  PlacesFile places = loadPlaces(cfg.places);
  for (const DomainConfig& d : cfg.domains) {
    const NavGrid grid = site::writeDomain(cfg, d, map, places);
    std::cout << "{\"domain\": " << jsonString(d.name) << ", \"free_cells\": "
              << grid.numFreeCells() << ", \"cell_size\": " << jsonNumber(grid.cellWidth());
    for (size_t a = 0; a < grid.areas().size(); ++a) {
      std::cout << ", " << jsonString(grid.areas()[a].name + "_cells") << ": "
                << grid.areaCells(static_cast<int>(a)).size();
    }
    GridAStar astar(grid);
    const int shop = grid.placeCell(shopName);
    for (const Place& p : grid.places()) {
      if (p.name == shopName) continue;
      try {
        GridRoute r = astar.plan(shop, grid.placeCell(p.name));
        std::uint32_t crossed = 0;
        int ba_cells = 0;
        for (int c : r.cells) {
          crossed |= grid.areaMask(c);
          if (grid.areaMask(c)) ++ba_cells;
        }
        std::string names;
        for (size_t a = 0; a < grid.areas().size(); ++a) {
          if (crossed & (1u << a)) names += (names.empty() ? "" : "+") + grid.areas()[a].name;
        }
        std::cout << ", " << jsonString(p.name) << ": {\"moves\": " << r.moves.size()
                  << ", \"ba_cells\": " << ba_cells << ", \"areas\": " << jsonString(names)
                  << "}";
      } catch (const NoPathError& e) {
        std::cout << ", " << jsonString(p.name) << ": " << jsonString(e.what());
      }
    }
    std::cout << "}\n";
  }
  return 0;
}

int main(int argc, char** argv) {
  return krr::guardedMain("make_nav_domain", mainBody, argc, argv);
}
