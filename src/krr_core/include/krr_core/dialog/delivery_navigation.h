/**
 * @file delivery_navigation.h
 * @brief The navigation side of deliveries: the robot's policies between the shop and the
 * rooms, the paper's P^N(shop, room) and P^N(room, shop), and the expected navigation cost of
 * each trip, all computed exactly from a navigation model built from the knowledge base.
 *
 * Input: the transition model of Procedure 2 (kb::NavigationKnowledge::buildModel) over the
 * free cells plus the absorbing `trapped` state. For every destination (each room and the
 * shop) the navigation task of the paper (every move costs step_cost, +Rmax on reaching the
 * goal, -Rmax when trapped) is solved by value iteration; the greedy policy is what the robot
 * drives with. Discounting is configurable and defaults to 1 (an episodic task with a step
 * limit): with the R-Max learner's discount 0.95 a policy may prefer never to set off through a
 * blocking area (waiting forever costs only 1 / (1 - 0.95) = 20 < Rmax), which would make a
 * hard room unreachable instead of risky. Under the fixed policy, with the episode's step
 * limit N,
 *   P^N(x, y) = P(reach y within N moves)  (mdp::reachProbability, exact),
 *   M(x, y)   = E[moves made before arriving, being trapped or hitting the limit]  (exact),
 *   C(x, y)   = step_cost M(x, y) + failure_penalty (1 - P^N(x, y)),
 * C being the paper's navigation reward without the goal bonus, as a cost.
 *
 * execute() drives one trip in the blockage simulator (the world at the trial's blocking
 * rate) with the same policy, so the knowledge the model came from (learned or outdated)
 * decides both what the dialog manager expects and how the robot actually drives.
 */
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "krr_core/common/random.h"
#include "krr_core/dialog/dialog_config.h"
#include "krr_core/kb/nav_domain.h"
#include "krr_core/kb/navigation_knowledge.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/sparse_model.h"
#include "krr_core/nav/blockage_simulator.h"

namespace krr {
namespace dialog {

/// @brief Parameters of delivery navigation.
struct DeliveryNavigationOptions {
  std::string shop;                  ///< place every delivery starts from (DialogConfig::shop)
  std::vector<std::string> rooms;    ///< destination places, in the dialog's room order
  mdp::NavigationReward reward{1.0, 40.0};  ///< step cost and Rmax of the navigation task
  double discount = 1.0;             ///< of the navigation task solved for the policies
  std::size_t step_limit = 200;      ///< moves per trip (the domain's episode limit)
  double epsilon = 1e-6;             ///< value-iteration accuracy
  double failure_penalty = 40.0;     ///< cost of a failed trip in C(x, y) and in execute()
  /// @throws ConfigError naming the field.
  void validate() const;
  /// @brief The options of config/dialog.yaml's navigation section for `rooms`.
  static DeliveryNavigationOptions fromConfig(const DialogConfig& c, std::vector<std::string> rooms,
                                              std::size_t step_limit);
};

/// @brief Exact figures of one trip under the robot's policy.
struct TripEstimate {
  double reach = 0.0;  ///< P^N(x, y)
  double moves = 0.0;  ///< M(x, y): expected moves made (success, trap or step limit)
  double cost = 0.0;   ///< C(x, y) = step_cost M + failure_penalty (1 - P^N)
};

/**
 * @brief What the dialog's serve reward needs of navigation: every delivery trip's figures
 * by room (shop -> room and room -> shop, in the dialog's room order). DeliveryNavigation
 * computes it from a navigation model; fromReach() builds it when only P^N are known.
 */
struct TripTable {
  std::vector<std::string> rooms;
  std::vector<TripEstimate> to_room, to_shop;
  /// @brief P^N(shop, room) for every room.
  Eigen::VectorXd reachFromShop() const;
  /// @brief P^N(room, shop) for every room.
  Eigen::VectorXd reachBack() const;
  /**
   * @brief Trips known only by their reach probabilities (no navigation model): moves
   * unknown (0), cost failure_penalty (1 - P^N). back empty: P^N(room, shop) = P^N(shop, room).
   * @throws ConfigError on sizes, probabilities outside [0, 1] or a negative penalty.
   */
  static TripTable fromReach(const std::vector<std::string>& rooms, const std::vector<double>& reach,
                             const std::vector<double>& back, double failure_penalty);
};

/// @brief What happened on one simulated trip.
struct TripResult {
  bool reached = false;  ///< arrived within the step limit
  bool trapped = false;  ///< ended by a trap (else, if not reached: the step limit)
  std::size_t moves = 0;
};

class DeliveryNavigation {
 public:
  /**
   * @param space the state space of `dynamics` (free cells + trapped)
   * @param dynamics Procedure 2's model (its rewards and discount are ignored)
   * @throws ConfigError on invalid options or a model of the wrong size, UnknownSymbolError
   *         for a place the grid does not have.
   */
  DeliveryNavigation(const kb::NavStateSpace& space, const mdp::SparseModel& dynamics,
                     const DeliveryNavigationOptions& options);

  std::size_t numRooms() const { return options_.rooms.size(); }
  const DeliveryNavigationOptions& options() const { return options_; }
  /// @brief Index of a room name. @throws UnknownSymbolError.
  std::size_t roomIndex(const std::string& room) const;

  /// @brief shop -> room r.
  const TripEstimate& toRoom(std::size_t r) const { return to_room_.at(r); }
  /// @brief room r -> shop.
  const TripEstimate& toShop(std::size_t r) const { return to_shop_.at(r); }
  /// @brief Every trip's figures, for the dialog model.
  TripTable trips() const;
  /**
   * @brief The same trips, driven with the same policies (chosen on this model), under other
   * dynamics over the same states, e.g. the simulator's true ones (kb::trueDynamics): what the
   * robot actually achieves with the knowledge it has. @throws ConfigError on a size mismatch.
   */
  TripTable evaluate(const mdp::SparseModel& dynamics) const;

  /// @brief The robot's move in each state (trapped: 0) when heading to room r / to the shop.
  const std::vector<mdp::ActionId>& policyToRoom(std::size_t r) const { return policy_.at(r); }
  const std::vector<mdp::ActionId>& policyToShop() const { return policy_.back(); }

  /**
   * @brief Drive shop -> room r (toRoom = true) or room r -> shop in the simulator under
   * `context`, at most step_limit moves. The simulator must be over the same grid.
   */
  TripResult execute(const nav::BlockageSimulator& sim, std::size_t r, bool toRoom,
                     const nav::Context& context, Rng& rng) const;

 private:
  TripEstimate estimate(const mdp::SparseModel& task, const std::vector<mdp::ActionId>& policy,
                        mdp::StateId start, mdp::StateId goal) const;

  const kb::NavStateSpace& space_;
  DeliveryNavigationOptions options_;
  std::vector<int> room_cell_;
  int shop_cell_ = -1;
  std::vector<std::vector<mdp::ActionId>> policy_;  // rooms..., then shop
  std::vector<TripEstimate> to_room_, to_shop_;
};

/**
 * @brief Delivery navigation on Procedure 2's model of `knowledge` for config.time (the robot's
 * current navigation knowledge, with whatever it has learned), with the options of
 * config/dialog.yaml and the domain's step limit.
 */
std::unique_ptr<DeliveryNavigation> deliveryNavigationFromKnowledge(
    const kb::NavDomain& domain, kb::NavigationKnowledge& knowledge, const DialogConfig& config,
    const std::vector<std::string>& rooms);

}  // namespace dialog
}  // namespace krr
