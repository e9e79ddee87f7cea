#include "krr_core/common/parallel.h"
#include "krr_core/dialog/delivery_experiment.h"

#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/resources.h"
#include "krr_core/pomdp/belief.h"
#include "krr_core/pomdp/tiger.h"

namespace krr {
namespace dialog {

std::string toString(KnowledgeCondition c) {
  return c == KnowledgeCondition::kLearned ? "learned" : "outdated";
}

KnowledgeCondition conditionFromString(const std::string& text) {
  if (text == "learned") return KnowledgeCondition::kLearned;
  if (text == "outdated") return KnowledgeCondition::kOutdated;
  throw ConfigError("condition '" + text + "' must be learned or outdated");
}

void DeliveryExperimentOptions::validate() const {
  auto bad = [](const std::string& f, double v) {
    throw ConfigError("delivery experiment: field '" + f + "': value " + std::to_string(v) +
                      " must be in [0, 1]");
  };
  if (!(blocking_rate >= 0 && blocking_rate <= 1)) bad("blocking_rate", blocking_rate);
  if (!(outdated_rate >= 0 && outdated_rate <= 1)) bad("outdated_rate", outdated_rate);
  if (domain_name.empty()) throw ConfigError("delivery experiment: field 'domain_name' is empty");
}

namespace {

bool fileExists(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

std::size_t sample(const Eigen::VectorXd& p, Rng& rng) {
  double u = uniform01(rng);
  for (Eigen::Index k = 0; k < p.size(); ++k) {
    if (u < p(k)) return static_cast<std::size_t>(k);
    u -= p(k);
  }
  // Rounding: the last entry with positive probability.
  for (Eigen::Index k = p.size() - 1; k > 0; --k)
    if (p(k) > 0) return static_cast<std::size_t>(k);
  return 0;
}

/// A fingerprint of the solver's behaviour (its policy on the Tiger problem after a fixed
/// number of trials), part of the policy cache key: a changed solver does not reuse policies
/// cached by an older one.
std::uint64_t solverFingerprint() {
  static const std::uint64_t fp = [] {
    const pomdp::Model tiger = pomdp::makeTiger();
    pomdp::SolverOptions so;
    so.precision = 1e-12;
    so.timeout = 1e9;
    so.maxTrials = 25;
    so.initTimeLimit = std::numeric_limits<double>::infinity();
    pomdp::PointBasedSolver solver(tiger, tiger.initialBelief(), so);
    solver.solve();
    return stableHash(solver.policy().toText());
  }();
  return fp;
}

}  // namespace

pomdp::AlphaVectorPolicy solveDialogPolicy(const pomdp::DialogPomdp& dialog,
                                           const DialogConfig& config,
                                           const std::string& cache_dir,
                                           PreparationReport* report) {
  Stopwatch clock;
  std::string file;
  if (!cache_dir.empty()) {
    std::ostringstream key;
    key.precision(17);
    key << "v2|" << solverFingerprint() << "|" << config.solver_precision << "|"
        << config.solver_max_trials << "|" << dialog.exportCassandra();
    char name[64];
    std::snprintf(name, sizeof(name), "policy_%016llx.txt",
                  static_cast<unsigned long long>(stableHash(key.str())));
    file = cache_dir + "/" + name;
    if (report) report->policy_file = file;
    if (fileExists(file)) {
      pomdp::AlphaVectorPolicy p = pomdp::AlphaVectorPolicy::load(file);
      if (p.numStates() != dialog.model().getS())
        throw ConfigError(file + ": cached policy has " + std::to_string(p.numStates()) +
                          " states, the dialog model " + std::to_string(dialog.model().getS()));
      if (report) {
        report->policy_from_cache = true;
        report->reproducible = true;  // only reproducible policies are cached
        report->solve_seconds = clock.seconds();
      }
      return p;
    }
  }
  pomdp::SolverOptions so;
  so.precision = config.solver_precision;
  so.timeout = config.solver_timeout;
  so.maxTrials = config.solver_max_trials;
  so.initTimeLimit = std::numeric_limits<double>::infinity();  // bounded by iterations only
  pomdp::PointBasedSolver solver(dialog.model(), dialog.model().initialBelief(), so);
  const bool converged = solver.solve();
  const pomdp::BoundsReport bounds = solver.report();
  const bool reproducible =
      converged || (so.maxTrials > 0 && bounds.trials >= so.maxTrials && bounds.time < so.timeout);
  pomdp::AlphaVectorPolicy policy = solver.policy();
  // Complete the lower bound with the exact value of serving at once (serving ends the
  // episode, so R(., serve a) is a valid alpha vector): point-based pruning drops serve vectors
  // that are not best at the beliefs the trials visited, and without them the policy compares
  // serving with asking arbitrarily at other beliefs (e.g. Table II's random beliefs).
  const pomdp::Model& m = dialog.model();
  for (std::size_t r = 0; r < dialog.numRequests(); ++r) {
    const std::size_t a = dialog.serveAction(r);
    Eigen::VectorXd alpha = m.rewardMatrix().col(static_cast<Eigen::Index>(a));
    alpha(static_cast<Eigen::Index>(dialog.terminalState())) = 0.0;
    policy.add(alpha, a);
  }
  if (report) {
    report->converged = converged;
    report->reproducible = reproducible;
    report->bounds = bounds;
    report->solve_seconds = clock.seconds();
  }
  if (!file.empty() && reproducible) {
    makeDirectories(cache_dir);
    policy.save(file);
  }
  return policy;
}

DeliveryExperiment::DeliveryExperiment(const kb::NavDomain& domain, const DialogConfig& config,
                                       const DeliveryExperimentOptions& options)
    : domain_(domain), config_(config), options_(options) {
  options_.validate();
  config_.validate();
  if (!domain.grid || !domain.space || !domain.simulator)
    throw ConfigError("delivery experiment: the navigation domain is not loaded");

  // Dialog knowledge first: its rooms are the delivery destinations.
  Stopwatch clock;
  knowledge_ = std::make_unique<DialogKnowledge>(config_.office_plog, config_.speech_plog);
  const double dialogReasoning = clock.seconds();

  // 1. Navigation knowledge with the condition's learned part.
  navKnowledge_ = std::make_unique<kb::NavigationKnowledge>(*domain.grid, domain.knowledge_files);
  prep_.knowledge_br = options_.condition == KnowledgeCondition::kLearned ? options_.blocking_rate
                                                                           : options_.outdated_rate;
  prep_.learning = prepareLearnedKnowledge(domain, *navKnowledge_, config_, knowledge_->base().rooms,
                                           prep_.knowledge_br, options_.seed, options_.cache_dir,
                                           options_.domain_name);

  // 2. Procedure 2 and the navigation side of deliveries.
  clock.reset();
  const kb::NavModel model = navKnowledge_->buildModel({config_.time}, config_.nav_discount);
  DeliveryNavigationOptions no;
  no.shop = config_.shop;
  no.rooms = knowledge_->base().rooms;
  no.reward = mdp::NavigationReward{config_.step_cost, config_.rmax};
  no.discount = config_.nav_discount;
  no.step_limit = static_cast<std::size_t>(domain.domain.step_limit);
  no.failure_penalty = config_.failure_penalty;
  nav_ = std::make_unique<DeliveryNavigation>(*domain.space, model.dynamics, no);
  prep_.nav_model_seconds = clock.seconds();

  // 3. The dialog POMDP and its policy.
  clock.reset();
  dialog_ = std::make_unique<pomdp::DialogPomdp>(knowledge_->buildSpec(*nav_, config_));
  prep_.dialog_model_seconds = dialogReasoning + clock.seconds();
  policy_ = solveDialogPolicy(*dialog_, config_, options_.cache_dir, &prep_);

  context_.time_of_day = domain.simulator->timeOfDayIndex(config_.time);
  context_.blocking_rate = options_.blocking_rate;
}

void DeliveryExperiment::setPolicy(const pomdp::AlphaVectorPolicy& policy) {
  if (policy.numStates() != dialog_->model().getS())
    throw ConfigError("delivery experiment: policy has " + std::to_string(policy.numStates()) +
                      " states, the dialog model " + std::to_string(dialog_->model().getS()));
  policy_ = policy;
}

DeliveryTrialResult DeliveryExperiment::runTrial(std::size_t index, long fixed_request) const {
  const pomdp::DialogPomdp& d = *dialog_;
  const pomdp::Model& m = d.model();
  const pomdp::DialogSpec& spec = d.spec();
  if (fixed_request >= static_cast<long>(d.numRequests()))
    throw ConfigError("delivery trial: request " + std::to_string(fixed_request) +
                      " out of range");
  DeliveryTrialResult r;
  r.trial = index;
  const std::uint64_t seed = options_.seed;
  {
    Rng rng = makeRng(seed, "delivery/request", index);
    r.request = sample(spec.prior, rng);  // drawn even when fixed: same streams either way
  }
  if (fixed_request >= 0) r.request = static_cast<std::size_t>(fixed_request);

  // Dialog.
  Rng dlg = makeRng(seed, "delivery/dialog", index);
  pomdp::DialogController ctl(d, policy_);
  while (!ctl.finished()) {
    const bool limit = ctl.atTurnLimit();
    const std::size_t a = ctl.nextAction();
    if (d.isServe(a)) {
      r.served = d.requestOfServe(a);
      r.forced = limit;
      r.entropy = ctl.entropy(pomdp::EntropyUnit::kNats);
      r.served_probability = ctl.belief()(static_cast<Eigen::Index>(r.served));
      ctl.observe(a, d.obsNone());
      break;
    }
    // The person answers through the speech model (questions keep the request).
    double u = uniform01(dlg);
    std::size_t o = d.obsNone();
    const auto& row = m.observationRow(r.request, a);
    for (const auto& e : row) {
      o = e.first;
      if (u < e.second) break;
      u -= e.second;
    }
    r.qa_cost -= m.getExpectedReward(r.request, a);
    ctl.observe(a, o);
  }
  r.turns = ctl.turns();
  r.correct = r.served == r.request;

  // Delivery: the navigation layer in the world at the trial's br.
  Rng navRng = makeRng(seed, "delivery/navigation", index);
  const std::size_t servedRoom = knowledge_->roomOf(r.served);
  const std::size_t goalRoom = knowledge_->roomOf(r.request);
  const nav::BlockageSimulator& sim = *domain_.simulator;
  auto drive = [&](std::size_t room, bool toRoom) {
    const TripResult t = nav_->execute(sim, room, toRoom, context_, navRng);
    ++r.trips;
    r.nav_moves += t.moves;
    if (!t.reached) r.nav_failed = true;
    return t.reached;
  };
  bool ok = drive(servedRoom, true);
  if (ok && !r.correct) {
    r.redelivered = true;  // back to the shop, learn the right request, deliver again
    ok = drive(servedRoom, false) && drive(goalRoom, true);
  }
  r.fulfilled = ok;
  r.delivery_reward = ok ? spec.successReward : spec.failureReward;
  r.nav_cost = config_.step_cost * static_cast<double>(r.nav_moves) +
               (r.nav_failed ? config_.failure_penalty : 0.0);
  r.reward = r.delivery_reward - r.qa_cost - r.nav_cost;
  return r;
}

std::vector<DeliveryTrialResult> DeliveryExperiment::runTrials(std::size_t begin,
                                                               std::size_t count,
                                                               std::size_t threads) const {
  return runParallelTrials<DeliveryTrialResult>(count, threads, [&]() {
    return [&](std::size_t k) { return runTrial(begin + k); };
  });
}

std::string deliveryCsvHeader() {
  return "trial,room,reward,fulfilled,qa_cost,turns,entropy,request,served,served_room,correct,"
         "forced,served_probability,trips,nav_moves,nav_failed,redelivered,delivery_reward,"
         "nav_cost";
}

std::string deliveryCsvRow(const pomdp::DialogPomdp& d, const DeliveryTrialResult& r) {
  const auto& rooms = d.spec().rooms;
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "%zu,%s,%.6g,%d,%.6g,%d,%.6g,%s,%s,%s,%d,%d,%.6g,%d,%zu,%d,%d,%.6g,%.6g", r.trial,
                rooms[d.requestParts(r.request)[1]].c_str(), r.reward, r.fulfilled ? 1 : 0,
                r.qa_cost, r.turns, r.entropy, d.requestName(r.request).c_str(),
                d.requestName(r.served).c_str(), rooms[d.requestParts(r.served)[1]].c_str(),
                r.correct ? 1 : 0, r.forced ? 1 : 0, r.served_probability, r.trips, r.nav_moves,
                r.nav_failed ? 1 : 0, r.redelivered ? 1 : 0, r.delivery_reward, r.nav_cost);
  return buf;
}

}  // namespace dialog
}  // namespace krr
