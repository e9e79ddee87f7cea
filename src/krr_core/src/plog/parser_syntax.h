/**
 * @file parser_syntax.h
 * @brief Private to the P-log parser: tokens, the raw (unresolved) statements that the parser
 * produces and the resolver turns into a Program (parser.cpp, lexer.cpp, resolver.cpp).
 */
#pragma once

#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "krr_core/plog/ast.h"
#include "krr_core/plog/budget.h"

namespace krr {
namespace plog {
namespace syntax {

enum class Tok {
  End, Ident, Var, Int, Decimal, LParen, RParen, LBrace, RBrace, LBracket, RBracket, Comma,
  Semicolon, Dot, DotDot, Colon, If, Bar, Eq, EqEq, Ne, Lt, Gt, Le, Ge, Plus, Minus, Star,
  Slash, Question, Hash, Arrow
};

/// @brief A token: its line and column only (the file is the text's, the same for all: a
/// SourceLocation per token copied the file's name once per token, 80 bytes a token).
struct Token {
  Tok kind = Tok::End;
  int line = 0, column = 0;
  std::string text;
  /// @brief Where the token starts in `file`.
  SourceLocation loc(const std::string& file) const { return SourceLocation{file, line, column}; }
};

/// @brief The tokens of a P-log text; comments and whitespace dropped, Tok::End last.
/// @throws ParseError at an unexpected character.
/// @throws BudgetExceededError when the tokens outgrow `guard`'s budget (if given).
std::vector<Token> lex(const std::string& src, const std::string& file,
                       MemoryGuard* guard = nullptr);

/// @brief A value held on the heap and copied deeply, absent until first written: the parts
/// of a raw statement that most statements (facts, rules) do not have, so that a million facts
/// do not each carry the fields of a query, an observation and a pr-atom.
template <class T>
class Boxed {
 public:
  Boxed() = default;
  Boxed(const Boxed& o) : p_(o.p_ ? std::make_unique<T>(*o.p_) : nullptr) {}
  Boxed(Boxed&&) noexcept = default;
  Boxed& operator=(const Boxed& o) {
    if (this != &o) p_ = o.p_ ? std::make_unique<T>(*o.p_) : nullptr;
    return *this;
  }
  Boxed& operator=(Boxed&&) noexcept = default;
  explicit operator bool() const { return p_ != nullptr; }
  /// @brief The value, or a default one when it was never written.
  const T& get() const {
    static const T empty{};
    return p_ ? *p_ : empty;
  }
  /// @brief The value, made on first use.
  T& mut() {
    if (!p_) p_ = std::make_unique<T>();
    return *p_;
  }

 private:
  std::unique_ptr<T> p_;
};

struct RawLit {
  bool naf = false;
  bool has_op = false;
  CompareOp op = CompareOp::Eq;
  Term lhs;
  SourceLocation loc;
  /// @brief The right side `y` of `lhs op y` (has_op), a default term otherwise.
  const Term& rhs() const { return rhs_.get(); }
  /// @brief The right side, to write (made on first use).
  Term& setRhs() { return rhs_.mut(); }

 private:
  /// (on the heap: most literals, every fact's head among them, have none)
  Boxed<Term> rhs_;
};

struct RawObs {
  RawLit lit;
  bool truth = true;
  SourceLocation loc;
};

struct RawQuery {
  std::vector<RawLit> formula;
  std::vector<RawObs> obs;
  std::vector<RawLit> dos;
  std::string text;
  SourceLocation loc;
};

/// @brief The fields of the rarer statement kinds (selection rules, pr-atoms, obs, do, queries).
struct RawStmtRare {
  std::string label;               // Random, Pr: `[r]`
  bool has_range = false;          // Random
  std::string range_var;
  std::vector<RawLit> range_body;
  std::string range_pred;          // plog2 random(a, p)
  RawLit pr_atom;                  // Pr
  double prob = 0;
  std::string prob_text;
  RawObs obs;                      // Obs
  RawLit do_lit;                   // Do
  std::vector<Term> do_args;       // Do: comma-separated arguments as written
  RawQuery query;                  // Query
};

struct RawStmt {
  enum class Kind { Rule, Random, Pr, Obs, Do, Query } kind = Kind::Rule;
  int priority = 0;                // Pr: knowledge generation
  bool consistency_restoring = false;  // Rule, Random: written with ':+'
  std::optional<RawLit> head;      // Rule (absent: constraint); Random: lhs = attribute term
  std::vector<RawLit> body;
  SourceLocation loc;
  Boxed<RawStmtRare> rare;
  /// @brief The rare fields (defaults when the statement has none).
  const RawStmtRare& r() const { return rare.get(); }
  /// @brief The rare fields, made when first written.
  RawStmtRare& w() { return rare.mut(); }
};

/// @brief What the parser found out about the text that the resolver needs.
struct ResolveSettings {
  int fresh = 0;                       ///< first number of fresh variables
  bool plog2 = false;                  ///< plog2.0 dialect (no implicit predicates)
  std::set<std::string> range_only;    ///< classic attributes declared with their range only
  bool strict_sorts = false;           ///< ParseOptions::strict_sorts
  MemoryGuard* guard = nullptr;        ///< the parse's memory budget (checked per statement)
};

/// @brief Resolve raw statements into work (declarations already in it).
void resolveStatements(Program& work, const std::vector<RawStmt>& stmts,
                       const ResolveSettings& settings);
/// @brief Resolve a raw query against work's declarations.
Query resolveRawQuery(Program& work, const RawQuery& query, int fresh);
/// @brief An attribute term against work's declarations (arity, argument sorts).
AttributeTerm resolveAttributeTerm(Program& work, const Term& term);

/// @brief Adds the predefined `boolean` sort when the program lacks it.
void ensureBoolean(Program& p);
/// @brief First fresh variable number for a parse into p (no collision with earlier parses).
int freshBase(const Program& p);

}  // namespace syntax
}  // namespace plog
}  // namespace krr
