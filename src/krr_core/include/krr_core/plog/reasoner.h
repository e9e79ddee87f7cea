/**
 * @file reasoner.h
 * @brief In-process P-log reasoner: load programs, add learned knowledge, answer queries and
 * build whole conditional probability tables (the inner loop of the paper's Procedure 2).
 *
 * Inference is exact: the relevance cone of each query is grounded and the possible-world
 * measure is summed by variable elimination over the random attribute instances (see
 * engine.h). Groundings are cached and PATCHED when knowledge is added or removed (facts of
 * guard attributes, pr-atoms; see IncrementalGrounder) instead of being redone, and a table
 * query recomputes only the rows that a changed ground pr-atom can reach (its body fixes the
 * do()-conditioning values of the row); every other change grounds again.
 *
 * The native engine is exact on its fragment only: negation stratified at the ground level,
 * no cyclic selections, no rule defining a random attribute, factors within its size limits.
 * Everything that can remove or split possible worlds anywhere in the program (constraints,
 * derived attributes with two values, loops through `not`, dynamic ranges) is part of every
 * query's cone, so a program outside the fragment is detected, never answered wrongly
 * (OutsideFragmentError). With Backend::Auto, the default, such queries are answered by the
 * clingo back end (AspBackend) instead.
 */
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "krr_core/plog/ast.h"
#include "krr_core/plog/budget.h"
#include "krr_core/plog/name_table.h"
#include "krr_core/plog/parser.h"

