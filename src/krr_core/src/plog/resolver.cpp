/**
 * @file resolver.cpp
 * @brief Resolution of raw P-log statements into a Program: attribute atoms vs comparisons,
 * booleans, sorts of variables, implicit declarations, obs/do tested in rule bodies, sorted
 * grounding of ill-sorted heads (ast.h describes the resolved form).
 */
#include "parser_syntax.h"

#include "krr_core/plog/arith.h"
#include "krr_core/plog/name_table.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <set>
#include <unordered_map>
#include <unordered_set>

#include "krr_core/common/errors.h"

namespace krr {
namespace plog {
namespace syntax {
namespace {

class Resolver {
 public:
  explicit Resolver(Program& p) : prog_(p) {}

  /// @brief Program::findAttribute in O(1): the resolver only appends declarations, so the
  /// index is extended with the new tail when the vector has grown (first declaration wins,
  /// as in the linear search). A linear search per literal made n implicit predicates cost n^2.
  /// Resolving one statement asks for the same name several times in a row: the last answer
  /// is kept (a hash lookup in a table of 10^5 names is a cache miss or two).
  const AttributeDecl* findAttr(const std::string& name) {
    indexNames(prog_.attributes, attr_index_, attr_decl_, attr_indexed_);
    // (names are only added, and the first declaration of a name keeps it: still valid)
    if (last_attr_ != kNone && last_attr_name_ == name)
      return &prog_.attributes[last_attr_];
    const int id = attr_index_.find(name);
    if (id < 0 || attr_decl_[static_cast<std::size_t>(id)] == kNone) return nullptr;
    last_attr_ = attr_decl_[static_cast<std::size_t>(id)];
    last_attr_name_ = name;
    return &prog_.attributes[last_attr_];
  }
  /// @brief Id of `name` in the attribute index, added (without a declaration) when absent:
  /// the statements' names are interned once, and the ids serve the later steps.
  int internAttrName(const std::string& name) {
    indexNames(prog_.attributes, attr_index_, attr_decl_, attr_indexed_);
    const int id = attr_index_.intern(name);
    if (static_cast<std::size_t>(id) == attr_decl_.size()) attr_decl_.push_back(kNone);
    return id;
  }
  bool declaredId(int id) const { return attr_decl_[static_cast<std::size_t>(id)] != kNone; }
  /// @brief The statement's head names attribute `id`: findAttr answers from its last-answer
  /// cache, without hashing the name again.
  void primeAttr(int id) {
    indexNames(prog_.attributes, attr_index_, attr_decl_, attr_indexed_);
    if (!declaredId(id)) return;
    last_attr_ = attr_decl_[static_cast<std::size_t>(id)];
    last_attr_name_ = attr_index_.name(id);
  }
  /// @brief The head's id of the k-th statement (as splitOverloadedPredicates interned it),
  /// -1 when not recorded.
  int headId(std::size_t k) const { return k < head_ids_.size() ? head_ids_[k] : -1; }

  /// @brief Hands the attribute index to the program (Program::attribute_names) so that the
  /// passes after parsing do not hash the names again: as it is when its ids are the
  /// declarations' positions, else made afresh from the declarations.
  void exportAttributeNames() {
    indexNames(prog_.attributes, attr_index_, attr_decl_, attr_indexed_);
    bool aligned = attr_index_.size() == prog_.attributes.size();
    for (std::size_t i = 0; aligned && i < attr_decl_.size(); ++i) aligned = attr_decl_[i] == i;
    if (aligned)
      prog_.attribute_names = std::make_shared<const AttributeNames>(std::move(attr_index_));
    else
      prog_.attribute_names = AttributeNames::make(prog_.attributes);
    attr_index_.clear();
    attr_decl_.clear();
    attr_indexed_ = 0;
    last_attr_ = kNone;
    head_ids_.clear();
  }

  /// @brief Program::findSort in O(1) (see findAttr).
  const SortDecl* findSortDecl(const std::string& name) {
    indexNames(prog_.sorts, sort_index_, sort_decl_, sort_indexed_);
    const int id = sort_index_.find(name);
    return id < 0 ? nullptr : &prog_.sorts[sort_decl_[static_cast<std::size_t>(id)]];
  }

  bool isAttributeTerm(const Term& t) {
    if (t.kind != Term::Kind::Symbol && t.kind != Term::Kind::Compound) return false;
    return findAttr(t.name) != nullptr;
  }

  AttributeTerm toAttr(const Term& t) {
    AttributeTerm a;
    a.name = t.name;
    a.args = t.args;
    a.loc = t.loc;
    const AttributeDecl* d = findAttr(t.name);
    if (!d) throw UnknownSymbolError(t.loc.str() + ": unknown attribute '" + t.name + "'");
    a.index = static_cast<int>(d - prog_.attributes.data());
    if (d->arg_sorts.size() != a.args.size())
      throw UnknownSymbolError(t.loc.str() + ": attribute '" + t.name + "' expects " +
                               std::to_string(d->arg_sorts.size()) + " argument(s), got " +
                               std::to_string(a.args.size()));
    for (size_t i = 0; i < a.args.size(); ++i) {
      checkValue(a.args[i], d->arg_sorts[i], [&]() {
        return "argument " + std::to_string(i + 1) + " of '" + t.name + "'";
      });
    }
    return a;
  }

