/**
 * @file asp_backend.cpp
 * @brief The P-log measure of clingo's answer sets and the AspBackend queries (the
 * translation is in asp_translation.cpp).
 *
 * Naming inside the generated program: every P-log variable X becomes VX (so that the
 * translation's own variables, all starting with W, never clash with it); every attribute atom
 * a(t) = y becomes val(a(t), y), so the P-log names only ever appear as function symbols and
 * constants inside the translation's own predicates (sort/2, val/2, sel/2, poss/3, npos/3,
 * pra/3, chosen/4, empty/2, intervene/1, q/1, ev/1 ...) and cannot clash with them. Only
 * chosen/4, empty/2, pra/3, q/1 and ev/1 are shown, to keep clingo's output small.
 */
#include "krr_core/plog/asp_backend.h"

#include "asp_translation.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "krr_core/common/errors.h"
#include "krr_core/plog/parser.h"

namespace krr {
namespace plog {

using namespace asp_detail;

namespace {

/// Slack on sums of assigned probabilities (they are decimal fractions read as doubles).
constexpr double kSumTolerance = 1e-9;
/// Per assigned value, the noise of adding exact decimals: sums within it are kept as written
/// (the native engine's kSumNoise).
constexpr double kSumNoise = 8 * 2.220446049250313e-16;

/// Numerators and denominators of the specs of one clingo run.
struct GroupResult {
  std::vector<double> num, den;
  std::vector<std::string> error;  ///< incoherence met in a world of the query's evidence
  std::vector<std::size_t> worlds;  ///< per scenario
  std::vector<std::size_t> scenario;  ///< per spec
  std::vector<std::string> warnings;  ///< probability sums renormalised within rounding
};

/// The P-log measure of clingo's answer sets. Every distinct shown atom is decoded once
/// (kind, integer arguments, attribute term and value as small integers); a world is then a
/// pass over integers with per-term scratch space, with no string built or compared.
class WorldMeasure {
 public:
  WorldMeasure(const Program& program, std::size_t specs) : program_(program), specs_(specs) {}

  /// @brief Decode the atoms that appeared since the last call.
  void decodeNew(const std::vector<std::string>& atoms) {
    atoms_ = &atoms;
    for (std::size_t i = decoded_.size(); i < atoms.size(); ++i) decoded_.push_back(decode(atoms[i]));
  }

