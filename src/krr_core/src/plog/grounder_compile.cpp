/**
 * @file grounder_compile.cpp
 * @brief Grounder: compiling a statement's terms and literals into slot-numbered form (each
 * variable a slot of the binding) with the sorts of its variables, before it is joined.
 */
#include <string>
#include <vector>

#include "grounder_internal.h"

namespace krr {
namespace plog {
namespace grounder_detail {

int Grounder::slotOf(Stmt& s, const std::string& name) {
  auto it = s.slots.find(name);
  if (it != s.slots.end()) return it->second;
  int id = static_cast<int>(s.slot_names.size());
  s.slots.emplace(name, id);
  s.slot_names.push_back(name);
  s.slot_sort.push_back(-1);
  return id;
}

CTerm Grounder::compile(Stmt& s, const Term& t) {
  CTerm c;
  switch (t.kind) {
    case Term::Kind::Symbol:
    case Term::Kind::Integer:
      c.k = CTerm::Const;
      c.sym = syms_->intern(toString(t));
      break;
    case Term::Kind::Variable:
      c.k = CTerm::Var;
      if (t.name == "_") {
        c.slot = slotOf(s, "_anon" + std::to_string(anon_++));
      } else {
        c.slot = slotOf(s, t.name);
      }
      break;
    case Term::Kind::Compound:
      if (t.isGround()) {
        c.k = CTerm::Const;
        c.sym = syms_->intern(toString(t));
        break;
      }
      c.k = CTerm::Comp;
      c.op = t.name;
      for (const auto& a : t.args) c.args.push_back(compile(s, a));
      break;
    case Term::Kind::Binary:
      c.k = CTerm::Bin;
      c.op = t.name;
      c.src = &t;
      for (const auto& a : t.args) c.args.push_back(compile(s, a));
      break;
    case Term::Kind::Negate:
      c.k = CTerm::Neg;
      c.src = &t;
      for (const auto& a : t.args) c.args.push_back(compile(s, a));
      break;
  }
  return c;
}

void Grounder::termVars(const CTerm& t, std::vector<int>& out) {
  if (t.k == CTerm::Var) out.push_back(t.slot);
  for (const auto& a : t.args) termVars(a, out);
}

CLit Grounder::compileLit(Stmt& s, const Literal& l, int origin) {
  CLit c;
  c.loc = l.loc;
  c.origin = origin;
  c.naf = l.naf;
  if (l.kind == Literal::Kind::Atom) {
    c.is_atom = true;
    c.attr = attrId(l.atom.attr, l.loc);
    c.dynamic = g_.attr_dynamic[c.attr];
    c.neg = l.negated;
    for (const auto& a : l.atom.attr.args) c.args.push_back(compile(s, a));
    c.value = compile(s, l.atom.value);
    for (const auto& a : c.args) termVars(a, c.vars);
    termVars(c.value, c.vars);
    c.guard = compiling_pr_ && c.naf && !c.neg && isGuard(c.attr);
  } else {
    c.is_atom = false;
    c.op = l.op;
    c.lhs = compile(s, l.lhs);
    c.rhs = compile(s, l.rhs);
    termVars(c.lhs, c.vars);
    termVars(c.rhs, c.vars);
  }
  return c;
}

void Grounder::typeSlots(Stmt& s, const VariableSorts& vs) {
  for (size_t i = 0; i < s.slot_names.size(); ++i) {
    auto it = vs.find(s.slot_names[i]);
    std::string sort = it != vs.end() ? it->second : prog_.domainSortOf(s.slot_names[i]);
    if (!sort.empty()) {
      auto si = sort_index_.find(sort);
      if (si == sort_index_.end())
        throw UnknownSymbolError(s.loc.str() + ": unknown sort '" + sort + "' of variable " +
                                 s.slot_names[i]);
      s.slot_sort[i] = si->second;
    }
  }
}

}  // namespace grounder_detail
}  // namespace plog
}  // namespace krr