  /// `what()` describes the position for the error message (built only when there is one).
  template <class What>
  void checkValue(const Term& v, const std::string& sort, const What& what_fn) {
    if (sort.empty()) return;
    if (v.kind != Term::Kind::Symbol && v.kind != Term::Kind::Integer &&
        v.kind != Term::Kind::Compound)
      return;
    if (!v.isGround()) return;
    const SortDecl* s = findSortDecl(sort);
    if (!s) throw UnknownSymbolError(v.loc.str() + ": unknown sort '" + sort + "'");
    if (last_sort_ == nullptr || last_sort_name_ != sort) {
      last_sort_ = &sort_cache_[sort];
      last_sort_name_ = sort;
    }
    auto& cache = *last_sort_;
    if (cache.size() != s->values.size()) {
      cache.clear();
      for (const auto& x : s->values) cache.insert(toString(x));
    }
    if (v.kind == Term::Kind::Symbol ? cache.count(v.name) > 0 : cache.count(toString(v)) > 0)
      return;
    const std::string what = what_fn();
    throw IllSortedValue(v.loc.str() + ": unknown value '" + toString(v) + "' for " + what +
                             " (not in sort " + sort + ")",
                         "value '" + toString(v) + "' for " + what + " is not in sort " + sort,
                         v.loc);
  }

  /// @brief A ground value outside the sort of its position (see ParseOptions::strict_sorts).
  struct IllSortedValue : UnknownSymbolError {
    IllSortedValue(const std::string& message, std::string what_value, SourceLocation where)
        : UnknownSymbolError(message), description(std::move(what_value)), loc(std::move(where)) {}
    std::string description;
    SourceLocation loc;
  };

  Atom makeAtom(const Term& attr_term, const Term& value) {
    Atom a;
    a.attr = toAttr(attr_term);
    a.value = value;
    a.loc = attr_term.loc;
    const AttributeDecl* d = findAttr(attr_term.name);
    checkValue(value, d->range_sort, [&]() { return "the value of '" + attr_term.name + "'"; });
    return a;
  }

  Term freshVar() { return Term::variable("_V" + std::to_string(fresh_++)); }

  /// @brief plog2.0 lets rule bodies test observations: `not obs(s, true, true)` holds when the
  /// program does not observe s = true. They are read as the hidden boolean attribute
  /// `obs(a(t), y, flag)` (untyped arguments), made true by one fact per observation.
  bool usesObsLiterals() {
    const AttributeDecl* d = findAttr("obs");
    return d && d->implicit && d->arg_sorts.size() == 3;
  }

  static bool rawUsesObs(const std::vector<RawLit>& body) {
    for (const auto& l : body)
      if (!l.has_op && l.lhs.kind == Term::Kind::Compound && l.lhs.name == "obs") return true;
    return false;
  }

  void declareObsAttribute(const std::vector<RawStmt>& stmts) {
    if (findAttr("obs")) return;
    for (const auto& s : stmts) {
      if (!rawUsesObs(s.body) && !rawUsesObs(s.r().range_body)) continue;
      AttributeDecl d;
      d.name = "obs";
      d.arg_sorts.assign(3, "");
      d.range_sort = "boolean";
      d.implicit = true;
      d.loc = s.loc;
      prog_.attributes.push_back(d);
      return;
    }
  }

  /// @brief `obs(a(t), y)` / `obs(a(t), y, true|false)` in a body as the atom
  /// obs(a(t), y, flag) = true, after checking a(t) and y against a's declaration.
  Atom obsAtom(const Term& t) {
    if (t.args.size() != 2 && t.args.size() != 3)
      throw ParseError(t.loc, "obs(a, y) or obs(a, y, true|false) expected in a rule body");
    const Term& a = t.args[0];
    if ((a.kind != Term::Kind::Symbol && a.kind != Term::Kind::Compound) ||
        !findAttr(a.name) || a.name == "obs")
      throw UnknownSymbolError(a.loc.str() + ": obs(...) needs an attribute term, got '" +
                               toString(a) + "'");
    makeAtom(a, t.args[1]);  // arity, argument sorts and value sort
    Term flag = t.args.size() == 3 ? t.args[2] : Term::symbol("true", t.loc);
    if (flag.kind != Term::Kind::Symbol || (flag.name != "true" && flag.name != "false"))
      throw ParseError(flag.loc, "expected 'true' or 'false' as third argument of obs");
    Atom o;
    o.attr.name = "obs";
    o.attr.args = {a, t.args[1], flag};
    o.attr.loc = t.loc;
    o.value = Term::symbol("true", t.loc);
    o.loc = t.loc;
    return o;
  }

  /// @brief plog2.0 programs test actions in rule bodies: `alarm :- do(A, f, true), not
  /// authorized(A, f).` Read as the hidden boolean attribute `do` with as many untyped
  /// arguments as the body uses, true for the argument tuples of the program's do statements
  /// (one fact each, doFact). The intervention itself is made as usual.
  void declareDoAttribute(const std::vector<RawStmt>& stmts) {
    if (findAttr("do")) return;
    for (const auto& s : stmts) {
      for (const auto* body : {&s.body, &s.r().range_body}) {
        for (const auto& l : *body) {
          if (l.has_op || l.lhs.kind != Term::Kind::Compound || l.lhs.name != "do") continue;
          AttributeDecl d;
          d.name = "do";
          d.arg_sorts.assign(l.lhs.args.size(), "");
          d.range_sort = "boolean";
          d.implicit = true;
          d.loc = l.loc;
          prog_.attributes.push_back(d);
          return;
        }
      }
    }
  }

