/**
 * @file model.h
 * @brief A finite, discrete POMDP with dense matrices and sparse per-action views.
 *
 * The interface follows AI-Toolbox (getS/getA/getO, getTransitionProbability, ...), so that
 * code written against that library reads the same here. Dialog POMDPs have a few dozen
 * states, so dense Eigen storage is cheap; the solver and the simulator additionally use the
 * sparse successor lists, the per-action observation support and the identity/terminal flags
 * computed once at construction (questions do not move the hidden state, serving ends the
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

/// @brief Discrete POMDP <S, A, O, T, Z, R, gamma> with an initial belief and optional names.
class Model {
 public:
  /// @brief One non-zero entry of a sparse row: (index, probability).
  using Entry = std::pair<std::size_t, double>;

  /**
   * @brief Build and validate a model.
   * @param transitions one S x S matrix per action, T[a](s, s1) = P(s1 | s, a)
   * @param observations one S x O matrix per action, O[a](s1, o) = P(o | s1, a)
   * @param rewards S x A matrix of expected immediate rewards R(s, a)
   * @param discount in (0, 1]
   * @param timeLimit seconds the construction may take (0: no limit). Building a model of
   *        thousands of states takes about a second; a caller with a time budget (pomdp_solve
   *        --timeout) passes what is left of it, so that construction cannot overrun it.
   * @throws ConfigError naming the action, state and offending sum or value, or saying that
   *        the time limit was reached.
   */
  Model(std::vector<Eigen::MatrixXd> transitions, std::vector<Eigen::MatrixXd> observations,
        Eigen::MatrixXd rewards, double discount, double timeLimit = 0.0);

  std::size_t getS() const { return s_; }
  std::size_t getA() const { return a_; }
  std::size_t getO() const { return o_; }
  double getDiscount() const { return discount_; }
  double getTransitionProbability(std::size_t s, std::size_t a, std::size_t s1) const {
    return t_[a](s, s1);
  }
  double getObservationProbability(std::size_t s1, std::size_t a, std::size_t o) const {
    return z_[a](s1, o);
  }
  double getExpectedReward(std::size_t s, std::size_t a) const { return r_(s, a); }

  /// @brief Sample (s1, o, r) from state s under action a; r is the expected reward R(s, a).
  std::tuple<std::size_t, std::size_t, double> sampleSOR(std::size_t s, std::size_t a,
                                                         Rng& rng) const;

  /// @brief T[a] as an S x S matrix (rows: s, columns: s1).
  const Eigen::MatrixXd& transitionMatrix(std::size_t a) const { return t_[a]; }
  /// @brief Transposed T[a] (rows: s1), so that predict(b) = T[a]^T b is a column product.
  const Eigen::MatrixXd& transitionMatrixTransposed(std::size_t a) const { return tt_[a]; }
  /// @brief Z[a] as an S x O matrix (rows: s1, columns: o).
  const Eigen::MatrixXd& observationMatrix(std::size_t a) const { return z_[a]; }
  /// @brief R as an S x A matrix.
  const Eigen::MatrixXd& rewardMatrix() const { return r_; }

  /// @brief Non-zero successors of (s, a), for sampling and sparse backups.
  const std::vector<Entry>& successors(std::size_t s, std::size_t a) const {
    return succ_[a * s_ + s];
  }
  /// @brief Non-zero observations of (s1, a).
  const std::vector<Entry>& observationRow(std::size_t s1, std::size_t a) const {
    return obsRow_[a * s_ + s1];
  }
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

 private:
  std::size_t s_ = 0, a_ = 0, o_ = 0;
  double discount_ = 1.0;
  std::vector<Eigen::MatrixXd> t_, tt_, z_;
  Eigen::MatrixXd r_;
  std::vector<std::vector<Entry>> succ_, obsRow_;
  std::vector<std::vector<std::size_t>> possibleObs_;
  std::vector<char> identity_, terminal_;
  Belief b0_;
  std::vector<std::string> stateNames_, actionNames_, obsNames_;
};

}  // namespace pomdp
}  // namespace krr