  /// @brief Measure of one answer set; sets holds_q / holds_ev per spec and the scenario
  /// (scn(g) atom, 0 when absent) the answer set belongs to.
  /// @throws IncoherentError when the world breaks a P-log coherence condition.
  double measure(const AspModel& model, std::vector<char>& holds_q, std::vector<char>& holds_ev,
                 long long& scenario) {
    std::fill(holds_q.begin(), holds_q.end(), 0);
    std::fill(holds_ev.begin(), holds_ev.end(), 0);
    scenario = 0;
    for (std::uint32_t t : touched_) {
      sel_[t].rule = -1;
      sel_[t].npos = -1;
      sel_[t].assigned.clear();
      in_touched_[t] = 0;
    }
    touched_.clear();
    for (std::uint32_t id : model) {
      const Decoded& d = decoded_[id];
      switch (d.kind) {
        case Decoded::kQ:
          holds_q[static_cast<std::size_t>(d.index)] = 1;
          break;
        case Decoded::kEv:
          holds_ev[static_cast<std::size_t>(d.index)] = 1;
          break;
        case Decoded::kVal:
          // shown for programs with consistency-restoring rules only (to tell worlds apart)
          break;
        case Decoded::kScn:
          scenario = d.index;
          break;
        case Decoded::kChosen: {
          Selected& s = touch(d.term);
          if (s.rule >= 0 && s.rule != d.index) {
            throw IncoherentError(
                "AspBackend: two random selection rules (" +
                where(program_.random_rules.at(static_cast<std::size_t>(s.rule)).loc) + " and " +
                where(program_.random_rules.at(static_cast<std::size_t>(d.index)).loc) +
                ") apply to " + terms_[d.term] + " in one possible world");
          }
          s.rule = d.index;
          s.value = d.value;
          s.npos = d.npos;
          break;
        }
        case Decoded::kEmpty:
          throw IncoherentError("AspBackend: the dynamic range of " + terms_[d.term] +
                                " (random selection at " +
                                where(program_.random_rules[static_cast<std::size_t>(d.index)].loc) +
                                ") is empty in a possible world");
        case Decoded::kPra: {
          const PrAtom& p = program_.pr_atoms[static_cast<std::size_t>(d.index)];
          Selected& s = touch(d.term);
          Assigned* found = nullptr;
          for (auto& a : s.assigned) {
            if (a.value == d.value) found = &a;
          }
          if (found != nullptr && found->pr != d.index &&
              std::fabs(found->probability - p.probability) > 1e-12) {
            const PrAtom& p2 = program_.pr_atoms.at(static_cast<std::size_t>(found->pr));
            throw IncoherentError("AspBackend: two pr-atoms (" + where(p2.loc) + " and " +
                                  where(p.loc) + ") assign different probabilities (" +
                                  p2.probability_text + " and " + p.probability_text + ") to " +
                                  terms_[d.term] + "=" + values_[d.value] +
                                  " in one possible world");
          }
          if (found != nullptr) {
            *found = {d.value, d.index, p.probability};
          } else {
            s.assigned.push_back({d.value, d.index, p.probability});
          }
          break;
        }
      }
    }
    double mu = 1.0;
    for (std::uint32_t t : touched_) {
      const double f = factor(t, model, false);
      if (f < 0.0) {
        // Report the incoherence of the first term in text order, whatever the atom order.
        std::vector<std::uint32_t> order = touched_;
        std::sort(order.begin(), order.end(),
                  [this](std::uint32_t a, std::uint32_t b) { return terms_[a] < terms_[b]; });
        for (std::uint32_t u : order) factor(u, model, true);
      }
      mu *= f;
    }
    return mu;
  }

  /// @brief The scenario of an answer set and the specs whose evidence it satisfies.
  long long scenarioOf(const AspModel& model, std::vector<std::size_t>& evidence) const {
    long long scn = 0;
    evidence.clear();
    for (std::uint32_t id : model) {
      if (decoded_[id].kind == Decoded::kScn) scn = decoded_[id].index;
      if (decoded_[id].kind == Decoded::kEv)
        evidence.push_back(static_cast<std::size_t>(decoded_[id].index));
    }
    return scn;
  }

  /// @brief The renormalisations met so far (see renormalisation), each once.
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  struct Decoded {
    enum Kind : std::uint8_t { kQ, kEv, kVal, kScn, kChosen, kEmpty, kPra } kind = kVal;
    long long index = 0;     ///< spec (q, ev), scenario, random rule (chosen, empty), pr-atom
    std::uint32_t term = 0;  ///< attribute term (chosen, empty, pra)
    std::uint32_t value = 0; ///< value (chosen, pra)
    long long npos = 0;      ///< possible values (chosen)
  };
  struct Assigned {
    std::uint32_t value;
    long long pr;
    double probability;
  };
  struct Selected {
    long long rule = -1;
    long long npos = -1;
    std::uint32_t value = 0;
    std::vector<Assigned> assigned;
  };

  std::string modelText(const AspModel& model) const {
    std::string s;
    for (std::uint32_t id : model) s += (*atoms_)[id] + " ";
    return s;
  }

  [[noreturn]] void bad(const std::string& atom) const {
    throw Error("AspBackend: unexpected atom '" + atom + "' in clingo answer set");
  }

  /// An integer argument of a bookkeeping atom.
  long long parseIndex(const std::string& s, const std::string& atom) const {
    char* end = nullptr;
    long long v = std::strtoll(s.c_str(), &end, 10);
    if (end == s.c_str() || *end != '\0') {
      throw Error("AspBackend: unexpected atom argument '" + s + "' in clingo answer set atom " +
                  atom);
    }
    return v;
  }