  /// @brief The fact do(t1, ..., tn) for a do statement whose arguments match the arity that
  /// rule bodies test (none otherwise: no body can refer to it).
  void addDoFact(const std::vector<Term>& args, const SourceLocation& loc) {
    const AttributeDecl* d = findAttr("do");
    if (!d || !d->implicit || d->arg_sorts.size() != args.size()) return;
    Rule r;
    r.loc = loc;
    Atom h;
    h.attr.name = "do";
    h.attr.args = args;
    h.attr.loc = loc;
    h.value = Term::symbol("true", loc);
    h.loc = loc;
    r.head = h;
    prog_.rules.push_back(r);
  }

  /// @brief The fact obs(a(t), y, flag) that makes body tests of an observation true.
  Rule obsFact(const Observation& o) {
    Term a;
    a.kind = o.literal.atom.attr.args.empty() ? Term::Kind::Symbol : Term::Kind::Compound;
    a.name = o.literal.atom.attr.name;
    a.args = o.literal.atom.attr.args;
    a.loc = o.loc;
    Rule r;
    r.loc = o.loc;
    Atom h;
    h.attr.name = "obs";
    h.attr.args = {a, o.literal.atom.value, Term::symbol(o.truth ? "true" : "false", o.loc)};
    h.attr.loc = o.loc;
    h.value = Term::symbol("true", o.loc);
    h.loc = o.loc;
    r.head = h;
    return r;
  }

  /// @brief `p(t)` / `-p(t)` (a literal without an operator, not a body's obs test) as the
  /// atom p(t) = true / false.
  Atom predicateAtom(const RawLit& r) {
    const Term* t = &r.lhs;
    bool neg = false;
    if (t->kind == Term::Kind::Negate) {
      neg = true;
      t = &t->args[0];
    }
    if (t->kind != Term::Kind::Symbol && t->kind != Term::Kind::Compound)
      throw ParseError(r.loc, "expected a literal, got '" + toString(r.lhs) + "'");
    const AttributeDecl* d = findAttr(t->name);
    if (!d) throw UnknownSymbolError(t->loc.str() + ": unknown predicate '" + t->name + "'");
    if (d->range_sort != "boolean")
      throw ParseError(r.loc, "attribute '" + t->name + "' has range " + d->range_sort +
                                  " and needs a value: " + t->name + "=...");
    return makeAtom(*t, Term::symbol(neg ? "false" : "true", t->loc));
  }

  // Resolve one raw literal into zero or more literals (rewrites may add literals).
  void resolveLit(const RawLit& r, std::vector<Literal>& out) {
    Literal l;
    l.naf = r.naf;
    l.loc = r.loc;
    if (!r.has_op && r.lhs.kind == Term::Kind::Compound && r.lhs.name == "obs" &&
        usesObsLiterals()) {
      l.kind = Literal::Kind::Atom;
      l.atom = obsAtom(r.lhs);
      out.push_back(std::move(l));
      return;
    }
    if (!r.has_op) {
      l.kind = Literal::Kind::Atom;
      l.atom = predicateAtom(r);
      out.push_back(std::move(l));
      return;
    }
    bool la = isAttributeTerm(r.lhs), ra = isAttributeTerm(r.rhs());
    if (la && ra && (r.op == CompareOp::Eq || r.op == CompareOp::Ne)) {
      // a(t) = y where y is also a declared 0-ary attribute name: prefer the value reading.
      const AttributeDecl* d = findAttr(r.lhs.name);
      const SortDecl* s = findSortDecl(d->range_sort);
      bool is_value = false;
      if (s)
        for (const auto& x : s->values)
          if (x == r.rhs()) is_value = true;
      if (is_value) ra = false;
    }
    if ((la || ra) && r.naf && (la && ra))
      throw Error(r.loc.str() + ": 'not' before an equality of two attribute terms is not "
                                "supported; bind them to variables first");
    if (la && !ra && (r.op == CompareOp::Eq || r.op == CompareOp::Ne)) {
      l.kind = Literal::Kind::Atom;
      l.negated = r.op == CompareOp::Ne;
      l.atom = makeAtom(r.lhs, r.rhs());
      out.push_back(std::move(l));
      return;
    }
    if (ra && !la && (r.op == CompareOp::Eq || r.op == CompareOp::Ne)) {
      l.kind = Literal::Kind::Atom;
      l.negated = r.op == CompareOp::Ne;
      l.atom = makeAtom(r.rhs(), r.lhs);
      out.push_back(std::move(l));
      return;
    }
    if (la && ra && r.op == CompareOp::Eq && !r.naf) {
      Term v = freshVar();
      for (const Term* side : {&r.lhs, &r.rhs()}) {
        Literal a;
        a.kind = Literal::Kind::Atom;
        a.loc = r.loc;
        a.atom = makeAtom(*side, v);
        out.push_back(a);
      }
      return;
    }
    Term lhs = r.lhs, rhs = r.rhs();
    if (la || ra) {
      if (r.naf)
        throw Error(r.loc.str() + ": 'not' before a comparison of attribute terms is not "
                                  "supported; bind the attribute to a variable first");
      if (la) {
        Term v = freshVar();
        Literal a;
        a.kind = Literal::Kind::Atom;
        a.loc = r.loc;
        a.atom = makeAtom(r.lhs, v);
        out.push_back(a);
        lhs = v;
      }
      if (ra) {
        Term v = freshVar();
        Literal a;
        a.kind = Literal::Kind::Atom;
        a.loc = r.loc;
        a.atom = makeAtom(r.rhs(), v);
        out.push_back(a);
        rhs = v;
      }
    }
    checkArith(lhs);
    checkArith(rhs);
    l.kind = Literal::Kind::Comparison;
    l.op = r.op;
    l.lhs = lhs;
    l.rhs = rhs;
    out.push_back(std::move(l));
  }

