#include "krr_core/common/cli.h"

#include <cmath>
#include <cstdlib>

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

}  // namespace krr
