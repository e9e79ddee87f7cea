#include "krr_core/common/cli.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include "krr_core/common/errors.h"

namespace krr {

double parseNumberOption(const std::string& option, const std::string& value) {
  char* end = nullptr;
  const double d = std::strtod(value.c_str(), &end);
  if (value.empty() || *end || !std::isfinite(d))
    throw ConfigError("option " + option + ": '" + value + "' is not a number");
  return d;
}

std::size_t parseCountOption(const std::string& option, const std::string& value) {
  const double d = parseNumberOption(option, value);
  if (d < 0 || d != std::floor(d) || d > 1e15)
    throw ConfigError("option " + option + ": '" + value + "' is not a non-negative integer");
  return static_cast<std::size_t>(d);
}

std::vector<std::string> splitOption(const std::string& value, char separator) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t pos = value.find(separator, start);
    out.push_back(value.substr(start, pos == std::string::npos ? std::string::npos : pos - start));
    if (pos == std::string::npos) return out;
    start = pos + 1;
  }
}

std::vector<double> parseNumberListOption(const std::string& option, const std::string& value) {
  std::vector<double> out;
  for (const std::string& item : splitOption(value)) out.push_back(parseNumberOption(option, item));
  return out;
}

std::vector<std::size_t> parseCountListOption(const std::string& option, const std::string& value) {
  std::vector<std::size_t> out;
  for (const std::string& item : splitOption(value)) out.push_back(parseCountOption(option, item));
  return out;
}

