/**
 * @file reasoner_native.cpp
 * @brief The Reasoner's native answers: a query's evidence, do() and formula on the exact
 * engine over a cached grounding (probability, distribution), and the table query with its
 * cache of do()-conditioned tables, whose rows are recomputed only where pr-atoms changed.
 */
#include "krr_core/plog/reasoner.h"

#include <algorithm>
#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "krr_core/plog/engine.h"
#include "krr_core/plog/grounder.h"
#include "reasoner_internal.h"

namespace krr {
namespace plog {

namespace reasoner_detail {

void collectAttrs(const Query& q, std::set<std::string>& out) {
  for (const auto& l : q.formula) out.insert(l.atom.attr.name);
  for (const auto& o : q.observations) out.insert(o.literal.atom.attr.name);
  for (const auto& d : q.interventions) out.insert(d.atom.attr.name);
}

}  // namespace reasoner_detail

using reasoner_detail::collectAttrs;

namespace {

int attrIndex(const Program& p, const std::string& name) {
  for (size_t i = 0; i < p.attributes.size(); ++i)
    if (p.attributes[i].name == name) return static_cast<int>(i);
  return -1;
}

int domainIndex(const GroundProgram& g, int inst, const std::string& value) {
  const GInstance& gi = g.instances[static_cast<size_t>(inst)];
  for (size_t i = 0; i < gi.domain.size(); ++i)
    if (g.symbols->text(gi.domain[i]) == value) return static_cast<int>(i);
  return -1;
}

// Adds one ground literal to a condition (dynamic literal or constant truth).
void addLiteral(const GroundProgram& g, const Program& p, const Literal& l, GCondition& c) {
  if (l.kind != Literal::Kind::Atom) throw Error(l.loc.str() + ": comparison in a query condition");
  const std::string inst_name = toString(l.atom.attr);
  const std::string value = toString(l.atom.value);
  int a = attrIndex(p, l.atom.attr.name);
  if (a < 0) throw UnknownSymbolError(l.loc.str() + ": unknown attribute '" + l.atom.attr.name + "'");
  bool truth;
  if (g.attr_dynamic[static_cast<size_t>(a)]) {
    int inst = g.findInstance(inst_name);
    if (inst >= 0) {
      int vi = domainIndex(g, inst, value);
      c.lits.push_back(GLit{inst, vi, l.naf, l.negated});
      return;
    }
    truth = false;  // the instance never gets a value
  } else {
    std::string prefix = inst_name + "=";
    if (!l.negated) {
      truth = g.staticHolds(a, prefix + value);
    } else {
      truth = false;
      for (const auto& s : g.static_atoms[static_cast<size_t>(a)])
        if (s.compare(0, prefix.size(), prefix) == 0 && s != prefix + value) truth = true;
    }
  }
  if (l.naf) truth = !truth;
  if (!truth) c.constant = false;
}

void applyDo(const GroundProgram& g, const Program& p, const Intervention& d, ExactEngine& e) {
  int a = attrIndex(p, d.atom.attr.name);
  if (a < 0 || !g.attr_dynamic[static_cast<size_t>(a)])
    throw Error(d.loc.str() + ": do(" + toString(d.atom) +
                ") on an attribute that is neither random nor derived from random attributes "
                "is not supported by the native reasoner");
  int inst = g.findInstance(toString(d.atom.attr));
  if (inst < 0)
    throw UnknownSymbolError(d.loc.str() + ": do(" + toString(d.atom) + "): attribute instance " +
                             toString(d.atom.attr) + " is never selected or derived");
  int vi = domainIndex(g, inst, toString(d.atom.value));
  if (vi < 0)
    throw UnknownSymbolError(d.loc.str() + ": value '" + toString(d.atom.value) +
                             "' is not in the range of " + toString(d.atom.attr));
  e.setFixed(inst, vi);
}

/// The attribute terms of a query (formula, observations, do-statements).
void collectAtoms(const Query& q, std::vector<AttributeTerm>& out) {
  for (const auto& l : q.formula)
    if (l.kind == Literal::Kind::Atom) out.push_back(l.atom.attr);
  for (const auto& o : q.observations) out.push_back(o.literal.atom.attr);
  for (const auto& d : q.interventions) out.push_back(d.atom.attr);
}

}  // namespace

std::vector<GCondition> Reasoner::prepareEngine(const GroundProgram& g, const Query& q,
                                                ExactEngine& e) {
  e.setTimeBudget(limits_.max_inference_seconds);
  e.setMemoryBudget(limits_.memory_budget, q.loc);
  e.setCancelFlag(&asp_won_);
  if (plan_callback_) e.setPlanCallback(plan_callback_);
  for (const auto& d : program_.interventions) applyDo(g, program_, d, e);
  for (const auto& d : q.interventions) applyDo(g, program_, d, e);
  std::vector<GCondition> evidence;
  const std::vector<Observation>* lists[] = {&program_.observations, &q.observations};
  for (const std::vector<Observation>* os : lists)
    for (const auto& o : *os) {
      GCondition c;
      c.truth = o.truth;
      addLiteral(g, program_, o.literal, c);
      evidence.push_back(c);
    }
  return evidence;
}

double Reasoner::nativeProbability(const Query& q) {
  std::set<std::string> attrs;
  collectAttrs(q, attrs);
  std::vector<AttributeTerm> atoms;
  collectAtoms(q, atoms);
  auto g = groundFor(attrs, &atoms);
  ExactEngine e(*g);
  std::vector<GCondition> evidence = prepareEngine(*g, q, e), formula(1);
  for (const auto& l : q.formula) addLiteral(*g, program_, l, formula[0]);
  auto m = e.measure(formula, evidence);
  noteWarnings(e.warnings());
  if (!(m.second > 0))
    throw IncoherentError(q.loc.str() + ": the evidence of query " + q.text +
                          " has probability zero (no possible world satisfies it)");
  return m.first / m.second;
}

std::vector<ValueProb> Reasoner::nativeDistribution(const AttributeTerm& at, const Query& ev,
                                                    const std::string& evidence) {
  const std::string attribute_term = toString(at);
  std::set<std::string> attrs{at.name};
  collectAttrs(ev, attrs);
  std::vector<AttributeTerm> atoms{at};
  collectAtoms(ev, atoms);
  auto g = groundFor(attrs, &atoms);
  int a = attrIndex(program_, at.name);
  std::vector<ValueProb> out;
  if (!g->attr_dynamic[static_cast<size_t>(a)]) {
    // static attribute: its value (if any) has probability 1
    std::string prefix = toString(at) + "=";
    for (const auto& s : g->static_atoms[static_cast<size_t>(a)])
      if (s.compare(0, prefix.size(), prefix) == 0) out.push_back({s.substr(prefix.size()), 1.0});
    return out;
  }
  int inst = g->findInstance(toString(at));
  if (inst < 0) return out;
  ExactEngine e(*g);
  std::vector<GCondition> evs = prepareEngine(*g, ev, e);
  std::vector<double> m = e.marginal(inst, evs);
  noteWarnings(e.warnings());
  double z = 0;
  for (double x : m) z += x;
  if (!(z > 0))
    throw IncoherentError("distribution of " + attribute_term + ": the evidence '" + evidence +
                          "' has probability zero");
  const GInstance& gi = g->instances[static_cast<size_t>(inst)];
  for (size_t v = 0; v < gi.domain.size(); ++v)
    if (m[v] > 0) out.push_back({g->symbols->text(gi.domain[v]), m[v] / z});
  return out;
}

namespace {

/// @brief The ground instance of a table query's target or conditioning attribute term.
/// @throws UnknownSymbolError when the grounding has none.
int tableInstance(const GroundProgram& g, const std::string& term, const char* role) {
  const int i = g.findInstance(term);
  if (i < 0)
    throw UnknownSymbolError("table query: " + std::string(role) + " " + term +
                             " is not a random or derived attribute instance of the program");
  return i;
}

/// @brief Marks in `todo` the rows of a cached table (rows by conditioning values, `stride`
/// per conditioning instance) that the ground pr-atoms changed since `since` may change: a
/// pr-atom with a literal c=v on a do()-fixed conditioning attribute is dead in every row
/// where c has another value, so it cannot change those rows.
void markChangedRows(const GroundProgram& g,
                     const std::vector<std::pair<std::uint64_t, std::pair<int, int>>>& changes,
                     std::uint64_t since, const std::vector<int>& ci,
                     const std::vector<size_t>& stride, std::vector<char>& todo) {
  std::vector<int> fixed(ci.size());
  for (const auto& ch : changes) {
    if (ch.first <= since) continue;
    const GPr& pr = g.instances[static_cast<size_t>(ch.second.first)].prs[static_cast<size_t>(ch.second.second)];
    std::fill(fixed.begin(), fixed.end(), -1);
    for (const auto& l : pr.body) {
      if (l.naf || l.neg || l.value < 0) continue;
      for (size_t k = 0; k < ci.size(); ++k)
        if (l.inst == ci[k]) fixed[k] = fixed[k] < 0 || fixed[k] == l.value ? l.value : -2;
    }
    bool dead = false;
    for (int f : fixed) dead = dead || f == -2;  // two values for one attribute: never fires
    if (dead) continue;
    // enumerate the rows matching the fixed positions
    std::vector<size_t> cur(ci.size(), 0);
    for (;;) {
      size_t row = 0;
      for (size_t k = 0; k < ci.size(); ++k)
        row += (fixed[k] >= 0 ? static_cast<size_t>(fixed[k]) : cur[k]) * stride[k];
      todo[row] = 1;
      size_t k = 0;
      for (; k < ci.size(); ++k) {
        if (fixed[k] >= 0) continue;
        if (++cur[k] < g.instances[static_cast<size_t>(ci[k])].domain.size()) break;
        cur[k] = 0;
      }
      if (k == ci.size()) break;
    }
  }
}

/// @brief One row of a table: the target's distribution for the conditioning values `cur`
/// (value indices of the instances ci), set as do() on the engine or added as observations.
TableRow tableRow(ExactEngine& e, const GroundProgram& g, int ti, const std::vector<int>& ci,
                  const std::vector<int>& cur, const std::vector<GCondition>& evs,
                  bool conditioning_as_do) {
  const GInstance& tg = g.instances[static_cast<size_t>(ti)];
  TableRow r;
  std::vector<GCondition> evr = evs;
  for (size_t k = 0; k < ci.size(); ++k) {
    const GInstance& cg = g.instances[static_cast<size_t>(ci[k])];
    r.conditioning_values.push_back(g.symbols->text(cg.domain[static_cast<size_t>(cur[k])]));
    if (conditioning_as_do) {
      e.setFixed(ci[k], cur[k]);
    } else {
      GCondition c;
      c.lits.push_back(GLit{ci[k], cur[k], false, false});
      evr.push_back(c);
    }
  }
  std::vector<std::pair<int, double>> m = e.marginalSparse(ti, evr);
  double z = 0;
  for (const auto& x : m) z += x.second;
  if (z > 0) {
    for (const auto& x : m) {
      if (!(x.second > 0)) continue;
      if (x.first == static_cast<int>(tg.domain.size()))
        r.undefined_probability = x.second / z;
      else
        r.distribution.push_back(
            {g.symbols->text(tg.domain[static_cast<size_t>(x.first)]), x.second / z});
    }
  } else {
    r.consistent = false;
  }
  return r;
}

}  // namespace

Table Reasoner::nativeTable(const AttributeTerm& tat, const std::vector<AttributeTerm>& cats,
                            const Query& ev, const std::string& evidence,
                            bool conditioning_as_do) {
  Table t;
  t.target = toString(tat);
  std::set<std::string> attrs{tat.name};
  for (const auto& c : cats) {
    t.conditioning.push_back(toString(c));
    attrs.insert(c.name);
  }
  collectAttrs(ev, attrs);
  auto entry = groundEntryFor(attrs);
  const GroundProgram* g = entry->g.get();
  const int ti = tableInstance(*g, t.target, "target");
  std::vector<int> ci;
  for (const auto& c : t.conditioning) ci.push_back(tableInstance(*g, c, "conditioning attribute"));
  ExactEngine e(*g);
  std::vector<GCondition> evs = prepareEngine(*g, ev, e);
  if (conditioning_as_do) e.indexBy(ci);
  size_t total = 1;
  std::vector<size_t> stride(ci.size(), 1);
  for (size_t k = 0; k < ci.size(); ++k) {
    stride[k] = total;
    total *= g->instances[static_cast<size_t>(ci[k])].domain.size();
  }

  // Rows to compute: all, unless the same table was computed on this grounding before and only
  // ground pr-atoms changed since; then only the rows whose do()-values a changed pr-atom's
  // body requires (markChangedRows).
  std::string cache_key = t.target + "|";
  for (const auto& c : t.conditioning) cache_key += c + ",";
  cache_key += "|" + evidence + (conditioning_as_do ? "|do" : "|obs");
  // Stored back only once the table is complete (an inference that stops leaves the cache
  // as it was; rows recomputed in place before the stop are those of the current program).
  auto cached = table_cache_.find(cache_key);
  std::shared_ptr<TableCache> cache = cached != table_cache_.end() ? cached->second : nullptr;
  std::vector<char> todo(total, 1);
  bool reuse = conditioning_as_do && cache && cache->entry_serial == entry->serial &&
               cache->seq >= entry->changes_from && cache->target == ti &&
               cache->conditioning == ci && cache->table.rows.size() == total;
  if (reuse) {
    std::fill(todo.begin(), todo.end(), 0);
    markChangedRows(*g, entry->changes, cache->seq, ci, stride, todo);
  }

  // With a reusable cached table, rows are recomputed in place there and the result is one
  // copy of it (the 50x50 office's table has about 5,000 rows of strings: copying them twice per query
  // cost more than recomputing the changed rows).
  std::vector<TableRow>* rows = &t.rows;
  if (reuse) {
    rows = &cache->table.rows;
  } else {
    t.rows.reserve(total);
  }
  std::vector<int> cur(ci.size(), 0);
  size_t computed = 0;
  for (size_t row = 0; row < total; ++row) {
    if (todo[row]) {
      ++computed;
      TableRow r = tableRow(e, *g, ti, ci, cur, evs, conditioning_as_do);
      if (reuse)
        (*rows)[row] = std::move(r);
      else
        rows->push_back(std::move(r));
    }
    for (size_t k = 0; k < cur.size(); ++k) {
      if (++cur[k] < static_cast<int>(g->instances[static_cast<size_t>(ci[k])].domain.size())) break;
      cur[k] = 0;
    }
  }
  stats_.table_rows_computed = computed;
  if (conditioning_as_do) {
    cacheTable(cache_key, cache, *entry, ti, ci, reuse, t);
  } else {
    table_cache_.erase(cache_key);
  }
  return t;
}

void Reasoner::cacheTable(const std::string& cache_key, std::shared_ptr<TableCache> cache,
                          GroundEntry& entry, int ti, const std::vector<int>& ci, bool reuse,
                          Table& t) {
  if (!cache) cache = table_cache_[cache_key] = std::make_shared<TableCache>();
  cache->entry_serial = entry.serial;
  cache->seq = entry.seq;
  cache->target = ti;
  cache->conditioning = ci;
  if (reuse) {
    t.rows = cache->table.rows;
  } else {
    cache->table = t;
  }
  // Changes older than every table cached on this grounding are no longer needed.
  std::uint64_t oldest = entry.seq;
  for (const auto& kv : table_cache_)
    if (kv.second && kv.second->entry_serial == entry.serial) oldest = std::min(oldest, kv.second->seq);
  size_t k = 0;
  while (k < entry.changes.size() && entry.changes[k].first <= oldest) ++k;
  if (k) {
    entry.changes.erase(entry.changes.begin(), entry.changes.begin() + static_cast<long>(k));
    entry.changes_from = std::max(entry.changes_from, oldest);
  }
}

}  // namespace plog
}  // namespace krr
