/**
 * @file grid_model.h
 * @brief Grid-specialised MDP layout for 4-connected navigation grids (the fast path).
 *
 * A W x H grid has cell states 0..W*H-1 (cell (x, y) is y*W + x, y = 0 is the top row) and one
 * absorbing failure state W*H (the robot is trapped). The four actions are up (y-1), down
 * (y+1), left (x-1), right (x+1). Each (cell, action) has six outcome probabilities: stay, up,
 * down, left, right, fail. Neighbour indices are implicit. The five outcomes a sweep reads
 * (the failure state is worth 0, so its probability never enters a backup) and the expected
 * reward are stored in blocks of kLanes = 8 neighbouring cells of a row ("array of structures
 * of arrays": for each block, action and outcome slot, 8 contiguous values), so the solver's
 * inner loop reads one contiguous stream and vectorises across the 8 cells (one AVX-512 or two
 * AVX2 registers) with compile-time offsets; failure probabilities live in a separate array
 * that only the model's accessors read. Rows are padded to a multiple of 8 cells with inert
 * cells. A move off the grid leaves the robot in place (it is folded into "stay"); other
 * obstacles are the caller's business (see navigation_task.h).
 *
 * P is the storage type of probabilities and rewards: double for exactness (tests,
 * conversion to SparseModel), float to halve memory traffic on very large grids. Values are
 * always computed in double.
 */
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "krr_core/common/random.h"
#include "krr_core/mdp/sparse_model.h"

namespace krr {
namespace mdp {

/// @brief Outcome slots of a grid action (also the order of the probability array).
enum GridOutcome : unsigned { kStay = 0, kUp = 1, kDown = 2, kLeft = 3, kRight = 4, kFail = 5 };
/// @brief Grid actions; action a moves towards outcome slot a + 1.
enum GridAction : unsigned { kActUp = 0, kActDown = 1, kActLeft = 2, kActRight = 3 };

/// @brief Grid MDP in structure-of-arrays layout; see the file comment.
template <class P>
class BasicGridModel {
 public:
  static constexpr unsigned kNumActions = 4;
  static constexpr unsigned kNumOutcomes = 6;
  static constexpr unsigned kLanes = 8;  ///< cells per storage block
  /// @brief Outcome slots stored in the sweep blocks: stay, up, down, left, right.
  static constexpr unsigned kSweepOutcomes = 5;
  /// @brief Values per block: actions x sweep outcome slots x lanes.
  static constexpr unsigned kBlockSize = kNumActions * kSweepOutcomes * kLanes;
  using Probabilities = std::array<double, kNumOutcomes>;

  /**
   * @brief A grid where every action keeps the robot in place with reward 0.
   * @throws ConfigError when a dimension is 0 or too large, or the discount is outside [0,1].
   */
  BasicGridModel(std::uint32_t width, std::uint32_t height, double discount);

  std::uint32_t width() const { return w_; }
  std::uint32_t height() const { return h_; }
  std::size_t numCells() const { return static_cast<std::size_t>(w_) * h_; }
  /// @brief Cells plus the failure state.
  std::size_t getS() const { return numCells() + 1; }
  std::size_t getA() const { return kNumActions; }
  double getDiscount() const { return discount_; }
  StateId failureState() const { return static_cast<StateId>(numCells()); }
  StateId cell(std::uint32_t x, std::uint32_t y) const { return y * w_ + x; }

  /**
   * @brief Set the outcome probabilities {stay, up, down, left, right, fail} and expected
   * reward of (cell, a). Moves off the grid are added to "stay".
   * @throws ConfigError naming cell, action and value for a probability outside [0, 1], a sum
   * not 1 within 1e-9, a non-finite reward or an index out of range.
   */
  void setOutcomes(StateId cell, ActionId a, const Probabilities& p, double reward);
  /// @brief Absorbing, value-0 cell (goal, obstacle). The failure state is always terminal.
  void setTerminal(StateId cell, bool terminal = true);
  bool isTerminal(StateId s) const { return s >= numCells() || live_[liveIndex(s)] == P(0); }

  /// @brief Stored probability of outcome slot k of (cell, a) (0 for the failure state).
  double outcomeProbability(StateId cell, ActionId a, unsigned k) const;
  /// @brief Next state of outcome slot k from cell (after folding, the neighbour or failure).
  StateId outcomeState(StateId cell, unsigned k) const;

  double getTransitionProbability(StateId s, ActionId a, StateId s1) const;
  double getExpectedReward(StateId s, ActionId a) const;
  std::pair<StateId, double> sampleSR(StateId s, ActionId a, Rng& rng) const;

  /// @brief The same MDP in the general layout (probabilities converted to double).
  SparseModel toSparse() const;

  /// @name Raw rows for the solvers.
  /// @{
  /// @brief Row width rounded up to a multiple of kLanes (padding cells are inert, value 0).
  std::size_t paddedWidth() const { return static_cast<std::size_t>(wb_) * kLanes; }
  /// @brief Blocks of row y: block b holds prob[a][k][lane] (k < kSweepOutcomes) of cells
  /// 8b..8b+7.
  const P* probBlocks(std::uint32_t y) const {
    return prob_.data() + static_cast<std::size_t>(y) * wb_ * kBlockSize;
  }
  /// @brief Rewards of row y: block b holds reward[a][lane].
  const P* rewardBlocks(std::uint32_t y) const {
    return reward_.data() + static_cast<std::size_t>(y) * wb_ * kNumActions * kLanes;
  }
  /// @brief 1 for non-terminal cells, 0 for terminal and padding ones (paddedWidth() values).
  const P* liveRow(std::uint32_t y) const { return live_.data() + static_cast<std::size_t>(y) * paddedWidth(); }
  /// @brief Bytes of model data a sweep reads.
  std::size_t modelBytes() const { return (prob_.size() + reward_.size() + live_.size()) * sizeof(P); }
  /// @brief Bytes of model data a sweep reads per row.
  std::size_t rowBytes() const { return modelBytes() / h_; }
  /// @}

 private:
  std::size_t probIndex(StateId cell, ActionId a, unsigned k) const {
    const std::size_t y = cell / w_, x = cell % w_;
    return (((y * wb_ + x / kLanes) * kNumActions + a) * kSweepOutcomes + k) * kLanes + x % kLanes;
  }
  std::size_t rewardIndex(StateId cell, ActionId a) const {
    const std::size_t y = cell / w_, x = cell % w_;
    return ((y * wb_ + x / kLanes) * kNumActions + a) * kLanes + x % kLanes;
  }
  std::size_t liveIndex(StateId cell) const {
    return static_cast<std::size_t>(cell / w_) * paddedWidth() + cell % w_;
  }

  std::uint32_t w_, h_;
  std::uint32_t wb_;  // blocks per row
  double discount_;
  std::vector<P> prob_;
  std::vector<P> fail_;  // [cell][action], outside the sweep blocks
  std::vector<P> reward_;
  std::vector<P> live_;
};

using GridModel = BasicGridModel<double>;
using GridModelF = BasicGridModel<float>;

extern template class BasicGridModel<double>;
extern template class BasicGridModel<float>;

}  // namespace mdp
}  // namespace krr