namespace krr {
namespace plog {

struct GroundProgram;
struct GCondition;
class ExactEngine;
class AspBackend;
struct AspOptions;

/// @brief Which inference engine answers queries.
enum class Backend {
  Native,  ///< the exact engine only: OutsideFragmentError outside its fragment
  Asp,     ///< clingo (AspBackend) for every query
  Auto     ///< native where its fragment applies (exact and faster), clingo otherwise
};
/// @brief log2 of an upper bound on the number of possible worlds clingo enumerates for
/// the program: the sum over its random selection rules of (ground instances of the attribute
/// term x log2 |range sort|); infinity when a sort is unknown.
double aspWorldsLog2(const Program& program);

/// @brief Upper bound on the work of the clingo back end for the program, in ground atoms
/// processed: at most 2^aspWorldsLog2 worlds, each of about the program's ground size (the
/// selected attribute instances with their possible values, the rules and pr-atoms; clingo
/// propagates over all of it per answer set). Infinity when a sort is unknown.
double aspWorkAtoms(const Program& program);

struct EnginePlan;

/// @brief Cost estimates of Backend::Auto for one query, in seconds.
struct AutoEstimate {
  /// @brief clingo: process start-up + aspWorkAtoms x seconds per atom (an upper bound:
  /// observations prune worlds).
  double asp_seconds = std::numeric_limits<double>::infinity();
  /// @brief The native engine's inference: the rows of its plan x (1 + the ground rules of
  /// derived instances, evaluated per row) x seconds per row (an upper bound too: rows stop at
  /// the first failing literal). NaN while it grounds (no plan yet).
  double native_seconds = std::numeric_limits<double>::quiet_NaN();
  /// @brief The plan has a table beyond the native engine's limit (2^kMaxFactorLog2): it will
  /// refuse the query.
  bool native_refuses = false;
};

/// @brief What Backend::Auto does with a query.
enum class AutoChoice {
  Native,  ///< the native engine; clingo joins only after AutoDecision::asp_join_seconds
  Race,    ///< both at once, the first answer wins (the other is abandoned)
  Asp      ///< clingo: the native engine cannot answer
};

struct AutoDecision {
  AutoChoice choice = AutoChoice::Native;
  /// @brief With AutoChoice::Native: seconds (after the plan, or after the start of the query
  /// while there is no plan) after which clingo joins if the native engine has not answered;
  /// infinity: never (clingo would need over kHopelessRatio times longer).
  double asp_join_seconds = std::numeric_limits<double>::infinity();
};

/// @brief Constants of the cost model (calibrated with bench_plog_auto, see the README).
struct AutoCostModel {
  static constexpr double kAspStartSeconds = 0.005;   ///< one clingo process
  static constexpr double kAspSecondsPerAtom = 1e-7;  ///< per ground atom per world
  static constexpr double kNativeSecondsPerRow = 1e-7;  ///< per row and evaluated rule
  /// @brief The native engine answers alone when its estimate is at most 1/kSureRatio of
  /// clingo's (both are upper bounds of unknown tightness: closer than that, they race).
  static constexpr double kSureRatio = 4;
  /// @brief clingo never joins when its estimate is kHopelessRatio times the native one.
  static constexpr double kHopelessRatio = 1000;
  /// @brief While the native engine grounds (no plan yet), clingo joins after
  /// max(kGroundingRaceFactor x race delay, half its own estimate).
  static constexpr double kGroundingRaceFactor = 2;
  /// @brief After the plan, clingo joins once the native engine has overrun its estimate
  /// this many times (or spent half clingo's estimate), at most after the race delay.
  static constexpr double kOverrun = 4;
};

/// @brief The native engine's estimated inference seconds for a plan.
double nativeCostSeconds(const EnginePlan& plan);
/// @brief clingo's estimated seconds for a program.
double aspCostSeconds(const Program& program);
/// @brief Backend::Auto's choice for the estimates (pure: unit-tested). Never clingo alone
/// while the native engine can answer: only AutoEstimate::native_refuses gives Asp; estimates
/// closer than kSureRatio race; otherwise the native engine, with clingo joining when the
/// native engine overruns its estimate (race_delay: the longest it then runs alone; 0: race
/// at once), never when clingo is hopeless.
AutoDecision decideAuto(const AutoEstimate& estimate, double race_delay);
const char* autoChoiceName(AutoChoice choice);

/// @brief Why the native engine will probably refuse the program, decided from the program
/// text before any grounding ("" when nothing points that way): a consistency-restoring rule,
/// or a dependency loop through `not` (or `!=`) between (attribute, value) pairs, arguments
/// ignored. Conservative: a program whose ground instances happen not to loop is named too
/// (the native engine may still answer it; Backend::Auto then only starts clingo earlier).
std::string negationLoopReason(const Program& program);

/// @brief "native", "asp" or "auto".
const char* backendName(Backend backend);
/// @brief Inverse of backendName. @throws ConfigError naming the accepted values.
Backend parseBackend(const std::string& name);

/// @brief One value of an attribute with its probability.
struct ValueProb {
  std::string value;
  double probability = 0;
};

/// @brief One row of a table query: the distribution of the target for one combination of
/// values of the conditioning attributes.
struct TableRow {
  std::vector<std::string> conditioning_values;  ///< in the order of Table::conditioning
  std::vector<ValueProb> distribution;           ///< values with probability > 0, sort order
  double undefined_probability = 0;  ///< mass of worlds where the target has no value
  bool consistent = true;            ///< false: the combination has probability zero
};

/// @brief P(target | conditioning) for every combination of conditioning values (sparse).
struct Table {
  std::string target;
  std::vector<std::string> conditioning;
  std::vector<TableRow> rows;  ///< mixed radix over the conditioning ranges, first fastest
};

/// @brief Answer to one query.
struct QueryAnswer {
  std::string query;  ///< normalised query text
  double probability = 0;
};

/// @brief Grounding / inference figures of the last call, for benchmarks.
struct ReasonerStats {
  size_t ground_instances = 0;
  size_t ground_statements = 0;
  double ground_seconds = 0;
  bool ground_incremental = false;  ///< the last grounding was a patch of a cached one
  /// @brief The last grounding holds only the instances its query reaches (GroundProgram::
  /// instance_restricted; see GroundingLimits::cone_restrict_min_instances).
  bool ground_restricted = false;
  size_t full_groundings = 0;       ///< groundings from scratch so far
  size_t incremental_groundings = 0;  ///< patches so far
  size_t table_rows_computed = 0;   ///< rows the last table query computed (others reused)
  Backend last_backend = Backend::Native;  ///< engine that answered the last query
  size_t asp_answers = 0;           ///< queries (or tables) answered by clingo so far
  /// @brief Raced queries on which clingo started with the native engine, not after its
  /// grounding, because the program may loop through negation (negationLoopReason).
  size_t asp_started_at_once = 0;
  /// @brief Backend::Auto: the estimates and the choice of the last query (the choice made at
  /// the native plan; Native without a plan when the native engine stopped before it).
  AutoEstimate last_estimate;
  AutoChoice last_auto_choice = AutoChoice::Native;
  bool last_asp_joined = false;  ///< clingo ran on the last Auto query
};

class Reasoner {
 public:
  Reasoner();
  ~Reasoner();

