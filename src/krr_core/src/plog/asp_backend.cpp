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

#include "krr_core/common/errors.h"
#include "krr_core/plog/parser.h"

namespace krr {
namespace plog {

using namespace asp_detail;

namespace {

/// Slack on sums of assigned probabilities (they are decimal fractions read as doubles).
constexpr double kSumTolerance = 1e-9;

std::string modelText(const AspModel& model) {
  std::string s;
  for (const auto& a : model) s += a + " ";
  return s;
}

/// An integer argument of a bookkeeping atom (the model is only printed on error).
long long parseIndex(const std::string& s, const AspModel& model) {
  char* end = nullptr;
  long long v = std::strtoll(s.c_str(), &end, 10);
  if (end == s.c_str() || *end != '\0') {
    throw Error("AspBackend: unexpected atom argument '" + s + "' in clingo answer set: " +
                modelText(model));
  }
  return v;
}

/// Numerators and denominators of the specs of one clingo run.
struct GroupResult {
  std::vector<double> num, den;
  std::vector<std::string> error;  ///< incoherence met in a world of the query's evidence
  std::vector<std::size_t> worlds;  ///< per scenario
  std::vector<std::size_t> scenario;  ///< per spec
};

/// P-log measure of one answer set; sets holds_q / holds_ev per spec and the scenario
/// (scn(g) atom, 0 when absent) the answer set belongs to.
/// @throws IncoherentError when the world breaks a P-log coherence condition.
double worldMeasure(const Program& program, const AspModel& model, std::vector<char>& holds_q,
                    std::vector<char>& holds_ev, long long& scenario) {
  struct Selected {
    long long rule = -1;
    long long npos = -1;
    std::string value;
    std::map<std::string, std::pair<long long, double>> assigned;  // value -> (pr-atom, v)
  };
  std::map<std::string, Selected> sel;
  std::fill(holds_q.begin(), holds_q.end(), 0);
  std::fill(holds_ev.begin(), holds_ev.end(), 0);
  scenario = 0;
  auto twoRules = [&program](const std::string& attr, long long r1, long long r2) {
    throw IncoherentError(
        "AspBackend: two random selection rules (" +
        where(program.random_rules.at(static_cast<std::size_t>(r1)).loc) + " and " +
        where(program.random_rules.at(static_cast<std::size_t>(r2)).loc) + ") apply to " +
        attr + " in one possible world");
  };
  auto bad = [&](const std::string& atom) {
    throw Error("AspBackend: unexpected atom '" + atom + "' in clingo answer set: " +
                modelText(model));
  };
  for (const auto& text : model) {
    AspAtom a = parseAspAtom(text);
    if (a.name == "q" || a.name == "ev") {
      if (a.args.size() != 1) bad(text);
      long long k = parseIndex(a.args[0], model);
      auto& v = a.name == "q" ? holds_q : holds_ev;
      if (k < 0 || k >= static_cast<long long>(v.size())) bad(text);
      v[static_cast<std::size_t>(k)] = 1;
    } else if (a.name == "val") {
      // shown for programs with consistency-restoring rules only (to tell worlds apart)
    } else if (a.name == "scn") {
      if (a.args.size() != 1) bad(text);
      scenario = parseIndex(a.args[0], model);
    } else if (a.name == "chosen") {
      if (a.args.size() != 4) bad(text);
      const long long r = parseIndex(a.args[0], model);
      if (r < 0 || r >= static_cast<long long>(program.random_rules.size())) bad(text);
      Selected& s = sel[a.args[1]];
      if (s.rule >= 0 && s.rule != r) twoRules(a.args[1], s.rule, r);
      s.rule = r;
      s.value = a.args[2];
      s.npos = parseIndex(a.args[3], model);
    } else if (a.name == "empty") {
      if (a.args.size() != 2) bad(text);
      const long long r = parseIndex(a.args[0], model);
      if (r < 0 || r >= static_cast<long long>(program.random_rules.size())) bad(text);
      throw IncoherentError("AspBackend: the dynamic range of " + a.args[1] +
                            " (random selection at " +
                            where(program.random_rules[static_cast<std::size_t>(r)].loc) +
                            ") is empty in a possible world");
    } else if (a.name == "pra") {
      if (a.args.size() != 3) bad(text);
      long long j = parseIndex(a.args[0], model);
      if (j < 0 || j >= static_cast<long long>(program.pr_atoms.size())) bad(text);
      const PrAtom& p = program.pr_atoms[static_cast<std::size_t>(j)];
      Selected& s = sel[a.args[1]];
      auto it = s.assigned.find(a.args[2]);
      if (it != s.assigned.end() && it->second.first != j &&
          std::fabs(it->second.second - p.probability) > 1e-12) {
        const PrAtom& p2 = program.pr_atoms.at(static_cast<std::size_t>(it->second.first));
        throw IncoherentError("AspBackend: two pr-atoms (" + where(p2.loc) + " and " +
                              where(p.loc) + ") assign different probabilities (" +
                              p2.probability_text + " and " + p.probability_text + ") to " +
                              a.args[1] + "=" + a.args[2] + " in one possible world");
      }
      s.assigned[a.args[2]] = {j, p.probability};
    } else {
      bad(text);
    }
  }
  double mu = 1.0;
  for (const auto& [attr, s] : sel) {
    if (s.rule < 0 || s.npos <= 0) {
      throw Error("AspBackend: incomplete bookkeeping for " + attr + " in answer set: " +
                  modelText(model));
    }
    double alpha = 0.0;
    for (const auto& [value, pv] : s.assigned) {
      if (pv.second < 0.0 || pv.second > 1.0) {
        throw IncoherentError(where(program.pr_atoms[static_cast<std::size_t>(pv.first)].loc) +
                              ": probability " + std::to_string(pv.second) +
                              " is outside [0, 1]");
      }
      alpha += pv.second;
    }
    if (alpha > 1.0 + kSumTolerance) {
      std::string list;
      for (const auto& [value, pv] : s.assigned) {
        list += " " + attr + "=" + value + ":" +
                program.pr_atoms[static_cast<std::size_t>(pv.first)].probability_text + " (" +
                where(program.pr_atoms[static_cast<std::size_t>(pv.first)].loc) + ")";
      }
      throw IncoherentError("AspBackend: the probabilities assigned to " + attr +
                            " sum to " + std::to_string(alpha) + " > 1 in a possible world:" +
                            list);
    }
    auto it = s.assigned.find(s.value);
    if (it != s.assigned.end()) {
      mu *= it->second.second;
    } else {
      long long beta = s.npos - static_cast<long long>(s.assigned.size());
      if (beta <= 0) {
        throw Error("AspBackend: inconsistent bookkeeping for " + attr + " in answer set: " +
                    modelText(model));
      }
      double rest = 1.0 - alpha;
      if (rest < kSumTolerance) rest = 0.0;
      mu *= rest / static_cast<double>(beta);
    }
  }
  return mu;
}

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
  if (res.costs.size() != res.models.size()) {
    throw Error("AspBackend: clingo printed no optimisation value for an answer set");
  }
  const auto best = *std::min_element(res.costs.begin(), res.costs.end());
  std::set<std::vector<std::string>> seen;
  std::vector<AspModel> out;
  for (std::size_t i = 0; i < res.models.size(); ++i) {
    if (res.costs[i] != best) continue;
    std::vector<std::string> atoms = res.models[i];
    std::sort(atoms.begin(), atoms.end());
    if (seen.insert(atoms).second) out.push_back(res.models[i]);
  }
  return out;
}

/// One clingo run answering specs under their scenarios' interventions.
GroupResult runScenarios(const Program& program,
                         const std::vector<std::vector<Intervention>>& scenarios,
                         const std::vector<QuerySpec>& specs,
                         const std::vector<std::size_t>& spec_scenario, const AspOptions& options,
                         AspStats& stats) {
  const bool cr = program.hasConsistencyRestoringRules();
  std::string text = translateBase(program) + translateScenarios(program, scenarios, specs);
  std::vector<std::string> args;
  if (cr) {
    // CR-Prolog as plog2.0 implements it: the possible worlds are the answer sets with the
    // fewest applied consistency-restoring rule instances. The query's evidence is part of
    // the program whose consistency is restored, so it is a constraint here (callers give
    // one scenario and specs with identical evidence, see runGroup).
    if (scenarios.size() != 1) throw Error("AspBackend: consistency-restoring rules need one scenario per run");
    text += "#minimize{ 1,WC,WT : appl(WC,WT) }.\n#show val/2.\n";
    for (std::size_t k = 0; k < specs.size(); ++k) text += ":- not ev(" + std::to_string(k) + ").\n";
    args.push_back("--opt-mode=optN");
  }
  const auto t0 = std::chrono::steady_clock::now();
  ClingoResult res = runClingo(text, options, args);
  stats.clingo_seconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ++stats.clingo_runs;
  if (cr) res.models = optimalWorlds(res);
  stats.worlds += res.models.size();
  GroupResult g;
  g.num.assign(specs.size(), 0.0);
  g.den.assign(specs.size(), 0.0);
  g.worlds.assign(scenarios.size(), 0);
  g.scenario = spec_scenario;
  g.error.assign(specs.size(), std::string());
  std::vector<char> hq(specs.size()), he(specs.size());
  for (const auto& m : res.models) {
    double mu = 0.0;
    long long scn = 0;
    try {
      mu = worldMeasure(program, m, hq, he, scn);
    } catch (const IncoherentError& e) {
      // The world is incoherent: an error for the queries of its scenario whose evidence it
      // satisfies only (the others exclude it, exactly as if their evidence were constraints).
      long long world_scn = 0;
      for (const auto& text : m) {
        AspAtom a = parseAspAtom(text);
        if (a.name == "scn" && a.args.size() == 1) world_scn = parseIndex(a.args[0], m);
      }
      for (const auto& text : m) {
        AspAtom a = parseAspAtom(text);
        if (a.name != "ev" || a.args.size() != 1) continue;
        const auto k = static_cast<std::size_t>(parseIndex(a.args[0], m));
        if (k < specs.size() && static_cast<long long>(spec_scenario[k]) == world_scn &&
            g.error[k].empty()) {
          g.error[k] = e.what();
        }
      }
      continue;
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
  }
  return g;
}

std::string evidenceKey(const std::vector<Observation>& observations) {
  std::vector<std::string> keys;
  for (const auto& o : observations) keys.push_back((o.truth ? "+" : "-") + toString(o.literal));
  std::sort(keys.begin(), keys.end());
  std::string k;
  for (const auto& s : keys) k += s + ";";
  return k;
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
  if (!cr && (scenarios.size() == 1 || (options_.multi_shot && !multi_shot_failed_))) {
    try {
      GroupResult g =
          runScenarios(program, scenarios, specs, query_scenario, options_, stats_);
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
