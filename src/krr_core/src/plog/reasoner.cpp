#include "krr_core/plog/reasoner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <limits>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <unordered_map>
#include <unordered_set>

#include "krr_core/common/files.h"
#include "krr_core/common/resources.h"
#include "krr_core/plog/asp_backend.h"
#include "krr_core/plog/engine.h"
#include "krr_core/plog/grounder.h"
#include "krr_core/plog/parser.h"
#include "scc.h"

namespace krr {
namespace plog {

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

void collectAttrs(const Query& q, std::set<std::string>& out) {
  for (const auto& l : q.formula) out.insert(l.atom.attr.name);
  for (const auto& o : q.observations) out.insert(o.literal.atom.attr.name);
  for (const auto& d : q.interventions) out.insert(d.atom.attr.name);
}

std::string setKey(const std::set<std::string>& s) {
  std::string k;
  for (const auto& x : s) k += x + ",";
  return k;
}

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

std::string prKey(const PrAtom& p) {
  std::vector<std::string> b;
  for (const auto& l : p.body) b.push_back(toString(l));
  std::sort(b.begin(), b.end());
  std::string k = p.label + "|" + toString(p.atom) + "|";
  for (const auto& x : b) k += x + ";";
  return k;
}

}  // namespace

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

namespace {

std::string ruleKey(const Rule& r) { return toString(r); }

// Attribute terms of the atom literals of a body.
template <class F>
void forBodyAttrs(const std::vector<Literal>& body, F f) {
  for (const auto& l : body)
    if (l.kind == Literal::Kind::Atom) f(l.atom.attr);
}

}  // namespace

Reasoner::Reasoner() {
  limits_.cancel = &asp_won_;
  program_ = parseProgram("", "<empty>");
  structuralChange();
}
Reasoner::~Reasoner() = default;

void Reasoner::rebuildPrIndex() {
  pr_index_.clear();
  pr_index_.reserve(pr_keys_.size());
  for (size_t i = 0; i < pr_keys_.size(); ++i) pr_index_[pr_keys_[i]] = i;
  pr_index_valid_ = true;
}

void Reasoner::ensureKeys() {
  if (keys_valid_) return;
  rule_keys_.clear();
  rule_key_count_.clear();
  rule_keys_.reserve(program_.rules.size());
  for (const auto& r : program_.rules) {
    rule_keys_.push_back(ruleKey(r));
    ++rule_key_count_[rule_keys_.back()];
  }
  pr_keys_.clear();
  pr_keys_.reserve(program_.pr_atoms.size());
  for (const auto& p : program_.pr_atoms) pr_keys_.push_back(prKey(p));
  pr_index_valid_ = false;
  keys_valid_ = true;
}

void Reasoner::structuralChange() {
  // ids of statements that have none yet (a freshly loaded program); their keys are made
  // when first needed (ensureKeys): a program that is only queried never needs them
  if (rule_ids_.size() != program_.rules.size()) {
    rule_ids_.clear();
    rule_ids_.reserve(program_.rules.size());
    for (size_t i = 0; i < program_.rules.size(); ++i) rule_ids_.push_back(next_id_++);
    keys_valid_ = false;
  }
  if (pr_ids_.size() != program_.pr_atoms.size()) {
    pr_ids_.clear();
    pr_ids_.reserve(program_.pr_atoms.size());
    for (size_t i = 0; i < program_.pr_atoms.size(); ++i) pr_ids_.push_back(next_id_++);
    keys_valid_ = false;
  }
  if (!keys_valid_) {
    rule_keys_.clear();
    rule_key_count_.clear();
    pr_keys_.clear();
    pr_index_.clear();
    pr_index_valid_ = false;
  }
  // attribute names -> index (the last declaration of a name wins)
  attr_count_ = program_.attributes.size();
  attr_index_ = std::make_unique<AttributeIndex>(program_, true);
  attr_random_.assign(program_.attributes.size(), 0);
  for (const auto& r : program_.random_rules) {
    const int a = attrOf(r.attr);
    if (a >= 0) attr_random_[static_cast<size_t>(a)] = 1;
  }
  // the dependency counts are made when statements are first added or removed (ensureCounts)
  counts_valid_ = false;
  edge_count_.clear();
  head_value_count_.clear();
  head_values_.clear();
  head_var_.clear();
  ++structure_version_;
  log_.clear();
  cone_cache_.clear();
  cone_pays_.clear();
  ground_cache_.clear();
  table_cache_.clear();
}

int Reasoner::attrByName(const std::string& name) const {
  const int a = attr_index_->find(name);
  return static_cast<size_t>(a) < attr_count_ ? a : -1;
}

int Reasoner::attrOf(const AttributeTerm& t) const {
  if (t.index >= 0 && static_cast<size_t>(t.index) >= attr_count_) return attrByName(t.name);
  return attr_index_->of(t);
}

void Reasoner::ensureCounts() {
  if (counts_valid_) return;
  edge_count_.clear();
  head_value_count_.clear();
  head_values_.assign(program_.attributes.size(), 0);
  head_var_.assign(program_.attributes.size(), 0);
  for (const auto& r : program_.rules) countRule(r, +1);
  for (const auto& p : program_.pr_atoms) countPr(p, +1);
  for (const auto& r : program_.random_rules) {
    const int a = attrOf(r.attr);
    if (a < 0) continue;
    auto edge = [&](const AttributeTerm& t) {
      const int b = attrOf(t);
      if (b >= 0)
        ++edge_count_[(static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b)];
    };
    forBodyAttrs(r.body, edge);
    forBodyAttrs(r.range_body, edge);
  }
  counts_valid_ = true;
}

bool Reasoner::countPr(const PrAtom& p, int delta) {
  const int a = attrOf(p.atom.attr);
  if (a < 0) return true;  // unknown attribute: let grounding report it
  const std::uint64_t child = static_cast<std::uint64_t>(a) << 32;
  bool changed = false;
  int seen[8];
  int nseen = 0;
  for (const auto& l : p.body) {
    if (l.kind != Literal::Kind::Atom) continue;
    const int b = attrOf(l.atom.attr);
    if (b < 0) return true;
    bool dup = false;
    for (int k = 0; k < nseen; ++k) dup = dup || seen[k] == b;
    if (dup) continue;
    if (nseen < 8) seen[nseen++] = b;
    int& c = edge_count_[child | static_cast<std::uint32_t>(b)];
    const int before = c;
    c += delta;
    if ((before > 0) != (c > 0)) changed = true;
  }
  return changed;
}

bool Reasoner::countRule(const Rule& r, int delta) {
  if (!r.head) return true;  // constraints always enter cones
  if (r.consistency_restoring) return true;  // a fresh grounding refuses it (ASP only)
  const int a = attrOf(r.head->attr);
  if (a < 0) return true;
  bool changed = !r.body.empty();  // rules with bodies: relations between attributes
  const std::uint64_t child = static_cast<std::uint64_t>(a) << 32;
  forBodyAttrs(r.body, [&](const AttributeTerm& t) {
    const int b = attrOf(t);
    if (b >= 0) edge_count_[child | static_cast<std::uint32_t>(b)] += delta;
  });
  if (attr_random_[static_cast<size_t>(a)]) return changed;
  // Derived attributes that may take two values in a world enter every cone (relevanceCone).
  const bool var = r.head->value.kind == Term::Kind::Variable;
  const std::string value = var ? "_var" : toString(r.head->value);
  auto multi = [&]() {
    return head_values_[static_cast<size_t>(a)] >= 2 || head_var_[static_cast<size_t>(a)] > 0;
  };
  const bool before = multi();
  int& c = head_value_count_[r.head->attr.name + "|" + value];
  if (c == 0 && delta > 0) ++head_values_[static_cast<size_t>(a)];
  c += delta;
  if (c == 0 && delta < 0) --head_values_[static_cast<size_t>(a)];
  if (var) head_var_[static_cast<size_t>(a)] += delta;
  return changed || before != multi();
}

void Reasoner::loadFile(const std::string& path, Dialect dialect) {
  loadString(readFile(path), path, dialect);
}

void Reasoner::loadString(const std::string& text, const std::string& name, Dialect dialect) {
  program_ = parseProgram(text, name, dialect, parse_options_);
  rule_ids_.clear();
  pr_ids_.clear();
  keys_valid_ = false;  // (also when the new program has no statement: the old keys go)
  structuralChange();
}

size_t Reasoner::addStatements(const std::string& text, const std::string& tag,
                               const std::string& name) {
  // Parse against the declarations only (copying every statement of a large knowledge base
  // for each addition would cost more than the parse); the statement vectors are sized like
  // the program's so that fresh variable names are the ones a full copy would get.
  Program work;
  work.dialect = program_.dialect;
  work.sorts = program_.sorts;
  work.attributes = program_.attributes;
  work.domains = program_.domains;
  work.rules.resize(program_.rules.size());
  work.random_rules.resize(program_.random_rules.size());
  work.pr_atoms.resize(program_.pr_atoms.size());
  work.queries.resize(program_.queries.size());
  const size_t nr = work.rules.size(), nrr = work.random_rules.size(),
               np = work.pr_atoms.size(), nq = work.queries.size();
  parseInto(work, text, name, Dialect::Auto, parse_options_);
  program_.warnings.insert(program_.warnings.end(), work.warnings.begin(), work.warnings.end());
  // Declarations, selection rules and program-level evidence change the structure.
  const bool structural =
      work.sorts.size() != program_.sorts.size() ||
      work.attributes.size() != program_.attributes.size() ||
      work.domains.size() != program_.domains.size() || work.random_rules.size() != nrr ||
      !work.observations.empty() || !work.interventions.empty() ||
      work.dialect != program_.dialect;
  if (structural) {
    program_.dialect = work.dialect;
    program_.sorts = std::move(work.sorts);
    program_.attributes = std::move(work.attributes);
    program_.attribute_names = std::move(work.attribute_names);
    program_.domains = std::move(work.domains);
    for (size_t i = nrr; i < work.random_rules.size(); ++i)
      program_.random_rules.push_back(std::move(work.random_rules[i]));
    for (auto& o : work.observations) program_.observations.push_back(std::move(o));
    for (auto& d : work.interventions) program_.interventions.push_back(std::move(d));
  }  // (sorts and attributes cannot be redeclared: the parser refuses that)
  for (size_t i = nq; i < work.queries.size(); ++i) program_.queries.push_back(std::move(work.queries[i]));
  std::vector<Rule> rules(std::make_move_iterator(work.rules.begin() + static_cast<long>(nr)),
                          std::make_move_iterator(work.rules.end()));
  std::vector<PrAtom> prs(std::make_move_iterator(work.pr_atoms.begin() + static_cast<long>(np)),
                          std::make_move_iterator(work.pr_atoms.end()));
  const size_t changed = addParsed(std::move(rules), std::move(prs), tag);
  if (structural) structuralChange();
  return changed;
}

size_t Reasoner::addStatements(std::vector<Rule> rules, std::vector<PrAtom> pr_atoms,
                               const std::string& tag) {
  return addParsed(std::move(rules), std::move(pr_atoms), tag);
}

size_t Reasoner::addParsed(std::vector<Rule> rules, std::vector<PrAtom> prs, const std::string& tag) {
  ensureKeys();
  ensureCounts();
  size_t changed = 0;
  bool structural = false;
  int generation = 0;
  for (const auto& p : program_.pr_atoms) generation = std::max(generation, p.priority);
  ++generation;
  if (!pr_index_valid_) rebuildPrIndex();
  const std::uint64_t seq = ++change_seq_;
  for (auto& p : prs) {
    p.tag = tag;
    p.priority = generation;
    std::string key = prKey(p);
    auto it = pr_index_.find(key);
    if (it != pr_index_.end()) {
      // Same label, atom and body: the new probability replaces the old one.
      PrAtom& old = program_.pr_atoms[it->second];
      log_.push_back({Change::kRemovePr, seq, pr_ids_[it->second], nullptr});
      old.probability = p.probability;
      old.probability_text = p.probability_text;
      old.tag = tag;
      old.loc = p.loc;
      old.priority = generation;
      pr_ids_[it->second] = next_id_++;
      log_.push_back({Change::kAddPr, seq, pr_ids_[it->second], nullptr});
    } else {
      structural = countPr(p, +1) || structural;
      pr_index_.emplace(key, program_.pr_atoms.size());
      pr_keys_.push_back(std::move(key));
      pr_ids_.push_back(next_id_++);
      log_.push_back({Change::kAddPr, seq, pr_ids_.back(), nullptr});
      program_.pr_atoms.push_back(std::move(p));
    }
    ++changed;
  }
  for (auto& r : rules) {
    std::string key = ruleKey(r);
    int& count = rule_key_count_[key];
    if (count > 0) continue;  // identical rule already there
    ++count;
    r.tag = tag;
    structural = countRule(r, +1) || structural;
    rule_keys_.push_back(std::move(key));
    rule_ids_.push_back(next_id_++);
    log_.push_back({Change::kAddRule, seq, rule_ids_.back(), nullptr});
    program_.rules.push_back(std::move(r));
    ++changed;
  }
  if (structural) structuralChange();
  return changed;
}

void Reasoner::eraseMarked(const std::vector<char>& rule_gone, const std::vector<char>& pr_gone) {
  ensureKeys();
  ensureCounts();
  bool structural = false;
  const std::uint64_t seq = ++change_seq_;
  size_t w = 0;
  for (size_t i = 0; i < program_.rules.size(); ++i) {
    if (rule_gone[i]) {
      structural = countRule(program_.rules[i], -1) || structural;
      if (--rule_key_count_[rule_keys_[i]] <= 0) rule_key_count_.erase(rule_keys_[i]);
      log_.push_back({Change::kRemoveRule, seq, rule_ids_[i],
                      std::make_shared<const Rule>(std::move(program_.rules[i]))});
      continue;
    }
    if (w != i) {
      program_.rules[w] = std::move(program_.rules[i]);
      rule_ids_[w] = rule_ids_[i];
      rule_keys_[w] = std::move(rule_keys_[i]);
    }
    ++w;
  }
  program_.rules.resize(w);
  rule_ids_.resize(w);
  rule_keys_.resize(w);
  w = 0;
  for (size_t i = 0; i < program_.pr_atoms.size(); ++i) {
    if (pr_gone[i]) {
      structural = countPr(program_.pr_atoms[i], -1) || structural;
      log_.push_back({Change::kRemovePr, seq, pr_ids_[i], nullptr});
      continue;
    }
    if (w != i) {
      program_.pr_atoms[w] = std::move(program_.pr_atoms[i]);
      pr_ids_[w] = pr_ids_[i];
      pr_keys_[w] = std::move(pr_keys_[i]);
    }
    ++w;
  }
  program_.pr_atoms.resize(w);
  pr_ids_.resize(w);
  pr_keys_.resize(w);
  pr_index_valid_ = false;
  if (structural) structuralChange();
}

size_t Reasoner::removeStatementsWithTag(const std::string& tag) {
  std::vector<char> rg(program_.rules.size(), 0), pg(program_.pr_atoms.size(), 0);
  size_t n = 0;
  for (size_t i = 0; i < rg.size(); ++i)
    if (program_.rules[i].tag == tag) rg[i] = 1, ++n;
  for (size_t i = 0; i < pg.size(); ++i)
    if (program_.pr_atoms[i].tag == tag) pg[i] = 1, ++n;
  if (n) eraseMarked(rg, pg);
  return n;
}

size_t Reasoner::removeStatements(const std::vector<Rule>& rules, const std::vector<PrAtom>& prs) {
  ensureKeys();
  std::vector<char> rg(program_.rules.size(), 0), pg(program_.pr_atoms.size(), 0);
  size_t n = 0;
  if (!prs.empty()) {
    if (!pr_index_valid_) rebuildPrIndex();
    for (const auto& p : prs) {
      auto it = pr_index_.find(prKey(p));
      if (it != pr_index_.end() && !pg[it->second]) pg[it->second] = 1, ++n;
    }
  }
  if (!rules.empty()) {
    std::unordered_map<std::string, int> wanted;
    for (const auto& r : rules) ++wanted[ruleKey(r)];
    for (size_t i = 0; i < rule_keys_.size(); ++i) {
      auto it = wanted.find(rule_keys_[i]);
      if (it != wanted.end()) rg[i] = 1, ++n;
    }
  }
  if (n) eraseMarked(rg, pg);
  return n;
}

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

const Program& Reasoner::declarations() {
  if (decls_version_ != structure_version_) {
    decls_ = Program();
    decls_.dialect = program_.dialect;
    decls_.sorts = program_.sorts;
    decls_.attributes = program_.attributes;
    decls_.domains = program_.domains;
    decls_version_ = structure_version_;
  }
  return decls_;
}

namespace {

void symbolsOf(const Term& t, std::unordered_set<std::string>& out) {
  if (t.kind == Term::Kind::Symbol) out.insert(t.name);
  for (const auto& a : t.args) symbolsOf(a, out);
}

void symbolsOf(const std::vector<Literal>& body, std::unordered_set<std::string>& out) {
  for (const auto& l : body) {
    if (l.kind == Literal::Kind::Atom) {
      for (const auto& a : l.atom.attr.args) symbolsOf(a, out);
      symbolsOf(l.atom.value, out);
    } else {
      symbolsOf(l.lhs, out);
      symbolsOf(l.rhs, out);
    }
  }
}

}  // namespace

const std::unordered_set<std::string>& Reasoner::knownSymbols() {
  const std::pair<std::uint64_t, std::uint64_t> version{structure_version_, change_seq_};
  if (known_symbols_valid_ && known_version_ == version) return known_symbols_;
  known_symbols_.clear();
  for (const auto& s : program_.sorts)
    for (const auto& v : s.values) symbolsOf(v, known_symbols_);
  for (const auto& r : program_.rules) {
    if (r.head) {
      for (const auto& a : r.head->attr.args) symbolsOf(a, known_symbols_);
      symbolsOf(r.head->value, known_symbols_);
    }
    symbolsOf(r.body, known_symbols_);
  }
  for (const auto& r : program_.random_rules) {
    symbolsOf(r.body, known_symbols_);
    symbolsOf(r.range_body, known_symbols_);
  }
  for (const auto& p : program_.pr_atoms) symbolsOf(p.body, known_symbols_);
  known_version_ = version;
  known_symbols_valid_ = true;
  return known_symbols_;
}

void Reasoner::checkQuery(const Query& q) {
  // Contradictory interventions: do(a=x) and do(a=y) cannot both be made, so the query has no
  // meaning (the engine would silently keep the last one).
  std::map<std::string, const Intervention*> done;
  const std::vector<Intervention>& prog_do = program_.interventions;
  for (const std::vector<Intervention>* ds : {&prog_do, &q.interventions})
    for (const auto& d : *ds) {
      const std::string inst = toString(d.atom.attr);
      auto it = done.emplace(inst, &d).first;
      if (it->second->atom.value != d.atom.value)
        throw IncoherentError(d.loc.str() + ": contradictory interventions do(" +
                              toString(it->second->atom) + ") (at " + it->second->loc.str() +
                              ") and do(" + toString(d.atom) + ") on " + inst);
    }
  // Constants in untyped argument positions (implicitly declared predicates such as
  // request(I, R, P)) are not checked by the parser: a typo or an unknown person would answer
  // probability 0. A symbol that no sort and no statement mentions can never be derived.
  auto check = [&](const Atom& a, const SourceLocation& loc) {
    const AttributeDecl* d = program_.findAttribute(a.attr.name);
    if (!d) return;
    for (size_t i = 0; i < a.attr.args.size() && i < d->arg_sorts.size(); ++i) {
      if (!d->arg_sorts[i].empty()) continue;  // typed: checked against its sort when parsed
      std::unordered_set<std::string> syms;
      symbolsOf(a.attr.args[i], syms);
      for (const auto& x : syms)
        if (!knownSymbols().count(x))
          throw UnknownSymbolError(loc.str() + ": unknown value '" + x + "' for argument " +
                                   std::to_string(i + 1) + " of '" + a.attr.name +
                                   "' (no sort or statement of the program mentions it)");
    }
  };
  for (const auto& l : q.formula) check(l.atom, l.loc);
  for (const auto& o : q.observations) check(o.literal.atom, o.loc);
  for (const auto& d : q.interventions) check(d.atom, d.loc);
}

const char* backendName(Backend backend) {
  switch (backend) {
    case Backend::Native: return "native";
    case Backend::Asp: return "asp";
    case Backend::Auto: return "auto";
  }
  return "?";
}

Backend parseBackend(const std::string& name) {
  if (name == "native") return Backend::Native;
  if (name == "asp") return Backend::Asp;
  if (name == "auto") return Backend::Auto;
  throw ConfigError("unknown P-log back end '" + name + "' (expected auto, native or asp)");
}

void Reasoner::setAspOptions(const AspOptions& options) {
  asp_options_ = std::make_unique<AspOptions>(options);
  asp_.reset();
}

AspBackend& Reasoner::asp() {
  AspOptions o = asp_options_ ? *asp_options_ : AspOptions();
  if (limits_.max_inference_seconds > 0)
    o.timeout_s = std::min(o.timeout_s, limits_.max_inference_seconds);
  if (!asp_ || asp_->options().timeout_s != o.timeout_s) asp_ = std::make_unique<AspBackend>(o);
  return *asp_;
}

namespace {

// Calls f(ground instances, |range|) for each random selection rule; false when a sort is
// unknown (no bound).
template <class F>
bool forRandomRules(const Program& program, F f) {
  for (const auto& r : program.random_rules) {
    const AttributeDecl* d = program.findAttribute(r.attr.name);
    const SortDecl* range = d ? program.findSort(d->range_sort) : nullptr;
    if (range == nullptr) return false;
    std::vector<std::string> vars;
    for (const auto& t : r.attr.args) t.collectVariables(vars);
    std::sort(vars.begin(), vars.end());
    vars.erase(std::unique(vars.begin(), vars.end()), vars.end());
    double instances = 1;
    for (const auto& v : vars) {
      auto it = r.variable_sorts.find(v);
      std::string sort = it != r.variable_sorts.end() ? it->second : program.domainSortOf(v);
      const SortDecl* sd = sort.empty() ? nullptr : program.findSort(sort);
      if (sd == nullptr) return false;
      instances *= static_cast<double>(sd->values.size());
    }
    f(instances, static_cast<double>(range->values.size()));
  }
  return true;
}

}  // namespace

double aspWorldsLog2(const Program& program) {
  double total = 0;
  if (!forRandomRules(program, [&](double instances, double range) {
        total += instances * std::log2(std::max(1.0, range));
      }))
    return std::numeric_limits<double>::infinity();
  return total;
}

double aspWorkAtoms(const Program& program) {
  // per world: each selected instance with its possible values (val, sel, poss), every rule
  // and pr-atom at least once
  double per_world = 1 + static_cast<double>(program.rules.size() + program.pr_atoms.size());
  if (!forRandomRules(program, [&](double instances, double range) {
        per_world += instances * (range + 2);
      }))
    return std::numeric_limits<double>::infinity();
  return std::exp2(aspWorldsLog2(program)) * per_world;
}

double aspCostSeconds(const Program& program) {
  return AutoCostModel::kAspStartSeconds + aspWorkAtoms(program) * AutoCostModel::kAspSecondsPerAtom;
}

double nativeCostSeconds(const EnginePlan& plan) {
  return plan.rows * (1.0 + static_cast<double>(plan.derived_rules)) *
         AutoCostModel::kNativeSecondsPerRow;
}

AutoDecision decideAuto(const AutoEstimate& e, double race_delay) {
  using M = AutoCostModel;
  const double inf = std::numeric_limits<double>::infinity();
  AutoDecision d;
  if (e.native_refuses) {
    d.choice = AutoChoice::Asp;
    d.asp_join_seconds = 0;
    return d;
  }
  race_delay = std::max(0.0, race_delay);
  if (std::isnan(e.native_seconds)) {
    // Grounding, no plan yet: clingo (which grounds the whole program) joins when the
    // grounding has taken a while, later if its own estimate is larger.
    d.choice = AutoChoice::Native;
    d.asp_join_seconds = std::max(M::kGroundingRaceFactor * race_delay, e.asp_seconds / 2);
    return d;
  }
  const double native = std::max(e.native_seconds, 0.0);
  if (!(e.asp_seconds >= M::kSureRatio * native)) {  // NaN estimates race too
    d.choice = AutoChoice::Race;
    d.asp_join_seconds = 0;
    return d;
  }
  d.choice = AutoChoice::Native;
  if (e.asp_seconds >= M::kHopelessRatio * native) {
    d.asp_join_seconds = inf;
    return d;
  }
  d.asp_join_seconds = std::min(race_delay, std::max(M::kOverrun * native, e.asp_seconds / 2));
  return d;
}

const char* autoChoiceName(AutoChoice choice) {
  switch (choice) {
    case AutoChoice::Native: return "native";
    case AutoChoice::Race: return "race";
    case AutoChoice::Asp: return "asp";
  }
  return "?";
}

std::string negationLoopReason(const Program& program) {
  for (const auto& r : program.rules)
    if (r.consistency_restoring)
      return r.loc.str() + ": consistency-restoring rule (':+')";
  for (const auto& r : program.random_rules)
    if (r.consistency_restoring)
      return r.loc.str() + ": consistency-restoring random selection (':+')";
  // Nodes: (attribute, head value) for constant head values, (attribute, *) for the others.
  // Attributes and values are interned ids (the parser's hints give most attributes without
  // a lookup), a node is the pair of ids: no string is built per rule.
  const AttributeIndex index(program);
  const int na = static_cast<int>(program.attributes.size());
  NameTable undeclared, values;
  auto attrOf = [&](const AttributeTerm& t) {
    const int a = index.of(t);
    return a >= 0 ? a : na + undeclared.intern(t.name);
  };
  auto attrKnown = [&](const AttributeTerm& t) {  // -1: no rule has it as its head
    const int a = index.of(t);
    if (a >= 0) return a;
    const int u = undeclared.find(t.name);
    return u < 0 ? -1 : na + u;
  };
  constexpr int kAny = -1;  // the value "*"
  auto constantValue = [&](const Term& t) {  // value id, or kAny
    if (!t.isGround() || t.kind == Term::Kind::Binary || t.kind == Term::Kind::Negate) return kAny;
    return t.kind == Term::Kind::Symbol ? values.intern(t.name) : values.intern(toString(t));
  };
  auto key = [](int attr, int value) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(attr)) << 32) |
           static_cast<std::uint32_t>(value);
  };
  std::unordered_map<std::uint64_t, int> node_id;  // (attribute, value) -> node
  std::vector<std::pair<int, int>> node_of;        // node -> (attribute, value)
  std::vector<int> first_node, last_node, next_node;  // nodes of an attribute, in order
  node_id.reserve(program.rules.size());
  auto nodeOf = [&](const Atom& head) {
    const int a = attrOf(head.attr);
    const int v = constantValue(head.value);
    auto [it, added] = node_id.emplace(key(a, v), static_cast<int>(node_of.size()));
    if (added) {
      const int n = it->second;
      node_of.push_back({a, v});
      next_node.push_back(-1);
      if (first_node.size() <= static_cast<size_t>(a)) {
        first_node.resize(static_cast<size_t>(a) + 1, -1);
        last_node.resize(static_cast<size_t>(a) + 1, -1);
      }
      if (first_node[static_cast<size_t>(a)] < 0) first_node[static_cast<size_t>(a)] = n;
      else next_node[static_cast<size_t>(last_node[static_cast<size_t>(a)])] = n;
      last_node[static_cast<size_t>(a)] = n;
    }
    return it->second;
  };
  auto nodeName = [&](int n) {
    const auto& av = node_of[static_cast<size_t>(n)];
    const std::string& attr = av.first < na ? program.attributes[static_cast<size_t>(av.first)].name
                                            : undeclared.name(av.first - na);
    return attr + "=" + (av.second == kAny ? std::string("*") : values.name(av.second));
  };
  std::vector<int> head_node(program.rules.size(), -1);
  for (size_t i = 0; i < program.rules.size(); ++i)
    if (program.rules[i].head) head_node[i] = nodeOf(*program.rules[i].head);
  // Edges (target, negative): `not` and `!=` count as negative, as the grounder's check of
  // static attributes does; a body atom with a constant value depends on that value's rules
  // and on the rules with a variable value, any other atom on every rule of its attribute.
  struct Edge {
    int from, to;
    bool negative;
  };
  std::vector<Edge> edge_list;
  for (size_t i = 0; i < program.rules.size(); ++i) {
    if (head_node[i] < 0) continue;
    const int from = head_node[i];
    for (const auto& l : program.rules[i].body) {
      if (l.kind != Literal::Kind::Atom) continue;
      const int a = attrKnown(l.atom.attr);
      if (a < 0 || static_cast<size_t>(a) >= first_node.size() ||
          first_node[static_cast<size_t>(a)] < 0)
        continue;
      const bool negative = l.naf || l.negated;
      const int v = l.negated ? kAny : constantValue(l.atom.value);
      if (!l.negated && v != kAny) {
        for (const int value : {v, kAny}) {
          auto n = node_id.find(key(a, value));
          if (n != node_id.end()) edge_list.push_back({from, n->second, negative});
        }
      } else {
        for (int n = first_node[static_cast<size_t>(a)]; n >= 0; n = next_node[static_cast<size_t>(n)])
          edge_list.push_back({from, n, negative});
      }
    }
  }
  // A negative edge inside a strongly connected component is a loop through negation.
  const CompactGraph edges = CompactGraph::fromEdges(node_of.size(), edge_list);
  int ncomp = 0;
  const std::vector<int> comp = stronglyConnectedComponents(edges, ncomp);
  for (size_t m = 0; m < edges.size(); ++m)
    for (size_t k = 0; k < edges.degree(m); ++k) {
      const int to = edges.to(m, k);
      if (edges.negative[static_cast<size_t>(edges.start[m]) + k] &&
          comp[static_cast<size_t>(to)] == comp[m])
        return nodeName(static_cast<int>(m)) + " may depend on " + nodeName(to) +
               " through negation, and " + nodeName(to) + " on " + nodeName(static_cast<int>(m));
    }
  return "";
}

