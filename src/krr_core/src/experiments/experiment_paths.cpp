#include "krr_core/experiments/experiment_paths.h"

#include <sys/stat.h>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resource_locator.h"
#include "krr_core/nav/navigation_config.h"

namespace krr {
namespace experiments {

namespace {

bool isFile(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

}  // namespace

ExperimentPaths ExperimentPaths::find(const std::string& root_hint, const std::string& domain) {
  const std::string root = findRepositoryRoot(root_hint, "config/dialog.yaml");
  ExperimentPaths p;
  p.root = root;
  p.dialog_yaml = root + "/config/dialog.yaml";
  p.delivery_yaml = root + "/config/experiments/delivery_trials.yaml";
  p.navigation_yaml = root + "/config/navigation.yaml";
  p.navigation_plog = root + "/config/navigation.plog";
  for (const std::string* f : {&p.dialog_yaml, &p.delivery_yaml, &p.navigation_yaml, &p.navigation_plog})
    if (!isFile(*f)) throw ConfigError("missing input file " + *f + " (repository root " + root + ")");
  p.domain = domain.empty() ? nav::loadNavigationConfig(p.navigation_yaml).defaultDomain().name : domain;
  p.geometry = root + "/maps/" + p.domain + "_geometry.plog";
  if (!isFile(p.geometry)) {
    const std::string chosen = domain.empty()
                                   ? "the first domain of " + p.navigation_yaml + "; --domain chooses another"
                                   : "--domain";
    throw ConfigError("no geometry file " + p.geometry + " for domain '" + p.domain + "' (" + chosen +
                      "): generate it with make_nav_domain --config " + p.navigation_yaml);
  }
  return p;
}

}  // namespace experiments
}  // namespace krr
