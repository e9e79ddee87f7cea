/**
 * @file grounder.h
 * @brief Relevance-restricted grounding of a P-log program for the native exact reasoner.
 *
 * The grounder splits the attributes of the program into STATIC ones (no random attribute
 * among their ancestors: evaluated once, bottom-up, into an indexed fact store) and DYNAMIC
 * ones (random attributes and the attributes derived from them). Only dynamic attribute
 * instances become nodes of the ground network; static literals are evaluated during grounding
 * (joins over the indexed facts, never nested enumeration of sort values when a fact binds a
 * variable), so ground bodies contain dynamic literals only.
 */
#pragma once

#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "krr_core/plog/ast.h"
#include "krr_core/plog/budget.h"

namespace krr {
namespace plog {

/// @brief Interned ground values (symbols, integers, compound values) of one grounding.
class SymbolTable {
 public:
  /// @brief Id of the value written as `text` (integers as decimal text).
  int intern(const std::string& text);
  int internInt(long long v);
  const std::string& text(int id) const { return texts_[static_cast<size_t>(id)]; }
  /// @brief True when the value is an integer (then *v receives it).
  bool isInt(int id, long long* v = nullptr) const;
  size_t size() const { return texts_.size(); }

 private:
  std::vector<std::string> texts_;
  std::vector<char> is_int_;
  std::vector<long long> ints_;
  std::unordered_map<std::string, int> ids_;
};

/// @brief A ground dynamic literal over an instance of the ground network.
/// The atom is "instance has value domain[value]"; `neg`: the instance has a value other than
/// domain[value]; `naf`: default negation of the (possibly negated) atom.
struct GLit {
  int inst = 0;
  int value = 0;  ///< index into the instance's domain
  bool naf = false;
  bool neg = false;
};

/// @brief A random selection rule of one instance, ground.
struct GSelection {
  std::string label;
  std::vector<GLit> body;
  bool dynamic_range = false;
  /// @brief For dynamic ranges: (value index, extra condition) pairs; a value is possible iff
  /// one of its conditions holds (empty condition = always).
  std::vector<std::pair<int, std::vector<GLit>>> range;
  SourceLocation loc;
};

/// @brief A ground pr-atom of one instance.
struct GPr {
  int value = 0;
  double probability = 0;
  std::string label;
  std::vector<GLit> body;
  SourceLocation loc;
  int priority = 0;  ///< PrAtom::priority
  /// @brief Id of the pr-atom statement it comes from (IncrementalGrounder; 0 otherwise).
  std::uint64_t src = 0;
  /// @brief 0: in force. > 0: switched off, by a static guard that holds (a default-negated
  /// fact `not f` of its body, see IncrementalGrounder) or because its statement was removed.
  /// Inference skips such pr-atoms; they stay in place so that indices remain stable.
  int inactive = 0;
};

/// @brief A dynamic attribute instance a(t): a node of the ground network.
struct GInstance {
  int attr = 0;              ///< index into Program::attributes
  std::vector<int> args;     ///< symbol ids
  std::vector<int> domain;   ///< symbol ids of the range sort, in sort order
  bool random = false;
  std::vector<GSelection> selections;
  std::vector<GPr> prs;
  /// @brief Derived instances: rules (value index, body).
  std::vector<std::pair<int, std::vector<GLit>>> rules;
  std::string name;          ///< printable a(t)
  int valueIndex(int sym) const;
};

/// @brief The ground network restricted to the relevance cone of some attributes.
struct GroundProgram {
  std::shared_ptr<SymbolTable> symbols;
  std::vector<GInstance> instances;
  std::unordered_map<std::string, int> instance_ids;  ///< printable a(t) -> index
  std::vector<std::pair<std::vector<GLit>, SourceLocation>> constraints;
  /// @brief Static facts: attr index -> set of printable ground atoms "a(t)=y" that hold.
  std::vector<std::set<std::string>> static_atoms;
  std::vector<bool> attr_dynamic;   ///< per Program::attributes
  std::vector<bool> attr_random;
  std::vector<bool> attr_in_cone;
  size_t ground_statements = 0;     ///< number of ground dynamic statements produced
  size_t derived_rules = 0;         ///< of which rules of instances that are not random
                                    ///< (the auto back end's cost estimate, EnginePlan)
  /// @brief The grounding is restricted to the instances the query's atoms reach (groundProgram
  /// with cone_atoms), not every instance of the cone's attributes.
  bool instance_restricted = false;

