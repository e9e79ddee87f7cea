/**
 * @file navigation_knowledge.h
 * @brief The navigation part of the knowledge base, and the two directions of KRR-RL on it.
 *
 * Procedure 2 (paper, Sec. III-A): a task-specific navigation MDP is *computed by reasoning*:
 * one P-log table query P(next_cell | do(curr_cell=C), do(act_move=M)) for every free cell C
 * and move M, with the exogenous attributes (time of day, walkers in blocking areas) observed
 * or marginalised. Nothing is copied from a learner: whatever the robot learned enters the
 * model only through the pr-atoms it wrote into the knowledge base.
 *
 * Knowledge extraction (Procedure 1, last line): the pairs R-Max has marked known are written
 * back as pr-atoms conditioned on the exogenous context they were learned in, e.g.
 *   pr(next_cell=12 | curr_cell=11, act_move=right, curr_time=morning) = 17/20.
 *   learned(11, right, morning).
 * The human (default) pr-atoms of config/navigation.plog carry `not learned(C, M, T)`, so in
 * that context the learned distribution replaces them, and everywhere else human knowledge
 * still applies. Learned statements carry the reasoner tag "learned", so re-learning a pair
 * replaces its probabilities instead of duplicating them, and they can be saved to (and
 * reloaded from) their own file, written atomically.
 *
 * Speed (Procedure 2 is run after every extraction): only what changed is handed to the
 * reasoner (statements of new or re-learned pairs, built from a parsed prototype instead of
 * re-parsing text), the reasoner patches its grounding (the `learned` facts switch the human
 * defaults off in place) and recomputes only the table rows of the changed pairs.
 */
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "krr_core/mdp/rmax_model.h"
#include "krr_core/mdp/sparse_model.h"
#include "krr_core/nav/nav_grid.h"
#include "krr_core/plog/reasoner.h"

namespace krr {
namespace kb {

/**
 * @brief States of navigation MDPs over a NavGrid: the free cells in ascending id order, then
 * one absorbing `trapped` state. Actions are the moves up, down, left, right (nav::Move order).
 */
class NavStateSpace {
 public:
  explicit NavStateSpace(const nav::NavGrid& grid);

  std::size_t numStates() const { return cells_.size() + 1; }
  std::size_t numActions() const { return 4; }
  /// @brief The state of a free cell. @throws UnknownSymbolError for a non-free or invalid cell.
  mdp::StateId stateOf(int cell) const;
  /// @brief The cell of a state, -1 for the trapped state.
  int cellOf(mdp::StateId s) const { return s < cells_.size() ? cells_[s] : -1; }
  mdp::StateId trappedState() const { return static_cast<mdp::StateId>(cells_.size()); }
  /// @brief The state of a named place of the map (the shop, a room).
  mdp::StateId placeState(const std::string& place) const { return stateOf(grid_->placeCell(place)); }
  const nav::NavGrid& grid() const { return *grid_; }

 private:
  std::shared_ptr<const nav::NavGrid> grid_;
  std::vector<int> cells_;
  std::vector<std::int32_t> state_of_cell_;
};

/// @brief A navigation transition model computed from the knowledge base.
struct NavModel {
  /// S = free cells + trapped, A = 4, rewards 0, trapped terminal, discount as requested.
  mdp::SparseModel dynamics;
  /// S*A flags: 1 where the row comes from learned per-pair knowledge in every context of the
  /// query (these pairs start "known" for R-Max; the rest, area knowledge included, are
  /// explored again).
  std::vector<std::uint8_t> learned;
  std::size_t numLearned() const;
};

/// @brief The navigation knowledge base: geometry + human knowledge + learned knowledge.
class NavigationKnowledge {
 public:
  /**
   * @param grid the navigation domain (its cells and moves index the model)
   * @param knowledge_files P-log files loaded in order (generated geometry, then
   *        config/navigation.plog, then optionally a learned-knowledge file)
   * @throws ParseError / UnknownSymbolError / IoError from loading, ConfigError when the
   *         program lacks the attributes the model needs (curr_cell, next_cell, act_move,
   *         curr_time) or its cell sort disagrees with the grid's free cells.
   */
  NavigationKnowledge(const nav::NavGrid& grid, const std::vector<std::string>& knowledge_files);

  /**
   * @brief Procedure 2: the navigation transition model under the given times of day.
   * @param times the times the robot may be in: one value (it knows the time), several (it
   *        does not: the reasoner marginalises over them with the program's prior on
   *        curr_time, restricted to these values), or empty (every time).
   * @param discount discount of the returned model.
   * @throws UnknownSymbolError for a time the program does not declare.
   */
  NavModel buildModel(const std::vector<std::string>& times, double discount = 0.95);

