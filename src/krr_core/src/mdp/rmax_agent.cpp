#include "krr_core/common/format.h"
#include "krr_core/mdp/rmax_agent.h"

#include <cmath>
#include <sstream>
#include <string>

#include "krr_core/common/errors.h"

namespace krr {
namespace mdp {

namespace {

std::string num(double v) { return formatNumber(v, 17); }

SolverOptions solverOptions(const RMaxParams& p) {
  SolverOptions o;
  o.epsilon = p.epsilon;
  o.max_iterations = p.max_sweeps;
  return o;
}

}  // namespace

void RMaxParams::validate() const {
  if (known_threshold == 0) throw ConfigError("RMaxParams.known_threshold (M) must be >= 1, got 0");
  if (!(rmax > 0.0) || !std::isfinite(rmax)) {
    throw ConfigError("RMaxParams.rmax must be > 0, got " + num(rmax));
  }
  if (!(discount > 0.0 && discount <= 1.0)) {
    throw ConfigError("RMaxParams.discount must be in (0, 1], got " + num(discount));
  }
  if (optimism == Optimism::kSelfLoop && discount >= 1.0) {
    throw ConfigError("RMaxParams.discount must be < 1 with Optimism::kSelfLoop, got " +
                      num(discount));
  }
  if (!(step_cost >= 0.0 && step_cost < rmax)) {
    throw ConfigError("RMaxParams.step_cost must be in [0, rmax), got " + num(step_cost));
  }
  if (step_limit == 0) throw ConfigError("RMaxParams.step_limit must be >= 1, got 0");
  if (!(epsilon > 0.0) || !std::isfinite(epsilon)) {
    throw ConfigError("RMaxParams.epsilon must be > 0, got " + num(epsilon));
  }
  if (max_sweeps == 0) throw ConfigError("RMaxParams.max_sweeps must be >= 1, got 0");
}

RMaxAgent::RMaxAgent(RMaxTask task, const RMaxParams& params)
    : params_((params.validate(), params)),
      model_(std::move(task), params.discount, params.known_threshold, params.rmax,
             params.optimism, params.refine_known) {
  values_.assign(model_.getS(), 0.0);
  policy_.assign(model_.getS(), 0);
  queued_.assign(model_.getS(), 0);
}

void RMaxAgent::setPrior(StateId s, ActionId a, const Distribution& d, bool known) {
  model_.setPrior(s, a, d, known);
  if (known) due_ = true;
}

Solution RMaxAgent::solveCold() const { return valueIterationView(model_, solverOptions(params_)); }

void RMaxAgent::replan() {
  due_ = false;
  ++stats_.replans;
  if (!planned_ || !params_.local_replanning) {
    // The first plan starts from zeros; later full plans start from the previous values.
    Solution sol =
        valueIterationView(model_, solverOptions(params_), planned_ ? &values_ : nullptr);
    model_.takeChanged();
    stats_.sweeps += sol.iterations;
    stats_.last_plan_backups = sol.iterations * model_.getS();
    stats_.backups += stats_.last_plan_backups;
    values_ = std::move(sol.values);
    policy_ = std::move(sol.policy);
    planned_ = true;
    return;
  }
  replanLocal(model_.takeChanged());
}

void RMaxAgent::replanLocal(const std::vector<StateId>& changed) {
  const double threshold = stoppingThreshold(params_.epsilon, params_.discount);
  const std::size_t cap = params_.max_sweeps * model_.getS();
  // FIFO worklist in a ring over queue_ (each state is queued at most once at a time).
  const std::size_t n = model_.getS();
  if (queue_.size() != n) queue_.assign(n, 0);
  std::size_t head = 0, size = 0;
  auto push = [&](StateId s) {
    if (queued_[s]) return;
    queued_[s] = 1;
    queue_[(head + size) % n] = s;
    ++size;
  };
  for (StateId s : changed) push(s);
  std::size_t backups = 0;
  while (size > 0 && backups < cap) {
    const StateId s = queue_[head];
    head = (head + 1) % n;
    --size;
    queued_[s] = 0;
    if (model_.isTerminal(s)) continue;
    const double v = bellmanBackup(model_, values_, s, &policy_[s]);
    ++backups;
    const double d = std::fabs(v - values_[s]);
    values_[s] = v;
    if (d > threshold) {
      for (StateId p : model_.predecessors(s)) push(p);
    }
  }
  while (size > 0) {  // budget exhausted: leave no stale flags behind
    queued_[queue_[head]] = 0;
    head = (head + 1) % n;
    --size;
  }
  stats_.last_plan_backups = backups;
  stats_.backups += backups;
}

ActionId RMaxAgent::act(StateId s) {
  if (s >= model_.getS() - 1) {
    throw ConfigError("RMaxAgent::act: state " + std::to_string(s) + " out of range [0, " +
                      std::to_string(model_.getS() - 1) + ")");
  }
  if (due_ || !planned_) replan();
  return policy_[s];
}

void RMaxAgent::observe(StateId s, ActionId a, double /*reward*/, StateId s1, bool /*done*/) {
  const RMaxModel::Update u = model_.observe(s, a, s1);
  ++stats_.steps;
  if (u == RMaxModel::Update::kNewlyKnown) due_ = true;
  if (params_.replan_every > 0 && stats_.steps % params_.replan_every == 0) due_ = true;
}

const std::vector<double>& RMaxAgent::values() {
  if (due_ || !planned_) replan();
  return values_;
}

const std::vector<ActionId>& RMaxAgent::policy() {
  if (due_ || !planned_) replan();
  return policy_;
}

}  // namespace mdp
}  // namespace krr
