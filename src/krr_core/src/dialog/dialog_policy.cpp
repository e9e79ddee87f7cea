#include "krr_core/dialog/dialog_policy.h"

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resources.h"

namespace krr {
namespace dialog {

namespace {

/// A fingerprint of the solver's behaviour (its bounds and policy on a small penalised
/// dialog after a fixed number of trials), part of the cache key: a changed solver never
/// reuses a policy cached by an older one.
std::uint64_t solverFingerprint() {
  static const std::uint64_t fp = [] {
    DialogSpec spec;
    spec.items = {"a", "b"};
    spec.rooms = {"near", "far"};
    spec.persons = {"p"};
    Eigen::VectorXd reach(2);
    reach << 1.0, 0.5;
    spec.delivery = deliveryMatrix(2, reach, 1);
    spec.serveCost = 40.0 * (Eigen::MatrixXd::Ones(4, 4) - Eigen::MatrixXd::Identity(4, 4));
    spec.turnLimit = 6;
    const DialogPomdp d(spec);
    CertifiedSolverOptions o;
    o.precision = 1e-12;
    o.timeout = 1e9;
    o.maxTrials = 25;
    CertifiedDialogSolver s(d, Eigen::VectorXd(), 0, o);
    s.solve();
    std::ostringstream t;
    t.precision(17);
    t << s.report().lower << " " << s.report().upper << "\n" << s.policy().toText();
    return stableHash(t.str());
  }();
  return fp;
}

std::string boundsText(const PolicyReport& r) {
  std::ostringstream o;
  o.precision(17);
  o << "krr-policy-bounds 1\nlower " << r.bounds.lower << "\nupper " << r.bounds.upper
    << "\ntrials " << r.bounds.trials << "\nalphas " << r.bounds.alphas << "\npoints "
    << r.bounds.points << "\nseconds " << r.bounds.time << "\n";
  return o.str();
}

void readBounds(const std::string& file, PolicyReport& r) {
  std::istringstream in(readFile(file));
  std::string key;
  int version = 0;
  if (!(in >> key >> version) || key != "krr-policy-bounds" || version != 1)
    throw IoError(file + ": not a policy bounds file (delete it to solve again)");
  while (in >> key) {
    if (key == "lower") in >> r.bounds.lower;
    else if (key == "upper") in >> r.bounds.upper;
    else if (key == "trials") in >> r.bounds.trials;
    else if (key == "alphas") in >> r.bounds.alphas;
    else if (key == "points") in >> r.bounds.points;
    else if (key == "seconds") in >> r.bounds.time;
    else throw IoError(file + ": unknown field '" + key + "' (delete it to solve again)");
    if (!in) throw IoError(file + ": bad value of '" + key + "' (delete it to solve again)");
  }
  if (!r.bounds.valid())
    throw IoError(file + ": bounds [" + std::to_string(r.bounds.lower) + ", " +
                  std::to_string(r.bounds.upper) + "] are not finite, ordered bounds (delete "
                  "it to solve again)");
}

}  // namespace

std::string policyMismatch(const pomdp::TurnLimitedPolicy& policy, const DialogPomdp& dialog) {
  if (policy.numStates() == dialog.model().getS() &&
      policy.turnLimit() == dialog.spec().turnLimit) {
    if (!policy.hasPlans() || policy.numObservations() == dialog.model().getO()) return "";
    return "policy's plans have " + std::to_string(policy.numObservations()) +
           " observations, the dialog model " + std::to_string(dialog.model().getO());
  }
  return "policy has " + std::to_string(policy.numStates()) + " states and turn limit " +
         std::to_string(policy.turnLimit()) + ", the dialog model " +
         std::to_string(dialog.model().getS()) + " and " +
         std::to_string(dialog.spec().turnLimit);
}

CertifiedSolverOptions certifiedSolverOptions(const DialogConfig& config) {
  CertifiedSolverOptions o;
  o.precision = config.solver_precision;
  o.timeout = config.solver_timeout;
  o.maxTrials = config.solver_max_trials;
  return o;
}

namespace {

/// The cache file of `dialog`'s policy under `so` (".txt"; its bounds are beside it, ".bounds").
std::string cacheFile(const DialogPomdp& dialog, const CertifiedSolverOptions& so,
                      const std::string& cache_dir) {
  std::ostringstream key;
  key.precision(17);
  // v3: the room-paid bound's chain of levels and trials aimed at trialTarget x precision;
  // v4: policies carry their plans' continuations (executed in O(1) per turn); v5: rarely
  // reached nodes export their commit plans.
  key << "certified v5|" << solverFingerprint() << "|" << dialog.spec().turnLimit << "|"
      << so.precision << "|" << so.maxTrials << "|" << so.seed << "|" << so.lowerGuidedEvery
      << "|" << so.commitLower << "|" << so.shareUpperBounds << so.roomPaidBound
      << so.roomLookahead << so.keepLeaves << "|" << so.trialTarget << "|"
      << dialog.exportCassandra();
  char name[64];
  std::snprintf(name, sizeof(name), "policy_%016llx",
                static_cast<unsigned long long>(stableHash(key.str())));
  return cache_dir + "/" + name + ".txt";
}

std::string boundsFileOf(const std::string& policy_file) {
  return policy_file.substr(0, policy_file.size() - 4) + ".bounds";
}

/// The cached entry `rep.file`, if complete (the policy file's presence marks it so).
std::optional<pomdp::TurnLimitedPolicy> loadCached(const DialogPomdp& dialog, double precision,
                                                   PolicyReport& rep) {
  if (!isRegularFile(rep.file) || !isRegularFile(boundsFileOf(rep.file))) return std::nullopt;
  pomdp::TurnLimitedPolicy p = pomdp::TurnLimitedPolicy::load(rep.file);
  const std::string mismatch = policyMismatch(p, dialog);
  if (!mismatch.empty())
    throw IoError(rep.file + ": cached " + mismatch + " (delete it to solve again)");
  readBounds(boundsFileOf(rep.file), rep);
  rep.from_cache = true;
  rep.reproducible = true;  // only reproducible policies are cached
  rep.converged = rep.bounds.gap() <= precision;
  return p;
}

}  // namespace

std::optional<pomdp::TurnLimitedPolicy> cachedDialogPolicy(const DialogPomdp& dialog,
                                                           const DialogConfig& config,
                                                           const std::string& cache_dir,
                                                           PolicyReport* report) {
  config.validate();
  if (cache_dir.empty()) return std::nullopt;
  Stopwatch clock;
  PolicyReport rep;
  const CertifiedSolverOptions so = certifiedSolverOptions(config);
  rep.file = cacheFile(dialog, so, cache_dir);
  std::optional<pomdp::TurnLimitedPolicy> p = loadCached(dialog, so.precision, rep);
  rep.seconds = clock.seconds();
  if (p && report) *report = rep;
  return p;
}

pomdp::TurnLimitedPolicy solveDialogPolicy(const DialogPomdp& dialog,
                                           const DialogConfig& config,
                                           const std::string& cache_dir, PolicyReport* report) {
  config.validate();
  Stopwatch clock;
  PolicyReport rep;
  const CertifiedSolverOptions so = certifiedSolverOptions(config);
  std::unique_ptr<FileLock> lock;  // parallel trial processes solve each model once
  if (!cache_dir.empty()) {
    rep.file = cacheFile(dialog, so, cache_dir);
    makeDirectories(cache_dir);
    try {
      lock = std::make_unique<FileLock>(rep.file.substr(0, rep.file.size() - 4) + ".lock");
    } catch (const IoError&) {
      // a read-only cache: load what is there, or work without caching below
    }
    if (std::optional<pomdp::TurnLimitedPolicy> p = loadCached(dialog, so.precision, rep)) {
      rep.seconds = clock.seconds();
      if (report) *report = rep;
      return std::move(*p);
    }
  }
  CertifiedDialogSolver solver(dialog, Eigen::VectorXd(), 0, so);
  solver.solve();
  const CertifiedReport cr = solver.report();
  pomdp::TurnLimitedPolicy policy = solver.policy();
  // The certified lower bound is what the exported policy guarantees at the prior.
  rep.bounds.lower = policy.value(dialog.model().initialBelief(), 0);
  rep.bounds.upper = cr.upper;
  rep.bounds.time = cr.seconds;
  rep.bounds.trials = cr.trials;
  rep.bounds.points = cr.nodes;
  rep.bounds.bytes = cr.bytes;
  rep.bounds.alphas = policy.size();
  if (!rep.bounds.valid())
    throw IncoherentError("dialog policy: the solver's bounds at the prior [" +
                          std::to_string(rep.bounds.lower) + ", " +
                          std::to_string(rep.bounds.upper) + "] are not finite, ordered bounds");
  rep.converged = rep.bounds.gap() <= so.precision;
  rep.reproducible = cr.reproducible();
  rep.stop = toString(cr.stop);
  if (!rep.file.empty() && rep.reproducible) {
    // Bounds first: the policy file's presence marks a complete entry.
    writeFileAtomic(boundsFileOf(rep.file), boundsText(rep));
    policy.save(rep.file);
  }
  if (!rep.reproducible) rep.file.clear();
  rep.seconds = clock.seconds();
  if (report) *report = rep;
  return policy;
}

std::string defaultCacheDir() {
  auto env = [](const char* name) {
    const char* v = std::getenv(name);
    return v ? std::string(v) : std::string();
  };
  std::string d = env("KRR_CACHE_DIR");
  if (!d.empty()) return d;
  d = env("XDG_CACHE_HOME");
  if (!d.empty()) return d + "/krr_rl/delivery";
  d = env("HOME");
  if (!d.empty()) return d + "/.cache/krr_rl/delivery";
  return "";
}

}  // namespace dialog
}  // namespace krr
