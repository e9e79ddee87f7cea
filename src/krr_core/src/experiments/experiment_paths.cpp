#include "krr_core/experiments/experiment_paths.h"

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resource_locator.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_core/site/site.h"

namespace krr {
namespace experiments {

nav::NavigationConfig ExperimentPaths::navigationConfig() const {
  return site ? site->navigation() : nav::loadNavigationConfig(navigation_yaml);
}

dialog::DialogConfig ExperimentPaths::dialogConfig() const {
  return site ? site->dialog() : dialog::loadDialogConfig(dialog_yaml);
}

ExperimentPaths ExperimentPaths::find(const std::string& root_hint, const std::string& domain,
                                      const std::string& site_dir) {
  const std::string root = findRepositoryRoot(root_hint, "config/dialog.yaml");
  ExperimentPaths p;
  p.root = root;
  p.dialog_yaml = root + "/config/dialog.yaml";
  p.delivery_yaml = root + "/config/experiments/delivery_trials.yaml";
  p.navigation_yaml = root + "/config/navigation.yaml";
  p.navigation_plog = root + "/config/navigation.plog";
  for (const std::string* f : {&p.dialog_yaml, &p.delivery_yaml, &p.navigation_yaml, &p.navigation_plog})
    if (!isRegularFile(*f))
      throw ConfigError("missing input file " + *f + " (repository root " + root + ")");
  if (!site_dir.empty()) p.site = std::make_shared<site::Site>(site::Site::load(site_dir, root + "/config"));
  const std::string domains = p.site ? p.site->manifest() : p.navigation_yaml;
  const nav::NavigationConfig navigation = p.navigationConfig();
  p.domain = domain.empty() ? navigation.defaultDomain().name : domain;
  try {
    navigation.domain(p.domain);
  } catch (const UnknownSymbolError& e) {
    throw ConfigError("--domain: value '" + p.domain + "': " + e.what() + " in " + domains);
  }
  p.geometry = site::geometryFileBeside(navigation.map, p.domain);
  if (!isRegularFile(p.geometry)) {
    const std::string chosen = domain.empty()
                                   ? "the first domain of " + domains + "; --domain chooses another"
                                   : "--domain";
    throw ConfigError("no geometry file " + p.geometry + " for domain '" + p.domain + "' (" + chosen +
                      "): generate it with make_nav_domain " +
                      (p.site ? "--site " + p.site->dir() : "--config " + p.navigation_yaml));
  }
  return p;
}

}  // namespace experiments
}  // namespace krr
