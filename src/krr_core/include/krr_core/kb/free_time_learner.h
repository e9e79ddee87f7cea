/**
 * @file free_time_learner.h
 * @brief Procedure 1 of the paper: while the robot has no task it selects navigation tasks,
 * learns them with R-Max, and writes what it knows back into the knowledge base.
 *
 * For each selected task the learner starts R-Max from the model the knowledge base gives
 * (Procedure 2: pairs backed by learned knowledge start known), runs episodes until the task
 * converged (no newly known pair for `convergence_episodes` episodes) or the episode budget is
 * spent, and extracts into the knowledge base either the known pairs or (the default) the
 * pooled estimates of what the knowledge says is shared: every sample of the learner so far,
 * pooled per blocking area (kb/area_knowledge.h). An interruption (a task
 * arrived) is checked between episodes; the pairs known so far are extracted before returning,
 * so an interrupted session loses nothing it learned.
 */
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "krr_core/kb/nav_domain.h"
#include "krr_core/kb/navigation_learning.h"

namespace krr {
namespace kb {

/// @brief A navigation task: drive from one named place to another.
struct NavTask {
  std::string start;
  std::string goal;
};

/// @brief The task selector Delta of Procedure 1.
class TaskSelector {
 public:
  virtual ~TaskSelector() = default;
  /// @brief The next task to practise, given how much the KB already knows.
  virtual NavTask next(const NavModel& current_model, const NavStateSpace& space, Rng& rng) = 0;
};

/**
 * @brief The task of `tasks` whose grid shortest route has the most moves `model` has not
 * learned yet (ties broken uniformly with one draw of `rng`): the "least known" rule of
 * LeastKnownSelector and of the delivery experiments' route selector, in one place.
 * @return its index. @throws ConfigError when `tasks` is empty.
 */
std::size_t leastKnownTask(const std::vector<NavTask>& tasks, const NavModel& model,
                           const NavStateSpace& space, Rng& rng);

/**
 * @brief Practise the task whose route the knowledge base knows least: for every candidate
 * (start, goal) pair, count the unknown pairs along the grid shortest path and pick the
 * largest count (ties broken at random). A simple curriculum; the paper leaves it open.
 */
class LeastKnownSelector : public TaskSelector {
 public:
  /// @brief `start`: where every practised task begins, the site's (no default place name).
  /// @throws ConfigError when fewer than two places are given.
  LeastKnownSelector(std::vector<std::string> places, std::string start);
  NavTask next(const NavModel& current_model, const NavStateSpace& space, Rng& rng) override;

 private:
  std::vector<std::string> places_;
  std::string start_;
};

/// @brief The trivial selector: always the same task (practise one route, e.g. per setting).
class FixedTaskSelector : public TaskSelector {
 public:
  explicit FixedTaskSelector(NavTask task) : task_(std::move(task)) {}
  NavTask next(const NavModel&, const NavStateSpace&, Rng&) override { return task_; }

 private:
  NavTask task_;
};

/// @brief What knowledge extraction writes back.
enum class Extraction {
  kPairs,  ///< each (cell, move) pair R-Max knows, as its own distribution
  kAreas,  ///< what the knowledge base says is shared: per blocking area (area_knowledge.h)
};

/// @brief "pairs" / "areas". @throws ConfigError for another name (fromString).
std::string toString(Extraction e);
Extraction extractionFromString(const std::string& name);

/// @brief Parameters of a free-time learning session.
struct FreeTimeOptions {
  Extraction extraction = Extraction::kAreas;
  std::string time = "morning";     ///< time of day the robot learns in (the KB context)
  double blocking_rate = -1;        ///< simulated br (< 0: the simulator's configuration)
  std::size_t max_episodes_per_task = 300;
  std::size_t convergence_episodes = 20;
  std::size_t max_tasks = 0;        ///< 0: until interrupted
  mdp::RMaxParams rmax;             ///< step_limit is taken from the domain
  void validate() const;
};

/// @brief What a session did.
struct FreeTimeReport {
  std::vector<NavTask> tasks;          ///< tasks practised, in order
  std::vector<std::size_t> episodes;   ///< episodes run per task
  std::vector<bool> converged;         ///< per task
  std::size_t pairs_extracted = 0;     ///< pairs (or areas) written to the KB, summed over tasks
  std::size_t samples = 0;             ///< own samples of the session (every move)
  bool interrupted = false;
};

class FreeTimeLearner {
 public:
  /// @param samples where the learner pools its samples (area extraction estimates from all of
  ///        them); pass the same one to later learners to keep pooling (a node learning between
  ///        tasks), or nothing for a private one.
  FreeTimeLearner(const NavDomain& domain, NavigationKnowledge& knowledge,
                  TaskSelector& selector, const FreeTimeOptions& options,
                  std::shared_ptr<mdp::VisitCounts> samples = nullptr);

  /**
   * @brief Run Procedure 1 until `interrupted()` returns true (checked before every episode)
   * or max_tasks tasks are done. `on_task` (optional) is called after each extraction, e.g.
   * to persist the learned knowledge.
   */
  FreeTimeReport run(Rng& rng, const std::function<bool()>& interrupted,
                     const std::function<void(const NavTask&)>& on_task = {});

 private:
  const NavDomain& domain_;
  NavigationKnowledge& knowledge_;
  TaskSelector& selector_;
  FreeTimeOptions options_;
  /// Every own sample of the learner's sessions (area extraction pools them all).
  std::shared_ptr<mdp::VisitCounts> samples_;
};

}  // namespace kb
}  // namespace krr