namespace {

/// @brief Neither engine could answer: say why for both (e.g. a factor too large natively, too
/// many possible worlds for clingo within the time budget).
Error bothFailed(const std::string& why, const std::exception& e) {
  return Error(why + "; the ASP back end could not answer either: " + e.what());
}

/// @brief Rethrows clingo's failure in a raced query: answers about the program as they are,
/// an abandoned or failed clingo run together with why the native engine did not answer.
[[noreturn]] void rethrowAspFailure(const std::exception_ptr& asp_error, const std::string& why) {
  try {
    std::rethrow_exception(asp_error);
  } catch (const IncoherentError&) {
    throw;
  } catch (const UnknownSymbolError&) {
    throw;
  } catch (const CancelledError&) {
    throw Error(why + "; the ASP back end was abandoned");
  } catch (const Error& e) {
    throw bothFailed(why, e);
  }
}

using RaceClock = std::chrono::steady_clock;

/// @brief `seconds` after `from`; time_point::max (never) when absurdly late.
RaceClock::time_point after(RaceClock::time_point from, double seconds) {
  if (!(seconds < 1e9)) return RaceClock::time_point::max();  // never (or absurdly late)
  return from + std::chrono::duration_cast<RaceClock::duration>(std::chrono::duration<double>(seconds));
}

/// @brief The clingo side of a raced query: a helper thread that runs `job` (clingo) at once,
/// at a join time, or when the query wants clingo's answer. The helper is detached and shares
/// only `Shared` with the query: a query the native engine answers before clingo starts returns
/// at once, without waiting for the helper to be scheduled (which took milliseconds on a loaded
/// machine). From construction to finish(), the clingo back end's cancel flag is this race's,
/// set when the native engine answers.
class AspRace {
 public:
  AspRace(AspBackend& backend, std::function<void()>& job, bool start_now,
          RaceClock::time_point join_at)
      : backend_(backend), job_(&job), sh_(std::make_shared<Shared>()) {
    backend_.setCancelFlag(&native_done_);
    sh_->start_now = start_now;
    sh_->join_at = join_at;
  }

