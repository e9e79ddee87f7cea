/**
 * @file asp_backend.h
 * @brief General P-log inference through the ASP solver clingo (second back end).
 *
 * The native exact engine is fast but only handles programs in its fast path. This back end
 * handles every P-log program whose ground form clingo can solve, including non-stratified
 * negation (even loops), by the textbook route of Baral, Gelfond and Rushton (2009): the
 * program is translated to ASP, clingo enumerates its answer sets (the possible worlds), and
 * the P-log measure of each world is computed here from bookkeeping atoms:
 *
 *  - attribute atom a(t) = y            -> val(a(t), y)   (one value per attribute term)
 *  - [r] random(a(t) : {Y : p(Y)}) :- B -> sel(r, a(t)) :- B, not intervene(a(t)).
 *                                          poss(r, a(t), Y) :- sel(r, a(t)), p(Y), range(Y).
 *                                          1 { val(a(t), Y) : poss(r, a(t), Y) } 1 :- sel(r, a(t)).
 *  - pr_r(a(t) = y | B) = v  (number j) -> pra(j, a(t), y) :- sel(r, a(t)), poss(r, a(t), y), B.
 *  - obs(l) / obs(l, false)            -> :- not l.  /  :- l.
 *  - do(a(t) = y)                       -> val(a(t), y).  intervene(a(t)).
 *
 * The measure of a world is the product, over its selected attribute terms, of the assigned
 * probability of the value taken when a pr-atom applies, else of the default
 * (1 - sum of the assigned probabilities of possible values) / (number of possible values
 * without one). Probabilities are normalised over all worlds. Several queries that share their
 * interventions are answered by one clingo run (their observations become flags, not
 * constraints, except when all of them have the same evidence: then it is a constraint and
 * clingo enumerates only the worlds that satisfy it); queries with different interventions
 * share one clingo process too on programs with few worlds, through a multi-shot Lua main
 * that solves once per intervention set (AspOptions::multi_shot).
 *
 * Semantic points (chosen to agree with the native engine where it defines them):
 *  - a world in which an attribute term gets two values, or that violates a constraint, is no
 *    possible world (it conditions every attribute, also those the query does not mention);
 *  - an even loop (p :- not q. q :- not p.) yields one possible world per answer set;
 *  - IncoherentError for: assigned probabilities summing above 1, two pr-atoms giving
 *    different probabilities to one a(t)=y, two selection rules firing for one a(t), an
 *    empty dynamic range, evidence of probability 0 -- each only when it occurs in a possible
 *    world satisfying the query's evidence;
 *  - a rule head with arithmetic (next = C+1) whose value falls outside the sort is an
 *    ill-typed ground instance and is dropped (the native engine raises UnknownSymbolError).
 *
 * Cost: one clingo process per call (about 5-7 ms on an idle machine for small
 * programs, dominated by process start-up), plus enumeration of all possible worlds, which is
 * exponential in the number of random attribute terms. Not thread-safe per object (statistics).
 */
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "krr_core/plog/ast.h"
#include "krr_core/plog/reasoner.h"

