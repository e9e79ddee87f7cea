#include "krr_core/experiments/experiment_cli.h"

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"

namespace krr {
namespace dialog {

const char* const kExperimentCliUsage =
    "  --br B --condition learned|outdated --seed S [--trial-begin K] [--threads T]\n"
    "  [--domain office_30x30] [--learned-cache DIR|none] [--out FILE] [--root DIR]\n"
    "  [--outdated-br 0.3] [--serve-cost none|expected] [--serve-cost-weight W]\n"
    "  [--wrong-delivery-penalty P] [--solver-trials N] [--solver-timeout S]\n";

bool ExperimentCli::take(const std::string& f, const std::string& v) {
  if (f == "--br") experiment.blocking_rate = parseNumberOption(f, v), haveBr_ = true;
  else if (f == "--condition") experiment.condition = conditionFromString(v), haveCondition_ = true;
  else if (f == "--seed") experiment.seed = parseCountOption(f, v), haveSeed_ = true;
  else if (f == "--outdated-br") experiment.outdated_rate = parseNumberOption(f, v);
  else if (f == "--domain") experiment.domain_name = v;
  else if (f == "--learned-cache") cache_ = v, haveCache_ = true;
  else if (f == "--trial-begin") begin = parseCountOption(f, v);
  else if (f == "--threads") threads = parseCountOption(f, v);
  else if (f == "--out") out = v;
  else if (f == "--root") root = v;
  else if (f == "--serve-cost") serve_cost = v;
  else if (f == "--serve-cost-weight") serve_cost_weight = parseNumberOption(f, v);
  else if (f == "--wrong-delivery-penalty") wrong_delivery_penalty = parseNumberOption(f, v);
  else if (f == "--solver-trials") solver_trials = static_cast<long>(parseCountOption(f, v));
  else if (f == "--solver-timeout") solver_timeout = parseNumberOption(f, v);
  else return false;
  return true;
}

void ExperimentCli::finish() {
  if (!haveBr_) throw ConfigError("--br is required");
  if (!haveCondition_) throw ConfigError("--condition is required");
  if (!haveSeed_) throw ConfigError("--seed is required");
  if (threads == 0) throw ConfigError("option --threads: must be at least 1");
  experiment.cache_dir = haveCache_ ? (cache_ == "none" ? "" : cache_) : defaultCacheDir();
  experiment.validate();
}

DialogConfig ExperimentCli::config(const ExperimentPaths& paths) const {
  DialogConfig c = loadDialogConfig(paths.dialog_yaml);
  if (!serve_cost.empty()) c.serve_cost_mode = serveCostModeFromString(serve_cost);
  if (serve_cost_weight >= 0) c.serve_cost_weight = serve_cost_weight;
  if (wrong_delivery_penalty >= 0) c.wrong_delivery_penalty = wrong_delivery_penalty;
  if (solver_trials >= 0) c.solver_max_trials = static_cast<std::size_t>(solver_trials);
  if (solver_timeout >= 0) c.solver_timeout = solver_timeout;
  c.validate();
  return c;
}

}  // namespace dialog
}  // namespace krr