  void checkArith(const Term& t) {
    if (t.kind == Term::Kind::Compound || t.kind == Term::Kind::Symbol) {
      if (findAttr(t.name) && t.kind == Term::Kind::Compound)
        throw Error(t.loc.str() + ": attribute term '" + toString(t) +
                    "' inside an arithmetic expression is not supported");
    }
    for (const auto& a : t.args) checkArith(a);
  }

  std::vector<Literal> resolveBody(const std::vector<RawLit>& raw) {
    std::vector<Literal> out;
    for (const auto& r : raw) resolveLit(r, out);
    return out;
  }

  Atom resolveHeadAtom(const RawLit& r, const char* what) {
    if (r.naf) throw ParseError(r.loc, std::string("'not' is not allowed in ") + what);
    const Term* h = &r.lhs;
    if (h->kind == Term::Kind::Negate) h = &h->args[0];
    if ((h->kind == Term::Kind::Symbol || h->kind == Term::Kind::Compound) &&
        !findAttr(h->name))
      throw UnknownSymbolError(h->loc.str() + ": undeclared attribute '" + h->name + "' in " +
                               what);
    // p(t) and -p(t) (a fact's head): the one atom resolveLit would make, without a literal
    if (!r.has_op && !(r.lhs.kind == Term::Kind::Compound && r.lhs.name == "obs"))
      return predicateAtom(r);
    std::vector<Literal> tmp;
    resolveLit(r, tmp);
    if (tmp.size() != 1 || tmp[0].kind != Literal::Kind::Atom || tmp[0].negated)
      throw ParseError(r.loc, std::string("expected an atom a(t)=y or p(t) as ") + what);
    return std::move(tmp[0].atom);
  }

  void typeTerm(const Term& t, const std::string& sort, VariableSorts& vs) {
    if (t.kind == Term::Kind::Variable && !sort.empty() && t.name != "_") vs.emplace(t.name, sort);
    if (t.kind == Term::Kind::Compound && !sort.empty())
      for (size_t i = 0; i < t.args.size(); ++i)
        if (!t.args[i].isGround())
          typeTerm(t.args[i], projectionSort(sort, t.name, t.args.size(), i), vs);
  }

  /// @brief Sort of the i-th argument of the records f(...) of `sort`, so that a variable
  /// nested in a value (`genotype_of(X) = g(g_a, Y)`) ranges over what can stand there. The
  /// sort is hidden (builtin: not exported; a re-parse derives it again).
  std::string projectionSort(const std::string& sort, const std::string& f, size_t arity,
                             size_t i) {
    const SortDecl* s = findSortDecl(sort);
    if (!s) return "";
    std::string name = "arg_" + sort + "_" + f + std::to_string(arity) + "_" + std::to_string(i);
    if (const SortDecl* old = findSortDecl(name)) return old->builtin ? name : "";
    SortDecl p;
    p.name = name;
    p.builtin = true;
    p.loc = s->loc;
    std::set<std::string> seen;
    for (const auto& v : s->values)
      if (v.kind == Term::Kind::Compound && v.name == f && v.args.size() == arity &&
          seen.insert(toString(v.args[i])).second)
        p.values.push_back(v.args[i]);
    if (p.values.empty()) return "";
    prog_.sorts.push_back(p);
    return name;
  }

  void typeAtom(const Atom& a, VariableSorts& vs) {
    const AttributeDecl* d = findAttr(a.attr.name);
    if (!d) return;
    for (size_t i = 0; i < a.attr.args.size() && i < d->arg_sorts.size(); ++i)
      typeTerm(a.attr.args[i], d->arg_sorts[i], vs);
    typeTerm(a.value, d->range_sort, vs);
  }

  void typeBody(const std::vector<Literal>& b, VariableSorts& vs) {
    for (const auto& l : b)
      if (l.kind == Literal::Kind::Atom) typeAtom(l.atom, vs);
  }

  void typeDomains(const std::vector<std::string>& vars, VariableSorts& vs) {
    for (const auto& v : vars) {
      std::string s = prog_.domainSortOf(v);
      if (!s.empty()) vs[v] = s;
    }
  }

  static void varsOfBody(const std::vector<Literal>& b, std::vector<std::string>& out) {
    for (const auto& l : b) {
      if (l.kind == Literal::Kind::Atom) {
        for (const auto& a : l.atom.attr.args) a.collectVariables(out);
        l.atom.value.collectVariables(out);
      } else {
        l.lhs.collectVariables(out);
        l.rhs.collectVariables(out);
      }
    }
  }
  static void varsOfAtom(const Atom& a, std::vector<std::string>& out) {
    for (const auto& x : a.attr.args) x.collectVariables(out);
    a.value.collectVariables(out);
  }

  void requireGround(const Atom& a, const char* what) {
    if (!a.value.isGround()) throw ParseError(a.loc, std::string(what) + " must be ground");
    for (const auto& x : a.attr.args)
      if (!x.isGround()) throw ParseError(a.loc, std::string(what) + " must be ground");
  }

