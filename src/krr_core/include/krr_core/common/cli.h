/**
 * @file cli.h
 * @brief Option-value parsing shared by the command-line programs, so every program rejects a
 * malformed number the same way: with a ConfigError naming the option and the value.
 */
#pragma once

#include <cstddef>
#include <string>

namespace krr {

/// @brief `value` as a finite number. @throws ConfigError naming `option`.
double parseNumberOption(const std::string& option, const std::string& value);

/// @brief `value` as a non-negative integer (at most 1e15). @throws ConfigError naming `option`.
std::size_t parseCountOption(const std::string& option, const std::string& value);

}  // namespace krr