  /// @brief Index of the instance a(t) or -1 (not dynamic / not in the cone).
  int findInstance(const std::string& printable) const;
  /// @brief Truth of a static ground atom "a(t)=y" (false when not derived).
  bool staticHolds(int attr, const std::string& printable_atom) const;
};

/// @brief Ground the part of `program` relevant to `cone_attributes` (names; their ancestors
/// are added automatically, and so are constraints and attributes that could get two values in
/// a world, which act as evidence, with their ancestors).
/// @throws krr::Error for programs outside the native fast path (rules defining random
/// attributes, negative cycles among static attributes), UnknownSymbolError for variables
/// whose sort cannot be determined, IncoherentError for static attributes with two values,
/// ParseError for integer overflow in a term, BudgetExceededError when `limits` are exhausted.
/// Atoms are ground only within the declared sorts of their attributes.
///
/// With `cone_atoms` (the attribute terms of a query's formula, observations and do-statements,
/// program-level ones included; their attributes must be among `cone_attributes`), only the
/// instances these atoms reach are ground: a demanded instance a(t) demands, for every random
/// selection rule, pr-atom and rule whose head a(u) unifies with a(t), the instances of its
/// body (and dynamic range) atoms under that unifier, transitively (a variable left unbound
/// demands every instance at its position; an attribute demanded at more than a few hundred
/// patterns is ground entirely). Attributes in every cone (constraints, derived attributes that
/// may get two values, loops through `not`, dynamic ranges, and their ancestors: the cone of
/// no name) are ground entirely. Sound because P-log's measure factorises along the cone: no
/// statement defining a demanded instance reads an instance outside (demand is closed over
/// bodies), and outside nothing removes or splits worlds (what could is ground entirely), so
/// the worlds extending an assignment of the cone have measures summing to its marginal: the
/// query's probability, a ratio of such marginals, is unchanged.
GroundProgram groundProgram(const Program& program, const std::set<std::string>& cone_attributes,
                            const GroundingLimits& limits = GroundingLimits(),
                            const std::vector<AttributeTerm>* cone_atoms = nullptr);

/// @brief Whether the attributes of `cone` have at least `min_instances` instances in all by
/// their declared argument sorts (an untyped argument counts as many): grounding only the
/// instances a query reaches then pays for a grounding per distinct query.
bool instanceConePays(const Program& program, const std::set<std::string>& cone,
                      std::size_t min_instances);

/// @brief All attributes the named ones depend on (the relevance cone), names included.
std::set<std::string> relevanceCone(const Program& program, const std::set<std::string>& names);

/**
 * @brief A grounding that is patched in place when knowledge is added or removed, instead of
 * grounding the whole program again (the knowledge-extraction loop of the paper: learned
 * pr-atoms and facts come and go, the rest of the knowledge base stays).
 *
 * Guards. A default-negated literal `not f(t)=y` in a pr-atom body, where f is an extensional
 * static attribute (defined by ground facts only, used nowhere else than in such literals), is
 * not evaluated while grounding: the ground pr-atom is kept and records the fact as a guard,
 * and it is in force (GPr::inactive == 0) exactly when none of its guard facts holds. Adding
 * or removing such a fact then flips the affected ground pr-atoms without grounding anything
 * (e.g. `learned(C, M, T)`, which switches human defaults off where knowledge was learned).
 *
 * Supported changes: ground facts of guard attributes added or removed; pr-atoms added
 * (ground against the existing fact store; they may not create new attribute instances) or
 * removed. Anything else (rules with bodies, selection rules, declarations, facts of other
 * attributes, ...) needs a full grounding: apply() then returns false. So does an added
 * pr-atom whose body reads instances that a grounding restricted to a query's instances
 * (ClosedCone::atoms) did not ground.
 */
class IncrementalGrounder {
 public:
  /// @brief Changes since the grounding (or since the last apply()).
  struct Delta {
    std::vector<const Rule*> added_facts;    ///< facts now in the program
    std::vector<const Rule*> removed_facts;  ///< copies of facts no longer in the program
    std::vector<std::pair<const PrAtom*, std::uint64_t>> added_prs;  ///< statement and its id
    std::vector<std::uint64_t> removed_prs;  ///< ids of removed pr-atom statements
  };

  /**
   * @brief Ground `program` restricted to the cone of `cone_attributes` (as groundProgram).
   * @param pr_ids ids of program.pr_atoms (same size), or nullptr for index + 1.
   * The program must outlive this object (apply() receives it again after changes).
   */
  IncrementalGrounder(const Program& program, const std::set<std::string>& cone_attributes,
                      const std::vector<std::uint64_t>* pr_ids = nullptr,
                      const GroundingLimits& limits = GroundingLimits());
  /// @brief A cone that relevanceCone(program, ...) has already computed (it is closed: its
  /// own cone), passed as ClosedCone{cone} so that it is not computed twice.
  /// `atoms`: as groundProgram's cone_atoms (nullptr: every instance of the attributes).
  struct ClosedCone {
    const std::set<std::string>& attributes;
    const std::vector<AttributeTerm>* atoms = nullptr;
  };
  IncrementalGrounder(const Program& program, ClosedCone cone,
                      const std::vector<std::uint64_t>* pr_ids = nullptr,
                      const GroundingLimits& limits = GroundingLimits());
  ~IncrementalGrounder();
  IncrementalGrounder(const IncrementalGrounder&) = delete;
  IncrementalGrounder& operator=(const IncrementalGrounder&) = delete;

  const std::shared_ptr<GroundProgram>& ground() const { return ground_; }

  /**
   * @brief Patch the grounding for the changes in `delta` (`program` is the changed program,
   * with the same declarations and cone). `changed` receives (instance, pr index) of every
   * ground pr-atom that was added or switched on or off.
   * @return false when a change is outside the supported kinds: the grounding is then in an
   * undefined state and must be discarded (ground the program again).
   * @throws IncoherentError when an added fact gives a static attribute a second value.
   */
  bool apply(const Program& program, const Delta& delta,
             std::vector<std::pair<int, int>>* changed);

  /// @brief Whether `attribute` is a guard attribute of this grounding.
  bool isGuardAttribute(const std::string& attribute) const;
  /// @brief Ground pr-atoms kept, and those of them whose statement was removed (tombstones).
  std::size_t atoms() const;
  std::size_t removedAtoms() const;

 private:
  class Impl;
  std::shared_ptr<GroundProgram> ground_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace plog
}  // namespace krr
