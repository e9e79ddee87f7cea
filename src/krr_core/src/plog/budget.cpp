/**
 * @file budget.cpp
 * @brief MemoryGuard: the memory budget of one phase of the P-log front end.
 */
#include "krr_core/plog/budget.h"

#include "krr_core/common/limits.h"
#include "krr_core/common/resources.h"

namespace krr {
namespace plog {

MemoryGuard::MemoryGuard(std::size_t budget)
    : budget_(budget ? budget : memoryBudget()), base_(heapBytesInUse()) {}

std::size_t MemoryGuard::used() const {
  const std::size_t now = heapBytesInUse();
  return now > base_ ? now - base_ : 0;
}

void MemoryGuard::check(const char* phase, const SourceLocation& where,
                        std::size_t about_to_allocate) const {
  // mallinfo2 walks the allocator's bins: measured before every small table it cost more than
  // the tables (35 % of nav_transfer). Small requests (< 64 KiB) measure every 256th call,
  // larger ones always: between two measures the heap grows by less than 16 MiB this way.
  if (about_to_allocate < (std::size_t{1} << 16) && (++calls_ & 255u) != 0) return;
  const std::size_t used_now = used();
  const std::size_t need = saturatingAdd(used_now, about_to_allocate);
  if (need <= budget_) return;
  std::string msg = (where.file.empty() ? std::string("<input>") : where.str()) +
                    ": memory budget of " + formatBytes(budget_) + " exhausted while " + phase +
                    " (";
  if (about_to_allocate)
    msg += formatBytes(used_now) + " used, " + formatBytes(about_to_allocate) + " more needed";
  else
    msg += formatBytes(used_now) + " used";
  msg += "; KRR_MEMORY_BUDGET_MIB sets the budget)";
  throw BudgetExceededError(msg);
}

}  // namespace plog
}  // namespace krr
