#include "krr_core/mdp/environment.h"

#include <string>

#include "krr_core/common/errors.h"
#include "krr_core/mdp/trip.h"

namespace krr {
namespace mdp {

ModelEnvironment::ModelEnvironment(const SparseModel& model, StateId start,
                                   std::vector<StateId> goals)
    : model_(model), start_(start), state_(start) {
  if (start_ >= model_.getS()) {
    throw ConfigError("ModelEnvironment: start " + std::to_string(start_) + " out of range");
  }
  goal_.assign(model_.getS(), 0);
  for (StateId g : goals) {
    if (g >= model_.getS()) {
      throw ConfigError("ModelEnvironment: goal " + std::to_string(g) + " out of range");
    }
    goal_[g] = 1;
  }
}

StateId ModelEnvironment::reset() {
  state_ = start_;
  return state_;
}

StepResult ModelEnvironment::step(ActionId a, Rng& rng) {
  if (a >= model_.getA()) {
    throw ConfigError("ModelEnvironment::step: action " + std::to_string(a) + " out of range");
  }
  StepResult r;
  const auto sr = model_.sampleSR(state_, a, rng);
  state_ = sr.first;
  r.next = state_;
  r.reward = sr.second;
  r.done = model_.isTerminal(state_) || goal_[state_];
  r.failed = r.done && !goal_[state_];
  return r;
}

EpisodeResult runEpisode(Environment& env, Agent& agent, std::size_t step_limit,
                         double timeout_penalty, Rng& rng) {
  if (step_limit == 0) throw ConfigError("runEpisode: step_limit must be > 0, got 0");
  EpisodeResult res;
  StateId s = env.reset();
  const TripSummary trip = runTrip(false, step_limit, [&](std::size_t) {
    const ActionId a = agent.act(s);
    if (a >= env.numActions()) {
      throw ConfigError("runEpisode: agent chose action " + std::to_string(a) + " in state " +
                        std::to_string(s) + ", out of range [0, " +
                        std::to_string(env.numActions()) + ")");
    }
    const StepResult r = env.step(a, rng);
    res.total_reward += r.reward;
    agent.observe(s, a, r.reward, r.next, r.done);
    s = r.next;
    TripMove m;
    m.reached = r.done && !r.failed;
    m.failed = r.done && r.failed;
    return m;
  });
  res.steps = trip.moves;
  res.success = trip.end == TripEnd::kReached;
  res.failed = trip.end == TripEnd::kFailed;
  if (trip.end == TripEnd::kStepLimit) {
    res.timed_out = true;
    res.total_reward -= timeout_penalty;
  }
  return res;
}

std::vector<EpisodeResult> runEpisodes(Environment& env, Agent& agent, std::size_t episodes,
                                       std::size_t step_limit, double timeout_penalty,
                                       Rng& rng) {
  std::vector<EpisodeResult> out;
  out.reserve(episodes);
  for (std::size_t e = 0; e < episodes; ++e) {
    out.push_back(runEpisode(env, agent, step_limit, timeout_penalty, rng));
  }
  return out;
}

}  // namespace mdp
}  // namespace krr
