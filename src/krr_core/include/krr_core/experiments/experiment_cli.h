/**
 * @file experiment_cli.h
 * @brief The options delivery_trials and dialog_entropy share (one parser, one meaning): the
 * experiment (br, condition, seed, knowledge cache), the trial range and threads, where the
 * inputs are, and the overrides of config/dialog.yaml an experiment may name.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "krr_core/experiments/delivery_experiment.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/experiments/experiment_paths.h"

namespace krr {
namespace dialog {

/// @brief Usage lines of the shared options.
extern const char* const kExperimentCliUsage;

struct ExperimentCli {
  DeliveryExperimentOptions experiment;  ///< --br --condition --seed --outdated-br --learned-cache
  std::string root;                      ///< --root
  std::size_t begin = 0;                 ///< --trial-begin
  std::size_t threads = 1;               ///< --threads
  std::string out;                       ///< --out
  // Overrides of config/dialog.yaml (unset: the file's value).
  std::string serve_cost;                ///< --serve-cost none|expected
  double serve_cost_weight = -1;         ///< --serve-cost-weight
  double wrong_delivery_penalty = -1;    ///< --wrong-delivery-penalty
  long solver_trials = -1;               ///< --solver-trials
  double solver_timeout = -1;            ///< --solver-timeout

  /// @brief Consume `flag value` if it is a shared option. @throws ConfigError on a bad value.
  bool take(const std::string& flag, const std::string& value);
  /// @brief Check the required options (--br, --condition, --seed) and resolve the cache.
  void finish();
  /// @brief The input paths of the domain.
  ExperimentPaths paths() const { return ExperimentPaths::find(root, experiment.domain_name); }
  /// @brief config/dialog.yaml with the overrides applied (validated).
  DialogConfig config(const ExperimentPaths& paths) const;

 private:
  bool haveBr_ = false, haveCondition_ = false, haveSeed_ = false, haveCache_ = false;
  std::string cache_;
};

}  // namespace dialog
}  // namespace krr
