#include "krr_ros/params.h"

#include <ros/package.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/nav/blocking_rate.h"

namespace krr_ros {

namespace fs = std::filesystem;

std::string describe(XmlRpc::XmlRpcValue& value) {
  switch (value.getType()) {
    case XmlRpc::XmlRpcValue::TypeString:
      return "'" + static_cast<std::string>(value) + "'";
    case XmlRpc::XmlRpcValue::TypeInvalid:
      return "<unset>";
    default: {
      std::ostringstream o;
      value.write(o);
      return o.str();
    }
  }
}

void ensureParentDirectory(const std::string& file) {
  const fs::path dir = fs::path(file).parent_path();
  if (dir.empty()) return;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw krr::IoError("cannot create directory " + dir.string() + ": " + ec.message());
}

std::string defaultDataDirectory() {
  if (const char* rh = std::getenv("ROS_HOME"); rh && *rh) return std::string(rh) + "/krr_rl";
  if (const char* home = std::getenv("HOME"); home && *home)
    return std::string(home) + "/.ros/krr_rl";
  return "/tmp/krr_rl";
}

void exitOnHelp(int argc, char** argv, const std::string& node) {
  bool help = false;
  for (int i = 1; i < argc; ++i)
    help = help || std::string(argv[i]) == "-h" || std::string(argv[i]) == "--help";
  if (!help) return;
  std::printf("usage: rosrun krr_ros %s [__name:=NAME] [_param:=value ...]\n"
              "       (or through launch/sim.launch; a ROS master must be running)\n"
              "Private parameters (~name), each with its default; unknown ones are refused:\n",
              node.c_str());
  std::string root;
  if (const char* env = std::getenv("KRR_ROOT"); env && *env) {
    root = env;
  } else {
    const std::string pkg = ros::package::getPath("krr_ros");
    root = pkg.empty() ? fs::current_path().string() : pkg + "/../..";
  }
  const fs::path cfg = fs::path(root) / "config" / (node + ".yaml");
  std::ifstream in(cfg);
  if (!in) {
    std::printf("  (see config/%s.yaml in the repository and src/krr_ros/README.md, section %s)\n",
                node.c_str(), node.c_str());
  } else {
    std::error_code ec;
    const fs::path shown = fs::weakly_canonical(cfg, ec);
    std::printf("  from %s:\n", (ec ? cfg : shown).c_str());
    for (std::string line; std::getline(in, line);) std::printf("  %s\n", line.c_str());
  }
  std::fflush(stdout);
  std::exit(0);
}

ParamReader::ParamReader(const ros::NodeHandle& nh) : nh_(nh) {
  read_.insert("base_dir");
  std::string base;
  if (nh_.getParam("base_dir", base) && !base.empty()) {
    base_dir_ = base;
  } else if (const char* env = std::getenv("KRR_ROOT"); env && *env) {
    base_dir_ = env;
  } else {
    const std::string pkg = ros::package::getPath("krr_ros");
    base_dir_ = pkg.empty() ? fs::current_path().string() : pkg + "/../..";
  }
  std::error_code ec;
  const fs::path canon = fs::weakly_canonical(base_dir_, ec);
  if (!ec) base_dir_ = canon.string();
  if (!fs::is_directory(base_dir_))
    refuse("base_dir", base_dir_, "is not a directory");
}

void ParamReader::refuse(const std::string& name, const std::string& value,
                       const std::string& why) const {
  throw krr::ConfigError("parameter " + nh_.getNamespace() + "/" + name + " = " + value + ": " +
                         why);
}

bool ParamReader::fetch(const std::string& name, XmlRpc::XmlRpcValue* value) {
  read_.insert(name);
  return nh_.getParam(name, *value);
}

std::string ParamReader::str(const std::string& name, const std::string& def,
                             const std::vector<std::string>& allowed) {
  XmlRpc::XmlRpcValue v;
  std::string s = def;
  if (fetch(name, &v)) {
    if (v.getType() != XmlRpc::XmlRpcValue::TypeString) refuse(name, describe(v), "must be a string");
    s = static_cast<std::string>(v);
  }
  if (!allowed.empty()) {
    bool ok = false;
    std::string list;
    for (const std::string& a : allowed) {
      ok = ok || a == s;
      list += (list.empty() ? "" : ", ") + a;
    }
    if (!ok) refuse(name, "'" + s + "'", "must be one of " + list);
  }
  return s;
}

double ParamReader::number(const std::string& name, double def, double lo, double hi) {
  XmlRpc::XmlRpcValue v;
  double d = def;
  if (fetch(name, &v)) {
    if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) d = static_cast<double>(v);
    else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) d = static_cast<int>(v);
    else refuse(name, describe(v), "must be a number");
  }
  if (!std::isfinite(d) || d < lo || d > hi) {
    std::ostringstream range;
    range << "must be in [" << lo << ", " << hi << "]";
    std::ostringstream val;
    val << d;
    refuse(name, val.str(), range.str());
  }
  return d;
}

