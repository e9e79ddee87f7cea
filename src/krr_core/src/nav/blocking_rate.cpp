#include "krr_core/nav/blocking_rate.h"

#include <yaml-cpp/yaml.h>

#include "krr_core/common/errors.h"
#include "krr_core/common/format.h"
#include "krr_core/common/yaml_section.h"

namespace krr {
namespace nav {

void refuseBlockingRate(double value, const std::string& where, const std::string& field,
                        RateUnset unset) {
  throw ConfigError(where + ": field '" + field + "': value " + formatNumber(value, 10) +
                    " must be in [0, 1]" +
                    (unset == RateUnset::kAllowed ? " (negative: not set)" : ""));
}

double checkBlockingRate(double value, const std::string& where, const std::string& field,
                         RateUnset unset) {
  if (!isBlockingRate(value, unset)) refuseBlockingRate(value, where, field, unset);
  return value;
}

double readBlockingRate(const YamlSection& section, const std::string& key, RateUnset unset,
                        std::optional<double> def) {
  if (!section.has(key)) {
    if (def) return *def;
    throw ConfigError(section.file() + ": missing field '" + section.field(key) + "'");
  }
  double value = 0.0;
  try {
    value = section.get(key).as<double>();
  } catch (const YAML::Exception&) {
    section.fail(key, "is not a number");
  }
  return checkBlockingRate(value, section.file(), section.field(key), unset);
}

}  // namespace nav
}  // namespace krr