  static std::uint32_t internIn(const std::string& text, std::vector<std::string>& names,
                                std::unordered_map<std::string, std::uint32_t>& index) {
    auto [it, added] = index.emplace(text, static_cast<std::uint32_t>(names.size()));
    if (added) names.push_back(text);
    return it->second;
  }

  Decoded decode(const std::string& text) {
    AspAtom a = parseAspAtom(text);
    Decoded d;
    auto range = [&](long long v, std::size_t n) {
      if (v < 0 || v >= static_cast<long long>(n)) bad(text);
      return v;
    };
    if (a.name == "q" || a.name == "ev") {
      if (a.args.size() != 1) bad(text);
      d.kind = a.name == "q" ? Decoded::kQ : Decoded::kEv;
      d.index = range(parseIndex(a.args[0], text), specs_);
    } else if (a.name == "val") {
      d.kind = Decoded::kVal;
    } else if (a.name == "scn") {
      if (a.args.size() != 1) bad(text);
      d.kind = Decoded::kScn;
      d.index = parseIndex(a.args[0], text);
    } else if (a.name == "chosen") {
      if (a.args.size() != 4) bad(text);
      d.kind = Decoded::kChosen;
      d.index = range(parseIndex(a.args[0], text), program_.random_rules.size());
      d.term = internIn(a.args[1], terms_, term_index_);
      d.value = internIn(a.args[2], values_, value_index_);
      d.npos = parseIndex(a.args[3], text);
    } else if (a.name == "empty") {
      if (a.args.size() != 2) bad(text);
      d.kind = Decoded::kEmpty;
      d.index = range(parseIndex(a.args[0], text), program_.random_rules.size());
      d.term = internIn(a.args[1], terms_, term_index_);
    } else if (a.name == "pra") {
      if (a.args.size() != 3) bad(text);
      d.kind = Decoded::kPra;
      d.index = range(parseIndex(a.args[0], text), program_.pr_atoms.size());
      d.term = internIn(a.args[1], terms_, term_index_);
      d.value = internIn(a.args[2], values_, value_index_);
    } else {
      bad(text);
    }
    if (terms_.size() > sel_.size()) {
      sel_.resize(terms_.size());
      in_touched_.resize(terms_.size(), 0);
    }
    return d;
  }

  Selected& touch(std::uint32_t term) {
    if (!in_touched_[term]) {
      in_touched_[term] = 1;
      touched_.push_back(term);
    }
    return sel_[term];
  }