  /// @brief Starts the helper (once). It is started when clingo may be needed: at once for a
  /// program that may loop through negation, otherwise at the plan when the decision races or
  /// sets a time for clingo to join (a thread started for every query cost a sizeable part of
  /// sub-millisecond queries). A grounding that took longer than clingo would have joined
  /// races at the plan.
  void spawn() {
    if (spawned_) return;
    spawned_ = true;
    std::thread([sh = sh_, job = job_]() {
      {
        std::unique_lock<std::mutex> lock(sh->m);
        for (;;) {
          if (sh->stop) return;  // the query is over: `job` must not be touched
          if (sh->start_now || RaceClock::now() >= sh->join_at) break;
          if (sh->join_at == RaceClock::time_point::max()) sh->cv.wait(lock);
          else sh->cv.wait_until(lock, sh->join_at);
        }
        sh->started = true;  // from here on the query waits for `finished`
      }
      (*job)();
      {
        std::lock_guard<std::mutex> lock(sh->m);
        sh->finished = true;
      }
      sh->cv.notify_all();
    }).detach();
  }

  /// @brief The decision at the native plan: clingo starts now, or joins after
  /// d.asp_join_seconds if the native engine has not answered by then.
  void decide(const AutoDecision& d) {
    {
      std::lock_guard<std::mutex> lock(sh_->m);
      if (d.choice != AutoChoice::Native || RaceClock::now() >= sh_->join_at) sh_->start_now = true;
      else sh_->join_at = after(RaceClock::now(), d.asp_join_seconds);
    }
    if (sh_->start_now || sh_->join_at != RaceClock::time_point::max()) spawn();
    sh_->cv.notify_all();
  }

