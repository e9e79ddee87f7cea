#include "krr_core/plog/ast.h"

#include <algorithm>
#include <sstream>

namespace krr {
namespace plog {

Term Term::symbol(const std::string& n, const SourceLocation& l) {
  Term t;
  t.kind = Kind::Symbol;
  t.name = n;
  t.loc = l;
  return t;
}

Term Term::integer(long long v, const SourceLocation& l) {
  Term t;
  t.kind = Kind::Integer;
  t.value = v;
  t.loc = l;
  return t;
}

Term Term::variable(const std::string& n, const SourceLocation& l) {
  Term t;
  t.kind = Kind::Variable;
  t.name = n;
  t.loc = l;
  return t;
}

bool Term::isGround() const {
  if (kind == Kind::Variable) return false;
  for (const auto& a : args)
    if (!a.isGround()) return false;
  return true;
}

void Term::collectVariables(std::vector<std::string>& out) const {
  if (kind == Kind::Variable) out.push_back(name);
  for (const auto& a : args) a.collectVariables(out);
}

bool operator==(const Term& a, const Term& b) {
  if (a.kind != b.kind) return false;
  if (a.kind == Term::Kind::Integer) return a.value == b.value;
  if (a.name != b.name || a.args.size() != b.args.size()) return false;
  for (size_t i = 0; i < a.args.size(); ++i)
    if (!(a.args[i] == b.args[i])) return false;
  return true;
}

const SortDecl* Program::findSort(const std::string& name) const {
  for (const auto& s : sorts)
    if (s.name == name) return &s;
  return nullptr;
}

const AttributeDecl* Program::findAttribute(const std::string& name) const {
  for (const auto& a : attributes)
    if (a.name == name) return &a;
  return nullptr;
}

std::string Program::domainSortOf(const std::string& variable) const {
  for (const auto& d : domains)
    for (const auto& v : d.variables)
      if (v == variable) return d.sort;
  return "";
}

bool Program::hasConsistencyRestoringRules() const {
  for (const auto& r : rules)
    if (r.consistency_restoring) return true;
  for (const auto& r : random_rules)
    if (r.consistency_restoring) return true;
  return false;
}

namespace {

int precedence(const Term& t) {
  if (t.kind != Term::Kind::Binary) return 3;
  if (t.name == "+" || t.name == "-") return 1;
  return 2;
}

}  // namespace

std::string toString(const Term& t) {
  switch (t.kind) {
    case Term::Kind::Symbol:
    case Term::Kind::Variable:
      return t.name;
    case Term::Kind::Integer:
      return std::to_string(t.value);
    case Term::Kind::Compound: {
      std::string s = t.name + "(";
      for (size_t i = 0; i < t.args.size(); ++i) s += (i ? "," : "") + toString(t.args[i]);
      return s + ")";
    }
    case Term::Kind::Negate: {
      std::string inner = toString(t.args.at(0));
      if (precedence(t.args.at(0)) < 3) inner = "(" + inner + ")";
      return "-" + inner;
    }
    case Term::Kind::Binary: {
      int p = precedence(t);
      std::string l = toString(t.args.at(0)), r = toString(t.args.at(1));
      if (precedence(t.args.at(0)) < p) l = "(" + l + ")";
      if (precedence(t.args.at(1)) <= p && t.args.at(1).kind == Term::Kind::Binary)
        r = "(" + r + ")";
      std::string op = t.name == "mod" ? " mod " : t.name;
      return l + op + r;
    }
  }
  return "";
}

std::string toString(const AttributeTerm& a) {
  if (a.args.empty()) return a.name;
  std::string s = a.name + "(";
  for (size_t i = 0; i < a.args.size(); ++i) s += (i ? "," : "") + toString(a.args[i]);
  return s + ")";
}

std::string toString(const Atom& a) {
  if (a.value.kind == Term::Kind::Symbol && a.value.name == "true") return toString(a.attr);
  return toString(a.attr) + "=" + toString(a.value);
}

std::string toString(CompareOp op) {
  switch (op) {
    case CompareOp::Eq: return "=";
    case CompareOp::Ne: return "!=";
    case CompareOp::Lt: return "<";
    case CompareOp::Le: return "<=";
    case CompareOp::Gt: return ">";
    case CompareOp::Ge: return ">=";
  }
  return "?";
}

std::string toString(const Literal& l) {
  std::string s = l.naf ? "not " : "";
  if (l.kind == Literal::Kind::Atom) {
    if (l.negated)
      s += toString(l.atom.attr) + "!=" + toString(l.atom.value);
    else
      s += toString(l.atom);
  } else {
    s += toString(l.lhs) + toString(l.op) + toString(l.rhs);
  }
  return s;
}

namespace {

std::string bodyString(const std::vector<Literal>& body) {
  std::string s;
  for (size_t i = 0; i < body.size(); ++i) s += (i ? ", " : "") + toString(body[i]);
  return s;
}

std::string sortValues(const SortDecl& s) {
  if (s.is_range) return "{" + std::to_string(s.range_lo) + ".." + std::to_string(s.range_hi) + "}";
  std::string r = "{";
  for (size_t i = 0; i < s.values.size(); ++i) r += (i ? ", " : "") + toString(s.values[i]);
  return r + "}";
}

std::string obsString(const Observation& o) {
  return "obs(" + toString(o.literal) + (o.truth ? "" : ", false") + ")";
}

}  // namespace

std::string toString(const Rule& r) {
  std::string s;
  if (r.head) s = toString(*r.head);
  if (r.consistency_restoring) return s + " :+" + (r.body.empty() ? "" : " " + bodyString(r.body)) + ".";
  if (!r.body.empty() || !r.head) s += (r.head ? " :- " : ":- ") + bodyString(r.body);
  return s + ".";
}

std::string toString(const RandomRule& r) {
  std::string s;
  if (!r.label.empty()) s += "[" + r.label + "] ";
  s += "random(" + toString(r.attr);
  if (r.has_range) s += " : {" + r.range_var + " : " + bodyString(r.range_body) + "}";
  s += ")";
  if (r.consistency_restoring) return s + " :+" + (r.body.empty() ? "" : " " + bodyString(r.body)) + ".";
  if (!r.body.empty()) s += " :- " + bodyString(r.body);
  return s + ".";
}

std::string toString(const PrAtom& p) {
  std::string s;
  if (!p.label.empty()) s += "[" + p.label + "] ";
  s += "pr(" + toString(p.atom);
  if (!p.body.empty()) s += " | " + bodyString(p.body);
  std::string v = p.probability_text;
  if (v.empty()) {
    std::ostringstream os;
    os.precision(17);
    os << p.probability;
    v = os.str();
  }
  return s + ") = " + v + ".";
}

std::string toString(const Query& q) {
  std::string s = "?{" + bodyString(q.formula) + "}";
  std::vector<std::string> cond;
  for (const auto& o : q.observations) cond.push_back(obsString(o));
  for (const auto& d : q.interventions) cond.push_back("do(" + toString(d.atom) + ")");
  for (size_t i = 0; i < cond.size(); ++i) s += (i ? ", " : " | ") + cond[i];
  return s + ".";
}

std::string toString(const Program& p) {
  std::ostringstream os;
  os << "% exported P-log program (classic dialect)\n";
  for (const auto& s : p.sorts) {
    if (s.builtin) continue;
    os << s.name << " = " << sortValues(s) << ".\n";
  }
  for (const auto& d : p.domains) {
    os << "#domain " << d.sort << "(";
    for (size_t i = 0; i < d.variables.size(); ++i) os << (i ? ";" : "") << d.variables[i];
    os << ").\n";
  }
  for (const auto& a : p.attributes) {
    if (a.implicit) continue;
    os << a.name << " : ";
    // a classic `a : s.` whose arity came from use (untyped arguments) is written as read
    bool typed = std::find(a.arg_sorts.begin(), a.arg_sorts.end(), "") == a.arg_sorts.end();
    for (size_t i = 0; typed && i < a.arg_sorts.size(); ++i)
      os << (i ? ", " : "") << a.arg_sorts[i];
    if (typed && !a.arg_sorts.empty()) os << " -> ";
    os << a.range_sort << ".\n";
  }
  for (const auto& r : p.rules) os << toString(r) << "\n";
  for (const auto& r : p.random_rules) os << toString(r) << "\n";
  // pr-atoms by knowledge generation (0 = the program as written; higher = learned later)
  int max_gen = 0;
  for (const auto& r : p.pr_atoms) max_gen = std::max(max_gen, r.priority);
  for (int gen = 0; gen <= max_gen; ++gen) {
    bool header = false;
    for (const auto& r : p.pr_atoms) {
      if (r.priority != gen) continue;
      if (gen > 0 && !header) {
        os << "#generation " << gen << ".\n";
        header = true;
      }
      os << toString(r) << "\n";
    }
  }
  for (const auto& o : p.observations) os << obsString(o) << ".\n";
  for (const auto& d : p.interventions) os << "do(" << toString(d.atom) << ").\n";
  for (const auto& q : p.queries) os << toString(q) << "\n";
  return os.str();
}

}  // namespace plog
}  // namespace krr