  /// The factor of one selected term: the assigned probability of its value, or its share of
  /// the unassigned mass. Negative when the term is incoherent; with raise, throws instead.
  double factor(std::uint32_t t, const AspModel& model, bool raise) const {
    const Selected& s = sel_[t];
    const std::string& attr = terms_[t];
    if (s.rule < 0 || s.npos <= 0) {
      throw Error("AspBackend: incomplete bookkeeping for " + attr + " in answer set: " +
                  modelText(model));
    }
    double alpha = 0.0;
    for (const auto& a : s.assigned) {
      if (a.probability < 0.0 || a.probability > 1.0) {
        if (!raise) return -1.0;
        throw IncoherentError(where(program_.pr_atoms[static_cast<std::size_t>(a.pr)].loc) +
                              ": probability " + std::to_string(a.probability) +
                              " is outside [0, 1]");
      }
      alpha += a.probability;
    }
    // Off by more than rounding: above 1, or below 1 with every possible value assigned (the
    // missing mass would go to no value); the native engine's rule (checkProbabilitySum).
    const bool all_assigned = static_cast<long long>(s.assigned.size()) == s.npos;
    if (alpha > 1.0 + kSumTolerance || (all_assigned && alpha < 1.0 - kSumTolerance)) {
      if (!raise) return -1.0;
      std::vector<Assigned> sorted = s.assigned;
      std::sort(sorted.begin(), sorted.end(), [this](const Assigned& a, const Assigned& b) {
        return values_[a.value] < values_[b.value];
      });
      std::string list;
      for (const auto& a : sorted) {
        const PrAtom& p = program_.pr_atoms[static_cast<std::size_t>(a.pr)];
        list += " " + attr + "=" + values_[a.value] + ":" + p.probability_text + " (" +
                where(p.loc) + ")";
      }
      throw IncoherentError("AspBackend: the probabilities assigned to " +
                            std::string(alpha > 1.0 ? "" : "all the possible values of ") + attr +
                            " sum to " + std::to_string(alpha) + (alpha > 1.0 ? " > 1" : " < 1") +
                            " in a possible world:" + list);
    }
    const double scale = renormalisation(t, alpha, all_assigned);
    for (const auto& a : s.assigned) {
      if (a.value == s.value) return a.probability * scale;
    }
    const long long beta = s.npos - static_cast<long long>(s.assigned.size());
    if (beta <= 0) {
      throw Error("AspBackend: inconsistent bookkeeping for " + attr + " in answer set: " +
                  modelText(model));
    }
    double rest = 1.0 - alpha;
    if (rest < kSumTolerance) rest = 0.0;
    return rest / static_cast<double>(beta);
  }

  /// @brief 1 / alpha when the sum alpha of term t's assigned probabilities is within
  /// rounding of 1 but off by more than the noise of exact decimals (above 1, or below it with
  /// every possible value assigned), else 1: the native engine's renormalisation, reported
  /// once per term in warnings() in its words.
  double renormalisation(std::uint32_t t, double alpha, bool all_assigned) const {
    const Selected& s = sel_[t];
    const double dev = std::fabs(alpha - 1.0);
    const double noise = kSumNoise * static_cast<double>(std::max<std::size_t>(1, s.assigned.size()));
    if (!((alpha > 1.0 || all_assigned) && dev > noise && dev <= kSumTolerance)) return 1.0;
    if (warned_.insert(t).second) {
      std::vector<Assigned> by_atom = s.assigned;
      std::sort(by_atom.begin(), by_atom.end(),
                [](const Assigned& a, const Assigned& b) { return a.pr < b.pr; });
      std::ostringstream os;
      os.precision(17);
      os << where(program_.pr_atoms[static_cast<std::size_t>(by_atom[0].pr)].loc)
         << ": warning: probabilities assigned to the values of " << terms_[t] << " sum to "
         << alpha << ", within rounding of 1: renormalised (pr-atoms at";
      for (const auto& a : by_atom)
        os << " " << where(program_.pr_atoms[static_cast<std::size_t>(a.pr)].loc);
      os << ")";
      warnings_.push_back(os.str());
    }
    return 1.0 / alpha;
  }

