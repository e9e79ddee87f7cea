/**
 * @file grounder.cpp
 * @brief The grounder's public entry points (groundProgram, IncrementalGrounder, the symbol
 * table) and the Grounder's driver: its set-up, the passes of a full grounding and the
 * patch of an incremental update (the passes themselves are in grounder_*.cpp).
 */
#include "krr_core/plog/grounder.h"

#include <chrono>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "grounder_internal.h"
#include "scc.h"

namespace krr {
namespace plog {

int SymbolTable::intern(const std::string& text) {
  auto it = ids_.find(text);
  if (it != ids_.end()) return it->second;
  int id = static_cast<int>(texts_.size());
  texts_.push_back(text);
  long long v = 0;
  bool isint = !text.empty();
  size_t start = (text[0] == '-' && text.size() > 1) ? 1 : 0;
  for (size_t i = start; i < text.size() && isint; ++i)
    if (text[i] < '0' || text[i] > '9') isint = false;
  if (isint) {
    try {
      v = std::stoll(text);
    } catch (...) {
      isint = false;
    }
  }
  is_int_.push_back(isint ? 1 : 0);
  ints_.push_back(v);
  ids_.emplace(text, id);
  return id;
}

int SymbolTable::internInt(long long v) { return intern(std::to_string(v)); }

bool SymbolTable::isInt(int id, long long* v) const {
  if (id < 0 || static_cast<size_t>(id) >= texts_.size()) return false;
  if (!is_int_[static_cast<size_t>(id)]) return false;
  if (v) *v = ints_[static_cast<size_t>(id)];
  return true;
}

int GInstance::valueIndex(int sym) const {
  for (size_t i = 0; i < domain.size(); ++i)
    if (domain[i] == sym) return static_cast<int>(i);
  return -1;
}

int GroundProgram::findInstance(const std::string& printable) const {
  auto it = instance_ids.find(printable);
  return it == instance_ids.end() ? -1 : it->second;
}

bool GroundProgram::staticHolds(int attr, const std::string& printable_atom) const {
  if (attr < 0 || static_cast<size_t>(attr) >= static_atoms.size()) return false;
  return static_atoms[static_cast<size_t>(attr)].count(printable_atom) > 0;
}

namespace grounder_detail {

Grounder::Grounder(const Program& p, GroundProgram& g) : prog_(p), g_(g), attr_index_(p, true) {
  g_.symbols = std::make_shared<SymbolTable>();
  syms_ = g_.symbols.get();

  for (size_t i = 0; i < p.sorts.size(); ++i) {
    sort_index_[p.sorts[i].name] = int(i);
    std::vector<int> vals;
    for (const auto& v : p.sorts[i].values) vals.push_back(syms_->intern(toString(v)));
    sort_vals_.push_back(vals);
  }
  true_ = syms_->intern("true");
  false_ = syms_->intern("false");
  facts_.resize(p.attributes.size());  // (made for the attributes that get facts)
  // symbol -> position in each sort (membership and value indices in O(1))
  sort_pos_.resize(sort_vals_.size());
  for (size_t i = 0; i < sort_vals_.size(); ++i) {
    int top = -1;  // only up to the sort's largest symbol id: n sorts x m symbols stays O(sizes)
    for (int v : sort_vals_[i]) top = std::max(top, v);
    sort_pos_[i].assign(static_cast<size_t>(top + 1), -1);
    for (size_t k = 0; k < sort_vals_[i].size(); ++k)
      if (sort_pos_[i][static_cast<size_t>(sort_vals_[i][k])] < 0)
        sort_pos_[i][static_cast<size_t>(sort_vals_[i][k])] = static_cast<int>(k);
  }
  attr_range_sort_.assign(p.attributes.size(), -1);
  attr_arg_sorts_.resize(p.attributes.size());
  const std::string* last_range = nullptr;  // (most attributes share their range: boolean)
  int last_range_sort = -1;
  for (size_t a = 0; a < p.attributes.size(); ++a) {
    const AttributeDecl& d = p.attributes[a];
    if (!last_range || *last_range != d.range_sort) {
      auto it = sort_index_.find(d.range_sort);
      last_range = &d.range_sort;
      last_range_sort = it == sort_index_.end() ? -1 : it->second;
    }
    attr_range_sort_[a] = last_range_sort;
    for (const auto& s : d.arg_sorts) {
      if (s.empty()) {
        attr_arg_sorts_[a].push_back(-1);
      } else {
        auto jt = sort_index_.find(s);
        attr_arg_sorts_[a].push_back(jt == sort_index_.end() ? -2 : jt->second);
      }
    }
  }
}

bool Grounder::applyDelta(const IncrementalGrounder::Delta& d,
                          std::vector<std::pair<int, int>>* changed) {
  start_ = std::chrono::steady_clock::now();
  changed_ = changed;
  frozen_ = true;
  struct Reset {
    Grounder* gr;
    ~Reset() {
      gr->frozen_ = false;
      gr->changed_ = nullptr;
    }
  } reset{this};
  for (const auto& ap : d.added_prs)
    if (demandsInstances(*ap.first)) return false;
  try {
    for (std::uint64_t id : d.removed_prs) {
      auto it = src_refs_.find(id);
      if (it == src_refs_.end()) continue;  // produced no ground pr-atom
      for (const auto& ref : it->second) {
        g_.instances[static_cast<size_t>(ref.first)].prs[static_cast<size_t>(ref.second)].inactive +=
            kRemovedStatement;
        ++removed_atoms_;
        if (changed_) changed_->push_back(ref);
      }
      src_refs_.erase(it);
    }
    for (const Rule* r : d.removed_facts)
      if (!changeFact(*r, -1)) return false;
    for (const Rule* r : d.added_facts)
      if (!changeFact(*r, +1)) return false;
    for (const auto& ap : d.added_prs) {
      const int a = attrId(ap.first->atom.attr, ap.first->loc);
      if (!g_.attr_in_cone[static_cast<size_t>(a)]) continue;  // outside the grounding
      groundPrAtom(*ap.first, ap.second);
    }
  } catch (const NeedFullGrounding&) {
    return false;
  }
  return true;
}

void Grounder::run(const std::set<std::string>& cone_names,
                   const std::vector<AttributeTerm>* atoms) {
  start_ = std::chrono::steady_clock::now();
  // Consistency-restoring rules make the possible worlds depend on a global minimisation
  // over all answer sets, which the native engine does not do.
  if (const Rule* cr = scanRules())
    throw OutsideFragmentError(cr->loc.str() + ": consistency-restoring rule (':+') is outside "
                               "the native reasoner's fragment (use the ASP back end)");
  for (const auto& r : prog_.random_rules)
    if (r.consistency_restoring)
      throw OutsideFragmentError(r.loc.str() + ": consistency-restoring rule (':+') is outside "
                                 "the native reasoner's fragment (use the ASP back end)");
  const size_t na = prog_.attributes.size();
  g_.attr_random.assign(na, false);
  g_.attr_dynamic.assign(na, false);
  g_.attr_in_cone.assign(na, false);
  for (const auto& r : prog_.random_rules) g_.attr_random[attrId(r.attr, r.loc)] = true;
  for (size_t i = 0; i < na; ++i) g_.attr_dynamic[i] = g_.attr_random[i];
  // Dynamic attributes: the random ones and those with a rule whose body has a dynamic
  // atom. One pass in program order (which also reports unknown attributes in that order),
  // then the rest propagates along body -> head edges: O(rules), where repeated passes cost
  // O(rules x chain length) on a chain b_i :- b_{i+1} that ends in a random attribute.
  for (size_t i = 0; i < prog_.rules.size(); ++i) {
    if (!(rule_flags_[i] & kHasHead)) continue;
    // (a rule is read only when its head is unknown, reported in rule order, or it has a
    // body: see scanRules)
    if (rule_head_attr_[i] < 0) attrId(prog_.rules[i].head->attr, prog_.rules[i].loc);
    const int h = rule_head_attr_[i];
    if (g_.attr_dynamic[h] || !(rule_flags_[i] & kHasBody)) continue;
    for (const auto& l : prog_.rules[i].body)
      if (l.kind == Literal::Kind::Atom && g_.attr_dynamic[attrId(l.atom.attr, l.loc)]) {
        g_.attr_dynamic[h] = true;
        break;
      }
  }
  {
    // (the pass looked up every body attribute of the rules whose head is still static)
    struct Use {
      int from, to;  // body attribute -> head attribute
      bool negative;
    };
    std::vector<Use> uses;
    for (size_t i = 0; i < prog_.rules.size(); ++i) {
      const int h = rule_head_attr_[i];
      if (h < 0 || g_.attr_dynamic[static_cast<size_t>(h)] || !(rule_flags_[i] & kHasBody))
        continue;
      for (const auto& l : prog_.rules[i].body)
        if (l.kind == Literal::Kind::Atom) uses.push_back({attr_index_.of(l.atom.attr), h, false});
    }
    const CompactGraph heads = CompactGraph::fromEdges(na, uses);
    std::vector<int> work;
    for (size_t a = 0; a < na; ++a)
      if (g_.attr_dynamic[a]) work.push_back(static_cast<int>(a));
    while (!work.empty()) {
      const size_t a = static_cast<size_t>(work.back());
      work.pop_back();
      for (size_t k = 0; k < heads.degree(a); ++k) {
        const size_t h = static_cast<size_t>(heads.to(a, k));
        if (!g_.attr_dynamic[h]) g_.attr_dynamic[h] = true, work.push_back(static_cast<int>(h));
      }
    }
  }
  for (size_t i = 0; i < prog_.rules.size(); ++i)
    if (rule_head_attr_[i] >= 0 && g_.attr_random[static_cast<size_t>(rule_head_attr_[i])])
      throw OutsideFragmentError(prog_.rules[i].loc.str() + ": rule defining random attribute '" +
                                 prog_.rules[i].head->attr.name +
                                 "' is outside the native reasoner's fast path (use the ASP back end)");
  for (const auto& n : cone_names) {
    const int a = attrLookup(n);
    if (a >= 0) g_.attr_in_cone[static_cast<size_t>(a)] = true;
  }
  computeGuardAttributes();
  evaluateStatic();
  countGuardFacts();
  if (atoms) computeInstancePatterns(*atoms);
  g_.instance_restricted = restricted_;
  groundDynamic();
  g_.static_atoms.assign(na, {});
  for (size_t a = 0; a < na; ++a) {
    if (g_.attr_dynamic[a] || !g_.attr_in_cone[a]) continue;
    for (const auto& t : factsOf(static_cast<int>(a)).tuples) {
      std::string s = prog_.attributes[a].name;
      if (t.size() > 1) {
        s += "(";
        for (size_t i = 0; i + 1 < t.size(); ++i) s += (i ? "," : "") + syms_->text(t[i]);
        s += ")";
      }
      s += "=" + syms_->text(t.back());
      g_.static_atoms[a].insert(s);
    }
  }
}

const Rule* Grounder::scanRules() {
  const size_t nr = prog_.rules.size();
  rule_head_attr_.assign(nr, -1);
  rule_flags_.assign(nr, 0);
  const Rule* first_cr = nullptr;
  for (size_t i = 0; i < nr; ++i) {
    const Rule& r = prog_.rules[i];
    if (r.consistency_restoring && !first_cr) first_cr = &r;
    unsigned char f = r.body.empty() ? 0 : kHasBody;
    if (r.head) {
      f |= kHasHead;
      rule_head_attr_[i] = attr_index_.of(r.head->attr);
      if (!(f & kHasBody)) {
        bool ground = r.head->value.isGround();
        for (const auto& t : r.head->attr.args) ground = ground && t.isGround();
        if (ground) f |= kGroundHead;
      }
    }
    rule_flags_[i] = f;
  }
  return first_cr;
}

}  // namespace grounder_detail

using grounder_detail::Grounder;

GroundProgram groundProgram(const Program& program, const std::set<std::string>& cone_attributes,
                            const GroundingLimits& limits,
                            const std::vector<AttributeTerm>* cone_atoms) {
  GroundProgram g;
  Grounder gr(program, g);
  gr.setLimits(limits);
  gr.run(relevanceCone(program, cone_attributes), cone_atoms);
  return g;
}

class IncrementalGrounder::Impl {
 public:
  Impl(const Program& p, GroundProgram& g) : grounder(p, g) {}
  Grounder grounder;
};

IncrementalGrounder::IncrementalGrounder(const Program& program,
                                         const std::set<std::string>& cone_attributes,
                                         const std::vector<std::uint64_t>* pr_ids,
                                         const GroundingLimits& limits)
    : IncrementalGrounder(program, ClosedCone{relevanceCone(program, cone_attributes)}, pr_ids,
                          limits) {}

IncrementalGrounder::IncrementalGrounder(const Program& program, ClosedCone cone,
                                         const std::vector<std::uint64_t>* pr_ids,
                                         const GroundingLimits& limits)
    : ground_(std::make_shared<GroundProgram>()) {
  impl_ = std::make_unique<Impl>(program, *ground_);
  impl_->grounder.setLimits(limits);
  impl_->grounder.setPrIds(pr_ids);
  impl_->grounder.run(cone.attributes, cone.atoms);
  impl_->grounder.setPrIds(nullptr);
}

IncrementalGrounder::~IncrementalGrounder() = default;

bool IncrementalGrounder::apply(const Program& program, const Delta& delta,
                                std::vector<std::pair<int, int>>* changed) {
  if (&program != &impl_->grounder.program()) return false;
  return impl_->grounder.applyDelta(delta, changed);
}

std::size_t IncrementalGrounder::atoms() const { return impl_->grounder.atoms_; }
std::size_t IncrementalGrounder::removedAtoms() const { return impl_->grounder.removed_atoms_; }

bool IncrementalGrounder::isGuardAttribute(const std::string& attribute) const {
  return impl_->grounder.isGuard(impl_->grounder.attrIndexOf(attribute));
}

}  // namespace plog
}  // namespace krr
