#include "krr_core/experiments/experiment_paths.h"

#include <sys/stat.h>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resource_locator.h"

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
  p.geometry = root + "/maps/" + domain + "_geometry.plog";
  for (const std::string* f : {&p.dialog_yaml, &p.delivery_yaml, &p.navigation_yaml, &p.navigation_plog})
    if (!isFile(*f)) throw ConfigError("missing input file " + *f + " (repository root " + root + ")");
  if (!isFile(p.geometry))
    throw ConfigError("no geometry file " + p.geometry + " for domain '" + domain +
                      "' (generate it with make_nav_domain)");
  return p;
}

}  // namespace experiments
}  // namespace krr