double ParamReader::blockingRate(const std::string& name) {
  const double v = number(name, -1, -std::numeric_limits<double>::max(),
                          std::numeric_limits<double>::max());
  return krr::nav::checkBlockingRate(v, "node parameters", nh_.getNamespace() + "/" + name,
                                     krr::nav::RateUnset::kAllowed);
}

long ParamReader::integer(const std::string& name, long def, long lo, long hi) {
  XmlRpc::XmlRpcValue v;
  long i = def;
  if (fetch(name, &v)) {
    if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) i = static_cast<int>(v);
    else refuse(name, describe(v), "must be an integer");
  }
  if (i < lo || i > hi)
    refuse(name, std::to_string(i),
         "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return i;
}

bool ParamReader::boolean(const std::string& name, bool def) {
  XmlRpc::XmlRpcValue v;
  if (!fetch(name, &v)) return def;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean)
    refuse(name, describe(v), "must be true or false");
  return static_cast<bool>(v);
}

std::vector<std::string> ParamReader::strings(const std::string& name,
                                              const std::vector<std::string>& def) {
  XmlRpc::XmlRpcValue v;
  if (!fetch(name, &v)) return def;
  if (v.getType() == XmlRpc::XmlRpcValue::TypeString) return {static_cast<std::string>(v)};
  if (v.getType() != XmlRpc::XmlRpcValue::TypeArray)
    refuse(name, describe(v), "must be a list of strings");
  std::vector<std::string> out;
  for (int i = 0; i < v.size(); ++i) {
    if (v[i].getType() != XmlRpc::XmlRpcValue::TypeString)
      refuse(name + "[" + std::to_string(i) + "]", describe(v[i]), "must be a string");
    out.push_back(static_cast<std::string>(v[i]));
  }
  return out;
}

std::vector<double> ParamReader::numbers(const std::string& name, const std::vector<double>& def,
                                         double lo, double hi) {
  XmlRpc::XmlRpcValue v;
  std::vector<double> out = def;
  if (fetch(name, &v)) {
    XmlRpc::XmlRpcValue list;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeArray) {
      list = v;
    } else {
      list.setSize(1);
      list[0] = v;
    }
    out.clear();
    for (int i = 0; i < list.size(); ++i) {
      const auto t = list[i].getType();
      if (t == XmlRpc::XmlRpcValue::TypeDouble) out.push_back(static_cast<double>(list[i]));
      else if (t == XmlRpc::XmlRpcValue::TypeInt) out.push_back(static_cast<int>(list[i]));
      else refuse(name + "[" + std::to_string(i) + "]", describe(list[i]), "must be a number");
    }
  }
  for (std::size_t i = 0; i < out.size(); ++i)
    if (!std::isfinite(out[i]) || out[i] < lo || out[i] > hi) {
      std::ostringstream range, val;
      range << "must be in [" << lo << ", " << hi << "]";
      val << out[i];
      refuse(name + "[" + std::to_string(i) + "]", val.str(), range.str());
    }
  return out;
}

std::string ParamReader::resolve(const std::string& path) const {
  if (path.empty() || fs::path(path).is_absolute()) return path;
  return (fs::path(base_dir_) / path).lexically_normal().string();
}

std::string ParamReader::path(const std::string& name, const std::string& def, bool must_exist) {
  const std::string p = resolve(str(name, def));
  if (must_exist && (p.empty() || !fs::is_regular_file(p)))
    refuse(name, "'" + p + "'", p.empty() ? "a file is required" : "no such file");
  return p;
}

std::vector<std::string> ParamReader::paths(const std::string& name,
                                            const std::vector<std::string>& def,
                                            bool must_exist) {
  std::vector<std::string> out;
  const std::vector<std::string> raw = strings(name, def);
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const std::string p = resolve(raw[i]);
    if (must_exist && !fs::is_regular_file(p))
      refuse(name + "[" + std::to_string(i) + "]", "'" + p + "'", "no such file");
    out.push_back(p);
  }
  return out;
}

std::uint64_t ParamReader::seed() {
  return static_cast<std::uint64_t>(integer("seed", 1, 0, 2147483647L));
}

void ParamReader::rejectUnknown() const {
  std::vector<std::string> names;
  if (!ros::param::getParamNames(names)) return;
  const std::string prefix = nh_.getNamespace() + "/";
  for (const std::string& n : names) {
    if (n.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string rest = n.substr(prefix.size());
    const std::string top = rest.substr(0, rest.find('/'));
    if (!read_.count(top)) {
      std::string known;
      for (const std::string& k : read_) known += (known.empty() ? "" : ", ") + k;
      throw krr::ConfigError("parameter " + n + " is not a parameter of this node (known: " +
                             known + ")");
    }
  }
}

}  // namespace krr_ros