  /// @brief Replace the program by the content of a file (dialect detected).
  void loadFile(const std::string& path, Dialect dialect = Dialect::Auto);
  /// @brief Replace the program by program text; `name` is used in error locations.
  void loadString(const std::string& text, const std::string& name = "<string>",
                  Dialect dialect = Dialect::Auto);
  /// @brief Add statements (facts, rules, pr-atoms, declarations) to the current program: this
  /// is how learned knowledge enters. A pr-atom with the same label, atom a(t)=y and body (as a
  /// set of literals) as an existing one REPLACES its probability instead of being duplicated,
  /// so re-learning updates the knowledge base; identical facts/rules are not duplicated.
  /// Added statements carry `tag` (see removeStatementsWithTag). Each call is a new knowledge
  /// generation: its pr-atoms override conflicting pr-atoms of earlier generations for the
  /// same value in the same world (learned knowledge refines the human-written prior).
  /// @return number of statements added or updated.
  size_t addStatements(const std::string& text, const std::string& tag = "",
                       const std::string& name = "<statements>");
  /// @brief Warnings of the parser about the loaded and added statements ("file:line:col:
  /// warning: ..."), e.g. facts left out because a value is outside its sort.
  const std::vector<std::string>& warnings() const { return program_.warnings; }
  /// @brief Make ill-sorted facts an error (UnknownSymbolError) instead of a warning in the
  /// programs and statements parsed from now on (see ParseOptions::strict_sorts).
  void setStrictSorts(bool strict) { parse_options_.strict_sorts = strict; }
  /// @brief Remove every rule and pr-atom added with this tag; returns how many.
  size_t removeStatementsWithTag(const std::string& tag);

  /// @brief addStatements() for statements that are already parsed and resolved against this
  /// program (e.g. parsed once, then copied with other ground values): no text to parse. Same
  /// semantics (replacement of pr-atoms with the same label/atom/body, no duplicate rules, one
  /// knowledge generation, tag). The caller guarantees they are well formed; their attributes
  /// are checked when grounding.
  size_t addStatements(std::vector<Rule> rules, std::vector<PrAtom> pr_atoms,
                       const std::string& tag = "");
  /// @brief Remove the statements equal to the given ones: pr-atoms with the same label, atom
  /// and body (whatever their probability), rules with the same text. @return how many.
  size_t removeStatements(const std::vector<Rule>& rules, const std::vector<PrAtom>& pr_atoms);

  /// @brief P(formula | obs, do) for a query such as `?{a=y} | obs(b=z), do(c=w)` (the `?`,
  /// braces and final period are optional). Program-level obs/do statements also apply.
  /// @throws IncoherentError when the evidence has probability zero or the program is incoherent.
  double probability(const std::string& query);
  double probability(const Query& query);

  /// @brief Distribution of an attribute instance (`next_cell`, `curr_room(dave)`) given
  /// evidence written as `obs(...), do(...)` (may be empty). Values with probability > 0; the
  /// mass of worlds where the instance has no value is left out.
  std::vector<ValueProb> distribution(const std::string& attribute_term,
                                      const std::string& evidence = "");

