/**
 * @file parser_syntax.h
 * @brief Private to the P-log parser: tokens, the raw (unresolved) statements that the parser
 * produces and the resolver turns into a Program (parser.cpp, lexer.cpp, resolver.cpp).
 */
#pragma once

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

struct Token {
  Tok kind = Tok::End;
  std::string text;
  SourceLocation loc;
};

/// @brief The tokens of a P-log text; comments and whitespace dropped, Tok::End last.
/// @throws ParseError at an unexpected character.
/// @throws BudgetExceededError when the tokens outgrow `guard`'s budget (if given).
std::vector<Token> lex(const std::string& src, const std::string& file,
                       MemoryGuard* guard = nullptr);

struct RawLit {
  bool naf = false;
  Term lhs;
  bool has_op = false;
  CompareOp op = CompareOp::Eq;
  Term rhs;
  SourceLocation loc;
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

struct RawStmt {
  enum class Kind { Rule, Random, Pr, Obs, Do, Query } kind = Kind::Rule;
  std::string label;
  std::optional<RawLit> head;      // Rule (absent: constraint); Random: lhs = attribute term
  std::vector<RawLit> body;
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
  int priority = 0;                // Pr: knowledge generation
  bool consistency_restoring = false;  // Rule, Random: written with ':+'
  SourceLocation loc;
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