  /// @brief Waits at most `wait` for clingo to finish.
  void waitFinished(std::chrono::duration<double> wait) {
    std::unique_lock<std::mutex> lock(sh_->m);
    sh_->cv.wait_for(lock, wait, [&]() { return sh_->finished; });
  }

  /// @brief Ends the race: with cancel_asp, clingo is told to stop (a helper that has not
  /// started exits on its own); otherwise clingo's answer is wanted and waited for.
  void finish(bool cancel_asp) {
    if (cancel_asp) native_done_ = true;
    if (!cancel_asp) spawn();  // clingo's answer is wanted
    std::unique_lock<std::mutex> lock(sh_->m);
    if (cancel_asp && !sh_->started) {
      sh_->stop = true;  // clingo never started: the helper exits on its own
    } else {
      sh_->start_now = true;
      sh_->cv.notify_all();
      sh_->cv.wait(lock, [&]() { return sh_->finished; });
    }
    lock.unlock();
    sh_->cv.notify_all();
    backend_.setCancelFlag(nullptr);
  }

 private:
  /// @brief All the helper thread shares with the query.
  struct Shared {
    std::mutex m;
    std::condition_variable cv;
    bool start_now = false, stop = false, started = false, finished = false;
    RaceClock::time_point join_at = RaceClock::time_point::max();
  };
  std::atomic<bool> native_done_{false};
  AspBackend& backend_;
  std::function<void()>* job_;
  std::shared_ptr<Shared> sh_;
  bool spawned_ = false;
};

}  // namespace

