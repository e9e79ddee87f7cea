#include "krr_core/common/limits.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "krr_core/common/errors.h"

namespace krr {

std::size_t defaultMemoryBudget() {
  std::size_t budget = kDefaultMemoryBudget;
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  if (pages > 0 && page > 0) {
    const std::size_t eighth = saturatingMul(static_cast<std::size_t>(pages),
                                             static_cast<std::size_t>(page)) / 8;
    budget = std::clamp(eighth, kDefaultMemoryBudget, kMaxDefaultMemoryBudget);
  }
  struct rlimit rl;
  if (::getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY)
    budget = std::min(budget, static_cast<std::size_t>(rl.rlim_cur) / 2);
  return budget;
}

std::size_t memoryBudget() {
  const char* env = std::getenv("KRR_MEMORY_BUDGET_MIB");
  if (!env || !*env) return defaultMemoryBudget();
  char* end = nullptr;
  const double mib = std::strtod(env, &end);
  if (end == env || *end != '\0' || !std::isfinite(mib) || mib <= 0.0 || mib > 1e12) {
    throw ConfigError(std::string("KRR_MEMORY_BUDGET_MIB: value '") + env +
                      "' must be a positive number of MiB");
  }
  return static_cast<std::size_t>(mib * 1024.0 * 1024.0);
}

std::size_t saturatingMul(std::size_t a, std::size_t b) {
  const std::size_t max = std::numeric_limits<std::size_t>::max();
  if (a != 0 && b > max / a) return max;
  return a * b;
}

std::size_t saturatingAdd(std::size_t a, std::size_t b) {
  const std::size_t max = std::numeric_limits<std::size_t>::max();
  return b > max - a ? max : a + b;
}

std::string formatBytes(std::size_t bytes) {
  if (bytes == std::numeric_limits<std::size_t>::max()) return "more than 16 EiB";
  static const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  double v = static_cast<double>(bytes);
  int u = 0;
  while (v >= 1024.0 && u < 6) {
    v /= 1024.0;
    ++u;
  }
  char buf[32];
  if (u == 0) {
    std::snprintf(buf, sizeof buf, "%zu B", bytes);
  } else {
    std::snprintf(buf, sizeof buf, "%.3g %s", v, units[u]);
  }
  return buf;
}

bool isPlainName(const std::string& name) {
  if (name.empty()) return false;
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

}  // namespace krr
