/**
 * @file grounder_static.cpp
 * @brief Grounder: the static attributes' facts, evaluated bottom-up to their fixpoint per
 * strongly connected component, and the guard facts an incremental update adds or removes.
 */
#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "grounder_internal.h"
#include "scc.h"

namespace krr {
namespace plog {
namespace grounder_detail {

void Grounder::evaluateStatic() {
  const size_t na = prog_.attributes.size();
  // Static rules grouped by head attribute; dependency graph among static attributes (in
  // compressed rows: one array for all, a 10^5-rule program has 10^5 attributes).
  struct Ref {
    int from, to;
    bool negative;
  };
  std::vector<Ref> rule_refs, edge_list, stat_list;  // head -> rule; head -> body attribute
  for (size_t r = 0; r < prog_.rules.size(); ++r) {
    const int h = rule_head_attr_[r];  // (every head is known by now: -1 is a constraint)
    if (h < 0 || g_.attr_dynamic[h]) continue;
    rule_refs.push_back({h, static_cast<int>(r), false});
    if (!(rule_flags_[r] & kHasBody)) continue;
    const Rule& rule = prog_.rules[r];
    for (const auto& l : rule.body)
      if (l.kind == Literal::Kind::Atom) {
        const Ref e{h, attrId(l.atom.attr, l.loc), l.naf || l.negated};
        edge_list.push_back(e);
        if (!g_.attr_dynamic[static_cast<size_t>(e.to)]) stat_list.push_back(e);
      }
  }
  const CompactGraph rules_of = CompactGraph::fromEdges(na, rule_refs);
  const CompactGraph edges = CompactGraph::fromEdges(na, edge_list);
  // Needed static attributes: cone attributes and everything they depend on (edges into
  // dynamic attributes are not followed), grouped in strongly connected components,
  // dependencies first (scc.h: iterative, a 100000-rule chain is that deep).
  const CompactGraph statEdges = CompactGraph::fromEdges(na, stat_list);
  std::vector<char> needed(na, 0);
  std::vector<int> todo;
  for (size_t a = 0; a < na; ++a)
    if (!g_.attr_dynamic[a] && g_.attr_in_cone[a]) needed[a] = 1, todo.push_back(static_cast<int>(a));
  while (!todo.empty()) {
    const size_t v = static_cast<size_t>(todo.back());
    todo.pop_back();
    for (size_t k = 0; k < statEdges.degree(v); ++k) {
      const int w = statEdges.to(v, k);
      if (!needed[static_cast<size_t>(w)]) needed[static_cast<size_t>(w)] = 1, todo.push_back(w);
    }
  }
  int ncomp = 0;
  const std::vector<int> comp = stronglyConnectedComponents(statEdges, ncomp);
  // the needed attributes by component (in attribute order within one)
  std::vector<Ref> members;
  for (size_t a = 0; a < na; ++a)
    if (needed[a]) members.push_back({comp[a], static_cast<int>(a), false});
  const CompactGraph comps = CompactGraph::fromEdges(static_cast<size_t>(ncomp), members);
  std::vector<int> c;
  for (size_t ci = 0; ci < comps.size(); ++ci) {
    if (comps.degree(ci) == 0) continue;
    c.assign(comps.target.begin() + comps.start[ci], comps.target.begin() + comps.start[ci + 1]);
    evaluateComponent(c, comp, edges, rules_of);
  }
}

void Grounder::evaluateComponent(const std::vector<int>& c, const std::vector<int>& comp,
                                 const CompactGraph& edges, const CompactGraph& rules_of) {
  for (int a : c)
    for (size_t k = 0; k < edges.degree(static_cast<size_t>(a)); ++k)
      if (edges.negative[static_cast<size_t>(edges.start[static_cast<size_t>(a)]) + k] &&
          !g_.attr_dynamic[static_cast<size_t>(edges.to(static_cast<size_t>(a), k))] &&
          comp[static_cast<size_t>(edges.to(static_cast<size_t>(a), k))] == comp[static_cast<size_t>(a)])
        throw OutsideFragmentError(prog_.attributes[a].loc.str() + ": attribute '" +
                    prog_.attributes[a].name +
                    "' depends on itself through negation (non-stratified); this is "
                    "outside the native reasoner's fast path (use the ASP back end)");
  bool recursive = c.size() > 1;
  for (int a : c)
    for (size_t k = 0; k < edges.degree(static_cast<size_t>(a)); ++k)
      if (edges.to(static_cast<size_t>(a), k) == a) recursive = true;
  std::vector<Stmt> stmts;
  std::vector<const Rule*> srcs;
  for (int a : c)
    for (size_t k = 0; k < rules_of.degree(static_cast<size_t>(a)); ++k) {
      const Rule& rule = prog_.rules[static_cast<size_t>(rules_of.to(static_cast<size_t>(a), k))];
      Stmt s;
      s.loc = rule.loc;
      for (const auto& l : rule.body) s.lits.push_back(compileLit(s, l, 0));
      stmts.push_back(std::move(s));
      srcs.push_back(&rule);
    }
  for (;;) {
    bool added = false;
    for (size_t k = 0; k < stmts.size(); ++k) {
      Stmt& s = stmts[k];
      const Rule& rule = *srcs[k];
      cur_loc_ = rule.loc;
      int h = rule_head_attr_[static_cast<size_t>(&rule - prog_.rules.data())];
      std::vector<CTerm> hargs;
      for (const auto& a : rule.head->attr.args) hargs.push_back(compile(s, a));
      CTerm hval = compile(s, rule.head->value);
      typeSlots(s, rule.variable_sorts);
      std::vector<int> required;
      for (const auto& a : hargs) termVars(a, required);
      termVars(hval, required);
      std::vector<std::pair<std::vector<int>, int>> news;
      runJoin(s, required, [&](const std::vector<int>& b, const std::vector<GLit>&,
                               const std::vector<int>&) {
        std::vector<int> args;
        for (const auto& a : hargs) {
          int v = evalTerm(a, b);
          if (v < 0) return;
          args.push_back(v);
        }
        int v = evalTerm(hval, b);
        if (v < 0) return;
        // ground only within the declared sorts: `p(X + 1) :- p(X).` stops at the end of
        // p's argument sort instead of counting forever
        if (!argsInSorts(h, args)) return;
        const int rs = attr_range_sort_[static_cast<size_t>(h)];
        if (rs >= 0 && posInSort(rs, v) < 0) return;
        news.push_back({args, v});
        spend(0, 0);
      });
      for (auto& nv : news) {
        FactSet& f = factsFor(h);
        if (f.add(nv.first, nv.second)) {
          added = true;
          spend(1, 0);
          auto it = f.by_args.find(nv.first);
          if (it->second.size() > 1)
            throw IncoherentError(rule.loc.str() + ": attribute " + instanceName(h, nv.first) +
                                  " gets two values (" + syms_->text(it->second[0]) + " and " +
                                  syms_->text(it->second[1]) + ")");
        }
      }
    }
    if (!recursive || !added) break;
  }
}

bool Grounder::guardHolds(const std::vector<int>& key) const {
  const std::vector<int> args(key.begin() + 1, key.end() - 1);
  return staticAtom(key.front(), args, key.back(), false);
}

void Grounder::computeGuardAttributes() {
  const size_t na = prog_.attributes.size();
  guard_attr_.assign(na, 0);
  for (size_t a = 0; a < na; ++a) guard_attr_[a] = g_.attr_dynamic[a] ? 0 : 1;
  auto off = [&](const AttributeTerm& t) {
    const int a = attr_index_.of(t);
    if (a >= 0) guard_attr_[static_cast<size_t>(a)] = 0;
  };
  auto offBody = [&](const std::vector<Literal>& body) {
    for (const auto& l : body)
      if (l.kind == Literal::Kind::Atom) off(l.atom.attr);
  };
  for (size_t i = 0; i < prog_.rules.size(); ++i) {
    const unsigned char f = rule_flags_[i];
    // (a head's attribute is rule_head_attr_: a rule is read only when it has a body)
    if ((f & kHasHead) && ((f & kHasBody) || !(f & kGroundHead)))
      guard_attr_[static_cast<size_t>(rule_head_attr_[i])] = 0;
    if (f & kHasBody) offBody(prog_.rules[i].body);
  }
  for (const auto& r : prog_.random_rules) {
    offBody(r.body);
    offBody(r.range_body);
  }
  for (const auto& p : prog_.pr_atoms)
    for (const auto& l : p.body)
      if (l.kind == Literal::Kind::Atom && !(l.naf && !l.negated)) off(l.atom.attr);
}

void Grounder::countGuardFacts() {
  for (size_t i = 0; i < prog_.rules.size(); ++i) {
    if (!(rule_flags_[i] & kHasHead) || (rule_flags_[i] & kHasBody)) continue;
    const int a = rule_head_attr_[i];
    if (!isGuard(a) || !g_.attr_in_cone[static_cast<size_t>(a)]) continue;
    ++fact_count_[factKey(a, *prog_.rules[i].head)];
  }
}

std::vector<int> Grounder::factKey(int attr, const Atom& head) {
  std::vector<int> key{attr};
  for (const auto& t : head.attr.args) key.push_back(syms_->intern(toString(t)));
  key.push_back(syms_->intern(toString(head.value)));
  return key;
}

bool Grounder::changeFact(const Rule& r, int delta) {
  if (!r.head || !r.body.empty()) return false;
  const int a = attr_index_.of(r.head->attr);
  if (!isGuard(a)) return false;
  bool ground = r.head->value.isGround();
  for (const auto& t : r.head->attr.args) ground = ground && t.isGround();
  if (!ground) return false;
  // Outside the cone: nothing of the grounding depends on the attribute (its facts are
  // neither evaluated nor counted).
  if (!g_.attr_in_cone[static_cast<size_t>(a)]) return true;
  const std::vector<int> key = factKey(a, *r.head);
  int& count = fact_count_[key];
  const int before = count;
  count += delta;
  if (count < 0) return false;  // removing a fact that was never counted
  if ((before > 0) == (count > 0)) return true;  // truth unchanged
  const std::vector<int> args(key.begin() + 1, key.end() - 1);
  const int value = key.back();
  FactSet& f = factsFor(a);
  if (delta > 0) {
    auto it = f.by_args.find(args);
    if (it != f.by_args.end() && !it->second.empty() && it->second[0] != value) {
      count = before;
      throw IncoherentError(r.loc.str() + ": attribute " + instanceName(a, args) +
                            " gets two values (" + syms_->text(it->second[0]) + " and " +
                            syms_->text(value) + ")");
    }
    f.add(args, value);
  } else {
    auto it = f.by_args.find(args);
    if (it != f.by_args.end()) {
      it->second.erase(std::remove(it->second.begin(), it->second.end(), value), it->second.end());
      if (it->second.empty()) f.by_args.erase(it);
    }
  }
  if (g_.attr_in_cone[static_cast<size_t>(a)] && static_cast<size_t>(a) < g_.static_atoms.size()) {
    std::string printable = instanceName(a, args) + "=" + syms_->text(value);
    if (delta > 0) g_.static_atoms[static_cast<size_t>(a)].insert(printable);
    else g_.static_atoms[static_cast<size_t>(a)].erase(printable);
  }
  auto rt = guard_refs_.find(key);
  if (rt != guard_refs_.end()) {
    for (const auto& ref : rt->second) {
      g_.instances[static_cast<size_t>(ref.first)].prs[static_cast<size_t>(ref.second)].inactive +=
          delta > 0 ? 1 : -1;
      if (changed_) changed_->push_back(ref);
    }
  }
  return true;
}

}  // namespace grounder_detail
}  // namespace plog
}  // namespace krr