void Reasoner::noteAspAnswer() {
  stats_.last_backend = Backend::Asp;
  ++stats_.asp_answers;
}

template <typename T, typename Native, typename Asp>
T Reasoner::dispatch(const std::set<std::string>& attrs, Native native, Asp asp_answer,
                     bool race) {
  auto viaAsp = [&]() {
    T r = asp_answer();
    noteAspAnswer();
    return r;
  };
  if (backend_ == Backend::Asp) return viaAsp();
  const std::string key = setKey(attrs);
  if (backend_ == Backend::Auto) {
    auto it = outside_fragment_.find(key);
    if (it != outside_fragment_.end() && it->second == structure_version_) return viaAsp();
  }
  if (backend_ == Backend::Native || !race) return dispatchInTurn<T>(key, native, viaAsp);
  return dispatchRace<T>(key, native, asp_answer);
}

template <typename T, typename Native, typename ViaAsp>
T Reasoner::dispatchInTurn(const std::string& key, Native& native, ViaAsp& via_asp) {
  std::string why;
  try {
    T r = native();
    stats_.last_backend = Backend::Native;
    return r;
  } catch (const OutsideFragmentError& e) {
    if (backend_ != Backend::Auto) throw;
    outside_fragment_[key] = structure_version_;
    why = e.what();
  }
  try {
    return via_asp();
  } catch (const IncoherentError&) {
    throw;  // an answer about the program, not a failure of the back end
  } catch (const UnknownSymbolError&) {
    throw;
  } catch (const Error& e) {
    throw bothFailed(why, e);
  }
}