  /// @brief Full conditional table of `target` for every value combination of `conditioning`
  /// (attribute terms), grounded once. With `conditioning_as_do` (default, as in the paper's
  /// transition model) the conditioning values are interventions do(c=v); otherwise they are
  /// observations. Exogenous random attributes are marginalised.
  Table tableQuery(const std::string& target, const std::vector<std::string>& conditioning,
                   const std::string& evidence = "", bool conditioning_as_do = true);

  /// @brief Answers to the queries contained in the loaded program, in order.
  std::vector<QueryAnswer> answerProgramQueries();

  /// @brief Values of a sort (UnknownSymbolError if undeclared).
  std::vector<std::string> sortValues(const std::string& sort) const;
  /// @brief Range (values of the range sort) of an attribute.
  std::vector<std::string> attributeRange(const std::string& attribute) const;
  std::vector<std::string> sortNames() const;
  std::vector<std::string> attributeNames() const;

  /// @brief The program in the classic dialect; parses back to an equivalent program.
  std::string exportProgram() const;

  /// @brief Budgets of every later grounding and inference (see GroundingLimits); exhausting
  /// one throws BudgetExceededError naming the statement, and the reasoner stays usable.
  void setLimits(const GroundingLimits& limits) {
    limits_ = limits;
    limits_.cancel = &asp_won_;
    parse_options_.memory_budget = limits.memory_budget;  // reading shares the budget
  }
  const GroundingLimits& limits() const { return limits_; }

  /// @brief Engine for later queries (default Backend::Auto). Under Auto, each query (and
  /// distribution; tables stay native) is planned by the native engine (grounding the query's
  /// cone, then listing the tables to fill, none filled) and decided by decideAuto on the
  /// estimates of both engines: the native engine alone (clingo joining only if it overruns its
  /// estimate), or a race (both run, the first answer wins, the other is abandoned: clingo is a
  /// child process, killed), or clingo when the native engine cannot answer. A program that
  /// may loop through negation (negationLoopReason) races from the start.
  void setBackend(Backend backend) { backend_ = backend; }
  /// @brief Longest time the native engine answers a query alone under Backend::Auto once
  /// it has overrun its estimate (default 0.25 s; 0: every query is raced from its plan).
  void setAutoRaceDelay(double seconds) { race_delay_ = seconds; }
  double autoRaceDelay() const { return race_delay_; }
  Backend backend() const { return backend_; }
  /// @brief Options of the clingo back end (binary, timeout; the timeout is also capped by
  /// the inference budget of setLimits).
  void setAspOptions(const AspOptions& options);

  const Program& program() const { return program_; }
  const ReasonerStats& stats() const { return stats_; }

