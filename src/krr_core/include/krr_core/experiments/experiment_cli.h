/**
 * @file experiment_cli.h
 * @brief The options delivery_trials and dialog_entropy share (one parser, one meaning): the
 * experiment (br, condition, seed, knowledge cache), the trial range and threads, where the
 * inputs are, and the overrides of config/dialog.yaml an experiment may name; and the input
 * files of the navigation experiments (nav_transfer, new_circumstances).
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "krr_core/common/cli.h"
#include "krr_core/experiments/delivery_experiment.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/experiments/experiment_paths.h"
#include "krr_core/site/site.h"

namespace krr {
namespace experiments {

/**
 * @brief What the delivery experiments run on: config/dialog.yaml (with its base,
 * config/navigation.yaml) and the changes of config/experiments/delivery_trials.yaml
 * (`planning` {step_cost, rmax}, `rmax_learning` {known_threshold, discount, replan_every,
 * optimism, refine_known}). @throws ConfigError naming file and field.
 */
dialog::DialogConfig loadDeliveryExperimentConfig(const ExperimentPaths& paths);

struct ExperimentCli {
  DeliveryExperimentOptions experiment;  ///< --br --condition --seed --outdated-br --learned-cache
  std::string root;                      ///< --root
  std::string site;                      ///< --site (a site folder; "" = the office of config/)
  std::size_t begin = 0;                 ///< --trial-begin
  std::size_t threads = 1;               ///< --threads
  std::string out;                       ///< --out
  // Overrides of config/dialog.yaml (unset: the file's value).
  std::string serve_cost;                ///< --serve-cost none|expected
  double serve_cost_weight = -1;         ///< --serve-cost-weight
  double wrong_delivery_penalty = -1;    ///< --wrong-delivery-penalty
  long solver_trials = -1;               ///< --solver-trials
  double solver_timeout = -1;            ///< --solver-timeout

  /// @brief Declare the shared options on `parser` (this object receives their values).
  void declare(OptionParser& parser);
  /// @brief Check the values and resolve the cache (a parse() check). @throws ConfigError.
  void finish();
  /// @brief The input paths of the domain.
  /// @brief The input files; an unnamed domain becomes the site's default (navigation.yaml's
  /// first), recorded in experiment.domain_name, which keys the caches.
  ExperimentPaths paths() {
    ExperimentPaths p = ExperimentPaths::find(root, experiment.domain_name, site);
    experiment.domain_name = p.domain;
    return p;
  }
  /// @brief loadDeliveryExperimentConfig() with the overrides applied (validated).
  dialog::DialogConfig config(const ExperimentPaths& paths) const;

 private:
  bool haveCache_ = false;
  std::string cache_;
};

/**
 * @brief The input files the navigation experiments (nav_transfer, new_circumstances) read:
 * --root, --options, --config, --geometry, --knowledge; unset ones default to the repository's.
 */
struct NavExperimentFiles {
  std::string root, options, config, geometry, knowledge;
  std::string site_dir;  ///< --site: a site folder (site/site.h); "" = the office of config/
  /// The site of --site after resolveRoot() (loaded and checked), or nullptr.
  std::shared_ptr<const site::Site> site;

  /// @brief Declare the options; `options_file` is the default under the root (e.g.
  /// config/experiments/nav_transfer.yaml), `options_note` said after it in the help.
  void declare(OptionParser& parser, const std::string& options_file,
               const std::string& options_note = "");
  /// @brief Find the repository root, default the options file and load --site.
  /// @throws ConfigError.
  void resolveRoot();
  /// @brief The navigation config (after resolveInputs), with the site's names over it.
  nav::NavigationConfig navigationConfig() const;
  /// @brief A place of the site's experiments (site.yaml experiments.<experiment>.<field>);
  /// "" without a site or when it names none.
  std::string sitePlace(const std::string& experiment, const std::string& field) const;
  /// @brief Where the site's shop is named (for messages): the dialog config's field, or
  /// site.yaml's.
  std::string shopSource() const;
  /// @brief Default the navigation config, `domain`'s geometry and the human knowledge.
  void resolveInputs(const std::string& domain);
  /// @brief The site's default domain (the first of the navigation config's, after
  /// resolveRoot), for runs that name none. @throws ConfigError.
  std::string defaultDomain() const;
  /// @brief The dialog config whose shop is the site's: dialog.yaml beside the navigation
  /// config (after resolveRoot).
  std::string dialogConfig() const;
  /// @brief The site's shop, navigation.shop of dialogConfig(): the start of the experiments'
  /// episodes when their options file names none. @throws ConfigError.
  std::string siteShop() const;

 private:
  std::string options_file_;
};

}  // namespace experiments
}  // namespace krr