bool Reasoner::mayLoopThroughNegation() {
  const std::pair<std::uint64_t, std::uint64_t> version{structure_version_, change_seq_};
  if (!negation_loop_valid_ || negation_loop_version_ != version) {
    negation_loop_reason_ = negationLoopReason(program_);
    negation_loop_version_ = version;
    negation_loop_valid_ = true;
  }
  return !negation_loop_reason_.empty();
}

AutoEstimate Reasoner::beginRace(bool asp_at_once) {
  if (asp_at_once) ++stats_.asp_started_at_once;
  AutoEstimate estimate;
  estimate.asp_seconds = aspCostSeconds(program_);
  stats_.last_estimate = estimate;
  stats_.last_auto_choice = asp_at_once ? AutoChoice::Race : AutoChoice::Native;
  stats_.last_asp_joined = false;
  return estimate;
}

AutoDecision Reasoner::decideAtPlan(const EnginePlan& plan, const AutoEstimate& estimate,
                                    bool asp_at_once) {
  AutoEstimate e = estimate;
  e.native_seconds = nativeCostSeconds(plan);
  e.native_refuses = plan.largest_log2 > kMaxFactorLog2;
  const AutoDecision d = decideAuto(e, race_delay_);
  stats_.last_estimate = e;
  if (!asp_at_once) stats_.last_auto_choice = d.choice;
  return d;
}

