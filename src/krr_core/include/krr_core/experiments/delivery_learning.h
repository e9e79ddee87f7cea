/**
 * @file delivery_learning.h
 * @brief Procedure 1 for the delivery routes, and the learned-knowledge cache of the delivery
 * experiment (paper, Table I: "outdated" knowledge learned at br = 0.3, "learned" knowledge
 * learned at the trial's br).
 *
 * The robot practises every delivery route (shop -> room and room -> shop for every room) with
 * R-Max in the simulated world at a given blocking rate (kb::FreeTimeLearner), and writes the
 * pairs it knows into the knowledge base as pr-atoms (knowledge extraction). The result is a
 * P-log file (kb::NavigationKnowledge::saveLearned); with a cache directory, the file is
 * written there under a name that encodes the domain, br, seed and a hash of the learning
 * parameters, and reused on the next run instead of learning again. Learning is deterministic
 * for a seed, so concurrent processes that miss the cache write identical files (atomically).
 */
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "krr_core/dialog/dialog_config.h"
#include "krr_core/kb/free_time_learner.h"

namespace krr {
namespace experiments {

/**
 * @brief Task selector of delivery learning: each round practises every route between the
 * shop and each room in both directions once, the route whose grid shortest path the
 * knowledge base knows least first (ties at random).
 */
class DeliveryRouteSelector : public kb::TaskSelector {
 public:
  /// @throws ConfigError with no room or a room equal to the shop.
  DeliveryRouteSelector(std::string shop, std::vector<std::string> rooms);
  kb::NavTask next(const kb::NavModel& current_model, const kb::NavStateSpace& space,
                   Rng& rng) override;
  /// @brief Routes per round (2 x rooms).
  std::size_t routesPerRound() const { return 2 * rooms_.size(); }

 private:
  std::string shop_;
  std::vector<std::string> rooms_;
  std::vector<kb::NavTask> remaining_;
};

/// @brief What prepareLearnedKnowledge did.
struct LearningReport {
  bool from_cache = false;
  std::string cache_file;         ///< empty without a cache directory
  std::size_t tasks = 0;          ///< tasks practised (0 from the cache)
  std::size_t episodes = 0;       ///< R-Max episodes run
  std::size_t pairs = 0;          ///< learned (cell, move) pairs in the knowledge base
  std::size_t areas = 0;          ///< blocking areas with learned knowledge (learning.mode areas)
  std::size_t samples = 0;        ///< moves the robot made while learning (0 from the cache)
  double seconds = 0.0;
};

/**
 * @brief Make `knowledge` hold exactly the knowledge learned on the delivery routes at
 * blocking rate `br` with root seed `seed` (its previous learned part is cleared): load it
 * from `cache_dir` if there, else learn (config's learning parameters, time of day
 * config.time) and, with a cache directory, save it there.
 * @param domain_name part of the cache key (the grid must be that domain's)
 * @throws ConfigError for br outside [0, 1]; IoError if the cache cannot be written.
 */
LearningReport prepareLearnedKnowledge(const kb::NavDomain& domain,
                                       kb::NavigationKnowledge& knowledge,
                                       const dialog::DialogConfig& config,
                                       const std::vector<std::string>& rooms,
                                       double br, std::uint64_t seed, const std::string& cache_dir,
                                       const std::string& domain_name);

/// @brief Cache file name of prepareLearnedKnowledge (without the directory): domain name, br,
/// seed and a hash of the learning parameters and of the simulator's configuration.
std::string learnedCacheName(const kb::NavDomain& domain, const dialog::DialogConfig& config,
                             const std::vector<std::string>& rooms, double br, std::uint64_t seed,
                             const std::string& domain_name);


}  // namespace experiments
}  // namespace krr