 private:
  /// @brief Budget, cancel flag and the program's and query's do() on a fresh engine; the
  /// program's and query's observations as conditions.
  std::vector<GCondition> prepareEngine(const GroundProgram& g, const Query& query,
                                        ExactEngine& engine);
  double nativeProbability(const Query& query);
  std::vector<ValueProb> nativeDistribution(const AttributeTerm& at, const Query& evidence,
                                            const std::string& evidence_text);
  Table nativeTable(const AttributeTerm& target, const std::vector<AttributeTerm>& conditioning,
                    const Query& evidence, const std::string& evidence_text,
                    bool conditioning_as_do);
  /// @brief The clingo back end, with the inference budget applied to its timeout.
  AspBackend& asp();
  /// @brief Run native(), falling back to asp_answer() under Backend::Auto when the native
  /// engine reports the program outside its fragment (remembered per query attributes and
  /// program structure, so the native grounding is not retried for every query).
  template <typename T, typename Native, typename Asp>
  T dispatch(const std::set<std::string>& attrs, Native native, Asp asp_answer,
             bool race = true);
  /// @brief dispatch without a race: the native engine, then (Backend::Auto, outside its
  /// fragment) via_asp(); `key`: the query attributes' key in outside_fragment_.
  template <typename T, typename Native, typename ViaAsp>
  T dispatchInTurn(const std::string& key, Native& native, ViaAsp& via_asp);
  /// @brief dispatch under Backend::Auto: the native engine plans, decideAuto chooses, and
  /// clingo runs on a helper thread when raced (at once for a program that may loop through
  /// negation); the first definite answer wins.
  template <typename T, typename Native, typename Asp>
  T dispatchRace(const std::string& key, Native& native, Asp& asp_answer);
  /// @brief Counts an answer of clingo in stats_.
  void noteAspAnswer();
  /// @brief negationLoopReason(program_) is not empty (cached per program version).
  bool mayLoopThroughNegation();
  /// @brief The estimate of a raced query before any plan (clingo's side), noted in stats_.
  AutoEstimate beginRace(bool asp_at_once);
  /// @brief decideAuto at the native engine's plan, noted in stats_.
  AutoDecision decideAtPlan(const EnginePlan& plan, const AutoEstimate& estimate,
                            bool asp_at_once);
  struct GroundEntry;
  struct TableCache;
  /// @brief Keeps a table conditioned by do() (complete) for later queries on the same
  /// grounding, and drops the grounding's changes no cached table needs any more.
  void cacheTable(const std::string& cache_key, std::shared_ptr<TableCache> cache,
                  GroundEntry& entry, int ti, const std::vector<int>& ci, bool reuse, Table& t);
  struct Change {
    enum Kind { kAddRule, kRemoveRule, kAddPr, kRemovePr } kind;
    std::uint64_t seq;
    std::uint64_t id;
    std::shared_ptr<const Rule> rule;  ///< removed rule (its content is gone from the program)
  };

  /// `atoms`: the query's attribute terms (formula, observations, do), for a grounding
  /// restricted to the instances they reach (the program's evidence is added); nullptr: every
  /// instance of the cone's attributes.
  std::shared_ptr<GroundEntry> groundEntryFor(const std::set<std::string>& attrs,
                                              const std::vector<AttributeTerm>* atoms = nullptr);
  std::shared_ptr<const GroundProgram> groundFor(const std::set<std::string>& attrs,
                                                 const std::vector<AttributeTerm>* atoms = nullptr);
  /// @brief The part of a grounding's cache key for `atoms` ("" when the grounding is not
  /// restricted to them: no atoms, or instanceConePays is false); all_atoms receives them with
  /// the program's evidence.
  std::string coneAtomsKey(const std::string& all_key, const std::set<std::string>& cone,
                           const std::vector<AttributeTerm>* atoms,
                           std::vector<AttributeTerm>& all_atoms);
  /// @brief Something other than facts and pr-atoms changed: rebuild the bookkeeping and drop
  /// every grounding.
  void structuralChange();
  size_t addParsed(std::vector<Rule> rules, std::vector<PrAtom> prs, const std::string& tag);
  void eraseMarked(const std::vector<char>& rule_gone, const std::vector<char>& pr_gone);
  /// @brief Update the dependency counts for a statement (+1 added, -1 removed); true when
  /// the dependency structure (hence some relevance cone) changed.
  bool countRule(const Rule& r, int delta);
  bool countPr(const PrAtom& p, int delta);
  void rebuildPrIndex();
  void trimLog();
  /// @brief The declarations (sorts, attributes, #domain) only: what parsing a query needs.
  const Program& declarations();
  /// @brief Refuse queries without meaning: contradictory do()s, and constants that nothing in
  /// the program mentions in untyped argument positions (UnknownSymbolError "unknown value").
  void checkQuery(const Query& q);
  /// @brief Every symbol of the sorts and statements (cached per program version).
  const std::unordered_set<std::string>& knownSymbols();

