/**
 * @file grounder_dynamic.cpp
 * @brief Grounder: instantiating the statements of dynamic attributes (random selection rules
 * with their ranges, pr-atoms, derived rules, constraints) into the ground network.
 */
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "grounder_internal.h"

namespace krr {
namespace plog {
namespace grounder_detail {

void Grounder::groundDynamic() {
  for (const auto& r : prog_.random_rules) {
    const int a = attrId(r.attr, r.loc);
    if (g_.attr_in_cone[static_cast<size_t>(a)] && headDemanded(a)) groundSelectionRule(r, a);
  }
  for (size_t i = 0; i < prog_.pr_atoms.size(); ++i) {
    const PrAtom& p = prog_.pr_atoms[i];
    const int a = attrId(p.atom.attr, p.loc);
    // (a pr-atom of an attribute that is not random is refused by groundPrAtom)
    if (!g_.attr_in_cone[static_cast<size_t>(a)] || (g_.attr_random[a] && !headDemanded(a))) continue;
    groundPrAtom(p, pr_ids_ ? (*pr_ids_)[i] : static_cast<std::uint64_t>(i + 1));
  }
  for (size_t ri = 0; ri < prog_.rules.size(); ++ri) {
    const int h = rule_head_attr_[ri];  // (-1: a constraint)
    if (h >= 0 && (!g_.attr_dynamic[h] || !g_.attr_in_cone[h] || !headDemanded(h))) continue;
    const Rule& r = prog_.rules[ri];
    if (!r.head) {
      bool touches = false;
      for (const auto& l : r.body)
        if (l.kind == Literal::Kind::Atom && g_.attr_in_cone[attrId(l.atom.attr, l.loc)])
          touches = true;
      if (!touches && !r.body.empty()) continue;
    }
    groundDynamicRule(r, h);
  }
}

void Grounder::groundSelectionRule(const RandomRule& r, int a) {
  cur_loc_ = r.loc;
  Stmt s;
  s.loc = r.loc;
  for (const auto& l : r.body) s.lits.push_back(compileLit(s, l, 0));
  int range_slot = -1;
  if (r.has_range) {
    range_slot = slotOf(s, r.range_var);
    for (const auto& l : r.range_body) s.lits.push_back(compileLit(s, l, 1));
  }
  std::vector<CTerm> hargs;
  for (const auto& t : r.attr.args) hargs.push_back(compile(s, t));
  typeSlots(s, r.variable_sorts);
  std::vector<int> required;
  for (const auto& t : hargs) termVars(t, required);
  const size_t nbody = r.body.size();
  std::unordered_map<std::string, std::pair<int, int>> groups;  // key -> (inst, sel idx)
  std::vector<char> done(s.lits.size(), 0);
  for (size_t i = nbody; i < s.lits.size(); ++i) done[i] = 1;  // range literals later
  std::vector<GLit> acc;
  std::vector<int> origin;
  const Emit emit = [&](const std::vector<int>& bb, const std::vector<GLit>& body,
                        const std::vector<int>&) {
    const int inst = admittedHead(a, hargs, bb);
    if (inst < 0) return;
    std::string key = std::to_string(inst) + ":" + litKey(body);
    auto it = groups.find(key);
    if (it == groups.end()) {
      GSelection sel;
      sel.label = r.label;
      sel.body = body;
      sel.dynamic_range = r.has_range;
      sel.loc = r.loc;
      GInstance& gi = g_.instances[static_cast<size_t>(inst)];
      gi.selections.push_back(sel);
      it = groups.emplace(key, std::make_pair(inst, int(gi.selections.size()) - 1)).first;
      ++g_.ground_statements;
      spend(0, 1);
    }
    if (range_slot >= 0) groundRange(s, nbody, bb, range_slot, inst, it->second.second);
  };
  forEachHeadPattern(s, a, hargs, [&](std::vector<int>& b) {
    join(s, done, b, acc, origin, required, emit);
  });
}

void Grounder::groundRange(Stmt& s, size_t nbody, const std::vector<int>& bb, int range_slot,
                           int inst, int sel_index) {
  std::vector<char> done2(s.lits.size(), 1);
  for (size_t i = nbody; i < s.lits.size(); ++i) done2[i] = 0;
  std::vector<int> b2 = bb;
  std::vector<GLit> acc2;
  std::vector<int> origin2;
  join(s, done2, b2, acc2, origin2, {range_slot}, [&](const std::vector<int>& b3,
                                                      const std::vector<GLit>& cond,
                                                      const std::vector<int>&) {
    GInstance& gi = g_.instances[static_cast<size_t>(inst)];
    int vi = valueIdx(inst, b3[static_cast<size_t>(range_slot)]);
    if (vi >= 0) gi.selections[static_cast<size_t>(sel_index)].range.push_back({vi, cond});
  });
}

void Grounder::groundDynamicRule(const Rule& r, int h) {
  cur_loc_ = r.loc;
  Stmt s;
  s.loc = r.loc;
  for (const auto& l : r.body) s.lits.push_back(compileLit(s, l, 0));
  std::vector<CTerm> hargs;
  CTerm hval;
  if (r.head) {
    for (const auto& t : r.head->attr.args) hargs.push_back(compile(s, t));
    hval = compile(s, r.head->value);
  }
  typeSlots(s, r.variable_sorts);
  std::vector<int> required;
  for (const auto& t : hargs) termVars(t, required);
  if (r.head) termVars(hval, required);
  const Emit emit = [&](const std::vector<int>& b, const std::vector<GLit>& acc,
                        const std::vector<int>&) {
    if (!r.head) {
      if (acc.empty())
        throw IncoherentError(r.loc.str() + ": constraint is violated by the facts of the "
                              "program (no possible world)");
      g_.constraints.push_back({acc, r.loc});
      ++g_.ground_statements;
      spend(0, 1);
      return;
    }
    const int inst = admittedHead(h, hargs, b);
    if (inst < 0) return;
    addDerivedRule(r, inst, evalTerm(hval, b), acc);
  };
  if (!r.head) {
    runJoin(s, required, emit);
    return;
  }
  forEachHeadPattern(s, h, hargs, [&](std::vector<int>& b) { runJoinFrom(s, b, required, emit); });
}

void Grounder::addDerivedRule(const Rule& r, int inst, int v, const std::vector<GLit>& body) {
  GInstance& gi = g_.instances[static_cast<size_t>(inst)];
  int vi = v < 0 ? -1 : valueIdx(inst, v);
  if (vi < 0)
    throw UnknownSymbolError(r.loc.str() + ": value '" + (v < 0 ? "?" : syms_->text(v)) +
                             "' is not in the range of " + gi.name);
  gi.rules.push_back({vi, body});
  ++g_.ground_statements;
  if (!gi.random) ++g_.derived_rules;
  spend(0, 1);
}

void Grounder::groundPrAtom(const PrAtom& p, std::uint64_t id) {
  int a = attrId(p.atom.attr, p.loc);
  if (!g_.attr_random[a]) {
    throw UnknownSymbolError(p.loc.str() + ": pr-atom for attribute '" + p.atom.attr.name +
                             "' which has no random selection rule");
  }
  cur_loc_ = p.loc;
  Stmt s;
  s.loc = p.loc;
  compiling_pr_ = true;
  for (const auto& l : p.body) s.lits.push_back(compileLit(s, l, 0));
  compiling_pr_ = false;
  std::vector<CTerm> hargs;
  for (const auto& t : p.atom.attr.args) hargs.push_back(compile(s, t));
  CTerm hval = compile(s, p.atom.value);
  typeSlots(s, p.variable_sorts);
  std::vector<int> required;
  for (const auto& t : hargs) termVars(t, required);
  termVars(hval, required);
  guard_acc_.clear();
  const Emit emit = [&](const std::vector<int>& b, const std::vector<GLit>& acc,
                        const std::vector<int>&) {
    const int inst = admittedHead(a, hargs, b);
    if (inst < 0) return;
    GInstance& gi = g_.instances[static_cast<size_t>(inst)];
    int v = evalTerm(hval, b);
    int vi = v < 0 ? -1 : valueIdx(inst, v);
    if (vi < 0) return;
    GPr pr;
    pr.value = vi;
    pr.probability = p.probability;
    pr.label = p.label;
    pr.body = acc;
    pr.loc = p.loc;
    pr.priority = p.priority;
    pr.src = id;
    const std::pair<int, int> ref{inst, static_cast<int>(gi.prs.size())};
    for (const auto& key : guard_acc_) {
      guard_refs_[key].push_back(ref);
      if (guardHolds(key)) ++pr.inactive;
    }
    gi.prs.push_back(std::move(pr));
    ++atoms_;
    src_refs_[id].push_back(ref);
    if (changed_) changed_->push_back(ref);
    ++g_.ground_statements;
    spend(0, 1);
  };
  forEachHeadPattern(s, a, hargs, [&](std::vector<int>& b) { runJoinFrom(s, b, required, emit); });
}

std::string Grounder::litKey(const std::vector<GLit>& body) {
  std::string k;
  for (const auto& l : body)
    k += std::to_string(l.inst) + "/" + std::to_string(l.value) + (l.naf ? "n" : "") +
         (l.neg ? "-" : "") + ";";
  return k;
}

}  // namespace grounder_detail
}  // namespace plog
}  // namespace krr