template <typename T, typename Native, typename Asp>
T Reasoner::dispatchRace(const std::string& key, Native& native, Asp& asp_answer) {
  // Auto: the native engine grounds and plans; decideAuto then chooses from both estimates
  // (see setBackend). A program that may loop through negation (negationLoopReason) is usually
  // refused by the native engine, but only once it has grounded the query's cone: clingo
  // starts at once instead, and the native engine joins after kGroundingRaceFactor race delays.
  const auto started = RaceClock::now();
  const bool asp_at_once = mayLoopThroughNegation();
  const AutoEstimate estimate = beginRace(asp_at_once);
  AspBackend& backend = asp();  // made here: the helper thread must not create it
  asp_won_ = false;
  std::optional<T> asp_result;
  std::exception_ptr asp_error;
  std::function<void()> run_asp = [&]() {
    try {
      asp_result.emplace(asp_answer());
      asp_won_ = true;
    } catch (const IncoherentError&) {
      asp_error = std::current_exception();
      asp_won_ = true;  // a definite answer too
    } catch (...) {
      asp_error = std::current_exception();
    }
  };
  // When clingo joins if the native engine has not answered: while it grounds, from the
  // estimate without a plan; from its plan on, from decideAuto.
  AspRace race(backend, run_asp, asp_at_once,
               after(started, decideAuto(estimate, race_delay_).asp_join_seconds));
  if (asp_at_once) race.spawn();
  plan_callback_ = [&](const EnginePlan& plan) {
    const AutoDecision d = decideAtPlan(plan, estimate, asp_at_once);
    race.decide(d);
    if (d.choice == AutoChoice::Asp)
      throw OutsideFragmentError("the native engine's largest table would have 2^" +
                                 std::to_string(plan.largest_log2) + " rows (at most 2^" +
                                 std::to_string(kMaxFactorLog2) + ")");
  };
  struct PlanGuard {
    std::function<void(const EnginePlan&)>& cb;
    ~PlanGuard() { cb = nullptr; }
  } plan_guard{plan_callback_};
  auto finish = [&](bool cancel_asp) {
    race.finish(cancel_asp);
    stats_.last_asp_joined = asp_result || asp_error;
    asp_won_ = false;
  };
  auto useAsp = [&](const std::string& why) -> T {
    if (!asp_result) rethrowAspFailure(asp_error, why);
    noteAspAnswer();
    return *asp_result;
  };
  if (asp_at_once) {
    // clingo usually answers these programs: the native engine joins only if it has not
    // within kGroundingRaceFactor race delays (the two would otherwise share the machine).
    race.waitFinished(std::chrono::duration<double>(race_delay_) *
                      AutoCostModel::kGroundingRaceFactor);
  }
  if (asp_won_) {
    finish(false);
    return useAsp("clingo answered first");
  }
  try {
    T r = native();
    finish(true);
    stats_.last_backend = Backend::Native;
    return r;
  } catch (const OutsideFragmentError& e) {
    finish(false);
    outside_fragment_[key] = structure_version_;
    return useAsp(e.what());
  } catch (const CancelledError&) {
    finish(false);  // clingo has answered (or failed): wait for its thread
    if (asp_result || asp_error) return useAsp("the native engine was abandoned");
    throw;
  } catch (...) {
    finish(true);
    throw;
  }
}