  Observation resolveObs(const RawObs& o) {
    Observation r;
    r.loc = o.loc;
    r.truth = o.truth;
    std::vector<Literal> tmp;
    resolveLit(o.lit, tmp);
    if (tmp.size() != 1 || tmp[0].kind != Literal::Kind::Atom || tmp[0].naf)
      throw ParseError(o.loc, "obs(...) needs an attribute atom a(t)=y or p(t)");
    r.literal = tmp[0];
    if (r.literal.negated) {
      r.literal.negated = false;
      r.truth = !r.truth;
    }
    requireGround(r.literal.atom, "observed atom");
    return r;
  }

  Intervention resolveDo(const RawLit& l) {
    Intervention d;
    d.loc = l.loc;
    d.atom = resolveHeadAtom(l, "do(...)");
    requireGround(d.atom, "do(...) atom");
    return d;
  }

  // A query/obs/do literal that did not resolve to an attribute atom names an unknown attribute.
  void requireKnownAttribute(const RawLit& r) {
    const Term* t = &r.lhs;
    if (t->kind == Term::Kind::Negate) t = &t->args[0];
    if ((t->kind == Term::Kind::Symbol || t->kind == Term::Kind::Compound) &&
        !findAttr(t->name))
      throw UnknownSymbolError(t->loc.str() + ": unknown attribute '" + t->name + "'");
  }

  Query resolveQuery(const RawQuery& rq) {
    if (usesObsLiterals() && !rq.obs.empty())
      throw Error(rq.loc.str() + ": a query that observes is not supported for a program whose "
                                 "rules test obs(...); write the observation as a fact");
    for (const auto& l : rq.formula) requireKnownAttribute(l);
    for (const auto& o : rq.obs) requireKnownAttribute(o.lit);
    for (const auto& d : rq.dos) requireKnownAttribute(d);
    Query q;
    q.loc = rq.loc;
    q.text = rq.text;
    q.formula = resolveBody(rq.formula);
    for (const auto& l : q.formula) {
      if (l.kind != Literal::Kind::Atom)
        throw ParseError(l.loc, "query formula must consist of attribute atoms");
      requireGround(l.atom, "query atom");
    }
    for (const auto& o : rq.obs) q.observations.push_back(resolveObs(o));
    for (const auto& d : rq.dos) q.interventions.push_back(resolveDo(d));
    return q;
  }

  // Declare implicit predicates for undeclared heads of rules/facts.
  void declareImplicit(const std::vector<RawStmt>& stmts) {
    // plog2.0 requires every attribute to be declared in its `attributes` section
    if (plog2_) return;
    if (guard_ && !stmts.empty())
      guard_->check("resolving the statements", stmts.front().loc,
                    stmts.size() * (sizeof(AttributeDecl) + 2 * sizeof(std::size_t)));
    prog_.attributes.reserve(prog_.attributes.size() + stmts.size());
    attr_index_.reserve(prog_.attributes.size() + stmts.size());
    attr_decl_.reserve(prog_.attributes.size() + stmts.size());
    for (std::size_t k = 0; k < stmts.size(); ++k) {
      const RawStmt& s = stmts[k];
      if (s.kind != RawStmt::Kind::Rule || !s.head) continue;
      const RawLit& h = *s.head;
      if (h.has_op && !(h.op == CompareOp::Eq && h.rhs().kind == Term::Kind::Symbol &&
                        (h.rhs().name == "true" || h.rhs().name == "false")))
        continue;
      const Term* t = &h.lhs;
      if (t->kind == Term::Kind::Negate) t = &t->args[0];
      if (t->kind != Term::Kind::Symbol && t->kind != Term::Kind::Compound) continue;
      // no lookup when splitOverloadedPredicates interned the head (the same name here)
      indexNames(prog_.attributes, attr_index_, attr_decl_, attr_indexed_);
      const int id = headId(k) >= 0 ? headId(k) : internAttrName(t->name);
      if (declaredId(id)) continue;
      attr_decl_[static_cast<std::size_t>(id)] = prog_.attributes.size();
      AttributeDecl d;
      d.name = t->name;
      d.arg_sorts.assign(t->args.size(), "");
      d.range_sort = "boolean";
      d.implicit = true;
      d.loc = t->loc;
      prog_.attributes.push_back(std::move(d));
      attr_indexed_ = prog_.attributes.size();
    }
  }

  /// @brief Give each classic range-only attribute `a : s.` that the statements use with
  /// arguments (`random(place(B))`) that arity; an argument's sort is the #domain sort of a
  /// variable written there, untyped otherwise. The classic solver reads its examples so.
  void inferClassicArity(const std::vector<RawStmt>& stmts) {
    if (range_only_.empty()) return;
    std::map<std::string, std::vector<std::string>> seen;  // name -> argument sorts
    std::function<void(const Term&)> visit = [&](const Term& t) {
      if (t.kind == Term::Kind::Compound && range_only_.count(t.name)) {
        auto it = seen.find(t.name);
        if (it == seen.end()) it = seen.emplace(t.name, std::vector<std::string>(t.args.size())).first;
        if (it->second.size() == t.args.size())
          for (size_t i = 0; i < t.args.size(); ++i)
            if (it->second[i].empty() && t.args[i].kind == Term::Kind::Variable)
              it->second[i] = prog_.domainSortOf(t.args[i].name);
      }
      for (const auto& a : t.args) visit(a);
    };
    auto lit = [&](const RawLit& l) {
      visit(l.lhs);
      if (l.has_op) visit(l.rhs());
    };
    for (const auto& s : stmts) {
      if (s.head) lit(*s.head);
      for (const auto& l : s.body) lit(l);
      if (!s.rare) continue;
      const RawStmtRare& x = s.r();
      for (const auto& l : x.range_body) lit(l);
      lit(x.pr_atom);
      lit(x.obs.lit);
      lit(x.do_lit);
      for (const auto& l : x.query.formula) lit(l);
      for (const auto& o : x.query.obs) lit(o.lit);
      for (const auto& l : x.query.dos) lit(l);
    }
    for (auto& a : prog_.attributes)
      if (a.arg_sorts.empty() && seen.count(a.name)) a.arg_sorts = seen[a.name];
  }

