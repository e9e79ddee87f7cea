/**
 * @file asp_translation.cpp
 * @brief P-log -> ASP translation for the clingo back end (asp_backend.cpp measures the
 * answer sets).
 *
 * Naming inside the generated program: every P-log variable X becomes VX (so that the
 * translation's own variables, all starting with W, never clash with it); every attribute atom
 * a(t) = y becomes val(a(t), y), so the P-log names only ever appear as function symbols and
 * constants inside the translation's own predicates (sort/2, val/2, sel/2, poss/3, npos/3,
 * pra/3, chosen/4, empty/2, intervene/1, q/1, ev/1 ...) and cannot clash with them. Only
 * chosen/4, empty/2, pra/3, q/1 and ev/1 are shown, to keep clingo's output small.
 */
#include "asp_translation.h"

#include "krr_core/plog/budget.h"

#include "krr_core/plog/arith.h"

#include <algorithm>
#include <cctype>
#include <set>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/plog/asp_backend.h"

namespace krr {
namespace plog {
namespace asp_detail {

std::string where(const SourceLocation& loc) {
  return loc.file.empty() ? std::string("<program>") : loc.str();
}

const AttributeDecl& attributeOf(const Program& program, const AttributeTerm& a) {
  const AttributeDecl* d = program.findAttribute(a.name);
  if (d == nullptr) {
    throw UnknownSymbolError(where(a.loc) + ": AspBackend: undeclared attribute '" + a.name + "'");
  }
  return *d;
}

namespace {

bool isLowerIdentifier(const std::string& s) {
  std::size_t i = 0;
  while (i < s.size() && s[i] == '_') ++i;
  if (i >= s.size() || !(s[i] >= 'a' && s[i] <= 'z')) return false;
  for (; i < s.size(); ++i) {
    char c = s[i];
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '\'')) return false;
  }
  return true;
}

/// A constant or function name in clingo syntax: kept when it is a clingo identifier, else an
/// error (P-log names are identifiers; anything else means a parser change we do not know).
std::string aspName(const std::string& name, const SourceLocation& loc) {
  if (!isLowerIdentifier(name)) {
    throw Error(where(loc) + ": AspBackend: name '" + name +
                "' is not a clingo identifier and cannot be translated");
  }
  return name;
}

std::string aspVar(const std::string& name) {
  if (name == "_") return "_";
  return "V" + name;
}

std::string aspTerm(const Term& t);

std::string aspOperand(const Term& t) {
  std::string s = aspTerm(t);
  if (t.kind == Term::Kind::Binary || t.kind == Term::Kind::Negate ||
      (t.kind == Term::Kind::Integer && t.value < 0)) {
    return "(" + s + ")";
  }
  return s;
}

std::string aspTerm(const Term& t) {
  switch (t.kind) {
    case Term::Kind::Symbol:
      return aspName(t.name, t.loc);
    case Term::Kind::Integer:
      return std::to_string(t.value);
    case Term::Kind::Variable:
      return aspVar(t.name);
    case Term::Kind::Compound: {
      std::string s = aspName(t.name, t.loc) + "(";
      for (std::size_t i = 0; i < t.args.size(); ++i) s += (i ? "," : "") + aspTerm(t.args[i]);
      return s + ")";
    }
    case Term::Kind::Negate:
      if (t.args.size() != 1) throw Error(where(t.loc) + ": AspBackend: malformed negation");
      return "-" + aspOperand(t.args[0]);
    case Term::Kind::Binary: {
      if (t.args.size() != 2) throw Error(where(t.loc) + ": AspBackend: malformed expression");
      std::string op = t.name;
      if (op == "mod") op = "\\";
      if (op != "+" && op != "-" && op != "*" && op != "/" && op != "\\") {
        throw Error(where(t.loc) + ": AspBackend: unsupported operator '" + t.name + "'");
      }
      return aspOperand(t.args[0]) + op + aspOperand(t.args[1]);
    }
  }
  return "";
}

std::string aspAttr(const AttributeTerm& a) {
  std::string s = aspName(a.name, a.loc);
  if (a.args.empty()) return s;
  s += "(";
  for (std::size_t i = 0; i < a.args.size(); ++i) s += (i ? "," : "") + aspTerm(a.args[i]);
  return s + ")";
}

std::string aspVal(const Atom& a) { return "val(" + aspAttr(a.attr) + "," + aspTerm(a.value) + ")"; }

std::string aspOp(CompareOp op, bool negate) {
  if (negate) {
    switch (op) {
      case CompareOp::Eq: op = CompareOp::Ne; break;
      case CompareOp::Ne: op = CompareOp::Eq; break;
      case CompareOp::Lt: op = CompareOp::Ge; break;
      case CompareOp::Le: op = CompareOp::Gt; break;
      case CompareOp::Gt: op = CompareOp::Le; break;
      case CompareOp::Ge: op = CompareOp::Lt; break;
    }
  }
  return toString(op);  // clingo writes comparisons as P-log does
}

void termVars(const Term& t, std::set<std::string>& out) {
  std::vector<std::string> v;
  t.collectVariables(v);
  for (auto& n : v)
    if (n != "_") out.insert(n);
}

void attrVars(const AttributeTerm& a, std::set<std::string>& out) {
  for (const auto& t : a.args) termVars(t, out);
}

void literalVars(const Literal& l, std::set<std::string>& out) {
  if (l.kind == Literal::Kind::Atom) {
    attrVars(l.atom.attr, out);
    termVars(l.atom.value, out);
  } else {
    termVars(l.lhs, out);
    termVars(l.rhs, out);
  }
}

/// Builds the body of one generated rule: literal translations plus, for every P-log variable
/// used, the sort atom that P-log grounding ranges it over.
class BodyBuilder {
 public:
  BodyBuilder(const Program& program, const VariableSorts& sorts, int& fresh)
      : program_(program), sorts_(sorts), fresh_(fresh) {}

