/**
 * @file pomdpx_io.h
 * @brief Reading and writing POMDPs in PomdpX, the XML format of APPL/SARSOP (format 1.0), so
 * that the benchmark set runs from the same files in both formats.
 *
 * Supported as SARSOP documents the format: state variables (vnamePrev / vnameCurr, fullyObs,
 * ValueEnum or NumValues, whose values are then s0, s1, ...; a0, ... for actions; o0, ... for
 * observations), several observation, action and reward variables, InitialStateBelief,
 * StateTransitionFunction, ObsFunction and RewardFunction as CondProb / Func with
 * Parameter type="TBL": Entry / Instance with value names or indices, the '*' (every value)
 * and '-' (enumerate, in declaration order, first '-' slowest) wildcards, ProbTable /
 * ValueTable with several numbers, and the keywords 'identity' (two '-', the last on the Var)
 * and 'uniform' (n numbers 1/n). Later entries override earlier ones; unspecified entries
 * are 0. Decision diagrams (type="DD") are refused: SARSOP does not read them either.
 *
 * The factored model is flattened: states are the product of the state variables in
 * SARSOP's order (fully observable variables first, then the others, each in declaration
 * order, the last varying fastest); actions the product of the action variables;
 * observations the product of the fully observable state variables (after the transition)
 * and the observation variables, so that the flat POMDP sees what SARSOP's MOMDP sees after
 * every step. T(s, a, s') is the product of the state variables' CondProbs (a partially
 * observable variable may depend on fully observable ones of the same slice), rewards depending
 * on next-slice variables or observations are reduced to their expectation R(s, a).
 *
 * Budgets and errors are those of the .pomdp reader (CassandraLimits, CassandraStats): the
 * declared sizes (flat S, A, O and every dense conditional table) are checked against the
 * memory budget before anything is allocated, T entries as they are generated; rows of a
 * CondProb within limits.sum_tolerance of 1 are renormalised by checkDistributionSum, the
 * .pomdp reader's rule. Every error is a krr::ParseError at file:line:col of the element (or
 * of the token inside it) naming what is wrong.
 */
#pragma once

#include <string>

#include "krr_core/pomdp/cassandra_io.h"
#include "krr_core/pomdp/model.h"

namespace krr {
namespace pomdp {

/// @brief Parse PomdpX text; file is used in error positions.
/// @throws ParseError (malformed XML, unknown names, wrong table sizes, probabilities off by
/// more than the tolerance, declared sizes above the memory budget, time budget exceeded).
Model readPomdpx(const std::string& text, const std::string& file = "<string>",
                 const CassandraLimits& limits = CassandraLimits(),
                 CassandraStats* stats = nullptr);
/// @brief Read a .pomdpx file (regular files only, see readFile). @throws IoError, ParseError.
Model loadPomdpx(const std::string& path, const CassandraLimits& limits = CassandraLimits(),
                 CassandraStats* stats = nullptr);
/// @brief The model as flat PomdpX: one state variable (state_0 / state_1), one action and
/// one observation variable whose values are the model's names, one reward function over
/// (action, state_0). Numbers have 17 significant digits, so reading it back gives the same
/// model; identity transitions use 'identity'.
/// @throws ConfigError if a name is empty, contains white space or is '*' or '-'.
std::string writePomdpx(const Model& model);
/// @brief Write writePomdpx(model) atomically to path.
void savePomdpx(const std::string& path, const Model& model);

/// @brief Load a POMDP file in either format: ".pomdpx" is PomdpX, ".pomdp" Cassandra's
/// format; any other name is read as PomdpX if its text starts with '<' (after white space),
/// else as .pomdp. The one loader of the command-line programs.
Model loadPomdpFile(const std::string& path, const CassandraLimits& limits = CassandraLimits(),
                    CassandraStats* stats = nullptr);

}  // namespace pomdp
}  // namespace krr
