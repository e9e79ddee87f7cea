#include "krr_core/mdp/environment.h"

#include <string>

#include "krr_core/common/errors.h"

namespace krr {
namespace mdp {

GridWorldEnvironment::GridWorldEnvironment(GridDynamics dynamics, StateId start,
                                           std::vector<StateId> goals,
                                           const NavigationReward& reward)
    : dyn_(std::move(dynamics)), start_(start), goals_(std::move(goals)), reward_(reward) {
  dyn_.validate();
  reward_.validate();
  goal_.assign(dyn_.numCells() + 1, 0);
  for (StateId g : goals_) {
    if (g >= dyn_.numCells() || dyn_.blocked[g]) {
      throw ConfigError("GridWorldEnvironment: goal " + std::to_string(g) +
                        " is out of range or an obstacle");
    }
    goal_[g] = 1;
  }
  if (start_ >= dyn_.numCells() || dyn_.blocked[start_] || goal_[start_]) {
    throw ConfigError("GridWorldEnvironment: start " + std::to_string(start_) +
                      " is out of range, an obstacle or a goal");
  }
  state_ = start_;
}

StateId GridWorldEnvironment::reset() {
  state_ = start_;
  return state_;
}

StepResult GridWorldEnvironment::step(ActionId a, Rng& rng) {
  if (a >= 4) throw ConfigError("GridWorldEnvironment::step: action " + std::to_string(a) +
                                " out of range [0, 4)");
  StepResult r;
  if (state_ >= dyn_.numCells() || goal_[state_]) {  // already over: stay
    r.next = state_;
    r.done = true;
    r.failed = state_ == failureState();
    return r;
  }
  double u = uniform01(rng);
  unsigned slot = kStay;
  for (unsigned k = 0; k < 6; ++k) {
    const double p = dyn_.p(state_, a, k);
    if (p <= 0.0) continue;
    slot = k;
    u -= p;
    if (u < 0.0) break;
  }
  state_ = dyn_.target(state_, slot);
  r.next = state_;
  r.failed = slot == kFail;
  const bool goal = !r.failed && goal_[state_];
  r.done = r.failed || goal;
  r.reward = reward_.arrival(goal, r.failed);
  return r;
}

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
  while (res.steps < step_limit) {
    const ActionId a = agent.act(s);
    if (a >= env.numActions()) {
      throw ConfigError("runEpisode: agent chose action " + std::to_string(a) + " in state " +
                        std::to_string(s) + ", out of range [0, " +
                        std::to_string(env.numActions()) + ")");
    }
    const StepResult r = env.step(a, rng);
    ++res.steps;
    res.total_reward += r.reward;
    agent.observe(s, a, r.reward, r.next, r.done);
    s = r.next;
    if (r.done) {
      res.failed = r.failed;
      res.success = !r.failed;
      return res;
    }
  }
  res.timed_out = true;
  res.total_reward -= timeout_penalty;
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
