/**
 * @file cassandra_io.h
 * @brief Reading and writing POMDPs in Tony Cassandra's .pomdp format.
 *
 * This is the format of pomdp-solve, APPL/SARSOP and most POMDP benchmarks, so our dialog
 * models can be solved by SARSOP for comparison and standard problems can be loaded here.
 * Supported: discount, values (reward | cost), states / actions / observations as counts or
 * name lists, start (probability vector | uniform | state name or index | include/exclude
 * lists), T: and O: in all forms (single entry, row, matrix, identity, uniform) with '*'
 * wildcards, R: single entries with wildcards and the row / matrix forms. Rewards are reduced
 * to expected rewards R(s, a) = sum_s' T(s,a,s') sum_o O(s',a,o) R(a,s,s',o). Later entries
 * override earlier ones, as in the reference parser. Every error is a krr::ParseError with
 * file:line:col of the offending token.
 */
#pragma once

#include <string>

#include "krr_core/pomdp/model.h"

namespace krr {
namespace pomdp {

/// @brief Parse .pomdp text; file is used in error positions. @throws ParseError.
Model readCassandra(const std::string& text, const std::string& file = "<string>");
/// @brief Read a .pomdp file. @throws IoError, ParseError.
Model loadCassandra(const std::string& path);
/// @brief The model as .pomdp text (17 significant digits: exact round trip). Zero entries
/// are omitted; identity transition matrices use the 'identity' keyword.
/// @throws ConfigError if a name is not a valid .pomdp identifier ([A-Za-z][A-Za-z0-9_-]*).
std::string writeCassandra(const Model& model);
/// @brief Write writeCassandra(model) atomically to path.
void saveCassandra(const std::string& path, const Model& model);

}  // namespace pomdp
}  // namespace krr
