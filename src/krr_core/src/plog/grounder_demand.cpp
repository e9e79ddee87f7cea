/**
 * @file grounder_demand.cpp
 * @brief Grounder: the instance-level relevance cone (groundProgram's cone_atoms): which
 * instances of each attribute a query's atoms demand, closed over the defining statements.
 */
#include <algorithm>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "grounder_internal.h"

namespace krr {
namespace plog {
namespace grounder_detail {

std::vector<std::vector<Grounder::Definition>> Grounder::definitionsByHead() const {
  std::vector<std::vector<Definition>> defs(prog_.attributes.size());
  for (const auto& r : prog_.random_rules) {
    const int a = attrLookupTerm(r.attr);
    if (a >= 0) defs[static_cast<size_t>(a)].push_back({&r.attr.args, {&r.body, &r.range_body}});
  }
  for (const auto& p : prog_.pr_atoms) {
    const int a = attrLookupTerm(p.atom.attr);
    if (a >= 0) defs[static_cast<size_t>(a)].push_back({&p.atom.attr.args, {&p.body}});
  }
  for (size_t i = 0; i < prog_.rules.size(); ++i)
    if (rule_head_attr_[i] >= 0)
      defs[static_cast<size_t>(rule_head_attr_[i])].push_back(
          {&prog_.rules[i].head->attr.args, {&prog_.rules[i].body}});
  return defs;
}

void Grounder::computeInstancePatterns(const std::vector<AttributeTerm>& atoms) {
  restricted_ = true;
  head_demand_.assign(prog_.attributes.size(), Demand());
  demand_work_.clear();
  for (const auto& n : relevanceCone(prog_, {})) {
    const int a = attrLookup(n);
    if (a >= 0) demand(a, std::vector<int>(prog_.attributes[static_cast<size_t>(a)].arg_sorts.size(), -1));
  }
  const std::unordered_map<std::string, int> none;
  for (const auto& t : atoms) {
    const int a = attrLookupTerm(t);
    if (a >= 0) demand(a, patternOf(t.args, none));
  }
  const std::vector<std::vector<Definition>> defs = definitionsByHead();
  std::unordered_map<std::string, int> bind;
  while (!demand_work_.empty()) {
    const std::pair<int, std::vector<int>> item = std::move(demand_work_.back());
    demand_work_.pop_back();
    for (const Definition& d : defs[static_cast<size_t>(item.first)]) {
      bind.clear();
      if (!unifyHead(*d.head_args, item.second, bind)) continue;
      for (const std::vector<Literal>* body : d.bodies)
        for (const auto& l : *body) {
          if (l.kind != Literal::Kind::Atom) continue;
          const int b = attrLookupTerm(l.atom.attr);
          if (b >= 0 && g_.attr_dynamic[static_cast<size_t>(b)]) demand(b, patternOf(l.atom.attr.args, bind));
        }
    }
  }
}

std::vector<int> Grounder::patternOf(const std::vector<Term>& args,
                                     const std::unordered_map<std::string, int>& bind) {
  std::vector<int> pat;
  pat.reserve(args.size());
  for (const auto& t : args) {
    int v = -1;
    if (t.kind == Term::Kind::Symbol || t.kind == Term::Kind::Integer ||
        (t.kind == Term::Kind::Compound && t.isGround())) {
      v = syms_->intern(toString(t));
    } else if (t.kind == Term::Kind::Variable) {
      auto it = bind.find(t.name);
      if (it != bind.end()) v = it->second;
    }
    pat.push_back(v);
  }
  return pat;
}

bool Grounder::unifyHead(const std::vector<Term>& args, const std::vector<int>& pat,
                         std::unordered_map<std::string, int>& bind) {
  for (size_t i = 0; i < args.size() && i < pat.size(); ++i) {
    if (pat[i] < 0) continue;
    const Term& t = args[i];
    if (t.kind == Term::Kind::Symbol || t.kind == Term::Kind::Integer ||
        (t.kind == Term::Kind::Compound && t.isGround())) {
      if (syms_->intern(toString(t)) != pat[i]) return false;
    } else if (t.kind == Term::Kind::Variable && t.name != "_") {
      auto ins = bind.emplace(t.name, pat[i]);
      if (!ins.second && ins.first->second != pat[i]) return false;
    }
  }
  return true;
}

void Grounder::demand(int a, std::vector<int> pat) {
  Demand& d = head_demand_[static_cast<size_t>(a)];
  if (d.all) return;
  bool any = std::all_of(pat.begin(), pat.end(), [](int v) { return v < 0; });
  if (!any) {
    for (const auto& p : d.pats)
      if (subsumes(p, pat)) return;
    if (d.pats.size() >= kMaxDemandPatterns) any = true, pat.assign(pat.size(), -1);
  }
  if (any) {
    d.all = true;
    d.pats.clear();
  } else {
    d.pats.erase(std::remove_if(d.pats.begin(), d.pats.end(),
                                [&](const std::vector<int>& p) { return subsumes(pat, p); }),
                 d.pats.end());
    d.pats.push_back(pat);
  }
  demand_work_.push_back({a, std::move(pat)});
}

bool Grounder::preBind(const Stmt& s, const std::vector<CTerm>& hargs, const std::vector<int>& pat,
                       std::vector<int>& b) const {
  for (size_t i = 0; i < hargs.size() && i < pat.size(); ++i) {
    if (pat[i] < 0) continue;
    const CTerm& t = hargs[i];
    if (t.k == CTerm::Const) {
      if (t.sym != pat[i]) return false;
      continue;
    }
    int& slot = b[static_cast<size_t>(t.slot)];
    if (slot >= 0 && slot != pat[i]) return false;
    const int sort = s.slot_sort[static_cast<size_t>(t.slot)];
    if (sort >= 0 && posInSort(sort, pat[i]) < 0) return false;  // never a binding
    slot = pat[i];
  }
  return true;
}

int Grounder::admittedHead(int a, const std::vector<CTerm>& hargs, const std::vector<int>& b) {
  std::vector<int> args;
  args.reserve(hargs.size());
  for (const auto& t : hargs) {
    const int v = evalTerm(t, b);
    if (v < 0) return -1;
    args.push_back(v);
  }
  if (!argsInSorts(a, args) || !headAdmitted(a, args)) return -1;
  return instanceFor(a, args);
}

bool Grounder::headAdmitted(int a, const std::vector<int>& args) const {
  if (cur_pattern_ == -1 || !restrictedHead(a)) return true;
  const auto& pats = head_demand_[static_cast<size_t>(a)].pats;
  for (size_t k = 0; k < pats.size(); ++k)
    if (subsumes(pats[k], args)) return cur_pattern_ == -2 || static_cast<int>(k) == cur_pattern_;
  return false;
}

bool Grounder::demandsInstances(const PrAtom& p) {
  if (!restricted_) return false;
  const int a = attrLookupTerm(p.atom.attr);
  if (a < 0) return true;
  const Demand& d = head_demand_[static_cast<size_t>(a)];
  const std::vector<std::vector<int>> heads =
      d.all ? std::vector<std::vector<int>>{std::vector<int>(p.atom.attr.args.size(), -1)} : d.pats;
  std::unordered_map<std::string, int> bind;
  for (const auto& pat : heads) {
    bind.clear();
    if (!unifyHead(p.atom.attr.args, pat, bind)) continue;
    for (const auto& l : p.body) {
      if (l.kind != Literal::Kind::Atom) continue;
      const int b = attrLookupTerm(l.atom.attr);
      if (b < 0) return true;
      if (g_.attr_dynamic[static_cast<size_t>(b)] && !demanded(b, patternOf(l.atom.attr.args, bind)))
        return true;
    }
  }
  return false;
}

bool Grounder::demanded(int a, const std::vector<int>& pat) const {
  const Demand& d = head_demand_[static_cast<size_t>(a)];
  if (d.all) return true;
  for (const auto& p : d.pats)
    if (subsumes(p, pat)) return true;
  return false;
}

}  // namespace grounder_detail
}  // namespace plog
}  // namespace krr
