#include "krr_core/common/format.h"
#include "krr_core/dialog/dialog_config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/nav/navigation_config.h"

namespace krr {
namespace dialog {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string num(double v) { return formatNumber(v, 10); }

std::string dump(const YAML::Node& n) {
  std::string s = YAML::Dump(n);
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}

/// Reads the fields of one YAML mapping, rejecting unknown keys, naming the full field path.
class Section {
 public:
  Section(const YAML::Node& node, std::string file, std::string prefix,
          std::set<std::string> allowed)
      : node_(node), file_(std::move(file)), prefix_(std::move(prefix)) {
    if (!node_.IsMap())
      throw ConfigError(file_ + ": field '" + (prefix_.empty() ? "(top)" : prefix_) +
                        "': value '" + dump(node_) + "' must be a mapping");
    for (auto it = node_.begin(); it != node_.end(); ++it) {
      const std::string key = it->first.Scalar();
      if (!allowed.count(key)) throw ConfigError(file_ + ": unknown field '" + field(key) + "'");
    }
  }
  std::string field(const std::string& key) const {
    return prefix_.empty() ? key : prefix_ + "." + key;
  }
  bool has(const std::string& key) const { return static_cast<bool>(node_[key]); }
  YAML::Node get(const std::string& key) const { return node_[key]; }

  double number(const std::string& key, double def, double lo, double hi,
                bool lo_open = false) const {
    const YAML::Node n = node_[key];
    if (!n) return def;
    double v;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      throw ConfigError(file_ + ": field '" + field(key) + "': value '" + dump(n) +
                        "' is not a number");
    }
    if (!std::isfinite(v) || v < lo || v > hi || (lo_open && v == lo))
      throw ConfigError(file_ + ": field '" + field(key) + "': value " + num(v) + " must be in " +
                        (lo_open ? "(" : "[") + num(lo) + ", " + num(hi) + "]");
    return v;
  }
  long integer(const std::string& key, long def, long lo, long hi) const {
    const YAML::Node n = node_[key];
    if (!n) return def;
    long v;
    try {
      v = n.as<long>();
    } catch (const YAML::Exception&) {
      throw ConfigError(file_ + ": field '" + field(key) + "': value '" + dump(n) +
                        "' is not an integer");
    }
    if (v < lo || v > hi)
      throw ConfigError(file_ + ": field '" + field(key) + "': value " + std::to_string(v) +
                        " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return v;
  }
  std::string string(const std::string& key, const std::string& def) const {
    const YAML::Node n = node_[key];
    if (!n) return def;
    if (!n.IsScalar() || n.Scalar().empty())
      throw ConfigError(file_ + ": field '" + field(key) + "': value '" + dump(n) +
                        "' must be a non-empty string");
    return n.Scalar();
  }
  bool boolean(const std::string& key, bool def) const {
    const YAML::Node n = node_[key];
    if (!n) return def;
    try {
      return n.as<bool>();
    } catch (const YAML::Exception&) {
      throw ConfigError(file_ + ": field '" + field(key) + "': value '" + dump(n) +
                        "' must be true or false");
    }
  }

 private:
  YAML::Node node_;
  std::string file_, prefix_;
};

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

DialogConfig loadDialogConfig(const std::string& path) {
  std::string text;
  try {
    text = readFile(path);
  } catch (const IoError& e) {
    throw ConfigError(path + ": cannot read dialog config: " + e.what());
  }
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ":" +
                      std::to_string(e.mark.column + 1) + ": broken YAML: " + e.msg);
  }
  if (!root || root.IsNull()) throw ConfigError(path + ": empty dialog config");
  DialogConfig c;
  const std::string dir = dirName(path);
  Section top(root, path, "", {"dialog", "serve_cost", "navigation", "solver", "learning", "knowledge"});
  if (top.has("dialog")) {
    Section s(top.get("dialog"), path, "dialog",
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
    c.discount = s.number("discount", c.discount, 0, 1, true);
    c.max_redeliveries = static_cast<int>(s.integer("max_redeliveries", c.max_redeliveries, 0, 100));
  }
  if (top.has("serve_cost")) {
    Section s(top.get("serve_cost"), path, "serve_cost", {"mode", "weight", "wrong_delivery_penalty"});
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
    Section s(top.get("navigation"), path, "navigation",
              {"shop", "time", "failure_penalty", "discount"});
    c.shop = s.string("shop", c.shop);
    c.time = s.string("time", c.time);
    c.failure_penalty = s.number("failure_penalty", c.failure_penalty, 0, kInf);
    c.nav_discount = s.number("discount", c.nav_discount, 0, 1, true);
  }
  if (top.has("solver")) {
    Section s(top.get("solver"), path, "solver", {"precision", "timeout", "max_trials"});
    c.solver_precision = s.number("precision", c.solver_precision, 0, kInf, true);
    c.solver_timeout = s.number("timeout", c.solver_timeout, 0, kInf, true);
    c.solver_max_trials = static_cast<std::size_t>(
        s.integer("max_trials", static_cast<long>(c.solver_max_trials), 0, 1000000000));
  }
  if (top.has("learning")) {
    Section s(top.get("learning"), path, "learning",
              {"known_threshold", "refine_known", "max_episodes_per_task",
               "convergence_episodes", "rounds", "mode"});
    c.known_threshold = static_cast<std::uint32_t>(s.integer("known_threshold", c.known_threshold, 1, 1000000));
    c.refine_known = s.boolean("refine_known", c.refine_known);
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
    Section s(top.get("knowledge"), path, "knowledge", {"office", "speech", "navigation"});
    c.office_plog = s.string("office", c.office_plog);
    c.speech_plog = s.string("speech", c.speech_plog);
    c.navigation_config = s.string("navigation", c.navigation_config);
  }
  c.office_plog = resolve(dir, c.office_plog);
  c.speech_plog = resolve(dir, c.speech_plog);
  if (!c.navigation_config.empty()) {
    // The navigation task's reward and R-Max live in the navigation config (one home).
    c.navigation_config = resolve(dir, c.navigation_config);
    nav::NavigationConfig n;
    try {
      n = nav::loadNavigationConfig(c.navigation_config);
    } catch (const ConfigError& e) {
      throw ConfigError(path + ": field 'knowledge.navigation': " + e.what());
    }
    c.step_cost = n.planning.step_cost;
    c.rmax = n.planning.rmax;
    c.rmax_discount = n.rmax_learning.discount;
    c.rmax_replan_every = static_cast<std::uint32_t>(n.rmax_learning.replan_every);
    c.rmax_optimism = n.rmax_learning.optimism == "self_loop" ? mdp::Optimism::kSelfLoop
                                                              : mdp::Optimism::kTerminalBonus;
  }
  c.validate();
  return c;
}

}  // namespace dialog
}  // namespace krr
