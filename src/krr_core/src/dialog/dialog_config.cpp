#include "krr_core/common/format.h"
#include "krr_core/dialog/dialog_config.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/yaml_section.h"
#include "krr_core/nav/navigation_config.h"

namespace krr {
namespace dialog {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string num(double v) { return formatNumber(v, 10); }

std::string resolve(const std::string& dir, const std::string& p) {
  return p[0] == '/' ? p : dir + "/" + p;
}

}  // namespace

std::string toString(ServeCostMode mode) {
  switch (mode) {
    case ServeCostMode::kNone: return "none";
    case ServeCostMode::kExpected: return "expected";
  }
  return "?";
}

ServeCostMode serveCostModeFromString(const std::string& text) {
  if (text == "none") return ServeCostMode::kNone;
  if (text == "expected") return ServeCostMode::kExpected;
  throw ConfigError("serve_cost.mode: value '" + text + "' must be none or expected");
}

mdp::RMaxParams DialogConfig::rmaxParams() const {
  mdp::RMaxParams p;
  p.step_cost = step_cost;
  p.rmax = rmax;
  p.known_threshold = known_threshold;
  p.refine_known = refine_known;
  p.discount = rmax_discount;
  p.replan_every = rmax_replan_every;
  p.optimism = rmax_optimism;
  return p;
}

void DialogConfig::setRMaxParams(const mdp::RMaxParams& p) {
  step_cost = p.step_cost;
  rmax = p.rmax;
  known_threshold = p.known_threshold;
  refine_known = p.refine_known;
  rmax_discount = p.discount;
  rmax_replan_every = p.replan_every;
  rmax_optimism = p.optimism;
}

void DialogConfig::validate() const {
  auto bad = [](const std::string& field, const std::string& value, const std::string& why) {
    throw ConfigError("dialog config: field '" + field + "': value " + value + " " + why);
  };
  auto nonneg = [&](double v, const std::string& f) {
    if (!std::isfinite(v) || v < 0) bad(f, num(v), "must be a finite number >= 0");
  };
  nonneg(general_cost, "dialog.general_question_cost");
  nonneg(confirm_cost, "dialog.confirm_question_cost");
  if (!std::isfinite(success_reward)) bad("dialog.success_reward", num(success_reward), "must be finite");
  if (!std::isfinite(failure_reward)) bad("dialog.failure_reward", num(failure_reward), "must be finite");
  if (!(failure_reward < success_reward))
    bad("dialog.failure_reward", num(failure_reward), "must be below dialog.success_reward");
  if (turn_limit < 0 || turn_limit > 1000) bad("dialog.turn_limit", std::to_string(turn_limit), "must be in [0, 1000]");
  if (!(discount > 0 && discount <= 1)) bad("dialog.discount", num(discount), "must be in (0, 1]");
  if (max_redeliveries < 0 || max_redeliveries > 100)
    bad("dialog.max_redeliveries", std::to_string(max_redeliveries), "must be in [0, 100]");
  nonneg(serve_cost_weight, "serve_cost.weight");
  nonneg(wrong_delivery_penalty, "serve_cost.wrong_delivery_penalty");
  if (shop.empty()) bad("navigation.shop", "\"\"", "must be a place name");
  if (time.empty()) bad("navigation.time", "\"\"", "must be a time of day");
  nonneg(step_cost, "navigation.step_cost");
  if (!(rmax > 0) || !std::isfinite(rmax)) bad("navigation.rmax", num(rmax), "must be > 0");
  if (!(step_cost < rmax)) bad("navigation.step_cost", num(step_cost), "must be below navigation.rmax");
  nonneg(failure_penalty, "navigation.failure_penalty");
  if (!(nav_discount > 0 && nav_discount <= 1)) bad("navigation.discount", num(nav_discount), "must be in (0, 1]");
  if (!(solver_precision > 0) || !std::isfinite(solver_precision)) bad("solver.precision", num(solver_precision), "must be > 0");
  if (!(solver_timeout > 0) || !std::isfinite(solver_timeout)) bad("solver.timeout", num(solver_timeout), "must be > 0");
  if (known_threshold < 1) bad("learning.known_threshold", std::to_string(known_threshold), "must be >= 1");
  if (max_episodes_per_task < 1) bad("learning.max_episodes_per_task", "0", "must be >= 1");
  if (convergence_episodes < 1) bad("learning.convergence_episodes", "0", "must be >= 1");
  if (learning_rounds < 1) bad("learning.rounds", "0", "must be >= 1");
  if (learning_mode != "areas" && learning_mode != "pairs")
    bad("learning.mode", "'" + learning_mode + "'", "must be areas or pairs");
  if (office_plog.empty()) bad("knowledge.office", "\"\"", "must be a file");
  if (speech_plog.empty()) bad("knowledge.speech", "\"\"", "must be a file");
}

void readSolverSettings(const YAML::Node& node, const std::string& path, DialogConfig& c) {
  YamlSection s(node, path, "solver", {"precision", "timeout", "max_trials"});
  c.solver_precision = s.number("precision", c.solver_precision, 0, kInf, YamlSection::kLowerOpen);
  c.solver_timeout = s.number("timeout", c.solver_timeout, 0, kInf, YamlSection::kLowerOpen);
  c.solver_max_trials = static_cast<std::size_t>(
      s.integer("max_trials", static_cast<long>(c.solver_max_trials), 0, 1000000000));
}

DialogConfig loadDialogConfig(const std::string& path) {
  const YAML::Node root = loadYamlFile(path, "dialog config");
  if (!root || root.IsNull()) throw ConfigError(path + ": empty dialog config");
  DialogConfig c;
  const std::string dir = dirName(path);
  YamlSection top(root, path, "", {"dialog", "serve_cost", "navigation", "solver", "learning", "knowledge"});
  if (top.has("dialog")) {
    YamlSection s(top.get("dialog"), path, "dialog",
              {"general_question_cost", "confirm_question_cost", "success_reward",
               "failure_reward", "turn_limit", "discount", "max_redeliveries"});
    c.general_cost = s.number("general_question_cost", c.general_cost, 0, kInf);
    c.confirm_cost = s.number("confirm_question_cost", c.confirm_cost, 0, kInf);
    c.success_reward = s.number("success_reward", c.success_reward, -kInf, kInf);
    c.failure_reward = s.number("failure_reward", c.failure_reward, -kInf, kInf);
    if (!(c.failure_reward < c.success_reward))
      throw ConfigError(path + ": field 'dialog.failure_reward': value " + num(c.failure_reward) +
                        " must be below dialog.success_reward (" + num(c.success_reward) + ")");
    c.turn_limit = static_cast<int>(s.integer("turn_limit", c.turn_limit, 0, 1000));
    c.discount = s.number("discount", c.discount, 0, 1, YamlSection::kLowerOpen);
    c.max_redeliveries = static_cast<int>(s.integer("max_redeliveries", c.max_redeliveries, 0, 100));
  }
  if (top.has("serve_cost")) {
    YamlSection s(top.get("serve_cost"), path, "serve_cost", {"mode", "weight", "wrong_delivery_penalty"});
    const std::string mode = s.string("mode", toString(c.serve_cost_mode));
    try {
      c.serve_cost_mode = serveCostModeFromString(mode);
    } catch (const ConfigError&) {
      throw ConfigError(path + ": field 'serve_cost.mode': value '" + mode +
                        "' must be none or expected");
    }
    c.serve_cost_weight = s.number("weight", c.serve_cost_weight, 0, kInf);
    c.wrong_delivery_penalty =
        s.number("wrong_delivery_penalty", c.wrong_delivery_penalty, 0, kInf);
  }
  if (top.has("navigation")) {
    YamlSection s(top.get("navigation"), path, "navigation", {"shop", "failure_penalty", "discount"});
    c.shop = s.string("shop", c.shop);
    c.failure_penalty = s.number("failure_penalty", c.failure_penalty, 0, kInf);
    c.nav_discount = s.number("discount", c.nav_discount, 0, 1, YamlSection::kLowerOpen);
  }
  if (top.has("solver")) readSolverSettings(top.get("solver"), path, c);
  if (top.has("learning")) {
    YamlSection s(top.get("learning"), path, "learning",
              {"max_episodes_per_task", "convergence_episodes", "rounds", "mode"});
    c.max_episodes_per_task = static_cast<std::size_t>(
        s.integer("max_episodes_per_task", static_cast<long>(c.max_episodes_per_task), 1, 100000000));
    c.convergence_episodes = static_cast<std::size_t>(
        s.integer("convergence_episodes", static_cast<long>(c.convergence_episodes), 1, 100000000));
    c.learning_rounds = static_cast<std::size_t>(s.integer("rounds", static_cast<long>(c.learning_rounds), 1, 1000));
    c.learning_mode = s.string("mode", c.learning_mode);
    if (c.learning_mode != "areas" && c.learning_mode != "pairs")
      throw ConfigError(path + ": field 'learning.mode': value '" + c.learning_mode +
                        "' must be areas or pairs");
  }
  if (top.has("knowledge")) {
    YamlSection s(top.get("knowledge"), path, "knowledge", {"office", "speech", "navigation"});
    c.office_plog = s.string("office", c.office_plog);
    c.speech_plog = s.string("speech", c.speech_plog);
    c.navigation_config = s.string("navigation", c.navigation_config);
  }
  c.office_plog = resolve(dir, c.office_plog);
  c.speech_plog = resolve(dir, c.speech_plog);
  if (!c.navigation_config.empty()) {
    // The navigation task's reward, R-Max and the time of day live in the navigation config
    // (one home); an experiment changes them in its own file (config/experiments/).
    c.navigation_config = resolve(dir, c.navigation_config);
    nav::NavigationConfig n;
    try {
      n = nav::loadNavigationConfig(c.navigation_config);
    } catch (const ConfigError& e) {
      throw ConfigError(path + ": field 'knowledge.navigation': " + e.what());
    }
    c.time = n.time;
    c.setRMaxParams(nav::rmaxParamsOf(n.planning, n.rmax_learning));
  }
  // The shop has no default name: it is the site's.
  if (c.shop.empty())
    throw ConfigError(path + ": field 'navigation.shop': missing: the place every delivery "
                      "starts from (a place of the navigation config's places file)");
  c.validate();
  return c;
}

}  // namespace dialog
}  // namespace krr
