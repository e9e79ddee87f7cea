/**
 * @file reasoner_dispatch.cpp
 * @brief The Reasoner's queries (probability, distribution, table) and their dispatch between
 * the native engine and clingo: in turn, or under Backend::Auto as a race with clingo on a
 * helper thread (AspRace), the first definite answer winning.
 */
#include "krr_core/plog/reasoner.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "krr_core/plog/asp_backend.h"
#include "krr_core/plog/engine.h"
#include "krr_core/plog/parser.h"
#include "reasoner_internal.h"

namespace krr {
namespace plog {

using reasoner_detail::collectAttrs;
using reasoner_detail::setKey;

namespace {

/// @brief Neither engine could answer: say why for both (e.g. a factor too large natively, too
/// many possible worlds for clingo within the time budget).
Error bothFailed(const std::string& why, const std::exception& e) {
  return Error(why + "; the ASP back end could not answer either: " + e.what());
}

/// @brief Rethrows clingo's failure in a raced query: answers about the program as they are,
/// an abandoned or failed clingo run together with why the native engine did not answer.
[[noreturn]] void rethrowAspFailure(const std::exception_ptr& asp_error, const std::string& why) {
  try {
    std::rethrow_exception(asp_error);
  } catch (const IncoherentError&) {
    throw;
  } catch (const UnknownSymbolError&) {
    throw;
  } catch (const CancelledError&) {
    throw Error(why + "; the ASP back end was abandoned");
  } catch (const Error& e) {
    throw bothFailed(why, e);
  }
}

using RaceClock = std::chrono::steady_clock;

/// @brief `seconds` after `from`; time_point::max (never) when absurdly late.
RaceClock::time_point after(RaceClock::time_point from, double seconds) {
  if (!(seconds < 1e9)) return RaceClock::time_point::max();  // never (or absurdly late)
  return from + std::chrono::duration_cast<RaceClock::duration>(std::chrono::duration<double>(seconds));
}

/// @brief The clingo side of a raced query: a helper thread that runs `job` (clingo) at once,
/// at a join time, or when the query wants clingo's answer. The helper is detached and shares
/// only `Shared` with the query: a query the native engine answers before clingo starts returns
/// at once, without waiting for the helper to be scheduled (which took milliseconds on a loaded
/// machine). From construction to finish(), the clingo back end's cancel flag is this race's,
/// set when the native engine answers.
class AspRace {
 public:
  AspRace(AspBackend& backend, std::function<void()>& job, bool start_now,
          RaceClock::time_point join_at)
      : backend_(backend), job_(&job), sh_(std::make_shared<Shared>()) {
    backend_.setCancelFlag(&native_done_);
    sh_->start_now = start_now;
    sh_->join_at = join_at;
  }

  /// @brief Starts the helper (once). It is started when clingo may be needed: at once for a
  /// program that may loop through negation, otherwise at the plan when the decision races or
  /// sets a time for clingo to join (a thread started for every query cost a sizeable part of
  /// sub-millisecond queries). A grounding that took longer than clingo would have joined
  /// races at the plan.
  void spawn() {
    if (spawned_) return;
    spawned_ = true;
    std::thread([sh = sh_, job = job_]() {
      {
        std::unique_lock<std::mutex> lock(sh->m);
        for (;;) {
          if (sh->stop) return;  // the query is over: `job` must not be touched
          if (sh->start_now || RaceClock::now() >= sh->join_at) break;
          if (sh->join_at == RaceClock::time_point::max()) sh->cv.wait(lock);
          else sh->cv.wait_until(lock, sh->join_at);
        }
        sh->started = true;  // from here on the query waits for `finished`
      }
      (*job)();
      {
        std::lock_guard<std::mutex> lock(sh->m);
        sh->finished = true;
      }
      sh->cv.notify_all();
    }).detach();
  }

  /// @brief The decision at the native plan: clingo starts now, or joins after
  /// d.asp_join_seconds if the native engine has not answered by then.
  void decide(const AutoDecision& d) {
    {
      std::lock_guard<std::mutex> lock(sh_->m);
      if (d.choice != AutoChoice::Native || RaceClock::now() >= sh_->join_at) sh_->start_now = true;
      else sh_->join_at = after(RaceClock::now(), d.asp_join_seconds);
    }
    if (sh_->start_now || sh_->join_at != RaceClock::time_point::max()) spawn();
    sh_->cv.notify_all();
  }