  /// @brief Classic programs overload undeclared predicate names by arity, as ASP does
  /// (Poker: pair(K, S) and pair(K)). One attribute has one arity here, so every arity but the
  /// first one used is renamed `name_<arity>` (a free name) throughout the statements.
  /// Returns false (and leaves `out` alone) when no predicate is overloaded: the statements are
  /// then used as they are, without a copy.
  bool splitOverloadedPredicates(const std::vector<RawStmt>& stmts, std::vector<RawStmt>& out) {
    if (plog2_) return false;
    // name -> its arities in first-use order: the first one per name, the others (rare) in
    // a map (by the names' ids in the attribute index, where every name is interned once and
    // the heads' ids are kept for the later steps; the renaming below does not depend on the
    // order of the names)
    if (guard_ && !stmts.empty())
      guard_->check("resolving the statements", stmts.front().loc,
                    (stmts.size() + 16) * (sizeof(std::string) + 32));
    // (at most a head and a few body names per statement)
    attr_index_.reserve(prog_.attributes.size() + stmts.size() + 16);
    attr_decl_.reserve(prog_.attributes.size() + stmts.size() + 16);
    head_ids_.assign(stmts.size(), -1);
    std::vector<size_t> first_arity;  // by id; kNone: not used as an undeclared predicate
    std::map<int, std::vector<size_t>> more_arities;
    auto top = [](const RawLit& l) -> const Term* {
      const Term* t = &l.lhs;
      if (t->kind == Term::Kind::Negate) t = &t->args[0];
      return (t->kind == Term::Kind::Symbol || t->kind == Term::Kind::Compound) ? t : nullptr;
    };
    auto note = [&](const RawLit& l) -> int {
      const Term* t = top(l);
      if (!t) return -1;
      const int id = internAttrName(t->name);
      if (declaredId(id) || t->name == "obs" || t->name == "do") return id;
      const size_t i = static_cast<size_t>(id);
      if (first_arity.size() <= i) first_arity.resize(i + 1, kNone);
      if (first_arity[i] == kNone) {
        first_arity[i] = t->args.size();
        return id;
      }
      if (first_arity[i] == t->args.size()) return id;
      auto& v = more_arities[id];
      if (std::find(v.begin(), v.end(), t->args.size()) == v.end()) v.push_back(t->args.size());
      return id;
    };
    constexpr size_t kAhead = 8;  // statements between a head's prefetch and its intern
    for (size_t k = 0; k < stmts.size(); ++k) {
      if (k + kAhead < stmts.size() && stmts[k + kAhead].head)
        if (const Term* t = top(*stmts[k + kAhead].head)) attr_index_.prefetch(t->name);
      const RawStmt& s = stmts[k];
      if (s.kind == RawStmt::Kind::Rule && s.head) head_ids_[k] = note(*s.head);
      for (const auto& l : s.body) note(l);
    }
    std::map<std::pair<std::string, size_t>, std::string> rename;
    for (const auto& a : more_arities) {
      const std::string name = attr_index_.name(a.first);
      for (size_t arity : a.second) {
        std::string n = name + "_" + std::to_string(arity);
        // (the index holds the declared names and every name the statements use)
        while (findAttr(n) || attr_index_.find(n) >= 0) n += "_";
        rename[{name, arity}] = n;
      }
    }
    if (rename.empty()) return false;
    head_ids_.clear();  // renamed heads are other names: looked up again
    out = stmts;
    auto fix = [&](RawLit& l) {
      Term* t = &l.lhs;
      if (t->kind == Term::Kind::Negate) t = &t->args[0];
      if (t->kind != Term::Kind::Symbol && t->kind != Term::Kind::Compound) return;
      auto it = rename.find({t->name, t->args.size()});
      if (it != rename.end()) t->name = it->second;
    };
    for (auto& s : out) {
      if (s.head) fix(*s.head);
      for (auto& l : s.body) fix(l);
      if (!s.rare) continue;
      RawStmtRare& x = s.w();
      for (auto& l : x.range_body) fix(l);
      fix(x.pr_atom);
      fix(x.obs.lit);
      for (auto& l : x.query.formula) fix(l);
      for (auto& o : x.query.obs) fix(o.lit);
    }
    return true;
  }

