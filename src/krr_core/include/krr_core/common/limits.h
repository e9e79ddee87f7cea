/**
 * @file limits.h
 * @brief Resource budgets shared by the file loaders, so that a small hostile file (a .pomdp
 * declaring 50000 states, a map image 100000 pixels wide) is refused with an error naming the
 * declaration and the size it would need, instead of exhausting memory.
 */
#pragma once

#include <cstddef>
#include <string>

namespace krr {

/// @brief The smallest default memory budget (and the default where the machine's memory is
/// unknown): 1 GiB.
constexpr std::size_t kDefaultMemoryBudget = std::size_t(1) << 30;
/// @brief The largest default memory budget: 8 GiB (more only through the variable).
constexpr std::size_t kMaxDefaultMemoryBudget = std::size_t(8) << 30;

/**
 * @brief The default memory budget from the machine: an eighth of its physical memory, within
 * [kDefaultMemoryBudget, kMaxDefaultMemoryBudget] (3 GiB on a 24 GiB machine), and at most half
 * of the process's address-space limit (RLIMIT_AS) when one is set, so that the budget is
 * reached before an allocation fails.
 */
std::size_t defaultMemoryBudget();

/// @brief The memory budget of a loader in bytes: $KRR_MEMORY_BUDGET_MIB (a positive number of
/// MiB) if set, else defaultMemoryBudget(). @throws ConfigError if the variable is malformed, so
/// that a typo never silently disables the limit.
std::size_t memoryBudget();

/// @brief a * b, saturating at SIZE_MAX: size estimates of declared dimensions must not wrap.
std::size_t saturatingMul(std::size_t a, std::size_t b);
/// @brief a + b, saturating at SIZE_MAX.
std::size_t saturatingAdd(std::size_t a, std::size_t b);

/// @brief A byte count for humans ("2.3 GiB", "512 B"); SIZE_MAX prints as "more than 16 EiB".
std::string formatBytes(std::size_t bytes);

/// @brief True for a plain identifier [A-Za-z0-9_-]+: safe as a file name stem (no '/', no '..').
bool isPlainName(const std::string& name);

}  // namespace krr
