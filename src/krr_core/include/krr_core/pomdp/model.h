/**
 * @file model.h
 * @brief A finite, discrete POMDP with sparse (and, when cheap, dense) T and O.
 *
 * T and O are always kept as sparse rows (CSR per action) and, when that is cheap and faster
 * (small or dense models), also as dense Eigen matrices; predict / expectNext /
 * weightByObservation use whichever form is kept, so solvers and belief updates work on both.
 *
 * The interface follows AI-Toolbox (getS/getA/getO, getTransitionProbability, ...), so that
 * code written against that library reads the same here. Solvers and simulators also use
 * the per-action observation support and the identity/terminal flags computed once at
 * construction (questions do not move the hidden state, serving ends the
 * episode: both facts are detected, not assumed).
 */
#pragma once

#include <cstddef>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "krr_core/common/random.h"

namespace krr {
namespace pomdp {

/// @brief A probability distribution over the states of a Model.
using Belief = Eigen::VectorXd;

/// @brief How a Model keeps T and O. kAuto: dense only when that is cheap and not slower
/// (see Model::kDenseStates); kDense / kSparse force one form (tests compare the two).
enum class ModelStorage { kAuto, kDense, kSparse };

/// @brief One non-zero entry of a sparse row: (index, probability).
using ModelEntry = std::pair<std::size_t, double>;

/// @brief A view of one contiguous sparse row (entries sorted by index), so that callers
/// iterate T and O rows the same way whatever the storage.
class EntryRange {
 public:
  EntryRange(const ModelEntry* b, const ModelEntry* e) : b_(b), e_(e) {}
  const ModelEntry* begin() const { return b_; }
  const ModelEntry* end() const { return e_; }
  std::size_t size() const { return static_cast<std::size_t>(e_ - b_); }
  bool empty() const { return b_ == e_; }
  const ModelEntry& front() const { return *b_; }
  const ModelEntry& back() const { return *(e_ - 1); }
  const ModelEntry& operator[](std::size_t i) const { return b_[i]; }

 private:
  const ModelEntry* b_;
  const ModelEntry* e_;
};

/// @brief Rows of a sparse matrix in compressed form (CSR): row r is entries[start[r],
/// start[r + 1]), sorted by column. The compact form of T (columns: next states) and O
/// (columns: observations) of one action.
struct SparseRows {
  std::size_t cols = 0;
  std::vector<std::size_t> start{0};  ///< rows + 1 offsets
  std::vector<ModelEntry> entries;
  std::size_t rows() const { return start.size() - 1; }
  EntryRange row(std::size_t r) const {
    return {entries.data() + start[r], entries.data() + start[r + 1]};
  }
  /// @brief Append a row (entries sorted by column, no zeros).
  void pushRow(const std::vector<ModelEntry>& row) {
    entries.insert(entries.end(), row.begin(), row.end());
    start.push_back(entries.size());
  }
};

/// @brief Discrete POMDP <S, A, O, T, Z, R, gamma> with an initial belief and optional names.
class Model {
 public:
  /// @brief One non-zero entry of a sparse row: (index, probability).
  using Entry = ModelEntry;

  /**
   * @brief Build and validate a model from dense matrices.
   * @param transitions one S x S matrix per action, T[a](s, s1) = P(s1 | s, a)
   * @param observations one S x O matrix per action, O[a](s1, o) = P(o | s1, a)
   * @param rewards S x A matrix of expected immediate rewards R(s, a)
   * @param discount in (0, 1]
   * @param timeLimit seconds the construction may take (0: no limit). Building a model of
   *        thousands of states takes about a second; a caller with a time budget (pomdp_solve
   *        --timeout) passes what is left of it, so that construction cannot overrun it.
   * @param storage kept form of T and O (the dense input is released when sparse is chosen)
   * @throws ConfigError naming the action, state and offending sum or value, or saying that
   *        the time limit was reached.
   */
  Model(std::vector<Eigen::MatrixXd> transitions, std::vector<Eigen::MatrixXd> observations,
        Eigen::MatrixXd rewards, double discount, double timeLimit = 0.0,
        ModelStorage storage = ModelStorage::kAuto);