  /// @brief Resolve the raw statements into prog_: implicit declarations first (they must be
  /// known before any statement is typed), then each statement in order.
  void resolveAll(const std::vector<RawStmt>& raw) {
    std::vector<RawStmt> renamed;
    const std::vector<RawStmt>& stmts = splitOverloadedPredicates(raw, renamed) ? renamed : raw;
    inferClassicArity(stmts);
    declareObsAttribute(stmts);
    declareDoAttribute(stmts);
    declareImplicit(stmts);
    reserveStatements(stmts);
    for (const auto& s : stmts) {
      if (guard_) guard_->tick("resolving the statements", s.loc);
      switch (s.kind) {
        case RawStmt::Kind::Rule:
          resolveRule(s, static_cast<std::size_t>(&s - stmts.data()));
          break;
        case RawStmt::Kind::Random:
          resolveRandom(s);
          break;
        case RawStmt::Kind::Pr:
          resolvePr(s);
          break;
        case RawStmt::Kind::Obs:
          requireKnownAttribute(s.r().obs.lit);
          prog_.observations.push_back(resolveObs(s.r().obs));
          if (usesObsLiterals()) prog_.rules.push_back(obsFact(prog_.observations.back()));
          break;
        case RawStmt::Kind::Do:
          resolveDoStatement(s);
          break;
        case RawStmt::Kind::Query:
          prog_.queries.push_back(resolveQuery(s.r().query));
          break;
      }
    }
    exportAttributeNames();
  }

  /// @brief Room for the statements' rules, selection rules and pr-atoms (charged to the
  /// memory budget first), so that a million facts do not reallocate the rules.
  void reserveStatements(const std::vector<RawStmt>& stmts) {
    std::size_t nr = 0, nrr = 0, np = 0;
    for (const auto& s : stmts) {
      nr += s.kind == RawStmt::Kind::Rule || s.kind == RawStmt::Kind::Obs ||
            s.kind == RawStmt::Kind::Do;
      nrr += s.kind == RawStmt::Kind::Random;
      np += s.kind == RawStmt::Kind::Pr;
    }
    if (guard_ && !stmts.empty())
      guard_->check("resolving the statements", stmts.front().loc,
                    nr * sizeof(Rule) + nrr * sizeof(RandomRule) + np * sizeof(PrAtom));
    prog_.rules.reserve(prog_.rules.size() + nr);
    prog_.random_rules.reserve(prog_.random_rules.size() + nrr);
    prog_.pr_atoms.reserve(prog_.pr_atoms.size() + np);
  }

  /// @brief A rule, fact or constraint (statement number k); one whose head is outside its
  /// sort is left out with a warning (unless strict_sorts_).
  void resolveRule(const RawStmt& s, std::size_t k) {
    Rule r;
    r.loc = s.loc;
    r.consistency_restoring = s.consistency_restoring;
    if (s.head) {
      const int hid = headId(k);
      if (hid >= 0) primeAttr(hid);
      try {
        r.head = resolveHeadAtom(*s.head, "a rule head");
      } catch (const IllSortedValue& e) {
        // Sorted grounding: the statement has no properly sorted ground instance.
        if (strict_sorts_) throw;
        prog_.warnings.push_back(
            e.loc.str() + ": warning: " + e.description +
            ": the statement has no well-sorted ground instance and is left out, as in "
            "P-log's sorted grounding (strict sorts make this an error)");
        return;
      }
    }
    r.body = resolveBody(s.body);
    std::vector<std::string> vars;
    if (r.head) {
      typeAtom(*r.head, r.variable_sorts);
      varsOfAtom(*r.head, vars);
    }
    typeBody(r.body, r.variable_sorts);
    varsOfBody(r.body, vars);
    typeDomains(vars, r.variable_sorts);
    prog_.rules.push_back(std::move(r));
  }

  /// @brief A random selection rule `[r] random(a(t), range) :- body.`.
  void resolveRandom(const RawStmt& s) {
    RandomRule r;
    r.loc = s.loc;
    r.label = s.r().label;
    r.consistency_restoring = s.consistency_restoring;
    const Term& t = s.head->lhs;
    if (t.kind != Term::Kind::Symbol && t.kind != Term::Kind::Compound)
      throw ParseError(s.head->loc, "random(...) needs an attribute term");
    r.attr = toAttr(t);
    const AttributeDecl* d = findAttr(t.name);
    r.has_range = s.r().has_range;
    if (s.r().has_range) resolveRandomRange(s, *d, r);
    r.body = resolveBody(s.body);
    std::vector<std::string> vars;
    for (const auto& a : r.attr.args) a.collectVariables(vars);
    for (size_t i = 0; i < r.attr.args.size(); ++i)
      typeTerm(r.attr.args[i], d->arg_sorts[i], r.variable_sorts);
    typeBody(r.body, r.variable_sorts);
    typeBody(r.range_body, r.variable_sorts);
    varsOfBody(r.body, vars);
    varsOfBody(r.range_body, vars);
    typeDomains(vars, r.variable_sorts);
    prog_.random_rules.push_back(std::move(r));
  }

  /// @brief The dynamic range of a selection rule: `random(a, p)` (plog2.0: the values y
  /// with p(y), through a fresh variable) or `random(a : {Y : body})`; its variable ranges
  /// over the attribute's range sort `d`.
  void resolveRandomRange(const RawStmt& s, const AttributeDecl& d, RandomRule& r) {
    if (!s.r().range_pred.empty()) {
      r.range_var = "_R" + std::to_string(fresh_++);
      RawLit pl;
      pl.loc = s.head->loc;
      pl.lhs.kind = Term::Kind::Compound;
      pl.lhs.name = s.r().range_pred;
      pl.lhs.loc = s.head->loc;
      pl.lhs.args.push_back(Term::variable(r.range_var, s.head->loc));
      r.range_body = resolveBody({pl});
    } else {
      r.range_var = s.r().range_var;
      r.range_body = resolveBody(s.r().range_body);
    }
    r.variable_sorts.emplace(r.range_var, d.range_sort);
  }

