/**
 * @file blocking_rate.h
 * @brief The one rule for a blocking rate (the probability that walkers block a move inside a
 * blocking area). Every reader of one (navigation.yaml, experiment files and options, the
 * free-time learner, the simulator's context, node parameters) calls it, so that all of them
 * accept the same values and refuse the others with the same message:
 *   "<where>: field '<field>': value 1.5 must be in [0, 1]".
 *
 * Where a setting may be left to the simulator's configured rates, a negative value means "not
 * set" (RateUnset::kAllowed); NaN is never a rate.
 */
#pragma once

#include <optional>
#include <string>

#include "krr_core/common/yaml_section.h"

namespace krr {
namespace nav {

/// @brief Whether a setting may leave the rate unset (negative), so that the configured rates apply.
enum class RateUnset { kRefused, kAllowed };

/// @brief The rule: `value` in [0, 1], or negative where unset is allowed. Inline and cheap,
/// because the simulator checks its context on every step.
inline bool isBlockingRate(double value, RateUnset unset) {
  return (value >= 0.0 && value <= 1.0) || (unset == RateUnset::kAllowed && value < 0.0);
}

/// @brief The message: throws ConfigError "<where>: field '<field>': value <v> must be in
/// [0, 1]" (with "(negative: not set)" where unset is allowed).
[[noreturn]] void refuseBlockingRate(double value, const std::string& where,
                                     const std::string& field, RateUnset unset);

/// @brief `value` if it is a blocking rate. @throws ConfigError (refuseBlockingRate) otherwise.
double checkBlockingRate(double value, const std::string& where,
                         const std::string& field = "blocking_rate",
                         RateUnset unset = RateUnset::kRefused);

/**
 * @brief The rate under `key` of a YAML section, checked by the rule with the section's file
 * and field path; `def` when the key is absent, or ConfigError "missing field" without `def`.
 */
double readBlockingRate(const YamlSection& section, const std::string& key, RateUnset unset,
                        std::optional<double> def = std::nullopt);

}  // namespace nav
}  // namespace krr
