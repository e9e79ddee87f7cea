// Private helper of the experiments: strict reading of small YAML option files (every
// field optional, unknown fields and bad values are ConfigErrors naming file and field).
#pragma once

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/mdp/rmax_agent.h"

namespace krr {
namespace kb {
namespace detail {

/// @brief One YAML mapping with a fixed set of allowed keys.
class YamlSection {
 public:
  YamlSection(const YAML::Node& node, std::string file, std::string prefix,
              const std::set<std::string>& allowed)
      : node_(node), file_(std::move(file)), prefix_(std::move(prefix)) {
    if (node_.IsNull()) return;
    if (!node_.IsMap())
      throw ConfigError(file_ + ": " + (prefix_.empty() ? std::string("the file") : "field '" + prefix_ + "'") +
                        " must be a mapping");
    for (auto it = node_.begin(); it != node_.end(); ++it) {
      const std::string k = it->first.Scalar();
      if (!allowed.count(k)) throw ConfigError(file_ + ": unknown field '" + field(k) + "'");
    }
  }

  bool has(const std::string& k) const { return node_.IsMap() && node_[k]; }
  YAML::Node get(const std::string& k) const { return node_[k]; }
  std::string field(const std::string& k) const { return prefix_.empty() ? k : prefix_ + "." + k; }
  const std::string& file() const { return file_; }

  double number(const std::string& k, double def, double lo, double hi) const {
    if (!has(k)) return def;
    double v;
    try {
      v = node_[k].as<double>();
    } catch (const YAML::Exception&) {
      throw ConfigError(file_ + ": field '" + field(k) + "': value '" + text(node_[k]) +
                        "' is not a number");
    }
    if (!std::isfinite(v) || v < lo || v > hi) {
      std::ostringstream o;
      o << file_ << ": field '" << field(k) << "': value " << v << " is outside [" << lo << ", "
        << hi << "]";
      throw ConfigError(o.str());
    }
    return v;
  }

  std::size_t count(const std::string& k, std::size_t def, std::size_t lo, std::size_t hi) const {
    if (!has(k)) return def;
    const double v = number(k, 0, static_cast<double>(lo), static_cast<double>(hi));
    if (v != std::floor(v))
      throw ConfigError(file_ + ": field '" + field(k) + "': value " + text(node_[k]) +
                        " is not an integer");
    return static_cast<std::size_t>(v);
  }

  std::string string(const std::string& k, const std::string& def) const {
    if (!has(k)) return def;
    if (!node_[k].IsScalar())
      throw ConfigError(file_ + ": field '" + field(k) + "': value '" + text(node_[k]) +
                        "' is not a string");
    return node_[k].Scalar();
  }

  std::vector<std::string> strings(const std::string& k, const std::vector<std::string>& def) const {
    if (!has(k)) return def;
    const YAML::Node n = node_[k];
    if (!n.IsSequence())
      throw ConfigError(file_ + ": field '" + field(k) + "': value '" + text(n) +
                        "' must be a list of names");
    std::vector<std::string> out;
    for (const auto& e : n) {
      if (!e.IsScalar())
        throw ConfigError(file_ + ": field '" + field(k) + "': element '" + text(e) +
                          "' is not a name");
      out.push_back(e.Scalar());
    }
    return out;
  }

  static std::string text(const YAML::Node& n) {
    YAML::Emitter e;
    e << YAML::Flow << n;
    return e.c_str();
  }

 private:
  YAML::Node node_;
  std::string file_, prefix_;
};

/// @brief R-Max parameters from the mapping `key` of `parent` (fields known_threshold, rmax,
/// replan_every, discount, step_cost, optimism: terminal_bonus | self_loop, refine_known).
inline void readRMax(const YamlSection& parent, const std::string& key, mdp::RMaxParams& p) {
  if (!parent.has(key)) return;
  YamlSection r(parent.get(key), parent.file(), parent.field(key),
                {"known_threshold", "rmax", "replan_every", "discount", "step_cost", "optimism",
                 "refine_known"});
  p.known_threshold = static_cast<std::uint32_t>(r.count("known_threshold", p.known_threshold, 1, 1000000));
  p.rmax = r.number("rmax", p.rmax, 1e-9, 1e12);
  p.replan_every = static_cast<std::uint32_t>(r.count("replan_every", p.replan_every, 0, 1000000));
  p.discount = r.number("discount", p.discount, 0.0, 1.0);
  p.step_cost = r.number("step_cost", p.step_cost, 0.0, 1e12);
  const std::string refine = r.string("refine_known", p.refine_known ? "true" : "false");
  if (refine != "true" && refine != "false")
    throw ConfigError(r.file() + ": field '" + r.field("refine_known") + "': value '" + refine +
                      "' is not true or false");
  p.refine_known = refine == "true";
  const std::string opt =
      r.string("optimism", p.optimism == mdp::Optimism::kSelfLoop ? "self_loop" : "terminal_bonus");
  if (opt == "self_loop") p.optimism = mdp::Optimism::kSelfLoop;
  else if (opt == "terminal_bonus") p.optimism = mdp::Optimism::kTerminalBonus;
  else
    throw ConfigError(r.file() + ": field '" + r.field("optimism") + "': unknown value '" + opt +
                      "' (expected terminal_bonus or self_loop)");
}

/// @brief Parse a YAML file; ConfigError naming the file (and line) when it is not YAML.
inline YAML::Node loadYamlFile(const std::string& path) {
  const std::string text = readFile(path);  // IoError when unreadable
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
}

}  // namespace detail
}  // namespace kb
}  // namespace krr
