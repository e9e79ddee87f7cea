#include "krr_ros/nav_kb.h"

#include "krr_core/common/errors.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/nav/navigation_config.h"

#include <utility>

namespace krr_ros {

NavKbParams NavKbParams::read(ParamReader& params) {
  NavKbParams p;
  p.navigation_config = params.path("navigation_config", "config/navigation.yaml", true);
  const std::string site = params.str("site", "");
  p.site_dir = site.empty() ? "" : params.resolve(site);
  if (!p.site_dir.empty()) {
    try {
      p.site = std::make_shared<const krr::site::Site>(
          krr::site::Site::read(p.site_dir, params.resolve("config")));
    } catch (const krr::ConfigError& e) {
      params.refuse("site", "'" + p.site_dir + "'", e.what());
    }
  }
  const krr::nav::NavigationConfig config = p.loadConfig();
  p.shop = p.site ? p.site->shop()
                  : krr::dialog::loadDialogConfig(params.resolve("config/dialog.yaml")).shop;
  p.domain = params.str("domain", config.defaultDomain().name);  // the site's, not a literal
  try {
    config.domain(p.domain);
  } catch (const krr::UnknownSymbolError& e) {
    params.refuse("domain", "'" + p.domain + "'", e.what());
  }
  p.geometry = params.path("geometry", krr::site::geometryFileBeside(config.map, p.domain), true);
  p.navigation_files = params.paths("navigation_files", {"config/navigation.plog"}, true);
  if (p.navigation_files.empty())
    params.refuse("navigation_files", "[]", "at least one P-log file is required");
  return p;
}

krr::nav::NavigationConfig NavKbParams::loadConfig() const {
  krr::nav::NavigationConfig c = krr::nav::loadNavigationConfig(navigation_config);
  return site ? site->navigationOver(std::move(c)) : c;
}

krr::kb::NavDomain NavKbParams::loadDomain() const {
  krr::kb::NavDomain d =
      krr::kb::NavDomain::load(loadConfig(), domain, geometry, navigation_files.front());
  d.knowledge_files = {geometry};
  d.knowledge_files.insert(d.knowledge_files.end(), navigation_files.begin(),
                           navigation_files.end());
  return d;
}

}  // namespace krr_ros
