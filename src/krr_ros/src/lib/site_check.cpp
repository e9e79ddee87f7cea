#include "krr_ros/site_check.h"

namespace krr_ros {

bool readCheckSite(ParamReader& r) { return r.boolean("check_site", true); }

krr::site::SiteReport requireConsistentSite(const ParamReader& r, const NodeSiteFiles& own) {
  krr::site::SiteFiles files = krr::site::SiteFiles::inConfigDir(r.resolve("config"));
  if (own.site) {
    files = own.site->files();
  } else {
    if (!own.navigation_config.empty()) files.navigation_config = own.navigation_config;
    if (!own.dialog_config.empty()) files.dialog_config = own.dialog_config;
    if (!own.language_config.empty()) files.language_config = own.language_config;
  }
  if (own.reasoner_domain_files) {
    files.reasoner_domain_files = own.reasoner_domain_files;
    files.reasoner_source = "parameters of " + ros::this_node::getName();
    files.reasoner_config.clear();
  }
  return krr::site::requireConsistentSite(files);
}

}  // namespace krr_ros
