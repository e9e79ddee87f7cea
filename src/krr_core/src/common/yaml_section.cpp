#include "krr_core/common/yaml_section.h"

#include <cmath>

#include "krr_core/common/files.h"
#include "krr_core/common/format.h"

namespace krr {

namespace {

std::string num(double v) { return formatNumber(v, 10); }

bool isEmpty(const YAML::Node& n) { return !n.IsDefined() || n.IsNull(); }

template <class E>
YAML::Node loadFile(const std::string& path, const std::string& what) {
  std::string text;
  try {
    text = readFile(path);
  } catch (const IoError& e) {
    throw E(path + ": cannot read " + what + ": " + e.what());
  }
  return parseYaml<E>(text, path);
}

}  // namespace

std::string yamlText(const YAML::Node& node) {
  if (!node.IsDefined()) return "";
  YAML::Emitter e;
  e << YAML::Flow << node;
  return e.c_str();
}

YAML::Node loadYamlFile(const std::string& path, const std::string& what) {
  return loadFile<ConfigError>(path, what);
}

YAML::Node loadYamlMapFile(const std::string& path, const std::string& what) {
  return loadFile<MapError>(path, what);
}

YamlSection::YamlSection(const YAML::Node& node, std::string file, std::string prefix,
                         const std::set<std::string>& allowed, Format format)
    : node_(node), file_(std::move(file)), prefix_(std::move(prefix)), format_(format) {
  if (isEmpty(node_)) return;
  if (!node_.IsMap()) {
    raise(file_ + ": " +
                      (prefix_.empty() ? std::string("the top level") : "field '" + prefix_ + "'") +
                      ": value '" + yamlText(node_) + "' must be a mapping");
  }
  if (format_ == Format::kMapServer) return;
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    const std::string key = it->first.IsScalar() ? it->first.Scalar() : yamlText(it->first);
    if (allowed.count(key)) continue;
    std::string expected;
    for (const std::string& a : allowed) expected += (expected.empty() ? "" : ", ") + a;
    raise(file_ + ": unknown field '" + field(key) + "' (expected " + expected + ")");
  }
}

bool YamlSection::has(const std::string& key) const {
  return !isEmpty(node_) && static_cast<bool>(node_[key]);
}

YAML::Node YamlSection::get(const std::string& key) const {
  return isEmpty(node_) ? YAML::Node() : node_[key];
}

std::string YamlSection::field(const std::string& key) const {
  return prefix_.empty() ? key : prefix_ + "." + key;
}

void YamlSection::raise(const std::string& what) const {
  if (format_ != Format::kConfig) throw MapError(what);
  throw ConfigError(what);
}

void YamlSection::fail(const std::string& key, const std::string& why) const {
  raise(file_ + ": field '" + field(key) + "': value '" + yamlText(get(key)) + "' " +
                    why);
}

void YamlSection::require(const std::string& key) const {
  if (!has(key)) raise(file_ + ": missing field '" + field(key) + "'");
}

double YamlSection::number(const std::string& key, double def, double lo, double hi,
                           Bound bound) const {
  if (!has(key)) return def;
  double v;
  try {
    v = get(key).as<double>();
  } catch (const YAML::Exception&) {
    fail(key, "is not a number");
  }
  const bool open = bound == kLowerOpen;
  if (!std::isfinite(v) || v < lo || v > hi || (open && v == lo)) {
    raise(file_ + ": field '" + field(key) + "': value " + num(v) + " must be in " +
                      (open ? "(" : "[") + num(lo) + ", " + num(hi) + "]");
  }
  return v;
}

long YamlSection::integer(const std::string& key, long def, long lo, long hi) const {
  if (!has(key)) return def;
  long v;
  try {
    v = get(key).as<long>();
  } catch (const YAML::Exception&) {
    fail(key, "is not an integer");
  }
  if (v < lo || v > hi) {
    raise(file_ + ": field '" + field(key) + "': value " + std::to_string(v) +
                      " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  return v;
}

std::size_t YamlSection::count(const std::string& key, std::size_t def, std::size_t lo,
                               std::size_t hi) const {
  return static_cast<std::size_t>(
      integer(key, static_cast<long>(def), static_cast<long>(lo), static_cast<long>(hi)));
}

std::string YamlSection::string(const std::string& key, const std::string& def) const {
  if (!has(key)) return def;
  const YAML::Node n = get(key);
  if (!n.IsScalar() || n.Scalar().empty()) fail(key, "must be a non-empty string");
  return n.Scalar();
}

bool YamlSection::boolean(const std::string& key, bool def) const {
  if (!has(key)) return def;
  try {
    return get(key).as<bool>();
  } catch (const YAML::Exception&) {
    fail(key, "must be true or false");
  }
}

std::vector<std::string> YamlSection::strings(const std::string& key,
                                              const std::vector<std::string>& def) const {
  if (!has(key)) return def;
  const YAML::Node n = get(key);
  if (!n.IsSequence()) fail(key, "must be a list of names");
  std::vector<std::string> out;
  for (const auto& e : n) {
    if (!e.IsScalar() || e.Scalar().empty()) {
      raise(file_ + ": field '" + field(key) + "': element '" + yamlText(e) +
                        "' is not a name");
    }
    out.push_back(e.Scalar());
  }
  return out;
}

std::vector<double> YamlSection::requiredNumbers(const std::string& key, std::size_t size,
                                                const std::string& what) const {
  require(key);
  const YAML::Node n = get(key);
  if (!n.IsSequence() || n.size() != size) fail(key, "must be " + what);
  std::vector<double> out;
  for (const auto& e : n) {
    try {
      out.push_back(e.as<double>());
    } catch (const YAML::Exception&) {
      fail(key, "must be " + std::to_string(size) + " numbers " + what);
    }
    if (!std::isfinite(out.back())) fail(key, "must be finite");
  }
  return out;
}

double YamlSection::requiredNumber(const std::string& key, double lo, double hi,
                                   Bound bound) const {
  require(key);
  return number(key, 0.0, lo, hi, bound);
}

long YamlSection::requiredInteger(const std::string& key, long lo, long hi) const {
  require(key);
  return integer(key, 0, lo, hi);
}

std::string YamlSection::requiredString(const std::string& key) const {
  require(key);
  return string(key, "");
}

}  // namespace krr