  /**
   * @brief Build and validate a model from sparse rows, never allocating S x S: the form the
   * .pomdp reader uses, so that RockSample-size models (thousands of states, a few successors
   * per state) fit in memory. Same checks and errors as the dense constructor.
   * @param transitions per action, S rows of (s1, P(s1 | s, a)) over S columns
   * @param observations per action, S rows of (o, P(o | s1, a)) over O columns
   */
  Model(std::vector<SparseRows> transitions, std::vector<SparseRows> observations,
        Eigen::MatrixXd rewards, double discount, double timeLimit = 0.0,
        ModelStorage storage = ModelStorage::kAuto);

  std::size_t getS() const { return s_; }
  std::size_t getA() const { return a_; }
  std::size_t getO() const { return o_; }
  double getDiscount() const { return discount_; }
  double getTransitionProbability(std::size_t s, std::size_t a, std::size_t s1) const;
  double getObservationProbability(std::size_t s1, std::size_t a, std::size_t o) const;
  double getExpectedReward(std::size_t s, std::size_t a) const { return r_(s, a); }

  /// @brief Sample (s1, o, r) from state s under action a; r is the expected reward R(s, a).
  std::tuple<std::size_t, std::size_t, double> sampleSOR(std::size_t s, std::size_t a,
                                                         Rng& rng) const;

  /// @brief True when T is kept as dense matrices (transitionMatrix() is available).
  bool hasDenseTransitions() const { return denseT_; }
  /// @brief True when O is kept as dense matrices (observationMatrix() is available).
  bool hasDenseObservations() const { return denseZ_; }
  /// @brief Bytes held by T, O and R in their kept forms (for memory reports and tests).
  std::size_t storageBytes() const;

  /// @brief T[a] as an S x S matrix (rows: s, columns: s1). @throws std::logic_error when T
  /// is sparse (use predict / expectNext / successors, or denseTransition for small models).
  const Eigen::MatrixXd& transitionMatrix(std::size_t a) const;
  /// @brief Transposed T[a] (rows: s1). @throws std::logic_error when T is sparse.
  const Eigen::MatrixXd& transitionMatrixTransposed(std::size_t a) const;
  /// @brief Z[a] as an S x O matrix (rows: s1, columns: o). @throws std::logic_error when O
  /// is sparse.
  const Eigen::MatrixXd& observationMatrix(std::size_t a) const;
  /// @brief T[a] as a new dense matrix, whatever the storage (small models only: S^2 doubles).
  Eigen::MatrixXd denseTransition(std::size_t a) const;
  /// @brief Z[a] as a new dense S x O matrix, whatever the storage.
  Eigen::MatrixXd denseObservation(std::size_t a) const;
  /// @brief Column o of Z[a] (P(o | s1, a) for every s1) as a dense vector.
  Eigen::VectorXd observationColumn(std::size_t a, std::size_t o) const;
  /// @brief R as an S x A matrix.
  const Eigen::MatrixXd& rewardMatrix() const { return r_; }

  /// @brief out = T[a]^T b: the predicted state distribution (unnormalised belief update).
  /// Sparse storage skips the states with b(s) = 0, so a peaked belief costs its support only.
  void predict(std::size_t a, const Eigen::VectorXd& b, Eigen::VectorXd& out) const;
  /// @brief out = T[a] v: the expectation of v over the successors of each state (backups).
  void expectNext(std::size_t a, const Eigen::VectorXd& v, Eigen::VectorXd& out) const;
  /// @brief v(s1) *= P(o | s1, a) for every s1 (the observation step of a belief update).
  void weightByObservation(std::size_t a, std::size_t o, Eigen::VectorXd& v) const;

  /// @brief Non-zero successors of (s, a), sorted by state, for sampling and sparse backups.
  EntryRange successors(std::size_t s, std::size_t a) const { return tRows_[a].row(s); }
  /// @brief Non-zero observations of (s1, a), sorted by observation.
  EntryRange observationRow(std::size_t s1, std::size_t a) const { return zRows_[a].row(s1); }
  /// @brief Observations with non-zero probability in some state after a (the branching set).
  const std::vector<std::size_t>& possibleObservations(std::size_t a) const {
    return possibleObs_[a];
  }
  /// @brief True when action a leaves every state unchanged (e.g. a dialog question).
  bool isIdentityTransition(std::size_t a) const { return identity_[a] != 0; }
  /// @brief True when s is absorbing with zero reward under every action (episode over).
  bool isTerminal(std::size_t s) const { return terminal_[s] != 0; }
  /// @brief True when some state is terminal.
  bool hasTerminalStates() const;