namespace {

std::string numberText(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

bool isHelp(const std::string& a) { return a == "-h" || a == "--help"; }

/// @brief An argument that names an option ("-x", "--xy", not "-" or a negative number).
bool looksLikeOption(const std::string& a) {
  if (a.size() < 2 || a[0] != '-') return false;
  return !(std::isdigit(static_cast<unsigned char>(a[1])) || a[1] == '.');
}

}  // namespace

OptionParser::OptionParser(std::string program, std::string summary)
    : program_(std::move(program)), summary_(std::move(summary)) {}

OptionParser& OptionParser::declare(Option o) {
  for (const std::string& n : o.names)
    if (find(n) || isHelp(n))
      throw std::logic_error(program_ + ": option " + n + " declared twice");
  options_.push_back(std::move(o));
  last_is_option_ = true;
  return *this;
}

OptionParser::Option* OptionParser::find(const std::string& name) {
  for (Option& o : options_) {
    for (const std::string& n : o.names)
      if (n == name) return &o;
    for (const std::string& n : o.deprecated_names)
      if (n == name) return &o;
  }
  return nullptr;
}

OptionParser& OptionParser::flag(const std::string& name, const std::string& help, bool* target) {
  return flag(name, help, [target] { *target = true; });
}

OptionParser& OptionParser::flag(const std::string& name, const std::string& help,
                                 std::function<void()> action) {
  Option o;
  o.names = {name};
  o.help = help;
  o.action = std::move(action);
  return declare(std::move(o));
}

OptionParser& OptionParser::add(const std::string& name, const std::string& value_name,
                                const std::string& help, Setter setter,
                                const std::string& default_text) {
  Option o;
  o.names = {name};
  o.value_name = value_name;
  o.help = help;
  o.default_text = default_text;
  o.setter = std::move(setter);
  return declare(std::move(o));
}

OptionParser& OptionParser::add(const std::string& name, const std::string& value_name,
                                const std::string& help, std::string* target) {
  return add(name, value_name, help, [target](const std::string& v) { *target = v; }, *target);
}

OptionParser& OptionParser::add(const std::string& name, const std::string& value_name,
                                const std::string& help, double* target) {
  return add(name, value_name, help,
             [target, name](const std::string& v) { *target = parseNumberOption(name, v); },
             numberText(*target));
}

OptionParser& OptionParser::add(const std::string& name, const std::string& value_name,
                                const std::string& help, std::size_t* target) {
  return add(name, value_name, help,
             [target, name](const std::string& v) { *target = parseCountOption(name, v); },
             std::to_string(*target));
}

OptionParser& OptionParser::add(const std::string& name, const std::string& value_name,
                                const std::string& help, std::uint32_t* target) {
  return add(name, value_name, help,
             [target, name](const std::string& v) {
               const std::size_t n = parseCountOption(name, v);
               if (n > 0xffffffffu)
                 throw ConfigError("option " + name + ": '" + v + "' is too large");
               *target = static_cast<std::uint32_t>(n);
             },
             std::to_string(*target));
}

OptionParser& OptionParser::add(const std::string& name, const std::string& value_name,
                                const std::string& help, int* target) {
  return add(name, value_name, help,
             [target, name](const std::string& v) {
               const double d = parseNumberOption(name, v);
               if (d != std::floor(d) || std::fabs(d) > 2147483647.0)
                 throw ConfigError("option " + name + ": '" + v + "' is not an integer");
               *target = static_cast<int>(d);
             },
             std::to_string(*target));
}

OptionParser& OptionParser::add(const std::string& name, const std::string& value_name,
                                const std::string& help, std::vector<std::string>* target) {
  return add(name, value_name, help + " (repeatable)",
             [target](const std::string& v) { target->push_back(v); });
}

OptionParser& OptionParser::positional(const std::string& value_name, const std::string& help,
                                       Setter setter, bool repeated) {
  positionals_.push_back({value_name, help, std::move(setter), repeated});
  last_is_option_ = false;
  return *this;
}

OptionParser& OptionParser::required() {
  if (last_is_option_) options_.back().is_required = true;
  return *this;
}

OptionParser& OptionParser::alias(const std::string& name) {
  if (!last_is_option_) return *this;
  if (find(name) || isHelp(name))
    throw std::logic_error(program_ + ": option " + name + " declared twice");
  options_.back().names.push_back(name);
  return *this;
}

OptionParser& OptionParser::deprecatedAlias(const std::string& name) {
  if (!last_is_option_) return *this;
  if (find(name) || isHelp(name))
    throw std::logic_error(program_ + ": option " + name + " declared twice");
  options_.back().deprecated_names.push_back(name);
  return *this;
}

OptionParser& OptionParser::defaultText(const std::string& text) {
  if (last_is_option_) options_.back().default_text = text;
  return *this;
}

OptionParser& OptionParser::epilog(const std::string& text) {
  epilog_ = text;
  return *this;
}

std::string OptionParser::usage() const {
  std::ostringstream out;
  out << "usage: " << program_;
  for (const Option& o : options_)
    if (o.is_required) out << " " << o.names[0] << (o.value_name.empty() ? "" : " " + o.value_name);
  out << " [options]";
  for (const Positional& p : positionals_)
    out << " [" << p.value_name << (p.repeated ? "..." : "") << "]";
  out << "\n";
  if (!summary_.empty()) out << summary_ << (summary_.back() == '\n' ? "" : "\n");
  constexpr std::size_t kColumn = 28, kWidth = 100;
  // One row of the table: the names, then the help wrapped at kWidth and indented to kColumn
  // (a '\n' in the help starts a new line).
  auto row = [&out](std::string left, const std::string& help) {
    left = "  " + left;
    if (left.size() + 2 > kColumn) {
      out << left << "\n";
      left.clear();
    }
    left.resize(kColumn, ' ');
    for (const std::string& paragraph : splitOption(help, '\n')) {
      std::string line;
      for (const std::string& word : splitOption(paragraph, ' ')) {
        if (!line.empty() && kColumn + line.size() + 1 + word.size() > kWidth) {
          out << left << line << "\n";
          left.assign(kColumn, ' ');
          line.clear();
        }
        line += (line.empty() ? "" : " ") + word;
      }
      out << left << line << "\n";
      left.assign(kColumn, ' ');
    }
  };
  if (!positionals_.empty()) {
    out << "arguments:\n";
    for (const Positional& p : positionals_) row(p.value_name + (p.repeated ? "..." : ""), p.help);
  }
  out << "options:\n";
  for (const Option& o : options_) {
    std::string left;
    for (const std::string& n : o.names) left += (left.empty() ? "" : ", ") + n;
    if (!o.value_name.empty()) left += " " + o.value_name;
    std::string help = o.help;
    if (o.is_required) help += " (required)";
    else if (!o.default_text.empty()) help += " (default " + o.default_text + ")";
    row(left, help);
  }
  row("-h, --help", "print this help and exit");
  if (!epilog_.empty()) out << epilog_ << (epilog_.back() == '\n' ? "" : "\n");
  return out.str();
}

int OptionParser::fail(const std::string& message) const {
  std::cerr << program_ << ": " << message << "\n" << usage();
  return 2;
}

bool OptionParser::given(const std::string& name) const {
  for (const Option& o : options_)
    for (const std::string& n : o.names)
      if (n == name) return o.given;
  return false;
}

void OptionParser::parseArguments(int argc, const char* const* argv, bool* help) {
  // --help anywhere among the options wins over every error: a pre-scan that only skips values.
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--") break;
    if (isHelp(a)) {
      *help = true;
      return;
    }
    const Option* o = a.find('=') == std::string::npos ? find(a) : nullptr;
    if (o && o->setter) ++i;
  }
  for (Option& o : options_) o.given = false;
  std::size_t next_positional = 0;
  bool options_ended = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (!options_ended && a == "--") {
      options_ended = true;
      continue;
    }
    if (options_ended || !looksLikeOption(a)) {
      if (next_positional >= positionals_.size())
        throw ConfigError("unexpected argument '" + a + "'");
      const Positional& p = positionals_[next_positional];
      if (!p.repeated) ++next_positional;
      p.setter(a);
      continue;
    }
    const std::size_t eq = a.find('=');
    const std::string name = a.substr(0, eq);
    Option* o = find(name);
    if (!o) throw ConfigError("unknown option " + name);
    for (const std::string& old : o->deprecated_names)
      if (old == name)
        std::cerr << program_ << ": option " << name << " is deprecated: use " << o->names[0]
                  << "\n";
    o->given = true;
    if (!o->setter) {
      if (eq != std::string::npos) throw ConfigError("option " + name + " takes no value");
      o->action();
      continue;
    }
    if (eq != std::string::npos) {
      o->setter(a.substr(eq + 1));
    } else {
      if (i + 1 >= argc) throw ConfigError("option " + name + " needs a value");
      o->setter(argv[++i]);
    }
  }
  for (const Option& o : options_)
    if (o.is_required && !o.given) throw ConfigError("option " + o.names[0] + " is required");
}

std::optional<int> OptionParser::parse(int argc, const char* const* argv,
                                       const std::function<void()>& check) {
  bool help = false;
  try {
    parseArguments(argc, argv, &help);
    if (help) {
      std::cout << usage();
      return 0;
    }
    if (check) check();
  } catch (const Error& e) {
    return fail(e.what());
  }
  return std::nullopt;
}

}  // namespace krr