  /**
   * @brief Knowledge extraction: write R-Max's known pairs (those learned from own samples;
   * priors the knowledge base supplied are skipped) as pr-atoms for time `time`.
   * Probabilities are written as exact fractions of the sample count.
   * @return the number of (cell, move) pairs written.
   */
  std::size_t addLearned(const std::vector<mdp::KnownPair>& pairs, const std::string& time);
  /**
   * @brief Like clearing the pairs learned at `time` and then addLearned(), but only what
   * differs is rewritten (a new experiment trial's knowledge mostly repeats the last one's).
   * Area knowledge and other times are kept. @return the number of pairs written.
   */
  std::size_t replaceLearned(const std::vector<mdp::KnownPair>& pairs, const std::string& time);
  /// @brief Number of learned pairs (of time `time`; all times if empty).
  std::size_t learnedPairCount(const std::string& time = "") const;

  /// @brief One learned distribution, structured: P(next_cell = outcomes[i].first | cell,
  /// move, time) = outcomes[i].second / denominator (numerators sum to the denominator).
  struct LearnedEntry {
    int cell = -1;
    int move = 0;  ///< nav::Move index (up, down, left, right)
    std::string time;
    std::vector<std::pair<std::string, long>> outcomes;  ///< value ("12", "trapped"), numerator
    long denominator = 1;
  };
  /// @brief Everything learned, one entry per (cell, move, time) in ascending key order: the
  /// content of learnedText(), for sending it elsewhere (e.g. to a ROS reasoner node).
  std::vector<LearnedEntry> learnedEntries() const;

  /**
   * @brief Knowledge extraction of what is shared (kb/area_knowledge.h): the pooled walker,
   * trap and noise rates of one time of day, replacing earlier ones of that time.
   */
  void setLearnedAreas(const std::string& time, const std::string& statements);
  /// @brief Times with area knowledge, and its statements.
  const std::map<std::string, std::string>& learnedAreas() const { return areas_; }

  /// @brief Forget everything learned (pairs and areas).
  void clearLearned();
  /// @brief Everything learned, as P-log text that loadLearned() reads back (pairs, then one
  /// block per time of area knowledge, each after a line "% --- areas, time T ---").
  std::string learnedText() const;
  /// @brief Save learnedText() atomically: a crash never leaves a half-written file.
  void saveLearned(const std::string& path) const;
  /// @brief Add the statements of a learned-knowledge file (as tag "learned").
  void loadLearned(const std::string& path);
  /// @brief loadLearned() of text already read (learnedText() of another instance, e.g. a
  /// copy of the knowledge for a concurrent reader); `name` is used in error locations.
  void loadLearnedText(std::string text, const std::string& name);

  const NavStateSpace& space() const { return space_; }
  plog::Reasoner& reasoner() { return reasoner_; }

 private:
  /// @brief One learned distribution: outcome values ("12", "trapped") with numerators of an
  /// exact fraction over `denominator` (numerators sum to the denominator).
  struct LearnedDistribution {
    std::vector<std::pair<std::string, long>> outcomes;
    long denominator = 1;
    bool operator==(const LearnedDistribution& o) const {
      return denominator == o.denominator && outcomes == o.outcomes;
    }
  };
  /// (cell, move index, time) -> distribution
  using LearnedMap = std::map<std::tuple<int, int, std::string>, LearnedDistribution>;

  std::string evidenceFor(const std::vector<std::string>& times) const;
  /// @brief Set these learned distributions (new keys or replacements) in learned_ and hand
  /// the reasoner only the difference.
  /// Write `updates`, removing `old_prs` / `old_facts` too (one removal: it re-indexes).
  void updateLearned(const LearnedMap& updates, std::vector<plog::PrAtom> old_prs = {},
                     std::vector<plog::Rule> old_facts = {});
  /// The distributions of R-Max's own known pairs (`updates`); @return how many.
  std::size_t learnedDistributions(const std::vector<mdp::KnownPair>& pairs,
                                   const std::string& time, LearnedMap& updates) const;
  /// @brief The statements of one learned distribution (copies of the parsed prototypes).
  void appendPrAtoms(const std::tuple<int, int, std::string>& key, const LearnedDistribution& d,
                     std::vector<plog::PrAtom>& out);
  plog::Rule learnedFact(const std::tuple<int, int, std::string>& key);
  const plog::Term& valueTerm(const std::string& value);

  NavStateSpace space_;
  plog::Reasoner reasoner_;
  std::vector<std::string> times_;  // values of sort time
  LearnedMap learned_;
  std::map<std::string, std::string> areas_;  // time -> area statements
  // Parsed prototypes of the learned statements and the ground terms to put in them.
  plog::PrAtom pr_proto_;
  plog::Rule fact_proto_;
  std::map<std::string, plog::Term> terms_;  // loc / move / time values by text
  std::size_t learned_line_ = 0;
};

/// @brief The reasoner tag of learned statements.
constexpr const char* kLearnedTag = "learned";

}  // namespace kb
}  // namespace krr