void Reasoner::noteWarnings(const std::vector<std::string>& warnings) {
  std::lock_guard<std::mutex> lock(warnings_mutex_);
  for (const auto& w : warnings)
    if (std::find(program_.warnings.begin(), program_.warnings.end(), w) == program_.warnings.end())
      program_.warnings.push_back(w);
}

double Reasoner::probability(const std::string& query) {
  return probability(parseQuery(declarations(), query));
}

double Reasoner::probability(const Query& q) {
  checkQuery(q);
  std::set<std::string> attrs;
  collectAttrs(q, attrs);
  return dispatch<double>(attrs, [&]() { return nativeProbability(q); },
                          [&]() {
                            const double p = asp().probability(program_, q);
                            noteWarnings(asp().warnings());
                            return p;
                          });
}

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

std::vector<ValueProb> Reasoner::distribution(const std::string& attribute_term,
                                              const std::string& evidence) {
  AttributeTerm at = parseAttributeTerm(declarations(), attribute_term);
  Query ev;
  if (!evidence.empty()) ev = parseQuery(declarations(), "| " + evidence, "<evidence>");
  checkQuery(ev);
  std::set<std::string> attrs{at.name};
  collectAttrs(ev, attrs);
  return dispatch<std::vector<ValueProb>>(
      attrs, [&]() { return nativeDistribution(at, ev, evidence); },
      [&]() {
        std::vector<ValueProb> out;
        for (const auto& vp : asp().distribution(program_, at, ev.observations, ev.interventions))
          if (vp.second > 0) out.push_back({vp.first, vp.second});
        noteWarnings(asp().warnings());
        return out;
      });
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

Table Reasoner::tableQuery(const std::string& target, const std::vector<std::string>& conditioning,
                           const std::string& evidence, bool conditioning_as_do) {
  Table t;
  const Program& decls = declarations();
  AttributeTerm tat = parseAttributeTerm(decls, target);
  t.target = toString(tat);
  std::vector<AttributeTerm> cats;
  std::set<std::string> attrs{tat.name};
  for (const auto& c : conditioning) {
    cats.push_back(parseAttributeTerm(decls, c));
    t.conditioning.push_back(toString(cats.back()));
    attrs.insert(cats.back().name);
  }
  Query ev;
  if (!evidence.empty()) ev = parseQuery(decls, "| " + evidence, "<evidence>");
  checkQuery(ev);
  collectAttrs(ev, attrs);
  return dispatch<Table>(
      attrs, [&]() { return nativeTable(tat, cats, ev, evidence, conditioning_as_do); },
      [&]() {
        // One clingo run per row: every combination of the conditioning ranges (first
        // fastest), as the native table.
        std::vector<std::vector<std::string>> ranges;
        size_t total = 1;
        for (const auto& c : cats) {
          ranges.push_back(attributeRange(c.name));
          total *= ranges.back().size();
        }
        std::vector<size_t> cur(cats.size(), 0);
        for (size_t row = 0; row < total; ++row) {
          TableRow r;
          std::string row_evidence = evidence;
          for (size_t k = 0; k < cats.size(); ++k) {
            const std::string& v = ranges[k][cur[k]];
            r.conditioning_values.push_back(v);
            row_evidence += std::string(row_evidence.empty() ? "" : ", ") +
                            (conditioning_as_do ? "do(" : "obs(") + toString(cats[k]) + "=" + v + ")";
          }
          const Query rq = row_evidence.empty()
                               ? Query()
                               : parseQuery(declarations(), "| " + row_evidence, "<table row>");
          const std::vector<Observation>& obs = rq.observations;
          const std::vector<Intervention>& dos = rq.interventions;
          try {
            double sum = 0;
            for (const auto& vp : asp().distribution(program_, tat, obs, dos)) {
              sum += vp.second;
              if (vp.second > 0) r.distribution.push_back({vp.first, vp.second});
            }
            r.undefined_probability = std::max(0.0, 1.0 - sum);
            noteWarnings(asp().warnings());
          } catch (const IncoherentError&) {
            r.consistent = false;
          }
          t.rows.push_back(std::move(r));
          for (size_t k = 0; k < cur.size(); ++k) {
            if (++cur[k] < ranges[k].size()) break;
            cur[k] = 0;
          }
        }
        return t;
      },
      /*race=*/false);
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

std::vector<QueryAnswer> Reasoner::answerProgramQueries() {
  std::vector<QueryAnswer> out;
  for (const auto& q : program_.queries) out.push_back({q.text, probability(q)});
  return out;
}

std::vector<std::string> Reasoner::sortValues(const std::string& sort) const {
  const SortDecl* s = program_.findSort(sort);
  if (!s) throw UnknownSymbolError("unknown sort '" + sort + "'");
  std::vector<std::string> out;
  for (const auto& v : s->values) out.push_back(toString(v));
  return out;
}

std::vector<std::string> Reasoner::attributeRange(const std::string& attribute) const {
  const AttributeDecl* a = program_.findAttribute(attribute);
  if (!a) throw UnknownSymbolError("unknown attribute '" + attribute + "'");
  return sortValues(a->range_sort);
}

std::vector<std::string> Reasoner::sortNames() const {
  std::vector<std::string> out;
  for (const auto& s : program_.sorts) out.push_back(s.name);
  return out;
}

std::vector<std::string> Reasoner::attributeNames() const {
  std::vector<std::string> out;
  for (const auto& a : program_.attributes) out.push_back(a.name);
  return out;
}

std::string Reasoner::exportProgram() const { return toString(program_); }

}  // namespace plog
}  // namespace krr
