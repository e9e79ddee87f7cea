/**
 * @file ast.h
 * @brief Abstract syntax of P-log programs (classic 2009 dialect and Balai's plog2.0 dialect).
 *
 * Both dialects parse into this one representation so that every back end (the native exact
 * reasoner and the clingo back end) sees the same program. The parser RESOLVES the program
 * before returning it: an equality `x = y` whose left side names a declared attribute becomes an
 * attribute Atom, everything else becomes a Comparison; bare predicates `p(t)` become the boolean
 * atom `p(t) = true`; `-p(t)` / `neg p(t)` become `p(t) = false`; `a(t) = b(u)` is rewritten into
 * `a(t) = _Vn, b(u) = _Vn` with a fresh variable. So back ends never see an unresolved equality.
 *
 * Stability contract: this header only grows (fields and functions are added, never renamed or
 * removed), because other back ends are written against it.
 */
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "krr_core/common/errors.h"

namespace krr {
namespace plog {

class AttributeNames;

/// @brief Which surface syntax a program was written in (export always writes Classic).
enum class Dialect { Auto, Classic, Plog2 };

/// @brief A term: constant, integer, variable, compound f(t1..tn), or arithmetic expression.
struct Term {
  enum class Kind {
    Symbol,    ///< constant such as `office1`, `true` (name holds it)
    Integer,   ///< integer constant (value holds it)
    Variable,  ///< variable such as `C1` or `_` / `_V3` (name holds it)
    Compound,  ///< f(t1,...,tn) used as a VALUE (not an attribute), e.g. a sort element
    Binary,    ///< arithmetic: name is one of "+", "-", "*", "/", "mod"; args = {lhs, rhs}
    Negate     ///< unary minus: args = {operand}
  };
  Kind kind = Kind::Symbol;
  std::string name;
  long long value = 0;
  std::vector<Term> args;
  SourceLocation loc;

