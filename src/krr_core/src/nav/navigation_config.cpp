#include "krr_core/common/format.h"
#include "krr_core/nav/navigation_config.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/limits.h"
#include "krr_core/common/yaml_section.h"
#include "krr_core/nav/blocking_rate.h"

namespace krr {
namespace nav {

namespace {

std::string num(double v) { return formatNumber(v, 10); }

std::string resolve(const std::string& base_dir, const std::string& p) {
  return p[0] == '/' ? p : base_dir + "/" + p;
}

void checkProbability(double v, const std::string& field) {
  if (!std::isfinite(v) || v < 0.0 || v > 1.0) {
    throw ConfigError("simulator config: field '" + field + "': value " + num(v) +
                      " must be in [0, 1]");
  }
}

}  // namespace

void validate(const SimulatorConfig& c) {
  checkProbability(c.move_success, "move_success");
  checkProbability(c.slip_stay, "slip_stay");
  checkProbability(c.slip_lateral, "slip_lateral");
  const double sum = c.move_success + c.slip_stay + c.slip_lateral;
  if (std::fabs(sum - 1.0) > 1e-9) {
    throw ConfigError("simulator config: field 'move_success': move_success + slip_stay + "
                      "slip_lateral = " + num(sum) + " must be 1");
  }
  checkBlockingRate(c.blocking_rate, "simulator config");
  checkProbability(c.trap_probability, "trap_probability");
  if (!std::isfinite(c.trap_reference_cell_size)) {
    throw ConfigError("simulator config: field 'trap_reference_cell_size': value " +
                      num(c.trap_reference_cell_size) + " must be finite");
  }
  if (c.times_of_day.size() != c.time_factors.size()) {
    throw ConfigError("simulator config: field 'time_of_day': " +
                      std::to_string(c.times_of_day.size()) + " names but " +
                      std::to_string(c.time_factors.size()) + " factors");
  }
  std::set<std::string> seen;
  for (size_t i = 0; i < c.times_of_day.size(); ++i) {
    if (c.times_of_day[i].empty() || !seen.insert(c.times_of_day[i]).second) {
      throw ConfigError("simulator config: field 'time_of_day': bad or duplicate name '" +
                        c.times_of_day[i] + "'");
    }
    if (!std::isfinite(c.time_factors[i]) || c.time_factors[i] < 0.0) {
      throw ConfigError("simulator config: field 'time_of_day." + c.times_of_day[i] +
                        "': value " + num(c.time_factors[i]) + " must be >= 0");
    }
  }
  for (const auto& a : c.areas) {
    // A negative rate means "not overridden".
    if (!std::isfinite(a.second.rate) || a.second.rate > 1.0) {
      throw ConfigError("simulator config: field 'areas." + a.first + ".rate': value " +
                        num(a.second.rate) + " must be in [0, 1]");
    }
    for (const auto& t : a.second.time_factor) {
      if (!seen.count(t.first)) {
        throw ConfigError("simulator config: field 'areas." + a.first + ".time_of_day': unknown "
                          "time of day '" + t.first + "'");
      }
      if (!std::isfinite(t.second) || t.second < 0.0) {
        throw ConfigError("simulator config: field 'areas." + a.first + ".time_of_day." +
                          t.first + "': value " + num(t.second) + " must be >= 0");
      }
    }
  }
}

const DomainConfig& NavigationConfig::domain(const std::string& name) const {
  for (const DomainConfig& d : domains) {
    if (d.name == name) return d;
  }
  std::string known;
  for (const DomainConfig& d : domains) known += (known.empty() ? "" : ", ") + d.name;
  throw UnknownSymbolError("navigation config: unknown domain '" + name + "' (domains: " +
                           (known.empty() ? "none" : known) + ")");
}

const DomainConfig& NavigationConfig::defaultDomain() const {
  if (domains.empty()) throw ConfigError("navigation config: field 'domains' is empty");
  return domains.front();
}

mdp::RMaxParams rmaxParamsOf(const PlanningConfig& planning, const RMaxLearningConfig& learning,
                             mdp::RMaxParams base) {
  base.step_cost = planning.step_cost;
  base.rmax = planning.rmax;
  base.known_threshold = static_cast<std::uint32_t>(learning.known_threshold);
  base.discount = learning.discount;
  base.replan_every = static_cast<std::uint32_t>(learning.replan_every);
  base.optimism = mdp::optimismFromName(learning.optimism);
  base.refine_known = learning.refine_known;
  return base;
}

void storeRMaxParams(const mdp::RMaxParams& p, PlanningConfig& planning,
                     RMaxLearningConfig& learning) {
  planning.step_cost = p.step_cost;
  planning.rmax = p.rmax;
  learning.known_threshold = static_cast<int>(p.known_threshold);
  learning.discount = p.discount;
  learning.replan_every = static_cast<int>(p.replan_every);
  learning.optimism = mdp::optimismName(p.optimism);
  learning.refine_known = p.refine_known;
}

std::vector<DomainConfig> readDomains(const YAML::Node& dn, const std::string& path,
                                      const std::string& field) {
  if (!dn.IsMap() || dn.size() == 0) {
    throw ConfigError(path + ": field '" + field + "': value '" + yamlText(dn) +
                      "' must be a non-empty mapping name -> {cols, rows, step_limit}");
  }
  std::vector<DomainConfig> out;
  for (auto it = dn.begin(); it != dn.end(); ++it) {
    DomainConfig d;
    d.name = it->first.Scalar();
    // The name becomes <map dir>/<name>.yaml: '../../x' or 'a/b' would write elsewhere.
    if (!isPlainName(d.name)) {
      throw ConfigError(path + ": field '" + field + "': name '" + d.name +
                        "' must be a plain identifier [A-Za-z0-9_-]+ (it names files in the "
                        "map directory)");
    }
    YamlSection s(it->second, path, field + "." + d.name, {"cols", "rows", "step_limit"});
    d.cols = s.requiredInteger("cols", 1, 10000);
    d.rows = s.requiredInteger("rows", 1, 10000);
    d.step_limit = s.requiredInteger("step_limit", 1, 100000000);
    out.push_back(d);
  }
  return out;
}

std::map<std::string, AreaConfig> readAreas(const YAML::Node& an, const std::string& path,
                                            const std::string& field,
                                            const std::vector<std::string>& times_of_day) {
  std::map<std::string, AreaConfig> out;
  if (!an.IsMap() && !(an.IsSequence() && an.size() == 0) && !an.IsNull()) {
    throw ConfigError(path + ": field '" + field + "': value '" + yamlText(an) +
                      "' must be a mapping area -> {rate, time_of_day}");
  }
  if (!an.IsMap()) return out;
  for (auto it = an.begin(); it != an.end(); ++it) {
    const std::string name = it->first.Scalar();
    YamlSection a(it->second, path, field + "." + name, {"rate", "time_of_day"});
    AreaConfig ac;
    ac.rate = a.number("rate", -1.0, 0.0, 1.0);
    if (a.has("time_of_day")) {
      const YAML::Node t = a.get("time_of_day");
      if (!t.IsMap()) {
        throw ConfigError(path + ": field '" + field + "." + name + ".time_of_day': value '" +
                          yamlText(t) + "' must be a mapping");
      }
      for (auto jt = t.begin(); jt != t.end(); ++jt) {
        const std::string tn = jt->first.Scalar();
        const std::string f = field + "." + name + ".time_of_day." + tn;
        if (std::find(times_of_day.begin(), times_of_day.end(), tn) == times_of_day.end())
          throw ConfigError(path + ": field '" + f + "': unknown time of day '" + tn + "'");
        double v;
        try {
          v = jt->second.as<double>();
        } catch (const YAML::Exception&) {
          throw ConfigError(path + ": field '" + f + "': value '" + yamlText(jt->second) +
                            "' is not a number");
        }
        if (!std::isfinite(v) || v < 0.0)
          throw ConfigError(path + ": field '" + f + "': value " + num(v) + " must be >= 0");
        ac.time_factor[tn] = v;
      }
    }
    out[name] = ac;
  }
  return out;
}

namespace {

/// @brief simulator.time_of_day: the times of day in file order and their blocking factors.
void readTimesOfDay(const YAML::Node& t, const std::string& path, SimulatorConfig& c) {
  if (!t.IsMap() || t.size() == 0) {
    throw ConfigError(path + ": field 'simulator.time_of_day': value '" + yamlText(t) +
                      "' must be a non-empty mapping name -> factor");
  }
  c.times_of_day.clear();
  c.time_factors.clear();
  for (auto it = t.begin(); it != t.end(); ++it) {
    const std::string name = it->first.Scalar();
    c.times_of_day.push_back(name);
    double v;
    try {
      v = it->second.as<double>();
    } catch (const YAML::Exception&) {
      throw ConfigError(path + ": field 'simulator.time_of_day." + name + "': value '" +
                        yamlText(it->second) + "' is not a number");
    }
    if (!std::isfinite(v) || v < 0.0) {
      throw ConfigError(path + ": field 'simulator.time_of_day." + name + "': value " +
                        num(v) + " must be >= 0");
    }
    c.time_factors.push_back(v);
  }
}

/// @brief The simulator section, validated as a whole (validate) once read.
void readSimulator(const YAML::Node& node, const std::string& path, SimulatorConfig& c) {
  YamlSection s(node, path, "simulator",
                {"move_success", "slip_stay", "slip_lateral", "blocking_rate", "blocking_mode",
                 "trap_probability", "trap_reference_cell_size", "time_of_day", "areas"});
  c.source = path;
  c.move_success = s.requiredNumber("move_success", 0.0, 1.0);
  c.slip_stay = s.requiredNumber("slip_stay", 0.0, 1.0);
  c.slip_lateral = s.requiredNumber("slip_lateral", 0.0, 1.0);
  const double sum = c.move_success + c.slip_stay + c.slip_lateral;
  if (std::fabs(sum - 1.0) > 1e-9) {
    throw ConfigError(path + ": field 'simulator.move_success': move_success + slip_stay + "
                      "slip_lateral = " + num(sum) + " must be 1");
  }
  c.blocking_rate = readBlockingRate(s, "blocking_rate", RateUnset::kRefused);
  const std::string mode = s.string("blocking_mode", "per_cell");
  if (mode == "per_cell") {
    c.blocking_mode = BlockingMode::kPerCell;
  } else if (mode == "on_entry") {
    c.blocking_mode = BlockingMode::kOnEntry;
  } else {
    throw ConfigError(path + ": field 'simulator.blocking_mode': unknown value '" + mode +
                      "' (expected per_cell or on_entry)");
  }
  c.trap_probability = s.requiredNumber("trap_probability", 0.0, 1.0);
  c.trap_reference_cell_size =
      s.number("trap_reference_cell_size", c.trap_reference_cell_size, 0.0, 1e6);
  if (s.has("time_of_day")) readTimesOfDay(s.get("time_of_day"), path, c);
  if (s.has("areas")) c.areas = readAreas(s.get("areas"), path, "simulator.areas", c.times_of_day);
  try {
    validate(c);
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": " + e.what());
  }
}

void readPlanner(const YAML::Node& node, const std::string& path, PlannerConfig& p) {
  YamlSection s(node, path, "planner",
                {"robot_radius", "algorithm", "timeout", "range", "interpolation_step", "simplify"});
  p.robot_radius = s.number("robot_radius", p.robot_radius, 0.0, 100.0);
  p.algorithm = s.string("algorithm", p.algorithm);
  if (p.algorithm != "rrtconnect" && p.algorithm != "prm") {
    throw ConfigError(path + ": field 'planner.algorithm': unknown value '" + p.algorithm +
                      "' (expected rrtconnect or prm)");
  }
  p.timeout = s.number("timeout", p.timeout, 0.0, 3600.0, YamlSection::kLowerOpen);
  p.range = s.number("range", p.range, 0.0, 1e6);
  p.interpolation_step =
      s.number("interpolation_step", p.interpolation_step, 0.0, 1e6, YamlSection::kLowerOpen);
  p.simplify = s.boolean("simplify", p.simplify);
}

void readPlanning(const YAML::Node& node, const std::string& path, PlanningConfig& p) {
  YamlSection s(node, path, "planning", {"step_cost", "rmax", "discount", "model_discount"});
  p.step_cost = s.number("step_cost", p.step_cost, 0.0, 1e12);
  p.rmax = s.number("rmax", p.rmax, 0.0, 1e12, YamlSection::kLowerOpen);
  p.discount = s.number("discount", p.discount, 0.0, 1.0, YamlSection::kLowerOpen);
  p.model_discount =
      s.number("model_discount", p.model_discount, 0.0, 1.0, YamlSection::kLowerOpen);
  if (!(p.step_cost < p.rmax)) {
    throw ConfigError(path + ": field 'planning.step_cost': value " + num(p.step_cost) +
                      " must be below planning.rmax (" + num(p.rmax) + ")");
  }
}

void readRMaxLearning(const YAML::Node& node, const std::string& path, RMaxLearningConfig& r) {
  YamlSection s(node, path, "rmax_learning",
                {"known_threshold", "discount", "replan_every", "optimism", "refine_known"});
  r.known_threshold = s.integer("known_threshold", r.known_threshold, 1, 1000000);
  r.discount = s.number("discount", r.discount, 0.0, 1.0, YamlSection::kLowerOpen);
  r.replan_every = s.integer("replan_every", r.replan_every, 0, 1000000);
  r.optimism = s.string("optimism", r.optimism);
  try {
    mdp::optimismFromName(r.optimism);
  } catch (const ConfigError& e) {
    throw ConfigError(path + ": field 'rmax_learning.optimism': " + e.what());
  }
  r.refine_known = s.boolean("refine_known", r.refine_known);
}

}  // namespace

NavigationConfig loadNavigationConfig(const std::string& path) {
  const YAML::Node root = loadYamlFile(path, "navigation config");
  NavigationConfig cfg;
  const std::string dir = dirName(path);
  YamlSection top(root, path, "", {"map", "places", "grid", "domains", "simulator", "planner",
                                   "planning", "rmax_learning", "context"});
  cfg.map = resolve(dir, top.requiredString("map"));
  cfg.places = resolve(dir, top.requiredString("places"));
  if (top.has("grid")) {
    YamlSection grid(top.get("grid"), path, "grid", {"max_blocked_fraction"});
    cfg.max_blocked_fraction = grid.number("max_blocked_fraction", cfg.max_blocked_fraction, 0.0,
                                           1.0, YamlSection::kLowerOpen);
  }
  if (!top.has("domains")) throw ConfigError(path + ": missing field 'domains'");
  cfg.domains = readDomains(top.get("domains"), path, "domains");
  if (top.has("simulator")) readSimulator(top.get("simulator"), path, cfg.simulator);
  if (top.has("planner")) readPlanner(top.get("planner"), path, cfg.planner);
  if (top.has("planning")) readPlanning(top.get("planning"), path, cfg.planning);
  if (top.has("rmax_learning")) readRMaxLearning(top.get("rmax_learning"), path, cfg.rmax_learning);
  if (top.has("context")) {
    YamlSection s(top.get("context"), path, "context", {"time"});
    cfg.time = s.string("time", cfg.time);
  }
  const std::vector<std::string>& times = cfg.simulator.times_of_day;
  if (std::find(times.begin(), times.end(), cfg.time) == times.end()) {
    throw ConfigError(path + ": field 'context.time': unknown time of day '" + cfg.time +
                      "' (not in simulator.time_of_day)");
  }
  return cfg;
}

}  // namespace nav
}  // namespace krr