namespace krr {
namespace plog {

/// @brief How the back end runs clingo.
struct AspOptions {
  /// @brief The clingo binary (>= 5.4), looked up in PATH when it contains no '/'.
  std::string clingo_path = "clingo";
  /// @brief Wall-clock limit per clingo run in seconds; clingo is killed beyond it.
  double timeout_s = 60.0;
  /// @brief Keep the temporary directory with the ASP program (for debugging).
  bool keep_files = false;
  /// @brief Largest clingo output read, in bytes: beyond it (too many possible worlds to
  /// enumerate) krr::Error is thrown instead of exhausting memory.
  std::size_t max_output_bytes = std::size_t(1) << 30;
  /// @brief Answer queries with different interventions in one clingo process (a Lua main
  /// solving once per intervention set), for programs of at most 2^kMultiShotMaxWorldsLog2
  /// worlds (aspWorldsLog2; larger ones ground far less per set). Falls back to one process
  /// per set, for the rest of the back end's life, if clingo lacks Lua support.
  bool multi_shot = true;
  /// @brief Appended to clingo's command line (e.g. "--parallel-mode=2").
  std::vector<std::string> extra_args;
  /// @brief When set and true, a running clingo is killed and CancelledError thrown (another
  /// back end answered first; checked every 10 ms).
  const std::atomic<bool>* cancel = nullptr;
};

/// @brief Largest world bound (log2, see aspWorldsLog2) of a program whose intervention sets
/// share one clingo process (AspOptions::multi_shot).
constexpr double kMultiShotMaxWorldsLog2 = 20;

/// @brief One answer set: its shown atoms as indices into ClingoResult::atoms, in clingo's
/// order. Atoms are interned because large runs print millions of answer sets over a few
/// thousand distinct atoms: integers instead of strings keep reading them cheap.
using AspModel = std::vector<std::uint32_t>;

/// @brief All answer sets of one clingo run.
struct ClingoResult {
  bool satisfiable = false;       ///< result of the (last, with a multi-shot script) solve
  /// @brief Every distinct shown atom, in clingo's syntax, in order of first appearance.
  std::vector<std::string> atoms;
  /// @brief Every answer set printed, in clingo's order (empty when a model callback took
  /// them, see runClingo).
  std::vector<AspModel> models;
  std::size_t model_count = 0;    ///< answer sets printed (kept or given to the callback)
  /// @brief With a #minimize statement: the optimisation value clingo printed after each
  /// model (costs[i] belongs to models[i]); empty otherwise.
  std::vector<std::vector<long long>> costs;
  /// @brief The atoms of a model as text (for tests and error messages).
  std::vector<std::string> atomTexts(const AspModel& model) const;
};

/// @brief Called for each answer set as it is read: the atoms known so far (the model's
/// indices are valid in it) and the model.
using AspModelCallback =
    std::function<void(const std::vector<std::string>& atoms, const AspModel& model)>;

/// @brief A shown atom split into its predicate name and argument texts.
struct AspAtom {
  std::string name;
  std::vector<std::string> args;
};

/// @brief Figures of the last inference, for benchmarks and the CLI's verbose output.
struct AspStats {
  std::size_t clingo_runs = 0;  ///< subprocess calls made
  std::size_t worlds = 0;       ///< answer sets read (possible worlds), summed over runs
  double clingo_seconds = 0.0;  ///< wall-clock time spent in clingo, summed over runs
};

/// @brief P-log inference by translation to ASP and enumeration of answer sets with clingo.
///
/// Stateless apart from its options and statistics: every call translates the given program
/// again, so a Reasoner can hand it the program it holds at the moment of the query.
class AspBackend {
 public:
  /// @brief Back end with the given clingo options (clingo is not run until a query).
  explicit AspBackend(AspOptions options = {});

  /// @brief The ASP translation of program (sorts, rules, random selections, pr-atoms and
  /// the program's own obs/do), without queries: what `--asp` prints for debugging.
  std::string translate(const Program& program) const;

  /// @brief P(query formula | program evidence, query obs, query do).
  /// @throws IncoherentError when an assigned probability sum exceeds 1 in a world (or falls
  ///         short of it with every possible value assigned) by more than rounding, two
  ///         random selections or conflicting pr-atoms apply to one attribute term, or the
  ///         evidence has probability 0 (no possible world, or zero total measure).
  /// @throws krr::Error when clingo is missing, fails or times out (message names the file).
  double probability(const Program& program, const Query& query);

  /// @brief Answers of several queries, all in one clingo process (see
  /// AspOptions::multi_shot). Result i answers queries[i]. Throws as probability(), except that when
  /// incoherence_errors is given, a query that would throw IncoherentError (evidence of
  /// probability 0, incoherent world satisfying its evidence) gets NaN and the message in
  /// (*incoherence_errors)[i] (empty for answered queries) instead.
  std::vector<double> probabilities(const Program& program, const std::vector<Query>& queries,
                                    std::vector<std::string>* incoherence_errors = nullptr);