  /// @brief Waits at most `wait` for clingo to finish.
  void waitFinished(std::chrono::duration<double> wait) {
    std::unique_lock<std::mutex> lock(sh_->m);
    sh_->cv.wait_for(lock, wait, [&]() { return sh_->finished; });
  }

  /// @brief Ends the race: with cancel_asp, clingo is told to stop (a helper that has not
  /// started exits on its own); otherwise clingo's answer is wanted and waited for.
  void finish(bool cancel_asp) {
    if (cancel_asp) native_done_ = true;
    if (!cancel_asp) spawn();  // clingo's answer is wanted
    std::unique_lock<std::mutex> lock(sh_->m);
    if (cancel_asp && !sh_->started) {
      sh_->stop = true;  // clingo never started: the helper exits on its own
    } else {
      sh_->start_now = true;
      sh_->cv.notify_all();
      sh_->cv.wait(lock, [&]() { return sh_->finished; });
    }
    lock.unlock();
    sh_->cv.notify_all();
    backend_.setCancelFlag(nullptr);
  }

 private:
  /// @brief All the helper thread shares with the query.
  struct Shared {
    std::mutex m;
    std::condition_variable cv;
    bool start_now = false, stop = false, started = false, finished = false;
    RaceClock::time_point join_at = RaceClock::time_point::max();
  };
  std::atomic<bool> native_done_{false};
  AspBackend& backend_;
  std::function<void()>* job_;
  std::shared_ptr<Shared> sh_;
  bool spawned_ = false;
};

}  // namespace

void Reasoner::noteAspAnswer() {
  stats_.last_backend = Backend::Asp;
  ++stats_.asp_answers;
}

template <typename T, typename Native, typename Asp>
T Reasoner::dispatch(const std::set<std::string>& attrs, Native native, Asp asp_answer,
                     bool race) {
  auto viaAsp = [&]() {
    T r = asp_answer();
    noteAspAnswer();
    return r;
  };
  if (backend_ == Backend::Asp) return viaAsp();
  const std::string key = setKey(attrs);
  if (backend_ == Backend::Auto) {
    auto it = outside_fragment_.find(key);
    if (it != outside_fragment_.end() && it->second == structure_version_) return viaAsp();
  }
  if (backend_ == Backend::Native || !race) return dispatchInTurn<T>(key, native, viaAsp);
  return dispatchRace<T>(key, native, asp_answer);
}

template <typename T, typename Native, typename ViaAsp>
T Reasoner::dispatchInTurn(const std::string& key, Native& native, ViaAsp& via_asp) {
  std::string why;
  try {
    T r = native();
    stats_.last_backend = Backend::Native;
    return r;
  } catch (const OutsideFragmentError& e) {
    if (backend_ != Backend::Auto) throw;
    outside_fragment_[key] = structure_version_;
    why = e.what();
  }
  try {
    return via_asp();
  } catch (const IncoherentError&) {
    throw;  // an answer about the program, not a failure of the back end
  } catch (const UnknownSymbolError&) {
    throw;
  } catch (const Error& e) {
    throw bothFailed(why, e);
  }
}

bool Reasoner::mayLoopThroughNegation() {
  const std::pair<std::uint64_t, std::uint64_t> version{structure_version_, change_seq_};
  if (!negation_loop_valid_ || negation_loop_version_ != version) {
    negation_loop_reason_ = negationLoopReason(program_);
    negation_loop_version_ = version;
    negation_loop_valid_ = true;
  }
  return !negation_loop_reason_.empty();
}

AutoEstimate Reasoner::beginRace(bool asp_at_once) {
  if (asp_at_once) ++stats_.asp_started_at_once;
  AutoEstimate estimate;
  estimate.asp_seconds = aspCostSeconds(program_);
  stats_.last_estimate = estimate;
  stats_.last_auto_choice = asp_at_once ? AutoChoice::Race : AutoChoice::Native;
  stats_.last_asp_joined = false;
  return estimate;
}

AutoDecision Reasoner::decideAtPlan(const EnginePlan& plan, const AutoEstimate& estimate,
                                    bool asp_at_once) {
  AutoEstimate e = estimate;
  e.native_seconds = nativeCostSeconds(plan);
  e.native_refuses = plan.largest_log2 > kMaxFactorLog2;
  const AutoDecision d = decideAuto(e, race_delay_);
  stats_.last_estimate = e;
  if (!asp_at_once) stats_.last_auto_choice = d.choice;
  return d;
}

template <typename T, typename Native, typename Asp>
T Reasoner::dispatchRace(const std::string& key, Native& native, Asp& asp_answer) {
  // Auto: the native engine grounds and plans; decideAuto then chooses from both estimates
  // (see setBackend). A program that may loop through negation (negationLoopReason) is usually
  // refused by the native engine, but only once it has grounded the query's cone: clingo
  // starts at once instead, and the native engine joins after kGroundingRaceFactor race delays.
  const auto started = RaceClock::now();
  const bool asp_at_once = mayLoopThroughNegation();
  const AutoEstimate estimate = beginRace(asp_at_once);
  AspBackend& backend = asp();  // made here: the helper thread must not create it
  asp_won_ = false;
  std::optional<T> asp_result;
  std::exception_ptr asp_error;
  std::function<void()> run_asp = [&]() {
    try {
      asp_result.emplace(asp_answer());
      asp_won_ = true;
    } catch (const IncoherentError&) {
      asp_error = std::current_exception();
      asp_won_ = true;  // a definite answer too
    } catch (...) {
      asp_error = std::current_exception();
    }
  };
  // When clingo joins if the native engine has not answered: while it grounds, from the
  // estimate without a plan; from its plan on, from decideAuto.
  AspRace race(backend, run_asp, asp_at_once,
               after(started, decideAuto(estimate, race_delay_).asp_join_seconds));
  if (asp_at_once) race.spawn();
  plan_callback_ = [&](const EnginePlan& plan) {
    const AutoDecision d = decideAtPlan(plan, estimate, asp_at_once);
    race.decide(d);
    if (d.choice == AutoChoice::Asp)
      throw OutsideFragmentError("the native engine's largest table would have 2^" +
                                 std::to_string(plan.largest_log2) + " rows (at most 2^" +
                                 std::to_string(kMaxFactorLog2) + ")");
  };
  struct PlanGuard {
    std::function<void(const EnginePlan&)>& cb;
    ~PlanGuard() { cb = nullptr; }
  } plan_guard{plan_callback_};
  auto finish = [&](bool cancel_asp) {
    race.finish(cancel_asp);
    stats_.last_asp_joined = asp_result || asp_error;
    asp_won_ = false;
  };
  auto useAsp = [&](const std::string& why) -> T {
    if (!asp_result) rethrowAspFailure(asp_error, why);
    noteAspAnswer();
    return *asp_result;
  };
  if (asp_at_once) {
    // clingo usually answers these programs: the native engine joins only if it has not
    // within kGroundingRaceFactor race delays (the two would otherwise share the machine).
    race.waitFinished(std::chrono::duration<double>(race_delay_) *
                      AutoCostModel::kGroundingRaceFactor);
  }
  if (asp_won_) {
    finish(false);
    return useAsp("clingo answered first");
  }
  try {
    T r = native();
    finish(true);
    stats_.last_backend = Backend::Native;
    return r;
  } catch (const OutsideFragmentError& e) {
    finish(false);
    outside_fragment_[key] = structure_version_;
    return useAsp(e.what());
  } catch (const CancelledError&) {
    finish(false);  // clingo has answered (or failed): wait for its thread
    if (asp_result || asp_error) return useAsp("the native engine was abandoned");
    throw;
  } catch (...) {
    finish(true);
    throw;
  }
}

void Reasoner::noteWarnings(const std::vector<std::string>& warnings) {
  std::lock_guard<std::mutex> lock(warnings_mutex_);
  for (const auto& w : warnings)
    if (std::find(program_.warnings.begin(), program_.warnings.end(), w) == program_.warnings.end())
      program_.warnings.push_back(w);
}

double Reasoner::probability(const std::string& query) {
  return probability(parseQuery(declarations(), query));
}

double Reasoner::probability(const Query& q) {
  checkQuery(q);
  std::set<std::string> attrs;
  collectAttrs(q, attrs);
  return dispatch<double>(attrs, [&]() { return nativeProbability(q); },
                          [&]() {
                            const double p = asp().probability(program_, q);
                            noteWarnings(asp().warnings());
                            return p;
                          });
}

std::vector<ValueProb> Reasoner::distribution(const std::string& attribute_term,
                                              const std::string& evidence) {
  AttributeTerm at = parseAttributeTerm(declarations(), attribute_term);
  Query ev;
  if (!evidence.empty()) ev = parseQuery(declarations(), "| " + evidence, "<evidence>");
  checkQuery(ev);
  std::set<std::string> attrs{at.name};
  collectAttrs(ev, attrs);
  return dispatch<std::vector<ValueProb>>(
      attrs, [&]() { return nativeDistribution(at, ev, evidence); },
      [&]() {
        std::vector<ValueProb> out;
        for (const auto& vp : asp().distribution(program_, at, ev.observations, ev.interventions))
          if (vp.second > 0) out.push_back({vp.first, vp.second});
        noteWarnings(asp().warnings());
        return out;
      });
}

Table Reasoner::tableQuery(const std::string& target, const std::vector<std::string>& conditioning,
                           const std::string& evidence, bool conditioning_as_do) {
  Table t;
  const Program& decls = declarations();
  AttributeTerm tat = parseAttributeTerm(decls, target);
  t.target = toString(tat);
  std::vector<AttributeTerm> cats;
  std::set<std::string> attrs{tat.name};
  for (const auto& c : conditioning) {
    cats.push_back(parseAttributeTerm(decls, c));
    t.conditioning.push_back(toString(cats.back()));
    attrs.insert(cats.back().name);
  }
  Query ev;
  if (!evidence.empty()) ev = parseQuery(decls, "| " + evidence, "<evidence>");
  checkQuery(ev);
  collectAttrs(ev, attrs);
  return dispatch<Table>(
      attrs, [&]() { return nativeTable(tat, cats, ev, evidence, conditioning_as_do); },
      [&]() {
        // One clingo run per row: every combination of the conditioning ranges (first
        // fastest), as the native table.
        std::vector<std::vector<std::string>> ranges;
        size_t total = 1;
        for (const auto& c : cats) {
          ranges.push_back(attributeRange(c.name));
          total *= ranges.back().size();
        }
        std::vector<size_t> cur(cats.size(), 0);
        for (size_t row = 0; row < total; ++row) {
          TableRow r;
          std::string row_evidence = evidence;
          for (size_t k = 0; k < cats.size(); ++k) {
            const std::string& v = ranges[k][cur[k]];
            r.conditioning_values.push_back(v);
            row_evidence += std::string(row_evidence.empty() ? "" : ", ") +
                            (conditioning_as_do ? "do(" : "obs(") + toString(cats[k]) + "=" + v + ")";
          }
          const Query rq = row_evidence.empty()
                               ? Query()
                               : parseQuery(declarations(), "| " + row_evidence, "<table row>");
          const std::vector<Observation>& obs = rq.observations;
          const std::vector<Intervention>& dos = rq.interventions;
          try {
            double sum = 0;
            for (const auto& vp : asp().distribution(program_, tat, obs, dos)) {
              sum += vp.second;
              if (vp.second > 0) r.distribution.push_back({vp.first, vp.second});
            }
            r.undefined_probability = std::max(0.0, 1.0 - sum);
            noteWarnings(asp().warnings());
          } catch (const IncoherentError&) {
            r.consistent = false;
          }
          t.rows.push_back(std::move(r));
          for (size_t k = 0; k < cur.size(); ++k) {
            if (++cur[k] < ranges[k].size()) break;
            cur[k] = 0;
          }
        }
        return t;
      },
      /*race=*/false);
}

std::vector<QueryAnswer> Reasoner::answerProgramQueries() {
  std::vector<QueryAnswer> out;
  for (const auto& q : program_.queries) out.push_back({q.text, probability(q)});
  return out;
}

}  // namespace plog
}  // namespace krr
