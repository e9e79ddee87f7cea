/**
 * @file yaml_section.h
 * @brief The one strict reader of the YAML configuration files (navigation, dialog and
 * experiment files), so that every file reports a bad field the same way: a ConfigError naming
 * the file and the full field path ("navigation.yaml: field 'planning.rmax': value -1 must be
 * in (0, 1e+12]"), and a typo in a key is an error, not a silently ignored setting.
 *
 * @code
 *   const YAML::Node root = krr::loadYamlFile(path, "navigation config");
 *   krr::YamlSection top(root, path, "", {"planning", "simulator"});
 *   if (top.has("planning")) {
 *     krr::YamlSection s(top.get("planning"), path, "planning", {"step_cost", "rmax"});
 *     step_cost = s.number("step_cost", step_cost, 0.0, 1e12);
 *     rmax = s.number("rmax", rmax, 0.0, 1e12, krr::YamlSection::kLowerOpen);
 *   }
 * @endcode
 */
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <set>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"

namespace krr {

/// @brief A YAML node in one line (flow style), for error messages.
std::string yamlText(const YAML::Node& node);

/**
 * @brief Parse YAML text; a syntax error becomes E("name:line:col: broken YAML: message").
 * E is ConfigError for configuration files, MapError for map files.
 */
template <class E = ConfigError>
YAML::Node parseYaml(const std::string& text, const std::string& name) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw E(name + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) +
            ": broken YAML: " + e.msg);
  }
}

/// @brief Read and parse a YAML file; an unreadable file is E("path: cannot read WHAT: why").
YAML::Node loadYamlFile(const std::string& path, const std::string& what);
/// @brief loadYamlFile() reporting errors as MapError (map and places files).
YAML::Node loadYamlMapFile(const std::string& path, const std::string& what);

/// @brief One YAML mapping with a fixed set of allowed keys; every getter takes the default
/// for an absent key and throws ConfigError naming file and field for a bad value.
class YamlSection {
 public:
  /// @brief Whether a number's lower bound belongs to its range.
  enum Bound { kClosed, kLowerOpen };
  /// @brief The file's kind: configuration files refuse a key outside `allowed` and throw
  /// ConfigError; map files throw MapError like the other map loaders, and a map_server map
  /// YAML ignores the keys it does not read (map_server does, and other tools add their own).
  enum class Format { kConfig, kMap, kMapServer };

  /**
   * @brief `node` must be a mapping whose keys are all in `allowed`; a null node (an empty
   * file, "section:" with nothing under it) is an empty mapping. `prefix` is the field path of
   * the node ("" for the top level). Format::kMap makes every error of this section a
   * MapError instead of a ConfigError; Format::kMapServer also ignores unknown keys.
   * @throws ConfigError (MapError) for a non-mapping or an unknown key.
   */
  YamlSection(const YAML::Node& node, std::string file, std::string prefix,
              const std::set<std::string>& allowed, Format format = Format::kConfig);

  bool has(const std::string& key) const;
  /// @brief The node of `key` (undefined when absent).
  YAML::Node get(const std::string& key) const;
  /// @brief Full field path of `key` ("prefix.key").
  std::string field(const std::string& key) const;
  const std::string& file() const { return file_; }

  /// @brief A finite number in [lo, hi] (or (lo, hi] with kLowerOpen).
  double number(const std::string& key, double def, double lo, double hi,
                Bound bound = kClosed) const;
  /// @brief An integer in [lo, hi].
  long integer(const std::string& key, long def, long lo, long hi) const;
  /// @brief A count (non-negative integer) in [lo, hi].
  std::size_t count(const std::string& key, std::size_t def, std::size_t lo, std::size_t hi) const;
  /// @brief A non-empty scalar.
  std::string string(const std::string& key, const std::string& def) const;
  /// @brief true or false.
  bool boolean(const std::string& key, bool def) const;
  /// @brief A list of non-empty scalars.
  std::vector<std::string> strings(const std::string& key,
                                   const std::vector<std::string>& def) const;
  /// @brief A list of exactly `size` finite numbers (`what` names them in the error, e.g.
  /// "[x, y, yaw]"); the key is required.
  std::vector<double> requiredNumbers(const std::string& key, std::size_t size,
                                      const std::string& what) const;

  /// @name Required fields: ConfigError "missing field 'prefix.key'" when absent.
  /// @{
  double requiredNumber(const std::string& key, double lo, double hi, Bound bound = kClosed) const;
  long requiredInteger(const std::string& key, long lo, long hi) const;
  std::string requiredString(const std::string& key) const;
  /// @}

  /// @brief ConfigError (MapError for a map file) "file: field 'prefix.key': value 'text' why".
  [[noreturn]] void fail(const std::string& key, const std::string& why) const;
  /// @brief The section's error type (Format) with `what`.
  [[noreturn]] void raise(const std::string& what) const;

 private:
  void require(const std::string& key) const;

  YAML::Node node_;
  std::string file_, prefix_;
  Format format_ = Format::kConfig;
};

}  // namespace krr
