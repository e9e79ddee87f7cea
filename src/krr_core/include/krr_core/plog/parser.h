/**
 * @file parser.h
 * @brief Parsing P-log text (classic and plog2.0 dialects) into a resolved Program.
 */
#pragma once

#include <cstddef>
#include <string>

#include "krr_core/plog/ast.h"

namespace krr {
namespace plog {

/// @brief Settings of the parser that change what it accepts.
struct ParseOptions {
  /// @brief A rule or fact whose head has a ground argument or value outside the declared
  /// sort (`connected(batteryB, streering_sensor2).`, a misspelling) has no properly sorted
  /// ground instance: P-log's grounding (and plog2.0) leaves it out. By default it is left out
  /// with a warning in Program::warnings naming file:line:col and the value; when true it is
  /// an UnknownSymbolError instead.
  bool strict_sorts = false;
  /// @brief Bytes by which reading and resolving one text may grow the heap; 0:
  /// krr::memoryBudget() (limits.h, $KRR_MEMORY_BUDGET_MIB). Exhausting it is a
  /// BudgetExceededError naming the phase and the statement (file:line:col).
  std::size_t memory_budget = 0;
};

/// @brief Parse and resolve a whole program; the dialect is detected from the presence of the
/// plog2.0 section keywords (`sorts`, `attributes`, `statements`).
/// @throws ParseError (file:line:col, offending and expected token), UnknownSymbolError
/// (undeclared sort / attribute / value, with location), krr::Error for unsupported constructs.
Program parseProgram(const std::string& text, const std::string& file_name);

/// @brief As parseProgram, with the dialect forced (Dialect::Auto detects).
Program parseProgram(const std::string& text, const std::string& file_name, Dialect dialect);

/// @brief Parse more statements (sorts, declarations, rules, pr-atoms, obs, do, queries) in the
/// context of an existing program and append them to it, resolving names against everything
/// already declared. Used to add learned knowledge at run time. On error `program` is unchanged.
void parseInto(Program& program, const std::string& text, const std::string& file_name,
               Dialect dialect = Dialect::Auto);

/// @brief parseProgram / parseInto with parser settings (see ParseOptions).
Program parseProgram(const std::string& text, const std::string& file_name, Dialect dialect,
                     const ParseOptions& options);
void parseInto(Program& program, const std::string& text, const std::string& file_name,
               Dialect dialect, const ParseOptions& options);

/// @brief Parse one query (`?{a=y} | obs(b=z), do(c=w)`, the leading `?` and braces optional,
/// trailing `.` optional) against a program's declarations.
Query parseQuery(const Program& program, const std::string& text,
                 const std::string& file_name = "<query>");

/// @brief Parse one attribute term (`next_cell`, `curr_room(dave)`) against a program.
AttributeTerm parseAttributeTerm(const Program& program, const std::string& text,
                                 const std::string& file_name = "<term>");

}  // namespace plog
}  // namespace krr
