#include "krr_core/kb/nav_domain.h"

#include "krr_core/nav/occupancy_grid.h"

#include <utility>

namespace krr {
namespace kb {

NavDomain NavDomain::load(const std::string& navigation_yaml, const std::string& domain_name,
                          const std::string& geometry_file, const std::string& navigation_plog) {
  return load(nav::loadNavigationConfig(navigation_yaml), domain_name, geometry_file,
              navigation_plog);
}

NavDomain NavDomain::load(nav::NavigationConfig config, const std::string& domain_name,
                          const std::string& geometry_file, const std::string& navigation_plog) {
  NavDomain d;
  d.config = std::move(config);
  d.domain = d.config.domain(domain_name);
  nav::NavGridOptions opt;
  opt.cols = d.domain.cols;
  opt.rows = d.domain.rows;
  opt.max_blocked_fraction = d.config.max_blocked_fraction;
  d.grid = std::make_shared<nav::NavGrid>(
      nav::NavGrid::fromMap(nav::loadMap(d.config.map), nav::loadPlaces(d.config.places), opt));
  d.space = std::make_shared<NavStateSpace>(*d.grid);
  d.simulator = std::make_shared<nav::BlockageSimulator>(*d.grid, d.config.simulator);
  d.knowledge_files = {geometry_file, navigation_plog};
  return d;
}

}  // namespace kb
}  // namespace krr
