/**
 * @file asp_backend.cpp
 * @brief P-log -> ASP translation and the P-log measure of clingo's answer sets.
 *
 * Naming inside the generated program: every P-log variable X becomes VX (so that the
 * translation's own variables, all starting with W, never clash with it); every attribute atom
 * a(t) = y becomes val(a(t), y), so the P-log names only ever appear as function symbols and
 * constants inside the translation's own predicates (sort/2, val/2, sel/2, poss/3, npos/3,
 * pra/3, chosen/4, empty/2, intervene/1, q/1, ev/1 ...) and cannot clash with them. Only
 * chosen/4, empty/2, pra/3, q/1 and ev/1 are shown, to keep clingo's output small.
 */
#include "krr_core/plog/asp_backend.h"

#include "krr_core/plog/arith.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/plog/parser.h"

namespace krr {
namespace plog {

namespace {

/// Slack on sums of assigned probabilities (they are decimal fractions read as doubles).
constexpr double kSumTolerance = 1e-9;

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

std::string where(const SourceLocation& loc) {
  return loc.file.empty() ? std::string("<program>") : loc.str();
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
  switch (op) {
    case CompareOp::Eq: return "=";
    case CompareOp::Ne: return "!=";
    case CompareOp::Lt: return "<";
    case CompareOp::Le: return "<=";
    case CompareOp::Gt: return ">";
    case CompareOp::Ge: return ">=";
  }
  return "=";
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

const AttributeDecl& attributeOf(const Program& program, const AttributeTerm& a) {
  const AttributeDecl* d = program.findAttribute(a.name);
  if (d == nullptr) {
    throw UnknownSymbolError(where(a.loc) + ": AspBackend: undeclared attribute '" + a.name + "'");
  }
  return *d;
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

/// What one answer of a clingo run is: a conjunction given observations (same interventions
/// for the whole run).
struct QuerySpec {
  std::vector<Literal> formula;
  std::vector<Observation> observations;
  std::string text;  ///< for error messages
};

std::string translateBase(const Program& program) {
  std::ostringstream out;
  int fresh = 0;
  out << "% P-log program translated to ASP by krr::plog::AspBackend\n";
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
  out << "% an attribute term has at most one value\n";
  out << ":- val(WA,WY1), val(WA,WY2), WY1 != WY2.\n";

  out << "% rules\n";
  for (const auto& r : program.rules) {
    out << kAspSourceMarker << where(r.loc) << "\n";
    BodyBuilder b(program, r.variable_sorts, fresh);
    std::string head;
    if (r.head) {
      head = aspVal(*r.head);
      b.attr(r.head->attr);
      b.term(r.head->value);
      // Arithmetic in the head (next = C+1): ground instances whose value falls outside the
      // sort are ill-typed and not part of the ground program, as in P-log's grounding.
      const AttributeDecl& decl = attributeOf(program, r.head->attr);
      auto arithmetic = [](const Term& t) {
        return t.kind == Term::Kind::Binary || t.kind == Term::Kind::Negate;
      };
      for (std::size_t k = 0; k < r.head->attr.args.size() && k < decl.arg_sorts.size(); ++k) {
        if (arithmetic(r.head->attr.args[k]) && !decl.arg_sorts[k].empty()) {
          b.raw("sort(" + aspName(decl.arg_sorts[k], decl.loc) + "," +
                aspTerm(r.head->attr.args[k]) + ")");
        }
      }
      if (arithmetic(r.head->value)) {
        b.raw("sort(" + aspName(decl.range_sort, decl.loc) + "," + aspTerm(r.head->value) + ")");
      }
    }
    b.literals(r.body);
    out << ruleText(head, b.str());
  }

  out << "% random selections: sel(rule, attribute term), poss(rule, attribute term, value)\n";
  for (std::size_t i = 0; i < program.random_rules.size(); ++i) {
    const RandomRule& r = program.random_rules[i];
    out << kAspSourceMarker << where(r.loc) << "\n";
    const AttributeDecl& decl = attributeOf(program, r.attr);
    const std::string a = aspAttr(r.attr), idx = std::to_string(i);
    {
      BodyBuilder b(program, r.variable_sorts, fresh);
      b.attr(r.attr);
      b.literals(r.body);
      b.raw("not intervene(" + a + ")");
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
  out << "% chosen(rule, attribute term, value, number of possible values); empty ranges\n";
  out << "npos(WI,WA,WN) :- sel(WI,WA), WN = #count{ WY : poss(WI,WA,WY) }.\n";
  out << "chosen(WI,WA,WY,WN) :- sel(WI,WA), val(WA,WY), npos(WI,WA,WN).\n";
  out << "empty(WI,WA) :- npos(WI,WA,0).\n";

  out << "% pr-atoms: pra(pr-atom, attribute term, value) when it applies\n";
  for (std::size_t j = 0; j < program.pr_atoms.size(); ++j) {
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

  out << "% interventions and observations of the program\n";
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
  out << kAspSourceMarker << "<translation>\n";
  out << "#defined intervene/1. #defined pobs/1. #defined pra/3. #defined val/2.\n";
  out << "#defined sel/2. #defined poss/3.\n";
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

std::string modelText(const AspModel& model) {
  std::string s;
  for (const auto& a : model) s += a + " ";
  return s;
}

/// An integer argument of a bookkeeping atom (the model is only printed on error).
long long parseIndex(const std::string& s, const AspModel& model) {
  char* end = nullptr;
  long long v = std::strtoll(s.c_str(), &end, 10);
  if (end == s.c_str() || *end != '\0') {
    throw Error("AspBackend: unexpected atom argument '" + s + "' in clingo answer set: " +
                modelText(model));
  }
  return v;
}

/// Numerators and denominators of the specs of one clingo run.
struct GroupResult {
  std::vector<double> num, den;
  std::vector<std::string> error;  ///< incoherence met in a world of the query's evidence
  std::vector<std::size_t> worlds;  ///< per scenario
  std::vector<std::size_t> scenario;  ///< per spec
};

/// P-log measure of one answer set; sets holds_q / holds_ev per spec and the scenario
/// (scn(g) atom, 0 when absent) the answer set belongs to.
/// @throws IncoherentError when the world breaks a P-log coherence condition.
double worldMeasure(const Program& program, const AspModel& model, std::vector<char>& holds_q,
                    std::vector<char>& holds_ev, long long& scenario) {
  struct Selected {
    long long rule = -1;
    long long npos = -1;
    std::string value;
    std::map<std::string, std::pair<long long, double>> assigned;  // value -> (pr-atom, v)
  };
  std::map<std::string, Selected> sel;
  std::fill(holds_q.begin(), holds_q.end(), 0);
  std::fill(holds_ev.begin(), holds_ev.end(), 0);
  scenario = 0;
  auto twoRules = [&program](const std::string& attr, long long r1, long long r2) {
    throw IncoherentError(
        "AspBackend: two random selection rules (" +
        where(program.random_rules.at(static_cast<std::size_t>(r1)).loc) + " and " +
        where(program.random_rules.at(static_cast<std::size_t>(r2)).loc) + ") apply to " +
        attr + " in one possible world");
  };
  auto bad = [&](const std::string& atom) {
    throw Error("AspBackend: unexpected atom '" + atom + "' in clingo answer set: " +
                modelText(model));
  };
  for (const auto& text : model) {
    AspAtom a = parseAspAtom(text);
    if (a.name == "q" || a.name == "ev") {
      if (a.args.size() != 1) bad(text);
      long long k = parseIndex(a.args[0], model);
      auto& v = a.name == "q" ? holds_q : holds_ev;
      if (k < 0 || k >= static_cast<long long>(v.size())) bad(text);
      v[static_cast<std::size_t>(k)] = 1;
    } else if (a.name == "scn") {
      if (a.args.size() != 1) bad(text);
      scenario = parseIndex(a.args[0], model);
    } else if (a.name == "chosen") {
      if (a.args.size() != 4) bad(text);
      const long long r = parseIndex(a.args[0], model);
      if (r < 0 || r >= static_cast<long long>(program.random_rules.size())) bad(text);
      Selected& s = sel[a.args[1]];
      if (s.rule >= 0 && s.rule != r) twoRules(a.args[1], s.rule, r);
      s.rule = r;
      s.value = a.args[2];
      s.npos = parseIndex(a.args[3], model);
    } else if (a.name == "empty") {
      if (a.args.size() != 2) bad(text);
      const long long r = parseIndex(a.args[0], model);
      if (r < 0 || r >= static_cast<long long>(program.random_rules.size())) bad(text);
      throw IncoherentError("AspBackend: the dynamic range of " + a.args[1] +
                            " (random selection at " +
                            where(program.random_rules[static_cast<std::size_t>(r)].loc) +
                            ") is empty in a possible world");
    } else if (a.name == "pra") {
      if (a.args.size() != 3) bad(text);
      long long j = parseIndex(a.args[0], model);
      if (j < 0 || j >= static_cast<long long>(program.pr_atoms.size())) bad(text);
      const PrAtom& p = program.pr_atoms[static_cast<std::size_t>(j)];
      Selected& s = sel[a.args[1]];
      auto it = s.assigned.find(a.args[2]);
      if (it != s.assigned.end() && it->second.first != j &&
          std::fabs(it->second.second - p.probability) > 1e-12) {
        const PrAtom& p2 = program.pr_atoms.at(static_cast<std::size_t>(it->second.first));
        throw IncoherentError("AspBackend: two pr-atoms (" + where(p2.loc) + " and " +
                              where(p.loc) + ") assign different probabilities (" +
                              p2.probability_text + " and " + p.probability_text + ") to " +
                              a.args[1] + "=" + a.args[2] + " in one possible world");
      }
      s.assigned[a.args[2]] = {j, p.probability};
    } else {
      bad(text);
    }
  }
  double mu = 1.0;
  for (const auto& [attr, s] : sel) {
    if (s.rule < 0 || s.npos <= 0) {
      throw Error("AspBackend: incomplete bookkeeping for " + attr + " in answer set: " +
                  modelText(model));
    }
    double alpha = 0.0;
    for (const auto& [value, pv] : s.assigned) {
      if (pv.second < 0.0 || pv.second > 1.0) {
        throw IncoherentError(where(program.pr_atoms[static_cast<std::size_t>(pv.first)].loc) +
                              ": probability " + std::to_string(pv.second) +
                              " is outside [0, 1]");
      }
      alpha += pv.second;
    }
    if (alpha > 1.0 + kSumTolerance) {
      std::string list;
      for (const auto& [value, pv] : s.assigned) {
        list += " " + attr + "=" + value + ":" +
                program.pr_atoms[static_cast<std::size_t>(pv.first)].probability_text + " (" +
                where(program.pr_atoms[static_cast<std::size_t>(pv.first)].loc) + ")";
      }
      throw IncoherentError("AspBackend: the probabilities assigned to " + attr +
                            " sum to " + std::to_string(alpha) + " > 1 in a possible world:" +
                            list);
    }
    auto it = s.assigned.find(s.value);
    if (it != s.assigned.end()) {
      mu *= it->second.second;
    } else {
      long long beta = s.npos - static_cast<long long>(s.assigned.size());
      if (beta <= 0) {
        throw Error("AspBackend: inconsistent bookkeeping for " + attr + " in answer set: " +
                    modelText(model));
      }
      double rest = 1.0 - alpha;
      if (rest < kSumTolerance) rest = 0.0;
      mu *= rest / static_cast<double>(beta);
    }
  }
  return mu;
}

}  // namespace

AspBackend::AspBackend(AspOptions options) : options_(std::move(options)) {}

std::string AspBackend::translate(const Program& program) const {
  return translateBase(program) + "#show val/2. #show sel/2. #show pra/3.\n";
}

namespace {

/// One clingo run answering specs under their scenarios' interventions.
GroupResult runScenarios(const Program& program,
                         const std::vector<std::vector<Intervention>>& scenarios,
                         const std::vector<QuerySpec>& specs,
                         const std::vector<std::size_t>& spec_scenario, const AspOptions& options,
                         AspStats& stats) {
  const std::string text =
      translateBase(program) + translateScenarios(program, scenarios, specs);
  const auto t0 = std::chrono::steady_clock::now();
  ClingoResult res = runClingo(text, options);
  stats.clingo_seconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ++stats.clingo_runs;
  stats.worlds += res.models.size();
  GroupResult g;
  g.num.assign(specs.size(), 0.0);
  g.den.assign(specs.size(), 0.0);
  g.worlds.assign(scenarios.size(), 0);
  g.scenario = spec_scenario;
  g.error.assign(specs.size(), std::string());
  std::vector<char> hq(specs.size()), he(specs.size());
  for (const auto& m : res.models) {
    double mu = 0.0;
    long long scn = 0;
    try {
      mu = worldMeasure(program, m, hq, he, scn);
    } catch (const IncoherentError& e) {
      // The world is incoherent: an error for the queries of its scenario whose evidence it
      // satisfies only (the others exclude it, exactly as if their evidence were constraints).
      long long world_scn = 0;
      for (const auto& text : m) {
        AspAtom a = parseAspAtom(text);
        if (a.name == "scn" && a.args.size() == 1) world_scn = parseIndex(a.args[0], m);
      }
      for (const auto& text : m) {
        AspAtom a = parseAspAtom(text);
        if (a.name != "ev" || a.args.size() != 1) continue;
        const auto k = static_cast<std::size_t>(parseIndex(a.args[0], m));
        if (k < specs.size() && static_cast<long long>(spec_scenario[k]) == world_scn &&
            g.error[k].empty()) {
          g.error[k] = e.what();
        }
      }
      continue;
    }
    if (scn < 0 || scn >= static_cast<long long>(scenarios.size())) {
      throw Error("AspBackend: answer set of unknown scenario " + std::to_string(scn));
    }
    ++g.worlds[static_cast<std::size_t>(scn)];
    for (std::size_t k = 0; k < specs.size(); ++k) {
      if (!he[k] || static_cast<long long>(spec_scenario[k]) != scn) continue;
      g.den[k] += mu;
      if (hq[k]) g.num[k] += mu;
    }
  }
  return g;
}

GroupResult runGroup(const Program& program, const std::vector<Intervention>& dos,
                     const std::vector<QuerySpec>& specs, const AspOptions& options,
                     AspStats& stats) {
  return runScenarios(program, {dos}, specs, std::vector<std::size_t>(specs.size(), 0), options,
                      stats);
}

double ratio(const GroupResult& g, std::size_t k, const std::string& text) {
  if (!g.error[k].empty()) throw IncoherentError(g.error[k]);
  if (g.worlds[g.scenario[k]] == 0) {
    throw IncoherentError("AspBackend: the program with the interventions of query '" + text +
                          "' has no possible world");
  }
  if (!(g.den[k] > 0.0)) {
    throw IncoherentError("AspBackend: the evidence of query '" + text +
                          "' has probability 0 (no possible world of non-zero measure "
                          "satisfies it)");
  }
  double p = g.num[k] / g.den[k];
  return std::min(1.0, std::max(0.0, p));
}

}  // namespace

double AspBackend::probability(const Program& program, const Query& query) {
  return probabilities(program, {query}).at(0);
}

std::vector<double> AspBackend::probabilities(const Program& program,
                                              const std::vector<Query>& queries,
                                              std::vector<std::string>* incoherence_errors) {
  std::vector<double> out(queries.size(), 0.0);
  if (incoherence_errors) incoherence_errors->assign(queries.size(), std::string());
  if (queries.empty()) return out;
  std::map<std::string, std::size_t> scenario_of_key;
  std::vector<std::vector<Intervention>> scenarios;
  std::vector<std::size_t> query_scenario(queries.size());
  for (std::size_t i = 0; i < queries.size(); ++i) {
    auto [it, added] =
        scenario_of_key.emplace(interventionKey(queries[i].interventions), scenarios.size());
    if (added) scenarios.push_back(queries[i].interventions);
    query_scenario[i] = it->second;
  }
  std::vector<QuerySpec> specs;
  for (const Query& q : queries) {
    specs.push_back({q.formula, q.observations, q.text.empty() ? toString(q) : q.text});
  }
  auto answer = [&](const GroupResult& g, std::size_t k, std::size_t i) {
    if (incoherence_errors == nullptr) {
      out[i] = ratio(g, k, specs[k].text);
      return;
    }
    try {
      out[i] = ratio(g, k, specs[k].text);
    } catch (const IncoherentError& e) {
      out[i] = std::numeric_limits<double>::quiet_NaN();
      (*incoherence_errors)[i] = e.what();
    }
  };
  if (scenarios.size() == 1 || (options_.multi_shot && !multi_shot_failed_)) {
    try {
      GroupResult g =
          runScenarios(program, scenarios, specs, query_scenario, options_, stats_);
      for (std::size_t i = 0; i < queries.size(); ++i) answer(g, i, i);
      return out;
    } catch (const IncoherentError&) {
      throw;
    } catch (const Error& e) {
      // clingo without Lua support: answer scenario by scenario from now on.
      const std::string what = e.what();
      if (scenarios.size() == 1 ||
          (what.find("lua") == std::string::npos && what.find("script") == std::string::npos)) {
        throw;
      }
      multi_shot_failed_ = true;
    }
  }
  for (std::size_t g = 0; g < scenarios.size(); ++g) {
    std::vector<QuerySpec> group_specs;
    std::vector<std::size_t> members;
    for (std::size_t i = 0; i < queries.size(); ++i) {
      if (query_scenario[i] != g) continue;
      members.push_back(i);
      group_specs.push_back(specs[i]);
    }
    GroupResult r = runGroup(program, scenarios[g], group_specs, options_, stats_);
    for (std::size_t k = 0; k < members.size(); ++k) answer(r, k, members[k]);
  }
  return out;
}

std::vector<double> AspBackend::answerQueries(const Program& program) {
  return probabilities(program, program.queries);
}

std::vector<std::pair<std::string, double>> AspBackend::distribution(
    const Program& program, const AttributeTerm& attribute,
    const std::vector<Observation>& observations, const std::vector<Intervention>& interventions) {
  const AttributeDecl& decl = attributeOf(program, attribute);
  for (const auto& t : attribute.args) {
    if (!t.isGround()) {
      throw Error(where(attribute.loc) + ": AspBackend: distribution of '" + toString(attribute) +
                  "' needs a ground attribute term");
    }
  }
  const SortDecl* range = program.findSort(decl.range_sort);
  if (range == nullptr) {
    throw UnknownSymbolError(where(decl.loc) + ": AspBackend: undeclared sort '" +
                             decl.range_sort + "' of attribute '" + decl.name + "'");
  }
  std::vector<QuerySpec> specs;
  for (const auto& v : range->values) {
    Literal l;
    l.kind = Literal::Kind::Atom;
    l.atom.attr = attribute;
    l.atom.value = v;
    l.loc = attribute.loc;
    specs.push_back({{l}, observations, toString(attribute) + "=" + toString(v)});
  }
  std::vector<std::pair<std::string, double>> out;
  if (specs.empty()) return out;
  GroupResult g = runGroup(program, interventions, specs, options_, stats_);
  for (std::size_t k = 0; k < specs.size(); ++k) {
    out.emplace_back(toString(range->values[k]), ratio(g, k, specs[k].text));
  }
  return out;
}

double AspBackend::probability(const Program& program, const std::string& query) {
  return probability(program, parseQuery(program, query));
}

std::vector<ValueProb> AspBackend::distribution(const Program& program,
                                                const std::string& attribute_term,
                                                const std::string& evidence) {
  AttributeTerm attr = parseAttributeTerm(program, attribute_term);
  std::vector<Observation> obs;
  std::vector<Intervention> dos;
  if (evidence.find_first_not_of(" \t\r\n") != std::string::npos) {
    // The parser reads evidence as the condition of a query; the formula is a placeholder.
    const AttributeDecl& decl = attributeOf(program, attr);
    const SortDecl* range = program.findSort(decl.range_sort);
    if (range == nullptr || range->values.empty()) {
      throw UnknownSymbolError("AspBackend: attribute '" + decl.name + "' has no range values");
    }
    Query q = parseQuery(program, "?{" + toString(attr) + "=" + toString(range->values[0]) +
                                      "} | " + evidence, "<evidence>");
    obs = q.observations;
    dos = q.interventions;
  }
  std::vector<ValueProb> out;
  for (const auto& [value, p] : distribution(program, attr, obs, dos)) {
    if (p > 0.0) out.push_back({value, p});
  }
  return out;
}

std::vector<QueryAnswer> AspBackend::answerProgramQueries(const Program& program) {
  std::vector<double> p = probabilities(program, program.queries);
  std::vector<QueryAnswer> out;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Query& q = program.queries[i];
    out.push_back({q.text.empty() ? toString(q) : q.text, p[i]});
  }
  return out;
}

}  // namespace plog
}  // namespace krr
