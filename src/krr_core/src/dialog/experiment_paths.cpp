#include "krr_core/dialog/experiment_paths.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <vector>

#include "krr_core/common/errors.h"

namespace krr {
namespace dialog {

namespace {

bool isFile(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

std::string parent(const std::string& dir) {
  const auto pos = dir.find_last_of('/');
  if (pos == std::string::npos || pos == 0) return "/";
  return dir.substr(0, pos);
}

/// Walk up from `start` to / looking for config/dialog.yaml.
std::string searchUp(std::string dir) {
  while (!dir.empty()) {
    if (isFile(dir + "/config/dialog.yaml")) return dir;
    if (dir == "/") break;
    dir = parent(dir);
  }
  return "";
}

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::string(v) : std::string();
}

}  // namespace

ExperimentPaths ExperimentPaths::find(const std::string& root_hint, const std::string& domain) {
  std::string root = root_hint;
  std::string searched;
  if (root.empty()) root = env("KRR_ROOT");
  if (root.empty()) {
    std::vector<char> buf(4096, 0);
    if (::getcwd(buf.data(), buf.size() - 1)) {
      root = searchUp(buf.data());
      searched += std::string(buf.data()) + " and its parents";
    }
    if (root.empty()) {
      const ssize_t n = ::readlink("/proc/self/exe", buf.data(), buf.size() - 1);
      if (n > 0) {
        buf[static_cast<std::size_t>(n)] = 0;
        root = searchUp(parent(buf.data()));
        searched += std::string(", ") + parent(buf.data()) + " and its parents";
      }
    }
    if (root.empty())
      throw ConfigError("cannot find the repository (a directory with config/dialog.yaml) in " +
                        searched + "; pass --root DIR or set KRR_ROOT");
  }
  ExperimentPaths p;
  p.root = root;
  p.dialog_yaml = root + "/config/dialog.yaml";
  p.navigation_yaml = root + "/config/navigation.yaml";
  p.navigation_plog = root + "/config/navigation.plog";
  p.geometry = root + "/maps/" + domain + "_geometry.plog";
  for (const std::string* f : {&p.dialog_yaml, &p.navigation_yaml, &p.navigation_plog})
    if (!isFile(*f)) throw ConfigError("missing input file " + *f + " (repository root " + root + ")");
  if (!isFile(p.geometry))
    throw ConfigError("no geometry file " + p.geometry + " for domain '" + domain +
                      "' (generate it with make_nav_domain)");
  return p;
}

std::string defaultCacheDir() {
  std::string d = env("KRR_CACHE_DIR");
  if (!d.empty()) return d;
  d = env("XDG_CACHE_HOME");
  if (!d.empty()) return d + "/krr_rl/delivery";
  d = env("HOME");
  if (!d.empty()) return d + "/.cache/krr_rl/delivery";
  return "";
}

}  // namespace dialog
}  // namespace krr
