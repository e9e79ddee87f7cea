#include "krr_core/site/site_options.h"

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resource_locator.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/site/site.h"

namespace krr {
namespace site {

std::string ResolvedSite::shop() const {
  if (!files.shop.empty()) return files.shop;
  if (files.dialog) return files.dialog->shop;
  return dialog::loadDialogConfig(files.dialog_config).shop;
}

void SiteOptions::declare(OptionParser& parser, bool with_shop) {
  parser.add("--config", "FILE", "navigation config", &config_)
      .defaultText("ROOT/config/navigation.yaml");
  parser.add("--dialog-config", "FILE", "dialog config whose navigation.shop is the shop",
             &dialog_config_)
      .defaultText("dialog.yaml beside the navigation config");
  if (with_shop) {
    parser.add("--shop", "NAME", "the place routes start from (overrides the dialog config's)",
               &shop_);
  }
  parser.add("--site", "DIR",
             "site folder: its map, places, domains and shop (site.yaml), with the generic "
             "settings of ROOT/config",
             &site_dir_);
  parser.add("--root", "DIR", kRepositoryRootHelp, &root_);
}

void SiteOptions::check() const {
  if (!site_dir_.empty() && (!config_.empty() || !dialog_config_.empty()))
    throw ConfigError("--site names the map, the places and the shop: no --config or "
                      "--dialog-config with it");
}

ResolvedSite SiteOptions::resolve() const {
  ResolvedSite r;
  if (!site_dir_.empty()) {
    const Site s = Site::read(site_dir_, findRepositoryRoot(root_) + "/config");
    r.navigation = s.navigation();
    r.config_path = s.manifest();
    r.files = s.files();
  } else {
    r.config_path = resourcePath(config_, "config/navigation.yaml", root_);
    r.navigation = nav::loadNavigationConfig(r.config_path);
    r.files = SiteFiles::inConfigDir(dirName(r.config_path));
    r.files.navigation_config = r.config_path;
    if (!dialog_config_.empty()) r.files.dialog_config = dialog_config_;
  }
  if (!shop_.empty()) {
    r.files.shop = shop_;
    r.files.shop_source = "option --shop";
  }
  return r;
}

}  // namespace site
}  // namespace krr