  /// @brief The answers to the queries written in the program itself (program.queries).
  std::vector<double> answerQueries(const Program& program);

  /// @brief Posterior distribution of a ground attribute term over its range sort, in the
  /// sort's declaration order, given extra observations and interventions. Values with
  /// probability 0 are included; the names are the values' classic-syntax text.
  std::vector<std::pair<std::string, double>> distribution(
      const Program& program, const AttributeTerm& attribute,
      const std::vector<Observation>& observations = {},
      const std::vector<Intervention>& interventions = {});

  /// @name Entry points shaped like Reasoner's, so a CLI can switch back ends on one flag.
  /// @{
  /// @brief P(formula | obs, do) for query text such as `?{a=y} | obs(b=z), do(c=w)`.
  double probability(const Program& program, const std::string& query);
  /// @brief Distribution of an attribute term given evidence text `obs(...), do(...)` (may be
  /// empty): values with probability > 0 in sort order, as Reasoner::distribution.
  std::vector<ValueProb> distribution(const Program& program, const std::string& attribute_term,
                                      const std::string& evidence = "");
  /// @brief Answers to program.queries with their text, as Reasoner::answerProgramQueries.
  std::vector<QueryAnswer> answerProgramQueries(const Program& program);
  /// @}

  /// @brief Probability sums within rounding of 1 that the calls so far renormalised
  /// (`file:line:col: warning: ...`, as ExactEngine::warnings), each once: the repair is
  /// reported whichever back end answers.
  const std::vector<std::string>& warnings() const { return warnings_; }

  /// @brief Figures of the calls made since construction or resetStats().
  const AspStats& stats() const { return stats_; }
  /// @brief Zero the statistics.
  void resetStats() { stats_ = AspStats(); }
  /// @brief The options in use.
  const AspOptions& options() const { return options_; }
  /// @brief See AspOptions::cancel (nullptr: never cancelled).
  void setCancelFlag(const std::atomic<bool>* flag) { options_.cancel = flag; }

 private:
  AspOptions options_;
  AspStats stats_;
  bool multi_shot_failed_ = false;  ///< clingo could not run the Lua multi-shot script
  std::vector<std::string> warnings_;  ///< warnings()

  /// @brief Adds a run's renormalisation warnings to warnings(), once each.
  void noteWarnings(const std::vector<std::string>& warnings);
};

/// @brief Comment line that the translation writes before the ASP rules of each P-log
/// statement, followed by the statement's file:line:col, so that clingo's messages can be
/// mapped back to the P-log program.
constexpr const char* kAspSourceMarker = "%@ ";

/// @brief clingo's message with every `LP_PATH:line:col` replaced by the P-log location of
/// the statement whose translation holds that line (the last kAspSourceMarker above it).
std::string pLogLocations(const std::string& message, const std::string& lp_path,
                          const std::string& asp_program);

/// @brief Run clingo on program and enumerate all its answer sets (--models=0 -V0).
/// @throws krr::Error if clingo is missing, fails (syntax, unsafe rule: clingo's message with
///         its locations mapped to the P-log statements, see pLogLocations) or exceeds
///         options.timeout_s; ConfigError for a non-positive timeout.
/// With on_model, each answer set is handed to it as it is read and not kept in the result
/// (ClingoResult::models stays empty, costs too: callers that optimise keep the models).
ClingoResult runClingo(const std::string& program, const AspOptions& options,
                       const std::vector<std::string>& extra_args = {},
                       const AspModelCallback& on_model = nullptr);

/// @brief Split text at separator outside parentheses and quoted strings (clingo terms);
/// with ' ' as separator, tabs and carriage returns also separate and empty parts are dropped.
std::vector<std::string> splitAspTerms(const std::string& text, char separator);

/// @brief "p(a,f(b,c))" -> {p, {a, f(b,c)}}; "p" -> {p, {}}.
AspAtom parseAspAtom(const std::string& text);

}  // namespace plog
}  // namespace krr