  void raw(const std::string& s) { parts_.push_back(s); }

  void literal(const Literal& l) {
    literalVars(l, vars_);
    if (l.kind == Literal::Kind::Comparison) {
      parts_.push_back(aspTerm(l.lhs) + aspOp(l.op, l.naf) + aspTerm(l.rhs));
      return;
    }
    if (!l.negated) {
      parts_.push_back((l.naf ? "not " : "") + aspVal(l.atom));
      return;
    }
    // a(t) != y: a(t) has a value and it is not y.
    std::string w = "W" + std::to_string(fresh_++);
    std::string attr = aspAttr(l.atom.attr), y = aspTerm(l.atom.value);
    if (!l.naf) {
      parts_.push_back("val(" + attr + "," + w + ")");
      parts_.push_back(w + "!=" + y);
    } else {
      parts_.push_back("#count{" + w + ":val(" + attr + "," + w + ")," + w + "!=" + y + "}=0");
    }
  }

  void literals(const std::vector<Literal>& ls) {
    for (const auto& l : ls) literal(l);
  }

  /// The ground instance of a consistency-restoring statement as a term: t(VX,VY) over the
  /// statement's P-log variables (`t` when it has none), for appl(statement, instance).
  std::string instanceTerm() const {
    if (vars_.empty()) return "t";
    std::string s = "t(";
    bool first = true;
    for (const auto& v : vars_) {
      s += (first ? "" : ",") + aspVar(v);
      first = false;
    }
    return s + ")";
  }

  void vars(const std::set<std::string>& v) { vars_.insert(v.begin(), v.end()); }
  void forget(const std::string& v) { vars_.erase(v); }
  void term(const Term& t) { termVars(t, vars_); }
  void attr(const AttributeTerm& a) { attrVars(a, vars_); }

  /// The body text (without the leading ":-"); sort atoms first so clingo binds them early.
  std::string str() const {
    std::vector<std::string> all;
    for (const auto& v : vars_) {
      auto it = sorts_.find(v);
      std::string sort = it != sorts_.end() ? it->second : program_.domainSortOf(v);
      if (sort.empty()) continue;
      all.push_back("sort(" + aspName(sort, {}) + "," + aspVar(v) + ")");
    }
    all.insert(all.end(), parts_.begin(), parts_.end());
    std::string s;
    for (std::size_t i = 0; i < all.size(); ++i) s += (i ? ", " : "") + all[i];
    return s;
  }

