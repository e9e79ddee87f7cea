/**
 * @file reasoner_internal.h
 * @brief Private to the Reasoner: its cached groundings and tables (Reasoner::GroundEntry,
 * Reasoner::TableCache) and the query helpers that the reasoner_*.cpp files share.
 */
#pragma once

#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "krr_core/plog/grounder.h"
#include "krr_core/plog/reasoner.h"

namespace krr {
namespace plog {

// ---------------------------------------------------------------------------------------------
// Incremental bookkeeping
// ---------------------------------------------------------------------------------------------

struct Reasoner::GroundEntry {
  std::unique_ptr<IncrementalGrounder> grounder;
  std::shared_ptr<GroundProgram> g;
  std::uint64_t structure = 0;  // structure_version_ it was built under
  std::uint64_t seq = 0;        // change_seq_ it reflects
  std::uint64_t serial = 0;     // unique, for the table cache
  std::uint64_t changes_from = 0;  // `changes` lists every change with seq > changes_from
  std::vector<std::pair<std::uint64_t, std::pair<int, int>>> changes;  // (seq, (inst, pr))
  std::size_t dead = 0, total = 0;  // removed / all ground pr-atoms (compaction)
};

struct Reasoner::TableCache {
  std::uint64_t entry_serial = 0, seq = 0;
  int target = -1;
  std::vector<int> conditioning;
  Table table;
};

namespace reasoner_detail {

/// @brief The attribute names of a query (formula, observations, do-statements).
void collectAttrs(const Query& q, std::set<std::string>& out);

/// @brief The key of a set of attribute names (the cone and outside-fragment caches).
std::string setKey(const std::set<std::string>& s);

}  // namespace reasoner_detail

}  // namespace plog
}  // namespace krr
