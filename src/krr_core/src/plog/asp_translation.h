/**
 * @file asp_translation.h
 * @brief Private to the clingo back end: the P-log -> ASP translation (asp_translation.cpp)
 * as the measure side (asp_backend.cpp) uses it.
 */
#pragma once

#include <string>
#include <vector>

#include "krr_core/plog/ast.h"

namespace krr {
namespace plog {
namespace asp_detail {

/// What one answer of a clingo run is: a conjunction given observations (same interventions
/// for the whole run).
struct QuerySpec {
  std::vector<Literal> formula;
  std::vector<Observation> observations;
  std::string text;  ///< for error messages
};

/// @brief "file:line:col", or "<program>" for a statement without a file.
std::string where(const SourceLocation& loc);

/// @brief The declaration of a's attribute. @throws UnknownSymbolError when undeclared.
const AttributeDecl& attributeOf(const Program& program, const AttributeTerm& a);

/// @brief The translation of the program itself: sorts, rules (cr-rules with their appl/2
/// atoms), random selections, pr-atoms, the program's obs and do.
std::string translateBase(const Program& program);

/// @brief The part of a clingo run specific to its queries: per scenario (set of
/// interventions) its do atoms, per spec ev(k) / q(k), the #show statements and, with several
/// scenarios, the Lua main that solves once per scenario.
std::string translateScenarios(const Program& program,
                               const std::vector<std::vector<Intervention>>& scenarios,
                               const std::vector<QuerySpec>& specs);

/// @brief Order-independent key of a set of interventions.
std::string interventionKey(const std::vector<Intervention>& dos);

}  // namespace asp_detail
}  // namespace plog
}  // namespace krr
