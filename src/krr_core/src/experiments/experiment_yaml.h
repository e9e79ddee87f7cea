// Private helper of the experiments (krr::experiments::detail): the base settings an experiment file overrides (read
// with the one YAML section reader, common/yaml_section.h: every field optional, unknown
// fields and bad values are ConfigErrors naming file and field).
#pragma once

#include <fstream>
#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/yaml_section.h"
#include "krr_core/mdp/rmax_agent.h"
#include "krr_core/nav/blocking_rate.h"
#include "krr_core/nav/navigation_config.h"

namespace krr {
namespace experiments {
namespace detail {

/// @brief The base settings an experiment file overrides. An experiment file lives in
/// config/experiments/ and names only what it changes; its base is config/navigation.yaml (the
/// navigation task and R-Max). Found as ../navigation.yaml from the experiment file; a file
/// elsewhere (e.g. a test's) has the compiled-in defaults as its base.
struct ExperimentBase {
  nav::PlanningConfig planning;
  nav::RMaxLearningConfig rmax_learning;
  double blocking_rate = 0.3;
  std::string time = "morning";  ///< context.time
  bool found = false;
};

inline ExperimentBase experimentBase(const std::string& experiment_file) {
  ExperimentBase b;
  const std::string dir = dirName(experiment_file);
  const std::string base = (dir.empty() ? std::string(".") : dir) + "/../navigation.yaml";
  if (dir.size() < 11 || dir.compare(dir.size() - 11, 11, "experiments") != 0 ||
      !std::ifstream(base).good())
    return b;
  const nav::NavigationConfig c = nav::loadNavigationConfig(base);
  b.planning = c.planning;
  b.rmax_learning = c.rmax_learning;
  b.blocking_rate = c.simulator.blocking_rate;
  b.time = c.time;
  b.found = true;
  return b;
}

/// @brief A base made of settings given in code (for experiment files outside config/experiments/).
inline ExperimentBase experimentBaseOf(const mdp::RMaxParams& p, double blocking_rate,
                                       double plan_discount) {
  ExperimentBase b;
  nav::storeRMaxParams(p, b.planning, b.rmax_learning);
  b.planning.discount = plan_discount;
  b.blocking_rate = blocking_rate;
  return b;
}

/// @brief `p` with the base's reward and R-Max settings (its other fields kept).
inline void applyRMax(const ExperimentBase& b, mdp::RMaxParams& p) {
  p = nav::rmaxParamsOf(b.planning, b.rmax_learning, p);
}

/// @brief The overrides of base settings in an experiment file's top level: `planning`
/// {step_cost, rmax, discount}, `rmax_learning` {known_threshold, discount, replan_every,
/// optimism, refine_known}, `simulator` {blocking_rate} (`unset`: whether the experiment lets
/// it be unset) and `context` {time}; a section the caller's `top` does not allow is refused there.
inline void readBaseOverrides(const YamlSection& top, ExperimentBase& b, nav::RateUnset unset) {
  if (top.has("planning")) {
    YamlSection p(top.get("planning"), top.file(), "planning", {"step_cost", "rmax", "discount"});
    b.planning.step_cost = p.number("step_cost", b.planning.step_cost, 0.0, 1e12);
    b.planning.rmax = p.number("rmax", b.planning.rmax, 1e-9, 1e12);
    b.planning.discount = p.number("discount", b.planning.discount, 1e-9, 1.0);
  }
  if (top.has("rmax_learning")) {
    YamlSection r(top.get("rmax_learning"), top.file(), "rmax_learning",
                  {"known_threshold", "discount", "replan_every", "optimism", "refine_known"});
    nav::RMaxLearningConfig& l = b.rmax_learning;
    l.known_threshold = static_cast<int>(r.integer("known_threshold", l.known_threshold, 1, 1000000));
    l.discount = r.number("discount", l.discount, 0.0, 1.0);
    l.replan_every = static_cast<int>(r.integer("replan_every", l.replan_every, 0, 1000000));
    l.refine_known = r.boolean("refine_known", l.refine_known);
    l.optimism = r.string("optimism", l.optimism);
    try {
      mdp::optimismFromName(l.optimism);
    } catch (const ConfigError& e) {
      throw ConfigError(r.file() + ": field '" + r.field("optimism") + "': " + e.what());
    }
  }
  if (top.has("simulator")) {
    YamlSection s(top.get("simulator"), top.file(), "simulator", {"blocking_rate"});
    b.blocking_rate = nav::readBlockingRate(s, "blocking_rate", unset, b.blocking_rate);
  }
  if (top.has("context")) {
    YamlSection c(top.get("context"), top.file(), "context", {"time"});
    b.time = c.string("time", b.time);
  }
}

}  // namespace detail
}  // namespace experiments
}  // namespace krr