  mutable std::unordered_set<std::uint32_t> warned_;  ///< terms already reported
  mutable std::vector<std::string> warnings_;         ///< warnings()
  const Program& program_;
  std::size_t specs_;
  const std::vector<std::string>* atoms_ = nullptr;
  std::vector<Decoded> decoded_;
  std::vector<std::string> terms_, values_;
  std::unordered_map<std::string, std::uint32_t> term_index_, value_index_;
  std::vector<Selected> sel_;
  std::vector<std::uint32_t> touched_;
  std::vector<char> in_touched_;
};

}  // namespace

AspBackend::AspBackend(AspOptions options) : options_(std::move(options)) {}

namespace {

/// The answer sets of an optimising run (--opt-mode=optN) that are possible worlds: those of
/// minimal cost, each once. clingo prints the models improving the bound before it enumerates
/// the optimal ones (so the first optimal model appears twice), and answer sets that differ
/// only in which consistency-restoring rules they apply are one world: models are compared
/// by their atoms, which include the world's val/2 atoms.
std::vector<AspModel> optimalWorlds(const ClingoResult& res) {
  if (res.models.empty()) return {};
  // No cr-rule can ever apply (e.g. only headless ones, `:+ body.`): #minimize has no
  // elements, clingo prints no optimisation value, and every answer set is a world.
  const bool no_costs = res.costs.empty();
  if (!no_costs && res.costs.size() != res.models.size()) {
    throw Error("AspBackend: clingo printed no optimisation value for an answer set");
  }
  const std::vector<long long> best =
      no_costs ? std::vector<long long>() : *std::min_element(res.costs.begin(), res.costs.end());
  std::set<AspModel> seen;
  std::vector<AspModel> out;
  for (std::size_t i = 0; i < res.models.size(); ++i) {
    if (!no_costs && res.costs[i] != best) continue;
    AspModel atoms = res.models[i];
    std::sort(atoms.begin(), atoms.end());
    if (seen.insert(atoms).second) out.push_back(res.models[i]);
  }
  return out;
}

std::string evidenceKey(const std::vector<Observation>& observations) {
  std::vector<std::string> keys;
  for (const auto& o : observations) keys.push_back((o.truth ? "+" : "-") + toString(o.literal));
  std::sort(keys.begin(), keys.end());
  std::string k;
  for (const auto& s : keys) k += s + ";";
  return k;
}

/// One clingo run answering specs under their scenarios' interventions. When every spec of
/// a scenario has the same evidence, the evidence is a constraint of that scenario (clingo
/// then never enumerates the worlds it excludes: on Poker, 15504 of 3.2 million); with
/// constrain_evidence false, it is only a flag.
GroupResult runScenarios(const Program& program,
                         const std::vector<std::vector<Intervention>>& scenarios,
                         const std::vector<QuerySpec>& specs,
                         const std::vector<std::size_t>& spec_scenario, const AspOptions& options,
                         AspStats& stats, bool constrain_evidence = true) {
  const bool cr = program.hasConsistencyRestoringRules();
  std::string text = translateBase(program) + translateScenarios(program, scenarios, specs);
  std::vector<std::string> args;
  std::vector<char> constrained(scenarios.size(), 0);
  if (cr) {
    // CR-Prolog as plog2.0 implements it: the possible worlds are the answer sets with the
    // fewest applied consistency-restoring rule instances. The query's evidence is part of
    // the program whose consistency is restored, so it is a constraint here (callers give
    // one scenario and specs with identical evidence, see runGroup).
    if (scenarios.size() != 1) throw Error("AspBackend: consistency-restoring rules need one scenario per run");
    text += "#minimize{ 1,WC,WT : appl(WC,WT) }.\n#show val/2.\n";
    for (std::size_t k = 0; k < specs.size(); ++k) text += ":- not ev(" + std::to_string(k) + ").\n";
    args.push_back("--opt-mode=optN");
  } else if (constrain_evidence) {
    for (std::size_t g = 0; g < scenarios.size(); ++g) {
      std::size_t first = specs.size();
      bool same = true;
      std::string key;
      for (std::size_t k = 0; k < specs.size(); ++k) {
        if (spec_scenario[k] != g) continue;
        const std::string kk = evidenceKey(specs[k].observations);
        if (first == specs.size()) {
          first = k;
          key = kk;
        } else if (kk != key) {
          same = false;
        }
      }
      if (first == specs.size() || !same || specs[first].observations.empty()) continue;
      constrained[g] = 1;
      text += ":- not ev(" + std::to_string(first) + ")" +
              (scenarios.size() > 1 ? ", scn(" + std::to_string(g) + ")" : std::string()) + ".\n";
    }
  }
  GroupResult g;
  g.num.assign(specs.size(), 0.0);
  g.den.assign(specs.size(), 0.0);
  g.worlds.assign(scenarios.size(), 0);
  g.scenario = spec_scenario;
  g.error.assign(specs.size(), std::string());
  std::vector<char> hq(specs.size()), he(specs.size());
  std::vector<std::size_t> evidence;
  WorldMeasure wm(program, specs.size());
  auto addWorld = [&](const AspModel& m) {
    double mu = 0.0;
    long long scn = 0;
    try {
      mu = wm.measure(m, hq, he, scn);
    } catch (const IncoherentError& e) {
      // The world is incoherent: an error for the queries of its scenario whose evidence it
      // satisfies only (the others exclude it, exactly as if their evidence were constraints).
      const long long world_scn = wm.scenarioOf(m, evidence);
      for (std::size_t k : evidence) {
        if (static_cast<long long>(spec_scenario[k]) == world_scn && g.error[k].empty()) {
          g.error[k] = e.what();
        }
      }
      return;
    }
    if (scn < 0 || scn >= static_cast<long long>(scenarios.size())) {
      throw Error("AspBackend: answer set of unknown scenario " + std::to_string(scn));
    }
    ++g.worlds[static_cast<std::size_t>(scn)];
    for (std::size_t k = 0; k < specs.size(); ++k) {
      if (!he[k] || static_cast<long long>(spec_scenario[k]) != scn) continue;
      g.den[k] += mu;
      if (hq[k]) g.num[k] += mu;
    }
  };
  const auto t0 = std::chrono::steady_clock::now();
  std::size_t worlds = 0;
  if (cr) {
    ClingoResult res = runClingo(text, options, args);
    wm.decodeNew(res.atoms);
    std::vector<AspModel> optimal = optimalWorlds(res);
    worlds = optimal.size();
    for (const auto& m : optimal) addWorld(m);
  } else {
    ClingoResult res = runClingo(text, options, args,
                                 [&](const std::vector<std::string>& atoms, const AspModel& m) {
                                   wm.decodeNew(atoms);
                                   addWorld(m);
                                 });
    worlds = res.model_count;
  }
  stats.clingo_seconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ++stats.clingo_runs;
  stats.worlds += worlds;
  g.warnings = wm.warnings();
  for (std::size_t s = 0; s < scenarios.size(); ++s) {
    // No world satisfies a constrained scenario's evidence: run again with the evidence as
    // a flag, to tell a program without possible worlds from evidence of probability zero.
    if (constrained[s] && g.worlds[s] == 0) {
      return runScenarios(program, scenarios, specs, spec_scenario, options, stats, false);
    }
  }
  return g;
}

/// The specs under one set of interventions. With consistency-restoring rules, the worlds
/// depend on the evidence (it takes part in the minimisation), so specs are answered in
/// one run per distinct evidence; GroupResult::scenario then numbers these runs.
GroupResult runGroup(const Program& program, const std::vector<Intervention>& dos,
                     const std::vector<QuerySpec>& specs, const AspOptions& options,
                     AspStats& stats) {
  if (!program.hasConsistencyRestoringRules()) {
    return runScenarios(program, {dos}, specs, std::vector<std::size_t>(specs.size(), 0),
                        options, stats);
  }
  std::map<std::string, std::vector<std::size_t>> by_evidence;
  for (std::size_t k = 0; k < specs.size(); ++k)
    by_evidence[evidenceKey(specs[k].observations)].push_back(k);
  GroupResult out;
  out.num.assign(specs.size(), 0.0);
  out.den.assign(specs.size(), 0.0);
  out.error.assign(specs.size(), std::string());
  out.scenario.assign(specs.size(), 0);
  for (const auto& [key, members] : by_evidence) {
    std::vector<QuerySpec> sub;
    for (std::size_t k : members) sub.push_back(specs[k]);
    GroupResult r = runScenarios(program, {dos}, sub, std::vector<std::size_t>(sub.size(), 0),
                                 options, stats);
    for (std::size_t m = 0; m < members.size(); ++m) {
      const std::size_t k = members[m];
      out.num[k] = r.num[m];
      out.den[k] = r.den[m];
      out.error[k] = r.error[m];
      out.scenario[k] = out.worlds.size();
    }
    out.worlds.push_back(r.worlds.at(0));
    for (const auto& w : r.warnings)
      if (std::find(out.warnings.begin(), out.warnings.end(), w) == out.warnings.end())
        out.warnings.push_back(w);
  }
  return out;
}

double ratio(const GroupResult& g, std::size_t k, const std::string& text) {
  if (!g.error[k].empty()) throw IncoherentError(g.error[k]);
  if (g.worlds[g.scenario[k]] == 0) {
    throw IncoherentError("AspBackend: the program with the interventions of query '" + text +
                          "' has no possible world");
  }
  if (!(g.den[k] > 0.0)) {
    throw IncoherentError("AspBackend: the evidence of query '" + text +
                          "' has probability 0 (no possible world of non-zero measure "
                          "satisfies it)");
  }
  double p = g.num[k] / g.den[k];
  return std::min(1.0, std::max(0.0, p));
}

}  // namespace

void AspBackend::noteWarnings(const std::vector<std::string>& warnings) {
  for (const auto& w : warnings)
    if (std::find(warnings_.begin(), warnings_.end(), w) == warnings_.end()) warnings_.push_back(w);
}

double AspBackend::probability(const Program& program, const Query& query) {
  return probabilities(program, {query}).at(0);
}

std::vector<double> AspBackend::probabilities(const Program& program,
                                              const std::vector<Query>& queries,
                                              std::vector<std::string>* incoherence_errors) {
  std::vector<double> out(queries.size(), 0.0);
  if (incoherence_errors) incoherence_errors->assign(queries.size(), std::string());
  if (queries.empty()) return out;
  std::map<std::string, std::size_t> scenario_of_key;
  std::vector<std::vector<Intervention>> scenarios;
  std::vector<std::size_t> query_scenario(queries.size());
  for (std::size_t i = 0; i < queries.size(); ++i) {
    auto [it, added] =
        scenario_of_key.emplace(interventionKey(queries[i].interventions), scenarios.size());
    if (added) scenarios.push_back(queries[i].interventions);
    query_scenario[i] = it->second;
  }
  std::vector<QuerySpec> specs;
  for (const Query& q : queries) {
    specs.push_back({q.formula, q.observations, q.text.empty() ? toString(q) : q.text});
  }
  auto answer = [&](const GroupResult& g, std::size_t k, std::size_t i) {
    if (incoherence_errors == nullptr) {
      out[i] = ratio(g, k, specs[k].text);
      return;
    }
    try {
      out[i] = ratio(g, k, specs[k].text);
    } catch (const IncoherentError& e) {
      out[i] = std::numeric_limits<double>::quiet_NaN();
      (*incoherence_errors)[i] = e.what();
    }
  };
  const bool cr = program.hasConsistencyRestoringRules();
  // One process for all intervention sets grounds the program with every intervened
  // attribute left open (the sets are chosen by external atoms after grounding): on large
  // programs that grounding is far bigger than a grounding per set with its do() facts (the
  // 50x50 navigation knowledge base: 46 s for two sets, 0.14 s per set alone). It saves
  // only process start-ups, so it is used where the whole program has few worlds.
  const bool small = aspWorldsLog2(program) <= kMultiShotMaxWorldsLog2;
  if (!cr && (scenarios.size() == 1 || (options_.multi_shot && !multi_shot_failed_ && small))) {
    try {
      GroupResult g =
          runScenarios(program, scenarios, specs, query_scenario, options_, stats_);
      noteWarnings(g.warnings);
      for (std::size_t i = 0; i < queries.size(); ++i) answer(g, i, i);
      return out;
    } catch (const IncoherentError&) {
      throw;
    } catch (const Error& e) {
      // clingo without Lua support: answer scenario by scenario from now on.
      const std::string what = e.what();
      if (scenarios.size() == 1 ||
          (what.find("lua") == std::string::npos && what.find("script") == std::string::npos)) {
        throw;
      }
      multi_shot_failed_ = true;
    }
  }
  for (std::size_t g = 0; g < scenarios.size(); ++g) {
    std::vector<QuerySpec> group_specs;
    std::vector<std::size_t> members;
    for (std::size_t i = 0; i < queries.size(); ++i) {
      if (query_scenario[i] != g) continue;
      members.push_back(i);
      group_specs.push_back(specs[i]);
    }
    GroupResult r = runGroup(program, scenarios[g], group_specs, options_, stats_);
    noteWarnings(r.warnings);
    for (std::size_t k = 0; k < members.size(); ++k) answer(r, k, members[k]);
  }
  return out;
}

std::vector<double> AspBackend::answerQueries(const Program& program) {
  return probabilities(program, program.queries);
}

std::vector<std::pair<std::string, double>> AspBackend::distribution(
    const Program& program, const AttributeTerm& attribute,
    const std::vector<Observation>& observations, const std::vector<Intervention>& interventions) {
  const AttributeDecl& decl = attributeOf(program, attribute);
  for (const auto& t : attribute.args) {
    if (!t.isGround()) {
      throw Error(where(attribute.loc) + ": AspBackend: distribution of '" + toString(attribute) +
                  "' needs a ground attribute term");
    }
  }
  const SortDecl* range = program.findSort(decl.range_sort);
  if (range == nullptr) {
    throw UnknownSymbolError(where(decl.loc) + ": AspBackend: undeclared sort '" +
                             decl.range_sort + "' of attribute '" + decl.name + "'");
  }
  std::vector<QuerySpec> specs;
  for (const auto& v : range->values) {
    Literal l;
    l.kind = Literal::Kind::Atom;
    l.atom.attr = attribute;
    l.atom.value = v;
    l.loc = attribute.loc;
    specs.push_back({{l}, observations, toString(attribute) + "=" + toString(v)});
  }
  std::vector<std::pair<std::string, double>> out;
  if (specs.empty()) return out;
  GroupResult g = runGroup(program, interventions, specs, options_, stats_);
  noteWarnings(g.warnings);
  for (std::size_t k = 0; k < specs.size(); ++k) {
    out.emplace_back(toString(range->values[k]), ratio(g, k, specs[k].text));
  }
  return out;
}

double AspBackend::probability(const Program& program, const std::string& query) {
  return probability(program, parseQuery(program, query));
}

std::vector<ValueProb> AspBackend::distribution(const Program& program,
                                                const std::string& attribute_term,
                                                const std::string& evidence) {
  AttributeTerm attr = parseAttributeTerm(program, attribute_term);
  std::vector<Observation> obs;
  std::vector<Intervention> dos;
  if (evidence.find_first_not_of(" \t\r\n") != std::string::npos) {
    // The parser reads evidence as the condition of a query; the formula is a placeholder.
    const AttributeDecl& decl = attributeOf(program, attr);
    const SortDecl* range = program.findSort(decl.range_sort);
    if (range == nullptr || range->values.empty()) {
      throw UnknownSymbolError("AspBackend: attribute '" + decl.name + "' has no range values");
    }
    Query q = parseQuery(program, "?{" + toString(attr) + "=" + toString(range->values[0]) +
                                      "} | " + evidence, "<evidence>");
    obs = q.observations;
    dos = q.interventions;
  }
  std::vector<ValueProb> out;
  for (const auto& [value, p] : distribution(program, attr, obs, dos)) {
    if (p > 0.0) out.push_back({value, p});
  }
  return out;
}

std::vector<QueryAnswer> AspBackend::answerProgramQueries(const Program& program) {
  std::vector<double> p = probabilities(program, program.queries);
  std::vector<QueryAnswer> out;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Query& q = program.queries[i];
    out.push_back({q.text.empty() ? toString(q) : q.text, p[i]});
  }
  return out;
}

}  // namespace plog
}  // namespace krr
