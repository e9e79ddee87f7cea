/**
 * @file reasoner_statements.cpp
 * @brief The Reasoner's statement bookkeeping: statements added and removed (with their ids,
 * keys and the change log that patches cached groundings), and the dependency counts that
 * tell when a change is structural (some relevance cone changes: every grounding goes).
 */
#include "krr_core/plog/reasoner.h"

#include <algorithm>
#include <cstdint>
#include <iterator>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "krr_core/plog/parser.h"
#include "reasoner_internal.h"

namespace krr {
namespace plog {

namespace {

std::string prKey(const PrAtom& p) {
  std::vector<std::string> b;
  for (const auto& l : p.body) b.push_back(toString(l));
  std::sort(b.begin(), b.end());
  std::string k = p.label + "|" + toString(p.atom) + "|";
  for (const auto& x : b) k += x + ";";
  return k;
}

}  // namespace

namespace {

std::string ruleKey(const Rule& r) { return toString(r); }

// Attribute terms of the atom literals of a body.
template <class F>
void forBodyAttrs(const std::vector<Literal>& body, F f) {
  for (const auto& l : body)
    if (l.kind == Literal::Kind::Atom) f(l.atom.attr);
}

}  // namespace

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

}  // namespace plog
}  // namespace krr
