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
 *
 * T and O are read into sparse rows (RockSample[5,7]: 3201 states, a few MB instead of the
 * 3.7 GiB of dense tables), but a few bytes ("states: 5000000", "T: * uniform") can still ask
 * for GiBs. The reader checks the declared sizes against a memory budget before it allocates
 * (at least one entry per T and O row), then every statement's new entries before it stores
 * them, and can stop after a time budget, so a hostile file is a ParseError, never bad_alloc
 * or a hang.
 */
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include "krr_core/pomdp/model.h"

namespace krr {
namespace pomdp {

/// @brief Resource budgets of the reader.
struct CassandraLimits {
  /// Bytes the parse and the resulting Model may use; 0: krr::memoryBudget() (limits.h unless
  /// $KRR_MEMORY_BUDGET_MIB says otherwise).
  std::size_t memory_budget = 0;
  /// Seconds the parse may take (checked between statements and in long loops); 0: no limit.
  /// Model construction gets what is left of it.
  double timeout = 0.0;
  /// Bytes per state pair (S^2) the caller will need on top of the model, e.g. dense S x S
  /// work matrices, so that a model the caller cannot use is refused at its declaration
  /// (pomdp_solve needs none: its solver sweeps sparse rows above 500 states).
  std::size_t extra_bytes_per_state_pair = 0;
  /// Largest |sum - 1| accepted for a T or O row (and the start vector); such rows are
  /// renormalised. The standard benchmark files (TagAvoid, RockSample, Hallway) are written with
  /// six decimals, so a row of n entries can be off by n * 5e-7 (TagAvoid: 1e-6); 1e-4 accepts
  /// rows of up to 200 rounded entries and still refuses every real modelling error we met
  /// (a missing entry is off by at least 1e-3 in these files).
  double sum_tolerance = 1e-4;
};

/// @brief What the reader had to repair; filled when requested (readCassandra's stats).
struct CassandraStats {
  /// Largest |sum - 1| of a T row, O row or the start vector (0 when all sum to 1 exactly).
  double max_sum_deviation = 0.0;
  /// Which distribution that was, e.g. "T row of action 'North' from state 's837'".
  std::string max_deviation_where;
  /// Rows (and start vector) divided by their sum because it differed from 1.
  std::size_t renormalised_rows = 0;
};

/// @brief Sums within this of 1 are floating-point noise of exact decimals (0.1 + 0.2 + 0.7):
/// such distributions are kept as written, so that read -> write -> read is exact.
constexpr double kExactSumNoise = 1e-9;

/// @brief The readers' one rule for a probability distribution whose entries sum to `sum`
/// (a .pomdp T or O row or start vector, a .pomdpx CondProb row), shared by the .pomdp and
/// .pomdpx readers so that both accept and repair exactly the same files.
/// @return false when |sum - 1| > tolerance (the caller reports the error at its location);
/// otherwise records |sum - 1| in stats (with where() when it is the largest so far), sets
/// *divisor to what the entries must be divided by (1 within kExactSumNoise, else sum, counted
/// in stats.renormalised_rows) and returns true.
bool checkDistributionSum(double sum, double tolerance, CassandraStats& stats,
                          const std::function<std::string()>& where, double* divisor);

/// @brief The least bytes a Model with S states, A actions and O observations needs while it
/// is read and built, known from the declarations alone: per (state, action) the reader's row
/// lists and locations, the CSR offsets, the reward and one entry in each T and O row; plus
/// the dense forms Model always keeps (T and its transpose up to Model::kDenseStates states,
/// O when it is at most Model::kDenseBytes). Every further T or O entry costs 32 bytes, checked
/// as it is read. Saturates at SIZE_MAX instead of wrapping.
std::size_t estimateModelBytes(std::size_t states, std::size_t actions, std::size_t observations);

/// @brief Parse .pomdp text; file is used in error positions. Distributions whose sum is within
/// limits.sum_tolerance of 1 are renormalised (reported in *stats if given).
/// @throws ParseError, also when a declaration needs more than the memory budget (naming the
/// declaration and the size), a distribution is off by more than the tolerance or has a
/// negative entry, or the parse exceeds limits.timeout.
Model readCassandra(const std::string& text, const std::string& file = "<string>",
                    const CassandraLimits& limits = CassandraLimits(),
                    CassandraStats* stats = nullptr);
/// @brief Read a .pomdp file (regular files only, see readFile). @throws IoError, ParseError.
Model loadCassandra(const std::string& path, const CassandraLimits& limits = CassandraLimits(),
                    CassandraStats* stats = nullptr);
/// @brief The model as .pomdp text (17 significant digits: exact round trip). Zero entries
/// are omitted; identity transition matrices use the 'identity' keyword.
/// @throws ConfigError if a name is not a valid .pomdp identifier ([A-Za-z][A-Za-z0-9_-]*).
std::string writeCassandra(const Model& model);
/// @brief Write writeCassandra(model) atomically to path.
void saveCassandra(const std::string& path, const Model& model);

}  // namespace pomdp
}  // namespace krr
