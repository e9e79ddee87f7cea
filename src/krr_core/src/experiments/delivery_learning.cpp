#include "krr_core/experiments/delivery_learning.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <cstdio>
#include <memory>
#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/resources.h"

namespace krr {
namespace experiments {

using dialog::DialogConfig;

DeliveryRouteSelector::DeliveryRouteSelector(std::string shop, std::vector<std::string> rooms)
    : shop_(std::move(shop)), rooms_(std::move(rooms)) {
  if (rooms_.empty()) throw ConfigError("delivery route selector: no room");
  for (const auto& r : rooms_)
    if (r == shop_) throw ConfigError("delivery route selector: room '" + r + "' is the shop");
}

kb::NavTask DeliveryRouteSelector::next(const kb::NavModel& model, const kb::NavStateSpace& space,
                                        Rng& rng) {
  if (remaining_.empty()) {
    for (const auto& r : rooms_) {
      remaining_.push_back({shop_, r});
      remaining_.push_back({r, shop_});
    }
  }
  const std::size_t pick = kb::leastKnownTask(remaining_, model, space, rng);
  const kb::NavTask task = remaining_[pick];
  remaining_.erase(remaining_.begin() + static_cast<long>(pick));
  return task;
}

namespace {

/// Blocking areas with learned knowledge at `time`.
std::size_t learnedAreaCount(const kb::NavigationKnowledge& k, const std::string& time) {
  const auto it = k.learnedAreas().find(time);
  if (it == k.learnedAreas().end()) return 0;
  std::size_t n = 0;
  for (std::size_t at = it->second.find("learned_area("); at != std::string::npos;
       at = it->second.find("learned_area(", at + 1))
    ++n;
  return n;
}

/// Simulator parameters that change what is learned (part of the cache key).
std::string simulatorKey(const kb::NavDomain& d) {
  const nav::SimulatorConfig& s = d.config.simulator;
  std::ostringstream o;
  o.precision(17);
  o << s.move_success << "|" << s.slip_stay << "|" << s.slip_lateral << "|"
    << static_cast<int>(s.blocking_mode) << "|" << s.trap_probability << "|"
    << s.trap_reference_cell_size << "|" << d.domain.step_limit << "|" << d.grid->cols() << "x"
    << d.grid->rows() << "|" << d.grid->numFreeCells();
  for (std::size_t i = 0; i < s.times_of_day.size(); ++i)
    o << "|" << s.times_of_day[i] << "=" << (i < s.time_factors.size() ? s.time_factors[i] : 1.0);
  for (const auto& [name, area] : s.areas) {
    o << "|" << name << ":" << area.rate;
    for (const auto& [t, f] : area.time_factor) o << "," << t << "=" << f;
  }
  return o.str();
}

}  // namespace

std::string learnedCacheName(const kb::NavDomain& domain, const DialogConfig& c,
                             const std::vector<std::string>& rooms, double br, std::uint64_t seed,
                             const std::string& domain_name) {
  std::ostringstream key;
  key.precision(17);
  key << "v2|" << c.learning_mode << "|" << c.time << "|" << c.shop << "|" << c.known_threshold << "|" << c.refine_known
      << "|" << c.max_episodes_per_task << "|" << c.convergence_episodes << "|"
      << c.learning_rounds << "|" << c.step_cost << "|" << c.rmax;
  // R-Max settings read from navigation.yaml since they became configurable: keyed only when
  // they differ from the values they had before, so existing caches stay valid.
  if (c.rmax_discount != 0.95 || c.rmax_replan_every != 10 ||
      c.rmax_optimism != mdp::Optimism::kTerminalBonus)
    key << "|rmax:" << c.rmax_discount << "|" << c.rmax_replan_every << "|"
        << mdp::optimismName(c.rmax_optimism);
  for (const auto& r : rooms) key << "|" << r;
  key << "|" << simulatorKey(domain);
  char buf[160];
  std::snprintf(buf, sizeof(buf), "learned_%s_br%.4g_seed%llu_%016llx.plog", domain_name.c_str(),
                br, static_cast<unsigned long long>(seed),
                static_cast<unsigned long long>(stableHash(key.str())));
  return buf;
}

LearningReport prepareLearnedKnowledge(const kb::NavDomain& domain,
                                       kb::NavigationKnowledge& knowledge,
                                       const DialogConfig& config,
                                       const std::vector<std::string>& rooms, double br,
                                       std::uint64_t seed, const std::string& cache_dir,
                                       const std::string& domain_name) {
  if (!(br >= 0.0 && br <= 1.0))
    throw ConfigError("delivery learning: blocking rate " + std::to_string(br) +
                      " is not in [0, 1]");
  config.validate();
  Stopwatch clock;
  LearningReport report;
  knowledge.clearLearned();
  std::unique_ptr<FileLock> lock;  // parallel trial processes learn each entry once
  if (!cache_dir.empty()) {
    report.cache_file =
        cache_dir + "/" + learnedCacheName(domain, config, rooms, br, seed, domain_name);
    makeDirectories(cache_dir);
    try {
      lock = std::make_unique<FileLock>(report.cache_file + ".lock");
    } catch (const IoError&) {
      // a read-only cache: load what is there, or work without caching below
    }
    if (isRegularFile(report.cache_file)) {
      knowledge.loadLearned(report.cache_file);
      report.from_cache = true;
      report.pairs = knowledge.buildModel({config.time}).numLearned();
      report.areas = learnedAreaCount(knowledge, config.time);
      report.seconds = clock.seconds();
      return report;
    }
  }
  DeliveryRouteSelector selector(config.shop, rooms);
  kb::FreeTimeOptions o;
  o.time = config.time;
  o.blocking_rate = br;
  o.max_episodes_per_task = config.max_episodes_per_task;
  o.convergence_episodes = config.convergence_episodes;
  o.max_tasks = config.learning_rounds * selector.routesPerRound();
  o.rmax = config.rmaxParams();
  o.extraction = kb::extractionFromString(config.learning_mode);
  kb::FreeTimeLearner learner(domain, knowledge, selector, o);
  char stream[64];
  std::snprintf(stream, sizeof(stream), "delivery/learning/br%.6g", br);
  Rng rng = makeRng(seed, stream);
  const kb::FreeTimeReport fr = learner.run(rng, {});
  report.tasks = fr.tasks.size();
  report.samples = fr.samples;
  for (std::size_t e : fr.episodes) report.episodes += e;
  report.pairs = knowledge.buildModel({config.time}).numLearned();
  report.areas = learnedAreaCount(knowledge, config.time);
  if (!report.cache_file.empty()) knowledge.saveLearned(report.cache_file);
  report.seconds = clock.seconds();
  return report;
}

}  // namespace experiments
}  // namespace krr
