/**
 * @file arith.h
 * @brief Checked integer arithmetic for P-log terms.
 *
 * Every place that evaluates a P-log term (parser constant folding, sort ranges, the grounder)
 * goes through these functions, so that hostile input can neither wrap silently (a wrong
 * answer) nor trap (INT64_MIN / -1 raises SIGFPE on x86).
 */
#pragma once

#include <string>

namespace krr {
namespace plog {

/// @brief Outcome of one checked operation.
enum class ArithStatus { Ok, Overflow, DivisionByZero, UnknownOperator };

/// @brief a op b for op in "+", "-", "*", "/" (truncating), "mod" (sign of a, as C++ %).
/// `a mod -1` is 0 for every a (also INT64_MIN, where the hardware instruction would trap).
inline ArithStatus checkedBinary(const std::string& op, long long a, long long b, long long* out) {
  if (op == "+") return __builtin_add_overflow(a, b, out) ? ArithStatus::Overflow : ArithStatus::Ok;
  if (op == "-") return __builtin_sub_overflow(a, b, out) ? ArithStatus::Overflow : ArithStatus::Ok;
  if (op == "*") return __builtin_mul_overflow(a, b, out) ? ArithStatus::Overflow : ArithStatus::Ok;
  if (op != "/" && op != "mod") return ArithStatus::UnknownOperator;
  if (b == 0) return ArithStatus::DivisionByZero;
  if (b == -1) {  // the only case that can overflow (or trap): INT64_MIN / -1
    if (op == "mod") {
      *out = 0;
      return ArithStatus::Ok;
    }
    return __builtin_sub_overflow(0LL, a, out) ? ArithStatus::Overflow : ArithStatus::Ok;
  }
  *out = op == "/" ? a / b : a % b;
  return ArithStatus::Ok;
}

/// @brief -a, checked (-INT64_MIN overflows).
inline ArithStatus checkedNegate(long long a, long long* out) {
  return __builtin_sub_overflow(0LL, a, out) ? ArithStatus::Overflow : ArithStatus::Ok;
}

/// @brief Number of integers in lo..hi (0 when hi < lo), computed without overflow; saturates
/// at the largest unsigned value only in the impossible case of a full 2^64 span.
inline unsigned long long rangeSize(long long lo, long long hi) {
  if (hi < lo) return 0;
  const unsigned long long span =
      static_cast<unsigned long long>(hi) - static_cast<unsigned long long>(lo);  // modulo 2^64
  return span == ~0ULL ? span : span + 1;
}

}  // namespace plog
}  // namespace krr
