#include "krr_core/experiments/experiment_cli.h"

#include <utility>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resource_locator.h"
#include "krr_core/common/yaml_section.h"
#include "krr_core/nav/navigation_config.h"
#include "krr_core/site/site.h"
#include "experiment_yaml.h"

namespace krr {
namespace experiments {

using dialog::DialogConfig;

void ExperimentCli::declare(OptionParser& p) {
  p.add("--br", "B", "blocking rate of the simulated world", &experiment.blocking_rate).required();
  p.add("--condition", "learned|outdated",
        "knowledge learned at --br (learned) or at --outdated-br (outdated)",
        [this](const std::string& v) { experiment.condition = conditionFromString(v); })
      .required();
  p.add("--seed", "S", "root seed of learning and of every trial", &experiment.seed).required();
  p.add("--trial-begin", "K", "index of the first trial (trial i depends only on seed and i)",
        &begin);
  p.add("--threads", "T", "worker threads", &threads);
  p.add("--domain", "NAME", "navigation domain (maps/NAME_geometry.plog)", &experiment.domain_name)
      .defaultText("the first domain of ROOT/config/navigation.yaml");
  p.add("--learned-cache", "DIR|none",
        "learned knowledge and solved policies; none: learn and solve every run",
        [this](const std::string& v) { cache_ = v, haveCache_ = true; },
        "$KRR_CACHE_DIR or ~/.cache/krr_rl/delivery");
  p.add("--out", "FILE", "CSV output", &out);
  p.add("--root", "DIR", kRepositoryRootHelp, &root);
  p.add("--site", "DIR", "site folder (site.yaml, map, places, knowledge, language)", &site)
      .defaultText("the office of ROOT/config");
  p.add("--outdated-br", "B", "blocking rate the outdated knowledge was learned at",
        &experiment.outdated_rate);
  p.add("--serve-cost", "none|expected", "override of config/dialog.yaml serve_cost", &serve_cost);
  p.add("--serve-cost-weight", "W", "override of serve_cost_weight", &serve_cost_weight)
      .defaultText("");
  p.add("--wrong-delivery-penalty", "P", "override of wrong_delivery_penalty",
        &wrong_delivery_penalty)
      .defaultText("");
  p.add("--solver-trials", "N", "override of the solver's trial budget",
        [this](const std::string& v) {
          solver_trials = static_cast<long>(parseCountOption("--solver-trials", v));
        });
  p.add("--solver-timeout", "S", "override of the solver's timeout (seconds)", &solver_timeout)
      .defaultText("");
}

void ExperimentCli::finish() {
  if (threads == 0) throw ConfigError("option --threads: must be at least 1");
  experiment.cache_dir = haveCache_ ? (cache_ == "none" ? "" : cache_) : dialog::defaultCacheDir();
  experiment.validate();
}

DialogConfig loadDeliveryExperimentConfig(const ExperimentPaths& paths) {
  DialogConfig c = paths.dialogConfig();
  const std::string& file = paths.delivery_yaml;
  detail::ExperimentBase b = detail::experimentBaseOf(c.rmaxParams(), 0.0, 1.0);
  const YamlSection top(parseYaml(readFile(file), file), file, "",
                        {"planning", "rmax_learning", "solver"});
  // The experiments' own dialog-solver budget (Tables I and II on certified policies).
  if (top.has("solver")) dialog::readSolverSettings(top.get("solver"), file, c);
  if (top.has("planning") && top.get("planning").IsMap() && top.get("planning")["discount"]) {
    throw ConfigError(file + ": field 'planning.discount': not a setting of the delivery "
                      "experiments (their trips' discount is config/dialog.yaml's "
                      "navigation.discount)");
  }
  detail::readBaseOverrides(top, b, nav::RateUnset::kRefused);
  c.setRMaxParams(nav::rmaxParamsOf(b.planning, b.rmax_learning, c.rmaxParams()));
  c.validate();
  return c;
}

DialogConfig ExperimentCli::config(const ExperimentPaths& paths) const {
  DialogConfig c = loadDeliveryExperimentConfig(paths);
  if (!serve_cost.empty()) c.serve_cost_mode = dialog::serveCostModeFromString(serve_cost);
  if (serve_cost_weight >= 0) c.serve_cost_weight = serve_cost_weight;
  if (wrong_delivery_penalty >= 0) c.wrong_delivery_penalty = wrong_delivery_penalty;
  if (solver_trials >= 0) c.solver_max_trials = static_cast<std::size_t>(solver_trials);
  if (solver_timeout >= 0) c.solver_timeout = solver_timeout;
  c.validate();
  return c;
}

void NavExperimentFiles::declare(OptionParser& p, const std::string& options_file,
                                 const std::string& options_note) {
  options_file_ = options_file;
  p.add("--root", "DIR", kRepositoryRootHelp, &root).deprecatedAlias("--repo");  // its old name
  p.add("--options", "FILE", "experiment options", &options)
      .defaultText("ROOT/" + options_file + options_note);
  p.add("--config", "FILE", "navigation config", &config).defaultText("ROOT/config/navigation.yaml");
  p.add("--geometry", "FILE", "domain geometry", &geometry)
      .defaultText("<domain>_geometry.plog beside the config's map");
  p.add("--knowledge", "FILE", "human navigation knowledge", &knowledge)
      .defaultText("ROOT/config/navigation.plog");
  p.add("--site", "DIR",
        "site folder: its map, places, domains and shop, and its experiment places (site.yaml "
        "experiments) instead of the options file's",
        &site_dir)
      .defaultText("the office of ROOT/config");
}

void NavExperimentFiles::resolveRoot() {
  root = findRepositoryRoot(root);
  if (options.empty()) options = root + "/" + options_file_;
  if (!site_dir.empty())
    site = std::make_shared<const site::Site>(site::Site::load(site_dir, root + "/config"));
}

nav::NavigationConfig NavExperimentFiles::navigationConfig() const {
  nav::NavigationConfig c =
      nav::loadNavigationConfig(config.empty() ? root + "/config/navigation.yaml" : config);
  return site ? site->navigationOver(std::move(c)) : c;
}

std::string NavExperimentFiles::sitePlace(const std::string& experiment,
                                          const std::string& field) const {
  return site ? site->experimentPlace(experiment, field) : "";
}

std::string NavExperimentFiles::shopSource() const {
  return site ? site->manifest() + ": field 'shop'"
              : dialogConfig() + ": field 'navigation.shop'";
}

std::string NavExperimentFiles::defaultDomain() const {
  return navigationConfig().defaultDomain().name;
}

std::string NavExperimentFiles::dialogConfig() const {
  return dirName(config.empty() ? root + "/config/navigation.yaml" : config) + "/dialog.yaml";
}

std::string NavExperimentFiles::siteShop() const {
  return site ? site->shop() : dialog::loadDialogConfig(dialogConfig()).shop;
}

void NavExperimentFiles::resolveInputs(const std::string& domain) {
  if (config.empty()) config = root + "/config/navigation.yaml";
  if (geometry.empty()) {
    geometry = site ? site->geometry(domain)
                    : site::geometryFileBeside(nav::loadNavigationConfig(config).map, domain);
  }
  if (knowledge.empty()) knowledge = root + "/config/navigation.plog";
}

}  // namespace experiments
}  // namespace krr
