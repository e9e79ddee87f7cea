/**
 * @file json.h
 * @brief Minimal JSON output helpers for CLIs and benchmarks (one object per line).
 */
#pragma once

#include <string>

namespace krr {

/// @brief s as a JSON string literal, quotes included.
std::string jsonString(const std::string& s);

/// @brief d as a JSON number with full precision (null for NaN/inf, which JSON lacks).
std::string jsonNumber(double d);

}  // namespace krr
