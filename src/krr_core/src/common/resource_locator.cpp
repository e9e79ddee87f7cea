#include "krr_core/common/resource_locator.h"

#include <unistd.h>

#include <climits>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"

namespace krr {

namespace {

const char* const kPackage = "krr_core";

std::string parentDir(const std::string& dir) {
  const auto pos = dir.find_last_of('/');
  if (pos == std::string::npos || pos == 0) return "/";
  return dir.substr(0, pos);
}

/// @brief `p` without symlinks and `..` (catkin_ws/src is a link to ../src), or "" if absent.
std::string canonical(const std::string& p) {
  char buf[PATH_MAX];
  return ::realpath(p.c_str(), buf) ? std::string(buf) : std::string();
}

std::string searchUp(std::string dir, const std::string& marker) {
  while (!dir.empty()) {
    if (isRegularFile(dir + "/" + marker)) return dir;
    if (dir == "/") break;
    dir = parentDir(dir);
  }
  return "";
}

/// @brief Whether `dir` is the krr_core package (its package.xml names it).
bool isPackageDir(const std::string& dir) {
  std::ifstream in(dir + "/package.xml");
  if (!in) return false;
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str().find(std::string("<name>") + kPackage + "</name>") != std::string::npos;
}

/// @brief The checkout holding the package in `dir` or `dir`/krr_core, if it holds `marker`.
std::string rootFromPackagePath(const std::string& dir, const std::string& marker) {
  for (const std::string& pkg : {dir, dir + "/" + kPackage}) {
    if (dir.empty() || !isPackageDir(pkg)) continue;
    const std::string root = canonical(pkg + "/../..");
    if (!root.empty() && isRegularFile(root + "/" + marker)) return root;
  }
  return "";
}

/// @brief Package directories to try: $ROS_PACKAGE_PATH, then the source spaces listed in
/// <prefix>/.catkin for every prefix of $CMAKE_PREFIX_PATH (what catkin's devel space writes).
std::vector<std::string> packageSearchPath() {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("ROS_PACKAGE_PATH"))
    for (const std::string& d : splitOption(env, ':')) dirs.push_back(d);
  if (const char* env = std::getenv("CMAKE_PREFIX_PATH")) {
    for (const std::string& prefix : splitOption(env, ':')) {
      std::ifstream in(prefix + "/.catkin");
      std::string spaces;
      if (in && std::getline(in, spaces))
        for (const std::string& d : splitOption(spaces, ';')) dirs.push_back(d);
    }
  }
  return dirs;
}

}  // namespace

const char* const kRepositoryRootHelp =
    "repository root (config/, maps/); default: $KRR_ROOT, else the checkout of the catkin "
    "package krr_core, else this program's, else the working directory's";

std::string findRepositoryRoot(const std::string& hint, const std::string& marker) {
  if (!hint.empty()) return hint;
  if (const char* env = std::getenv("KRR_ROOT")) {
    if (*env) return env;
  }
  std::string searched = "the krr_core package on $ROS_PACKAGE_PATH / $CMAKE_PREFIX_PATH";
  for (const std::string& dir : packageSearchPath()) {
    const std::string root = rootFromPackagePath(dir, marker);
    if (!root.empty()) return root;
  }
  const std::string exe = canonical("/proc/self/exe");
  if (!exe.empty()) {
    const std::string root = searchUp(parentDir(exe), marker);
    if (!root.empty()) return root;
    searched += ", " + parentDir(exe) + " and its parents";
  }
  std::vector<char> buf(PATH_MAX, 0);
  if (::getcwd(buf.data(), buf.size() - 1)) {
    const std::string root = searchUp(buf.data(), marker);
    if (!root.empty()) return root;
    searched += ", " + std::string(buf.data()) + " and its parents";
  }
  throw ConfigError("cannot find the repository (a directory with " + marker + ") in " +
                    searched + "; pass its path or set KRR_ROOT");
}

std::string resourcePath(const std::string& given, const std::string& relative,
                         const std::string& root_hint) {
  if (!given.empty()) return given;
  return findRepositoryRoot(root_hint) + "/" + relative;
}

}  // namespace krr
