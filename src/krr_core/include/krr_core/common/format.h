/**
 * @file format.h
 * @brief Number formatting shared by error messages and text exports, so that every module
 * prints values the same way (enough digits to identify the value a user wrote).
 */
#pragma once

#include <string>

namespace krr {

/// @brief `v` with `precision` significant digits (std::ostream default notation).
std::string formatNumber(double v, int precision = 17);

}  // namespace krr
