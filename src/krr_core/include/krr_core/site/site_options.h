/**
 * @file site_options.h
 * @brief The command-line options of a program that runs on one site's map and shop
 * (make_nav_domain, bench_planning), declared and resolved in one place so that every such
 * program names a site the same way.
 *
 * Either the files of a configuration directory (`--config FILE`, the navigation config, and
 * `--dialog-config FILE`, the dialog config whose navigation.shop is the shop; by default the
 * dialog.yaml beside the navigation config) or a site folder (`--site DIR`, site/site.h, over
 * ROOT/config's generic settings; `--root DIR`); optionally `--shop NAME` over either's shop.
 */
#pragma once

#include <string>

#include "krr_core/common/cli.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_core/site/site_check.h"

namespace krr {
namespace site {

/// @brief A configuration as a program given SiteOptions runs on it.
struct ResolvedSite {
  nav::NavigationConfig navigation;  ///< the navigation config (a site's: the base with its names)
  std::string config_path;           ///< the file naming it in messages (or the site's manifest)
  SiteFiles files;                   ///< the files for checkSite(), --shop applied
  /// @brief Where routes start: --shop, else the (site's) dialog config's navigation.shop.
  /// @throws ConfigError / IoError when the dialog config cannot be read.
  std::string shop() const;
};

/// @brief --config, --dialog-config, --site, --root and optionally --shop (see the file comment).
class SiteOptions {
 public:
  /// @brief Declare the options on `parser`; `with_shop` adds --shop NAME.
  void declare(OptionParser& parser, bool with_shop = false);
  /// @brief The combination check for OptionParser::parse: --site with --config or
  /// --dialog-config is a ConfigError (the site folder names those files).
  void check() const;
  /// @brief Read the configuration the options name. Site::read, not load: the caller runs
  /// the consistency check once, on files (e.g. site::requireConsistentSite).
  /// @throws ConfigError / IoError naming the file, the field and the value.
  ResolvedSite resolve() const;

 private:
  std::string config_, dialog_config_, shop_, site_dir_, root_;
};

}  // namespace site
}  // namespace krr