  static Term symbol(const std::string& n, const SourceLocation& l = {});
  static Term integer(long long v, const SourceLocation& l = {});
  static Term variable(const std::string& n, const SourceLocation& l = {});
  /// @brief True when the term contains no variables.
  bool isGround() const;
  /// @brief Names of the variables occurring in the term (appended, duplicates possible).
  void collectVariables(std::vector<std::string>& out) const;
};

/// @brief Structural equality of terms (locations ignored).
bool operator==(const Term& a, const Term& b);
inline bool operator!=(const Term& a, const Term& b) { return !(a == b); }

/// @brief An attribute term a(t1,...,tn) (n may be 0): the "random variable" of P-log.
struct AttributeTerm {
  std::string name;
  std::vector<Term> args;
  SourceLocation loc;
  /// @brief Position of the attribute's declaration in Program::attributes, set by the parser
  /// when it resolves the term (-1: not known). A hint that spares the grounder and the
  /// reasoner a name lookup per atom: valid only while Program::attributes[index].name is
  /// `name`, which every user checks first (declarations may move between programs).
  int index = -1;
};

/// @brief The attribute atom a(t) = y. Predicates p(t) are boolean attributes: p(t) = true.
struct Atom {
  AttributeTerm attr;
  Term value;  ///< Symbol "true"/"false" for predicates; may be a Variable
  SourceLocation loc;
};

/// @brief Comparison operators (== and = are both Eq, != and <> both Ne).
enum class CompareOp { Eq, Ne, Lt, Le, Gt, Ge };

/// @brief A body literal: an (optionally strongly negated) attribute atom, optionally under
/// default negation `not`, or a comparison between (arithmetic) terms.
struct Literal {
  enum class Kind { Atom, Comparison };
  Kind kind = Kind::Atom;
  /// @brief Default negation: `not l`.
  bool naf = false;
  /// @brief Strong negation of the atom: `a(t) != y` (a(t) has a value and it is not y).
  /// `-p(t)` is NOT represented this way: it is the positive atom p(t) = false.
  bool negated = false;
  Atom atom;             ///< Kind::Atom
  CompareOp op = CompareOp::Eq;  ///< Kind::Comparison
  Term lhs, rhs;         ///< Kind::Comparison
  SourceLocation loc;
};

/// @brief A sort declaration `s = {a, b}.`, `s = {0..24}.`, `#s = 1..5.`, `#s = {a}+{b}.`.
/// Values are fully expanded at parse time (ranges and unions), in declaration order.
struct SortDecl {
  std::string name;          ///< without the plog2 '#'
  std::vector<Term> values;  ///< ground Symbol / Integer / Compound terms, duplicates removed
  /// @brief When the sort was written as one integer range lo..hi (kept for compact export).
  bool is_range = false;
  long long range_lo = 0, range_hi = -1;
  bool builtin = false;      ///< the predefined `boolean` sort
  SourceLocation loc;
};

/// @brief Attribute declaration `a : s.`, `a : s1, s2 -> s3.` (plog2: `a : #s1, #s2 -> #s3.`).
struct AttributeDecl {
  std::string name;
  std::vector<std::string> arg_sorts;  ///< sort names; "" = untyped (implicit predicates)
  std::string range_sort;              ///< "boolean" for predicates
  /// @brief True when the parser created the declaration for a predicate that is used as a
  /// fact or rule head without being declared (classic programs often do this).
  bool implicit = false;
  SourceLocation loc;
};

/// @brief `#domain cell(C; C1).`: variables C and C1 range over sort cell in every statement.
struct DomainDecl {
  std::string sort;
  std::vector<std::string> variables;
  SourceLocation loc;
};

/// @brief Maps each variable of a statement to its sort (from #domain, the argument positions
/// of attributes and the value positions of atoms). Variables absent from the map are bound
/// only by comparisons (`X = C + 1`).
using VariableSorts = std::map<std::string, std::string>;

/// @brief A regular rule `head :- body.`, a fact (empty body) or a constraint `:- body.`.
struct Rule {
  std::optional<Atom> head;  ///< absent for constraints
  std::vector<Literal> body;
  VariableSorts variable_sorts;
  std::string tag;           ///< optional user tag (set by Reasoner::addStatements)
  SourceLocation loc;
  /// @brief Consistency-restoring rule `head :+ body.` (plog2.0): applied only in the
  /// cardinality-minimal numbers of ground instances that make the program consistent.
  bool consistency_restoring = false;
  bool isConstraint() const { return !head.has_value(); }
};

/// @brief `[r] random(a(t) : {X : p(X)}) :- body.`  (plog2: `random(a(t), p) :- body.`).
struct RandomRule {
  std::string label;         ///< "" when unlabelled
  AttributeTerm attr;
  /// @brief Dynamic range: value y is possible iff range_body holds with range_var = y.
  /// Absent: the whole range sort of the attribute.
  bool has_range = false;
  std::string range_var;     ///< variable name (fresh "_R<n>" for the plog2 form)
  std::vector<Literal> range_body;
  std::vector<Literal> body;
  VariableSorts variable_sorts;
  SourceLocation loc;
  /// @brief `random(a) :+ body.`: a consistency-restoring random selection (see Rule).
  bool consistency_restoring = false;
};

/// @brief `[r] pr(a(t) = y | body) = v.`: causal probability v of a(t) = y when body holds.
struct PrAtom {
  std::string label;         ///< "" when unlabelled (applies to any selection rule of a(t))
  Atom atom;
  std::vector<Literal> body;
  double probability = 0.0;
  std::string probability_text;  ///< as written ("8/10", "0.83") for faithful export
  VariableSorts variable_sorts;
  std::string tag;           ///< optional user tag (set by Reasoner::addStatements)
  SourceLocation loc;
  /// @brief Generation of knowledge: 0 for the loaded program, incremented by each
  /// Reasoner::addStatements call. When two applicable pr-atoms give different probabilities
  /// to the same value in a world, the higher generation (newer, learned knowledge) wins;
  /// equal generations make the program incoherent.
  int priority = 0;
};

/// @brief `obs(l).`, `obs(l, false)` / `obs(neg l)` (truth = false), plog2 `obs(a, y)`.
struct Observation {
  Literal literal;   ///< ground Kind::Atom literal (naf never set)
  bool truth = true; ///< false: l is observed NOT to hold
  SourceLocation loc;
};

/// @brief `do(a(t) = y).` (plog2 `do(a, y)`): intervention fixing a random attribute.
struct Intervention {
  Atom atom;  ///< ground
  SourceLocation loc;
};

/// @brief `?{l1, ..., ln} | obs(...), do(...).` or plog2 `? a = y | ...`: the probability that
/// the conjunction of the formula literals holds given the observations and interventions.
struct Query {
  std::vector<Literal> formula;  ///< ground Kind::Atom literals (conjunction)
  std::vector<Observation> observations;
  std::vector<Intervention> interventions;
  std::string text;              ///< source text of the query, normalised whitespace
  SourceLocation loc;
};

/// @brief A whole P-log program after resolution.
struct Program {
  Dialect dialect = Dialect::Classic;
  std::vector<SortDecl> sorts;          ///< includes the builtin `boolean` first
  std::vector<AttributeDecl> attributes;
  std::vector<DomainDecl> domains;
  std::vector<Rule> rules;              ///< facts, rules and constraints
  std::vector<RandomRule> random_rules;
  std::vector<PrAtom> pr_atoms;
  std::vector<Observation> observations;
  std::vector<Intervention> interventions;
  std::vector<Query> queries;
  /// @brief What the parser left out or read in a lenient way, one "file:line:col: warning:
  /// ..." line each (e.g. a fact with a value outside its sort, which sorted grounding drops).
  std::vector<std::string> warnings;
  /// @brief The attribute names as the parser interned them (name_table.h), shared by the
  /// passes over the program instead of each hashing every name again. A cache: used only
  /// while it still names exactly `attributes` (checked in order), so a program edited by hand
  /// needs no care; nullptr when absent.
  std::shared_ptr<const AttributeNames> attribute_names;

  /// @brief Declaration of a sort, nullptr when absent.
  const SortDecl* findSort(const std::string& name) const;
  /// @brief Declaration of an attribute, nullptr when absent.
  const AttributeDecl* findAttribute(const std::string& name) const;
  /// @brief Sort of a #domain-typed variable ("" when untyped).
  std::string domainSortOf(const std::string& variable) const;
  /// @brief True when some rule or random selection is consistency-restoring (`:+`).
  bool hasConsistencyRestoringRules() const;
};

/// @brief Text of a term in classic syntax (`f(a,1)`, `C+1`, `X`).
std::string toString(const Term& t);
/// @brief `a(t1,t2)` or `a` for arity 0.
std::string toString(const AttributeTerm& a);
/// @brief `a(t)=y`.
std::string toString(const Atom& a);
/// @brief `not a(t)=y`, `a(t)!=y`, `X<>Y`, `C1=C+1`.
std::string toString(const Literal& l);
/// @brief "=", "!=", "<", "<=", ">", ">=".
std::string toString(CompareOp op);
/// @brief Whole program in the classic dialect; parses back to an equivalent program.
std::string toString(const Program& p);
/// @brief One statement in the classic dialect, with its final period.
std::string toString(const Rule& r);
std::string toString(const RandomRule& r);
std::string toString(const PrAtom& p);
std::string toString(const Query& q);

}  // namespace plog
}  // namespace krr
