// site::SiteOptions, the options of the programs that run on one site's map and shop
// (make_nav_domain, bench_planning): a configuration directory or a site folder, resolved in
// one place, with --shop over either's shop and --site refused beside the files it names.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/site/site_options.h"
#include "../support/nav_fixtures.h"

namespace {

namespace fs = std::filesystem;
using krr::site::ResolvedSite;
using krr::site::SiteOptions;

/// @brief Parse `args` as a program declaring SiteOptions would; returns parse()'s status.
std::optional<int> parse(SiteOptions& options, std::vector<const char*> args,
                         bool with_shop = true) {
  krr::OptionParser parser("test", "SiteOptions under test");
  options.declare(parser, with_shop);
  args.insert(args.begin(), "test");
  return parser.parse(static_cast<int>(args.size()), args.data(), [&] { options.check(); });
}

std::string root() { return fs::weakly_canonical(krr_test::repoPath("")).string(); }

}  // namespace

TEST(SiteOptions, TheConfigDirectoryAndItsDialogConfigsShop) {
  SiteOptions options;
  ASSERT_FALSE(parse(options, {"--root", root().c_str()}));
  const ResolvedSite site = options.resolve();
  EXPECT_EQ(fs::weakly_canonical(site.config_path), fs::path(root()) / "config/navigation.yaml");
  EXPECT_EQ(site.files.navigation_config, site.config_path);
  EXPECT_EQ(site.navigation.domains.size(), 2u);
  EXPECT_EQ(site.shop(), "shop");
}

TEST(SiteOptions, ASiteFolderNamesItsMapDomainsAndShop) {
  SiteOptions options;
  const std::string lab = root() + "/config/sites/lab";
  ASSERT_FALSE(parse(options, {"--site", lab.c_str(), "--root", root().c_str()}));
  const ResolvedSite site = options.resolve();
  EXPECT_EQ(site.config_path, lab + "/site.yaml");
  ASSERT_EQ(site.navigation.domains.size(), 1u);
  EXPECT_EQ(site.navigation.domains[0].name, "lab_24x16");
  EXPECT_EQ(site.shop(), "mailroom");
}

TEST(SiteOptions, ShopOptionWinsAndIsNamedAsItsSource) {
  SiteOptions options;
  ASSERT_FALSE(parse(options, {"--root", root().c_str(), "--shop", "room9"}));
  const ResolvedSite site = options.resolve();
  EXPECT_EQ(site.shop(), "room9");
  EXPECT_EQ(site.files.shop_source, "option --shop");
  // Without with_shop there is no --shop: a usage error (status 2), not a silent default.
  SiteOptions plain;
  EXPECT_EQ(parse(plain, {"--shop", "x"}, /*with_shop=*/false), std::optional<int>(2));
}

TEST(SiteOptions, SiteBesideTheFilesItNamesIsRefused) {
  SiteOptions a, b;
  EXPECT_EQ(parse(a, {"--site", "x", "--config", "y"}), std::optional<int>(2));
  EXPECT_EQ(parse(b, {"--site", "x", "--dialog-config", "y"}), std::optional<int>(2));
}

TEST(SiteOptions, AMissingSiteIsAConfigErrorNamingIt) {
  SiteOptions options;
  ASSERT_FALSE(parse(options, {"--site", "/nonexistent/site", "--root", root().c_str()}));
  try {
    options.resolve();
    FAIL() << "resolved a missing site";
  } catch (const krr::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/site"), std::string::npos) << e.what();
  }
}