  /// @brief The start distribution (uniform unless set).
  const Belief& initialBelief() const { return b0_; }
  /// @brief Set the start distribution. @throws ConfigError if not a distribution over S.
  void setInitialBelief(const Belief& b0);

  /// @brief Names used in files and logs; defaults are "s0", "a0", "o0", ...
  const std::vector<std::string>& stateNames() const { return stateNames_; }
  const std::vector<std::string>& actionNames() const { return actionNames_; }
  const std::vector<std::string>& observationNames() const { return obsNames_; }
  /// @brief Replace the names. @throws ConfigError on wrong count or duplicate names.
  void setNames(std::vector<std::string> states, std::vector<std::string> actions,
                std::vector<std::string> observations);
  /// @brief Index of a name; @throws UnknownSymbolError naming the kind ("state", ...).
  std::size_t stateIndex(const std::string& name) const;
  std::size_t actionIndex(const std::string& name) const;
  std::size_t observationIndex(const std::string& name) const;

  /// @brief Tolerance used to validate probability sums.
  static constexpr double kTolerance = 1e-6;
  /// @brief Largest |R(s, a)| a model may have (the readers refuse larger reward entries at
  /// their file:line:col). It keeps every bound finite: for any double discount below 1,
  /// 1 / (1 - discount) <= 2^53 (about 9.0e15), so |V| <= |R| / (1 - discount) <= 9.0e27, and
  /// a finite horizon H (turn counters, at most 2^64) gives |R| * H <= 1.8e31; both are far
  /// below DBL_MAX (1.8e308), with room for the solver's sums over states and observations.
  /// Real models are nowhere near it (the dialog's largest reward is 120, RockSample's 10).
  static constexpr double kMaxAbsReward = 1e12;
  /// @brief kAuto keeps T dense up to this many states: below it, Eigen's vectorised dense
  /// products beat the sparse loops whatever the density (dialog models: 31 states).
  static constexpr std::size_t kDenseStates = 64;
  /// @brief kAuto keeps T dense above kDenseStates only with at least this share of non-zero
  /// entries (the sparse loops cost about 5x a dense multiply-add per entry).
  static constexpr double kDenseDensity = 0.2;
  /// @brief kAuto never keeps a dense T (with its transpose) or O above this many bytes: at
  /// RockSample[5,7] dense T alone is 0.98 GB, for 40k non-zero entries.
  static constexpr std::size_t kDenseBytes = std::size_t(64) << 20;

 private:
  std::size_t s_ = 0, a_ = 0, o_ = 0;
  double discount_ = 1.0;
  /// @brief Checks, derived flags and the choice of storage, shared by both constructors.
  void finish(ModelStorage storage, double timeLimit, double startSeconds);
  /// @brief Observation count, discount range and reward matrix shape and values, the checks
  /// both constructors (dense and sparse rows) make once the sizes are known.
  void checkSizesAndRewards(double discount) const;
  void validateRows(double timeLimit, double startSeconds) const;
  /// @brief out = T[a]^T v (transposed) or T[a] v, in whichever form T is kept.
  void applyTransition(std::size_t a, const Eigen::VectorXd& v, Eigen::VectorXd& out,
                       bool transposed) const;
  bool denseT_ = false, denseZ_ = false;
  std::vector<Eigen::MatrixXd> t_, tt_, z_;  // empty when the form is sparse
  Eigen::MatrixXd r_;
  std::vector<SparseRows> tRows_, zRows_;   // always kept: successors, sampling, sparse products
  std::vector<std::vector<std::size_t>> possibleObs_;
  std::vector<char> identity_, terminal_;
  Belief b0_;
  std::vector<std::string> stateNames_, actionNames_, obsNames_;
};

}  // namespace pomdp
}  // namespace krr