 private:
  const Program& program_;
  const VariableSorts& sorts_;
  int& fresh_;
  std::vector<std::string> parts_;
  std::set<std::string> vars_;
};

std::string ruleText(const std::string& head, const std::string& body) {
  if (body.empty()) return head + ".\n";
  return head + (head.empty() ? ":- " : " :- ") + body + ".\n";
}

/// Positive translation of a ground observation/query literal as a rule body (no naf).
std::string groundLiteralBody(const Program& program, const Literal& l, int& fresh) {
  static const VariableSorts kNoSorts;
  Literal pos = l;
  pos.naf = false;
  BodyBuilder b(program, kNoSorts, fresh);
  b.literal(pos);
  return b.str();
}

/// @brief `sort(s, v).` for every value of every sort (an integer range in one atom).
void translateSorts(const Program& program, std::ostream& out) {
  out << "% sorts\n";
  for (const auto& s : program.sorts) {
    const std::string name = aspName(s.name, s.loc);
    if (s.is_range && s.range_lo <= s.range_hi &&
        s.values.size() == rangeSize(s.range_lo, s.range_hi)) {
      out << "sort(" << name << "," << s.range_lo << ".." << s.range_hi << ").\n";
      continue;
    }
    for (const auto& v : s.values) out << "sort(" << name << "," << aspTerm(v) << ").\n";
  }
}

/// @brief Arithmetic in a rule's head (next = C+1): ground instances whose value falls outside
/// the sort are ill-typed and not part of the ground program, as in P-log's grounding, so the
/// body requires the computed arguments and value to be in their sorts.
void addHeadSortGuards(const Program& program, const Atom& head, BodyBuilder& b) {
  const AttributeDecl& decl = attributeOf(program, head.attr);
  auto arithmetic = [](const Term& t) {
    return t.kind == Term::Kind::Binary || t.kind == Term::Kind::Negate;
  };
  for (std::size_t k = 0; k < head.attr.args.size() && k < decl.arg_sorts.size(); ++k) {
    if (arithmetic(head.attr.args[k]) && !decl.arg_sorts[k].empty()) {
      b.raw("sort(" + aspName(decl.arg_sorts[k], decl.loc) + "," +
            aspTerm(head.attr.args[k]) + ")");
    }
  }
  if (arithmetic(head.value)) {
    b.raw("sort(" + aspName(decl.range_sort, decl.loc) + "," + aspTerm(head.value) + ")");
  }
}

/// @brief Rule ri; a consistency-restoring rule (:+) fires only where its appl(r(ri), instance)
/// atom is chosen.
void translateRule(const Program& program, std::size_t ri, int& fresh, std::ostream& out) {
  const Rule& r = program.rules[ri];
  out << kAspSourceMarker << where(r.loc) << "\n";
  BodyBuilder b(program, r.variable_sorts, fresh);
  std::string head;
  if (r.head) {
    head = aspVal(*r.head);
    b.attr(r.head->attr);
    b.term(r.head->value);
    addHeadSortGuards(program, *r.head, b);
  }
  b.literals(r.body);
  if (r.consistency_restoring) {
    if (!r.head) return;  // `:+ body.` could only make a world inconsistent: never applied
    const std::string appl = "appl(r(" + std::to_string(ri) + ")," + b.instanceTerm() + ")";
    out << "{ " << appl << " }" << (b.str().empty() ? ".\n" : " :- " + b.str() + ".\n");
    b.raw(appl);
  }
  out << ruleText(head, b.str());
}

/// @brief Random selection rule i: sel(i, a) where it applies (and a is not intervened on),
/// poss(i, a, y) for the values of its range, and the choice of one possible value.
void translateRandomRule(const Program& program, std::size_t i, int& fresh, std::ostream& out) {
  const RandomRule& r = program.random_rules[i];
  out << kAspSourceMarker << where(r.loc) << "\n";
  const AttributeDecl& decl = attributeOf(program, r.attr);
  const std::string a = aspAttr(r.attr), idx = std::to_string(i);
  {
    BodyBuilder b(program, r.variable_sorts, fresh);
    b.attr(r.attr);
    b.literals(r.body);
    b.raw("not intervene(" + a + ")");
    if (r.consistency_restoring) {
      const std::string appl = "appl(s(" + idx + ")," + b.instanceTerm() + ")";
      out << "{ " << appl << " } :- " << b.str() << ".\n";
      b.raw(appl);
    }
    out << ruleText("sel(" + idx + "," + a + ")", b.str());
  }
  {
    BodyBuilder b(program, r.variable_sorts, fresh);
    std::string y = r.has_range ? aspVar(r.range_var) : "WY";
    b.raw("sel(" + idx + "," + a + ")");
    b.raw("sort(" + aspName(decl.range_sort, decl.loc) + "," + y + ")");
    if (r.has_range) {
      // The range may use variables bound by the selection body (random(y : {Z : Z > X})
      // :- x = X), so the body is evaluated again with the range.
      b.literals(r.body);
      b.literals(r.range_body);
      b.forget(r.range_var);  // already ranged over the attribute's range sort above
    }
    out << ruleText("poss(" + idx + "," + a + "," + y + ")", b.str());
  }
  // An empty dynamic range leaves the term without a value (npos = 0 is then reported as
  // incoherent, as the native engine does) instead of silently killing the world.
  out << "1 { val(" << a << ",WY) : poss(" << idx << "," << a << ",WY) } 1 :- sel(" << idx
      << "," << a << "), poss(" << idx << "," << a << ",_).\n";
}

/// @brief Pr-atom j: pra(j, a, y) when it applies, once per selection rule it may apply to
/// (those with its label; any rule WI when it has none).
void translatePrAtom(const Program& program, std::size_t j, int& fresh, std::ostream& out) {
  const PrAtom& p = program.pr_atoms[j];
  out << kAspSourceMarker << where(p.loc) << "\n";
  attributeOf(program, p.atom.attr);
  const std::string a = aspAttr(p.atom.attr), y = aspTerm(p.atom.value);
  std::vector<std::string> rules;
  if (p.label.empty()) {
    rules.push_back("WI");
  } else {
    for (std::size_t i = 0; i < program.random_rules.size(); ++i) {
      if (program.random_rules[i].label == p.label) rules.push_back(std::to_string(i));
    }
  }
  for (const auto& ri : rules) {
    BodyBuilder b(program, p.variable_sorts, fresh);
    b.raw("sel(" + ri + "," + a + ")");
    b.raw("poss(" + ri + "," + a + "," + y + ")");
    b.attr(p.atom.attr);
    b.term(p.atom.value);
    b.literals(p.body);
    out << ruleText("pra(" + std::to_string(j) + "," + a + "," + y + ")", b.str());
  }
}

/// @brief The program's own do (facts marked intervened) and obs (constraints on pobs(k)).
void translateProgramEvidence(const Program& program, int& fresh, std::ostream& out) {
  for (const auto& d : program.interventions) {
    out << kAspSourceMarker << where(d.loc) << "\n";
    out << aspVal(d.atom) << ". intervene(" << aspAttr(d.atom.attr) << ").\n";
  }
  for (std::size_t k = 0; k < program.observations.size(); ++k) {
    const Observation& o = program.observations[k];
    out << kAspSourceMarker << where(o.loc) << "\n";
    out << ruleText("pobs(" + std::to_string(k) + ")",
                    groundLiteralBody(program, o.literal, fresh));
    out << ":- " << (o.truth ? "not " : "") << "pobs(" << k << ").\n";
  }
}

}  // namespace

std::string translateBase(const Program& program) {
  std::ostringstream out;
  MemoryGuard guard;  // the translation's memory budget (krr::memoryBudget())
  int fresh = 0;
  out << "% P-log program translated to ASP by krr::plog::AspBackend\n";
  translateSorts(program, out);
  out << "% an attribute term has at most one value\n";
  out << ":- val(WA,WY1), val(WA,WY2), WY1 != WY2.\n";

  out << "% rules; a consistency-restoring rule (:+) only fires where appl(r(i), instance) is\n";
  out << "% chosen, and the number of such atoms is minimised (see runScenarios)\n";
  for (std::size_t ri = 0; ri < program.rules.size(); ++ri) {
    guard.tick("translating the program to ASP", program.rules[ri].loc);
    translateRule(program, ri, fresh, out);
  }

  out << "% random selections: sel(rule, attribute term), poss(rule, attribute term, value)\n";
  for (std::size_t i = 0; i < program.random_rules.size(); ++i)
    translateRandomRule(program, i, fresh, out);
  out << "% chosen(rule, attribute term, value, number of possible values); empty ranges\n";
  out << "npos(WI,WA,WN) :- sel(WI,WA), WN = #count{ WY : poss(WI,WA,WY) }.\n";
  out << "chosen(WI,WA,WY,WN) :- sel(WI,WA), val(WA,WY), npos(WI,WA,WN).\n";
  out << "empty(WI,WA) :- npos(WI,WA,0).\n";

  out << "% pr-atoms: pra(pr-atom, attribute term, value) when it applies\n";
  for (std::size_t j = 0; j < program.pr_atoms.size(); ++j) translatePrAtom(program, j, fresh, out);

  out << "% interventions and observations of the program\n";
  translateProgramEvidence(program, fresh, out);
  out << kAspSourceMarker << "<translation>\n";
  out << "#defined intervene/1. #defined pobs/1. #defined pra/3. #defined val/2.\n";
  out << "#defined sel/2. #defined poss/3. #defined appl/2.\n";
  return out.str();
}

/// The part of a clingo run specific to its queries. Each scenario g is one set of
/// interventions; with several scenarios they are guarded by the external atom scn(g) and a
/// Lua main solves once per scenario (multi-shot), so one clingo process answers all of them.
/// spec_scenario[k] is the scenario of spec k (specs are numbered globally).
std::string translateScenarios(const Program& program,
                               const std::vector<std::vector<Intervention>>& scenarios,
                               const std::vector<QuerySpec>& specs) {
  std::ostringstream out;
  int fresh = 1000000;
  const bool multi = scenarios.size() > 1;
  out << "% query interventions\n";
  for (std::size_t g = 0; g < scenarios.size(); ++g) {
    const std::string guard = multi ? " :- scn(" + std::to_string(g) + ").\n" : ".\n";
    for (const auto& d : scenarios[g]) {
      out << aspVal(d.atom) << guard << "intervene(" << aspAttr(d.atom.attr) << ")" << guard;
    }
  }
  out << "% queries: ev(k) when the evidence of query k holds, q(k) when its formula holds\n";
  for (std::size_t k = 0; k < specs.size(); ++k) {
    const QuerySpec& s = specs[k];
    const std::string ks = std::to_string(k);
    std::string ev;
    for (std::size_t m = 0; m < s.observations.size(); ++m) {
      const std::string lit = "qobs(" + ks + "," + std::to_string(m) + ")";
      out << ruleText(lit, groundLiteralBody(program, s.observations[m].literal, fresh));
      ev += (ev.empty() ? "" : ", ") + std::string(s.observations[m].truth ? "" : "not ") + lit;
    }
    out << ruleText("ev(" + ks + ")", ev);
    std::string q;
    for (std::size_t m = 0; m < s.formula.size(); ++m) {
      const std::string lit = "qlit(" + ks + "," + std::to_string(m) + ")";
      out << ruleText(lit, groundLiteralBody(program, s.formula[m], fresh));
      q += (q.empty() ? "" : ", ") + std::string(s.formula[m].naf ? "not " : "") + lit;
    }
    out << ruleText("q(" + ks + ")", q);
  }
  out << "#defined qobs/2. #defined qlit/2.\n";
  out << "#show chosen/4. #show empty/2. #show pra/3. #show q/1. #show ev/1.\n";
  if (multi) {
    out << "#external scn(0.." << scenarios.size() - 1 << ").\n#show scn/1.\n";
    out << "#script (lua)\n"
           "function main(prg)\n"
           "  prg:ground({{\"base\", {}}})\n"
           "  for g = 0, "
        << scenarios.size() - 1
        << " do\n"
           "    if g > 0 then prg:assign_external(clingo.Function(\"scn\", {clingo.Number(g - 1)}), "
           "false) end\n"
           "    prg:assign_external(clingo.Function(\"scn\", {clingo.Number(g)}), true)\n"
           "    prg:solve()\n"
           "  end\n"
           "end\n"
           "#end.\n";
  }
  return out.str();
}

std::string interventionKey(const std::vector<Intervention>& dos) {
  std::vector<std::string> keys;
  for (const auto& d : dos) keys.push_back(toString(d.atom));
  std::sort(keys.begin(), keys.end());
  std::string k;
  for (const auto& s : keys) k += s + ";";
  return k;
}

}  // namespace asp_detail

std::string AspBackend::translate(const Program& program) const {
  std::string minimise;
  if (program.hasConsistencyRestoringRules()) minimise = "#minimize{ 1,WC,WT : appl(WC,WT) }.\n";
  return asp_detail::translateBase(program) + minimise + "#show val/2. #show sel/2. #show pra/3.\n";
}

}  // namespace plog
}  // namespace krr
