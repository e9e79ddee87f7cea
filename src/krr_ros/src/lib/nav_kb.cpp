#include "krr_ros/nav_kb.h"

#include "krr_core/common/errors.h"
#include "krr_core/nav/navigation_config.h"

namespace krr_ros {

NavKbParams NavKbParams::read(ParamReader& params) {
  NavKbParams p;
  p.navigation_config = params.path("navigation_config", "config/navigation.yaml", true);
  const krr::nav::NavigationConfig config = krr::nav::loadNavigationConfig(p.navigation_config);
  p.domain = params.str("domain", config.defaultDomain().name);  // the site's, not a literal
  try {
    config.domain(p.domain);
  } catch (const krr::UnknownSymbolError& e) {
    params.refuse("domain", "'" + p.domain + "'", e.what());
  }
  p.geometry = params.path("geometry", "maps/" + p.domain + "_geometry.plog", true);
  p.navigation_files = params.paths("navigation_files", {"config/navigation.plog"}, true);
  if (p.navigation_files.empty())
    params.refuse("navigation_files", "[]", "at least one P-log file is required");
  return p;
}

krr::nav::NavigationConfig NavKbParams::loadConfig() const {
  return krr::nav::loadNavigationConfig(navigation_config);
}

krr::kb::NavDomain NavKbParams::loadDomain() const {
  krr::kb::NavDomain d =
      krr::kb::NavDomain::load(navigation_config, domain, geometry, navigation_files.front());
  d.knowledge_files = {geometry};
  d.knowledge_files.insert(d.knowledge_files.end(), navigation_files.begin(),
                           navigation_files.end());
  return d;
}

}  // namespace krr_ros