  /// @brief A pr-atom `[r] pr(a(t) = y | body) = p.` (p in [0, 1]).
  void resolvePr(const RawStmt& s) {
    PrAtom p;
    p.loc = s.loc;
    p.label = s.r().label;
    p.atom = resolveHeadAtom(s.r().pr_atom, "the atom of a pr-atom");
    p.body = resolveBody(s.body);
    p.probability = s.r().prob;
    p.probability_text = s.r().prob_text;
    p.priority = s.priority;
    if (!(p.probability >= 0.0 && p.probability <= 1.0))
      throw IncoherentError(s.loc.str() + ": probability " + s.r().prob_text + " of pr(" +
                            toString(p.atom) + ") is outside [0,1]");
    std::vector<std::string> vars;
    varsOfAtom(p.atom, vars);
    varsOfBody(p.body, vars);
    typeAtom(p.atom, p.variable_sorts);
    typeBody(p.body, p.variable_sorts);
    typeDomains(vars, p.variable_sorts);
    prog_.pr_atoms.push_back(std::move(p));
  }

  /// @brief A `do(...)` statement: an intervention, and the do fact its arguments make.
  void resolveDoStatement(const RawStmt& s) {
    const auto& a = s.r().do_args;
    auto isTerm = [](const Term& t) {
      return t.kind == Term::Kind::Symbol || t.kind == Term::Kind::Compound;
    };
    if (a.size() == 3 && isTerm(a[0]) && !findAttr(a[0].name) && isTerm(a[1]) &&
        findAttr(a[1].name) && a[1].name != "do") {
      // Agent form do(agent, a(t), y) (plog2.0's do with an agent, flag omitted): the
      // agent fixes a(t) = y.
      RawLit l;
      l.loc = s.r().do_lit.loc;
      l.lhs = a[1];
      l.has_op = true;
      l.op = CompareOp::Eq;
      l.setRhs() = a[2];
      prog_.interventions.push_back(resolveDo(l));
    } else {
      requireKnownAttribute(s.r().do_lit);
      prog_.interventions.push_back(resolveDo(s.r().do_lit));
    }
    addDoFact(a, s.loc);
  }

  int fresh_ = 0;
  /// @brief The statements are in the plog2.0 dialect (no implicit predicates).
  bool plog2_ = false;
  /// @brief ParseOptions::strict_sorts.
  bool strict_sorts_ = false;
  MemoryGuard* guard_ = nullptr;
  /// @brief Classic attributes declared with their range only (arity taken from use).
  std::set<std::string> range_only_;

 private:
  Program& prog_;
  std::map<std::string, std::unordered_set<std::string>> sort_cache_;
  /// The entry of sort_cache_ used last and its sort (see checkValue).
  std::unordered_set<std::string>* last_sort_ = nullptr;
  std::string last_sort_name_;
  /// findAttr's last answer: the name and its index.
  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  std::size_t last_attr_ = kNone;
  std::string last_attr_name_;
  /// Names of the attributes and sorts -> position of their first declaration
  /// (attr_decl_[id], sort_decl_[id]), extended as declarations are appended.
  NameTable attr_index_, sort_index_;
  /// (attr_decl_[id] is kNone for a name that the statements use and nothing declares.)
  std::vector<std::size_t> attr_decl_, sort_decl_;
  std::size_t attr_indexed_ = 0, sort_indexed_ = 0;
  /// Per statement: the id of its head's name in attr_index_ (splitOverloadedPredicates),
  /// empty when the statements were renamed or not scanned.
  std::vector<int> head_ids_;
  template <class Decls>
  static void indexNames(const Decls& decls, NameTable& index, std::vector<std::size_t>& first,
                         std::size_t& indexed) {
    for (; indexed < decls.size(); ++indexed) {
      const int id = index.intern(decls[indexed].name);
      if (static_cast<std::size_t>(id) == first.size()) first.push_back(indexed);
      else if (first[static_cast<std::size_t>(id)] == kNone) first[static_cast<std::size_t>(id)] = indexed;
    }
  }
};

}  // namespace

void ensureBoolean(Program& p) {
  if (p.findSort("boolean")) return;
  SortDecl b;
  b.name = "boolean";
  b.builtin = true;
  b.values = {Term::symbol("true"), Term::symbol("false")};
  p.sorts.insert(p.sorts.begin(), b);
}

int freshBase(const Program& p) {
  // Fresh variable numbers must not collide with those of earlier parses into the program.
  return static_cast<int>(p.rules.size() + p.random_rules.size() + p.pr_atoms.size() +
                          p.queries.size()) * 4 + 1000;
}

void resolveStatements(Program& work, const std::vector<RawStmt>& stmts,
                       const ResolveSettings& settings) {
  Resolver res(work);
  res.fresh_ = settings.fresh;
  res.plog2_ = settings.plog2;
  res.range_only_ = settings.range_only;
  res.strict_sorts_ = settings.strict_sorts;
  res.guard_ = settings.guard;
  res.resolveAll(stmts);
}

Query resolveRawQuery(Program& work, const RawQuery& query, int fresh) {
  Resolver res(work);
  res.fresh_ = fresh;
  return res.resolveQuery(query);
}

AttributeTerm resolveAttributeTerm(Program& work, const Term& term) {
  Resolver res(work);
  return res.toAttr(term);
}

}  // namespace syntax
}  // namespace plog
}  // namespace krr
