/**
 * @file reasoner_grounding.cpp
 * @brief The Reasoner's cache of groundings: one per relevance cone (and, for a query
 * restricted to its instances, per query), patched with the change log when only facts and
 * pr-atoms changed, ground afresh otherwise.
 */
#include "krr_core/plog/reasoner.h"

#include <algorithm>
#include <cstdint>
#include <iterator>
#include <memory>
#include <set>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include "krr_core/common/resources.h"
#include "krr_core/plog/grounder.h"
#include "reasoner_internal.h"

namespace krr {
namespace plog {

namespace reasoner_detail {

std::string setKey(const std::set<std::string>& s) {
  std::string k;
  for (const auto& x : s) k += x + ",";
  return k;
}

}  // namespace reasoner_detail

using reasoner_detail::setKey;

namespace {

/// Groundings restricted to a query's instances are one per distinct query (each small): past
/// this many in a cache, the oldest goes, so that a long-running reasoner keeps a bounded set.
constexpr size_t kMaxRestrictedGroundings = 64;

/// Drops the oldest (smallest serial) restricted grounding of `cache` when it holds more than
/// kMaxRestrictedGroundings of them.
template <class Cache>
void evictOldestRestricted(Cache& cache) {
  size_t n = 0;
  auto oldest = cache.end();
  for (auto it = cache.begin(); it != cache.end(); ++it) {
    if (!it->second->g->instance_restricted) continue;
    ++n;
    if (oldest == cache.end() || it->second->serial < oldest->second->serial) oldest = it;
  }
  if (n > kMaxRestrictedGroundings) cache.erase(oldest);
}

}  // namespace

void Reasoner::trimLog() {
  // A grounding that is never used again must not keep the log growing: past a size, stale
  // groundings are dropped (they are made afresh if needed).
  if (log_.size() > 500000) {
    for (auto it = ground_cache_.begin(); it != ground_cache_.end();)
      it = it->second->seq < change_seq_ ? ground_cache_.erase(it) : std::next(it);
  }
  std::uint64_t oldest = change_seq_;
  for (const auto& kv : ground_cache_) oldest = std::min(oldest, kv.second->seq);
  size_t k = 0;
  while (k < log_.size() && log_[k].seq <= oldest) ++k;
  if (k) log_.erase(log_.begin(), log_.begin() + static_cast<long>(k));
}

std::shared_ptr<Reasoner::GroundEntry> Reasoner::groundEntryFor(
    const std::set<std::string>& attrs, const std::vector<AttributeTerm>* atoms) {
  std::set<std::string> all = attrs;
  for (const auto& o : program_.observations) all.insert(o.literal.atom.attr.name);
  for (const auto& d : program_.interventions) all.insert(d.atom.attr.name);
  for (const auto& a : all)
    if (attrByName(a) < 0) throw UnknownSymbolError("unknown attribute '" + a + "'");
  const std::string all_key = setKey(all);
  auto ct = cone_cache_.find(all_key);
  if (ct == cone_cache_.end() || ct->second.first != structure_version_)
    ct = cone_cache_.insert_or_assign(all_key, std::make_pair(structure_version_,
                                                               relevanceCone(program_, all))).first;
  std::vector<AttributeTerm> all_atoms;
  const std::string atoms_key = coneAtomsKey(all_key, ct->second.second, atoms, all_atoms);
  const std::string key = setKey(ct->second.second) + atoms_key;
  const std::vector<AttributeTerm>* restrict_to = atoms_key.empty() ? nullptr : &all_atoms;
  // The cache holds finished groundings only: an entry is stored when its grounding (or patch)
  // has succeeded. A grounding that stops (budget, memory, cancellation, an error in the
  // program) leaves no entry behind; an empty one made room for it was the crash of issue 24
  // (the next trimLog() read the empty entry).
  auto cached = ground_cache_.find(key);
  std::shared_ptr<GroundEntry> e = cached != ground_cache_.end() ? cached->second : nullptr;
  if (e && e->structure == structure_version_ && e->seq == change_seq_) return e;
  // Drops the cached grounding for `key` (half patched, stale or refused) and the log
  // entries that only it kept alive.
  auto discard = [&]() {
    ground_cache_.erase(key);
    e.reset();
    trimLog();
  };
  if (e && e->structure == structure_version_) {
    // Patch the grounding with the net changes since it was made.
    Stopwatch sw;
    IncrementalGrounder::Delta delta;
    std::unordered_set<std::uint64_t> added, removed;
    // The log is in seq order: only its tail is newer than this grounding (other groundings
    // may keep older entries alive).
    const auto since = std::partition_point(log_.begin(), log_.end(),
                                            [&](const Change& c) { return c.seq <= e->seq; });
    for (auto c = since; c != log_.end(); ++c) {
      if (c->kind == Change::kAddRule || c->kind == Change::kAddPr) added.insert(c->id);
      else removed.insert(c->id);
    }
    for (auto it = since; it != log_.end(); ++it) {
      const Change& c = *it;
      if (added.count(c.id)) continue;  // added and removed since: unseen
      if (c.kind == Change::kRemovePr) delta.removed_prs.push_back(c.id);
      else if (c.kind == Change::kRemoveRule) delta.removed_facts.push_back(c.rule.get());
    }
    for (size_t i = 0; i < rule_ids_.size(); ++i)
      if (added.count(rule_ids_[i]) && !removed.count(rule_ids_[i]))
        delta.added_facts.push_back(&program_.rules[i]);
    for (size_t i = 0; i < pr_ids_.size(); ++i)
      if (added.count(pr_ids_[i]) && !removed.count(pr_ids_[i]))
        delta.added_prs.push_back({&program_.pr_atoms[i], pr_ids_[i]});
    std::vector<std::pair<int, int>> changed;
    bool ok = false;
    try {
      ok = e->grounder->apply(program_, delta, &changed);
    } catch (...) {
      discard();  // patched in place up to the error: no longer a grounding of any program
      throw;
    }
    if (ok) {
      e->dead = e->grounder->removedAtoms();
      e->total = e->grounder->atoms();
      e->seq = change_seq_;
      if (e->changes.size() + changed.size() > 500000) {
        e->changes.clear();
        e->changes_from = change_seq_;
      } else {
        for (const auto& ref : changed) e->changes.push_back({change_seq_, ref});
      }
      stats_.ground_seconds = sw.seconds();
      stats_.ground_instances = e->g->instances.size();
      stats_.ground_statements = e->g->ground_statements;
      stats_.ground_incremental = true;
      stats_.ground_restricted = e->g->instance_restricted;
      ++stats_.incremental_groundings;
      // Too many removed statements kept as tombstones: ground afresh (compaction; the
      // patched grounding is freed first, so that both are never in memory at once).
      if (e->dead > 50000 && e->dead * 2 > e->total) {
        discard();
      } else {
        trimLog();
        return e;
      }
    } else {
      discard();  // the patch needs a full grounding and stopped half way
    }
  } else if (e) {
    discard();  // made under another structure: never patched
  }
  Stopwatch sw;
  auto fresh = std::make_shared<GroundEntry>();
  fresh->grounder =
      std::make_unique<IncrementalGrounder>(program_, IncrementalGrounder::ClosedCone{ct->second.second, restrict_to},
                                            &pr_ids_, limits_);
  fresh->g = fresh->grounder->ground();  // may throw: nothing is stored then
  fresh->structure = structure_version_;
  fresh->seq = fresh->changes_from = change_seq_;
  fresh->serial = ++entry_serial_;
  fresh->total = fresh->grounder->atoms();
  stats_.ground_seconds = sw.seconds();
  stats_.ground_instances = fresh->g->instances.size();
  stats_.ground_statements = fresh->g->ground_statements;
  stats_.ground_incremental = false;
  stats_.ground_restricted = fresh->g->instance_restricted;
  ++stats_.full_groundings;
  ground_cache_[key] = fresh;
  if (fresh->g->instance_restricted) evictOldestRestricted(ground_cache_);
  trimLog();
  return fresh;
}

std::shared_ptr<const GroundProgram> Reasoner::groundFor(const std::set<std::string>& attrs,
                                                         const std::vector<AttributeTerm>* atoms) {
  return groundEntryFor(attrs, atoms)->g;
}

std::string Reasoner::coneAtomsKey(const std::string& all_key, const std::set<std::string>& cone,
                                   const std::vector<AttributeTerm>* atoms,
                                   std::vector<AttributeTerm>& all_atoms) {
  if (!atoms) return "";
  // (the threshold is part of the key: setLimits may change it)
  const std::string pays_key = all_key + "#" + std::to_string(limits_.cone_restrict_min_instances);
  auto pt = cone_pays_.find(pays_key);
  if (pt == cone_pays_.end() || pt->second.first != structure_version_)
    pt = cone_pays_.insert_or_assign(pays_key, std::make_pair(structure_version_,
             instanceConePays(program_, cone, limits_.cone_restrict_min_instances))).first;
  if (!pt->second.second) return "";
  all_atoms = *atoms;
  for (const auto& o : program_.observations) all_atoms.push_back(o.literal.atom.attr);
  for (const auto& d : program_.interventions) all_atoms.push_back(d.atom.attr);
  std::vector<std::string> names;
  for (const auto& t : all_atoms) names.push_back(toString(t));
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  std::string k = "|instances:";
  for (const auto& n : names) k += n + ";";
  return k;
}

}  // namespace plog
}  // namespace krr
