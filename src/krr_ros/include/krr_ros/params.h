/**
 * @file params.h
 * @brief Reading a node's private parameters into a validated struct.
 *
 * Every node reads all of its parameters once, at start, through a ParamReader. A missing
 * parameter takes its documented default; a parameter of the wrong type, out of range, naming a
 * file that does not exist, or not known to the node at all (a typo in a YAML file) is refused
 * with a krr::ConfigError naming the parameter and the value, e.g.
 *   "parameter ~sim_rate = -1: must be in [0, 1000]".
 * The node logs it and exits: nothing runs on a half-understood configuration.
 *
 * Relative paths are resolved against the repository root: the parameter ~base_dir if set,
 * else the environment variable KRR_ROOT, else two directories above the krr_ros package
 * (src/krr_ros/../..), so `config/office.plog` works from any working directory.
 */
#pragma once

#include <ros/ros.h>

#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace krr_ros {

/// @brief Reads and validates the private parameters (~name) of one node.
class ParamReader {
 public:
  /// @param nh the node's private handle (ros::NodeHandle("~")).
  explicit ParamReader(const ros::NodeHandle& nh);

  /// @brief A string; `allowed` (if not empty) lists the accepted values.
  std::string str(const std::string& name, const std::string& def,
                  const std::vector<std::string>& allowed = {});
  /// @brief A number (int or double on the server) in [lo, hi].
  double number(const std::string& name, double def, double lo, double hi);
  /// @brief A blocking rate whose negative value (the default, -1) leaves the rates to
  /// navigation.yaml; checked by the core's one rule (krr_core/nav/blocking_rate.h), so a node
  /// refuses what the experiments refuse, with the same message.
  double blockingRate(const std::string& name);
  /// @brief An integer in [lo, hi].
  long integer(const std::string& name, long def, long lo, long hi);
  /// @brief A boolean.
  bool boolean(const std::string& name, bool def);
  /// @brief A list of strings (a YAML list; a single string is a one-element list).
  std::vector<std::string> strings(const std::string& name, const std::vector<std::string>& def);
  /// @brief A list of numbers, each in [lo, hi] (a single number is a one-element list).
  std::vector<double> numbers(const std::string& name, const std::vector<double>& def, double lo,
                              double hi);
  /// @brief A path resolved against baseDir(); with must_exist, a missing file is refused.
  std::string path(const std::string& name, const std::string& def, bool must_exist);
  /// @brief A list of paths, each resolved and (with must_exist) checked.
  std::vector<std::string> paths(const std::string& name, const std::vector<std::string>& def,
                                 bool must_exist);
  /// @brief The node's ~seed (default 1): the root seed of every random stream of the node.
  std::uint64_t seed();

  /// @brief Refuse parameters under the node's namespace that were never read (typos).
  /// Call after reading everything.
  void rejectUnknown() const;

  /// @brief Refuse a parameter: throws krr::ConfigError "parameter <ns>/<name> = <value>: <why>".
  [[noreturn]] void refuse(const std::string& name, const std::string& value,
                           const std::string& why) const;

  /// @brief Whether the parameter is set (on the server), before reading it.
  bool has(const std::string& name) const { return nh_.hasParam(name); }

  /// @brief Resolve a relative path against baseDir() (absolute paths are returned as is).
  std::string resolve(const std::string& path) const;
  /// @brief The directory relative paths are resolved against.
  const std::string& baseDir() const { return base_dir_; }

 private:
  bool fetch(const std::string& name, XmlRpc::XmlRpcValue* value);

  ros::NodeHandle nh_;
  std::string base_dir_;
  std::set<std::string> read_;
};

/// @brief Text of an XmlRpc value for error messages.
std::string describe(XmlRpc::XmlRpcValue& value);

/// @brief Create the parent directory of a file path if missing; krr::IoError on failure.
void ensureParentDirectory(const std::string& file);

/// @brief The default directory for files a node writes: $ROS_HOME/krr_rl or ~/.ros/krr_rl.
std::string defaultDataDirectory();

/**
 * @brief `-h` / `--help` among the arguments: print how to start `node` and its parameters
 * (config/<node>.yaml, which documents each with its default), then exit 0 - before
 * ros::init, so no ROS master is needed (without this the node would wait for one forever).
 */
void exitOnHelp(int argc, char** argv, const std::string& node);

}  // namespace krr_ros