  Program program_;
  // Statement bookkeeping, parallel to program_.rules / program_.pr_atoms.
  std::vector<std::uint64_t> rule_ids_, pr_ids_;
  /// Keys (statement text) of the rules and pr-atoms, valid when keys_valid_ (ensureKeys).
  std::vector<std::string> rule_keys_, pr_keys_;
  std::unordered_map<std::string, int> rule_key_count_;
  bool keys_valid_ = true;
  /// @brief Make rule_keys_, rule_key_count_ and pr_keys_ when they are not valid (after a
  /// program was loaded: queries alone never need them, adding or removing statements does).
  void ensureKeys();
  std::unordered_map<std::string, size_t> pr_index_;  ///< pr key -> position (if valid)
  bool pr_index_valid_ = false;
  std::uint64_t next_id_ = 1;
  // Dependency structure (attribute indices), to know when relevance cones may change.
  /// @brief Attribute names -> index (the last declaration of a name wins); the program's
  /// shared table when it is valid (AttributeIndex).
  std::unique_ptr<AttributeIndex> attr_index_;
  std::size_t attr_count_ = 0;   ///< attributes indexed (program_.attributes may have grown)
  /// @brief Index of an attribute, -1 when it is not among those indexed.
  int attrByName(const std::string& name) const;
  int attrOf(const AttributeTerm& term) const;
  std::vector<char> attr_random_;
  /// @brief The counts below are up to date (they are made on the first change after a
  /// structural one: loading a program and querying it never needs them).
  bool counts_valid_ = false;
  void ensureCounts();
  std::unordered_map<std::uint64_t, int> edge_count_;   ///< (child, parent) -> statements
  std::unordered_map<std::string, int> head_value_count_;  ///< "attr|value" -> rules
  std::vector<int> head_values_;                        ///< attr -> distinct head values
  std::vector<char> head_var_;                          ///< attr -> some head value is a variable
  std::uint64_t structure_version_ = 1;
  // Change log since the oldest cached grounding.
  std::uint64_t change_seq_ = 0;
  std::vector<Change> log_;
  std::uint64_t entry_serial_ = 0;
  std::map<std::string, std::pair<std::uint64_t, std::set<std::string>>> cone_cache_;
  /// cone key -> (structure version, instanceConePays for it)
  std::map<std::string, std::pair<std::uint64_t, bool>> cone_pays_;
  std::map<std::string, std::shared_ptr<GroundEntry>> ground_cache_;
  std::map<std::string, std::shared_ptr<TableCache>> table_cache_;
  Program decls_;
  std::uint64_t decls_version_ = 0;
  ReasonerStats stats_;
  GroundingLimits limits_;
  std::unordered_set<std::string> known_symbols_;
  std::pair<std::uint64_t, std::uint64_t> known_version_{0, 0};
  bool known_symbols_valid_ = false;
  Backend backend_ = Backend::Auto;
  ParseOptions parse_options_;
  /// @brief Adds the engine's warnings (renormalised probability sums) to warnings(), once.
  void noteWarnings(const std::vector<std::string>& warnings);
  std::mutex warnings_mutex_;
  double race_delay_ = 0.25;
  /// @brief negationLoopReason(program_), cached per (structure version, change sequence).
  std::string negation_loop_reason_;
  std::pair<std::uint64_t, std::uint64_t> negation_loop_version_{0, 0};
  bool negation_loop_valid_ = false;
  /// @brief Set while Backend::Auto races a query: the native engine reports its plan.
  std::function<void(const EnginePlan&)> plan_callback_;
  /// @brief Set while racing once clingo has answered: the native computation stops.
  std::atomic<bool> asp_won_{false};
  std::unique_ptr<AspOptions> asp_options_;
  std::unique_ptr<AspBackend> asp_;
  /// @brief Query-attribute keys the native engine refused (outside its fragment), with the
  /// structure version: later queries on them go to clingo directly.
  std::map<std::string, std::uint64_t> outside_fragment_;
};

}  // namespace plog
}  // namespace krr
