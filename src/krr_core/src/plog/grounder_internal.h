/**
 * @file grounder_internal.h
 * @brief Private to the grounder: the Grounder class (one grounding of a program, made whole
 * or patched in place) with its compiled terms and fact store, so that its parts can live in
 * separate grounder_*.cpp files by responsibility.
 */
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "krr_core/plog/grounder.h"
#include "krr_core/plog/name_table.h"

#include "scc.h"

namespace krr {
namespace plog {
namespace grounder_detail {

// -------------------------------------------------------------------------------------------
// Compiled terms and literals
// -------------------------------------------------------------------------------------------

struct CTerm {
  enum K { Const, Var, Bin, Neg, Comp } k = Const;
  int sym = -1;
  int slot = -1;
  std::string op;
  std::vector<CTerm> args;
  const Term* src = nullptr;  // Bin / Neg: the source term, for overflow errors
};

struct CLit {
  bool is_atom = true;
  int attr = -1;
  bool dynamic = false;
  bool naf = false, neg = false;
  std::vector<CTerm> args;
  CTerm value;
  CompareOp op = CompareOp::Eq;
  CTerm lhs, rhs;
  int origin = 0;  // 0 = body, 1 = range body
  SourceLocation loc;
  std::vector<int> vars;  // slots
  bool guard = false;     // default-negated guard-attribute literal of a pr-atom (deferred)
};

struct VecHash {
  size_t operator()(const std::vector<int>& v) const {
    size_t h = 1469598103934665603ull;
    for (int x : v) {
      h ^= static_cast<size_t>(x) + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
    }
    return h;
  }
};

// Static facts of one attribute: tuples (args..., value).
struct FactSet {
  int arity = 0;
  std::vector<std::vector<int>> tuples;
  std::unordered_map<std::vector<int>, std::vector<int>, VecHash> by_args;  // args -> values
  bool add(const std::vector<int>& args, int value) {
    auto& vals = by_args[args];
    for (int v : vals)
      if (v == value) return false;
    vals.push_back(value);
    std::vector<int> t;
    t.reserve(args.size() + 1);
    t.insert(t.end(), args.begin(), args.end());
    t.push_back(value);
    tuples.push_back(std::move(t));
    return true;
  }
  /// @brief pos -> sym -> ids of the tuples with that symbol there, in the order they were
  /// added. Made when a join first asks for it (most attributes are only ever tested with
  /// every position bound: indexing each of 10^5 facts up front cost more than the rest).
  const std::vector<std::unordered_map<int, std::vector<int>>>& posIndex() const {
    for (; indexed_ < tuples.size(); ++indexed_) {
      const std::vector<int>& t = tuples[indexed_];
      if (pos_index_.size() < t.size()) pos_index_.resize(t.size());
      for (size_t i = 0; i < t.size(); ++i) pos_index_[i][t[i]].push_back(static_cast<int>(indexed_));
    }
    return pos_index_;
  }

 private:
  mutable std::vector<std::unordered_map<int, std::vector<int>>> pos_index_;
  mutable size_t indexed_ = 0;  ///< tuples in pos_index_
};

// Thrown inside an incremental update that needs a full grounding.
struct NeedFullGrounding {};

constexpr int kRemovedStatement = 1 << 20;  // GPr::inactive of a removed statement's atoms

class Grounder {
 public:
  Grounder(const Program& p, GroundProgram& g);

  // ---- incremental interface (IncrementalGrounder) ----
  void setPrIds(const std::vector<std::uint64_t>* ids) { pr_ids_ = ids; }
  bool isGuard(int attr) const {
    return attr >= 0 && static_cast<size_t>(attr) < guard_attr_.size() && guard_attr_[static_cast<size_t>(attr)];
  }
  int attrIndexOf(const std::string& n) const {
    return attrLookup(n);
  }
  const Program& program() const { return prog_; }

  bool applyDelta(const IncrementalGrounder::Delta& d, std::vector<std::pair<int, int>>* changed);

  /// @brief Ground the attributes `cone_names` (closed); with `atoms`, only the instances
  /// they reach (groundProgram's cone_atoms).
  void run(const std::set<std::string>& cone_names, const std::vector<AttributeTerm>* atoms);

 private:
  /// rule_flags_ bits.
  static constexpr unsigned char kHasHead = 1, kHasBody = 2, kGroundHead = 4;

  /// @brief One pass over the rules that records what the later passes need of each (its
  /// head's attribute in rule_head_attr_, -1 when unknown or absent, and rule_flags_), so
  /// that they do not read the rules again: 10^5 rules are 40 MB, and every pass over them
  /// cost a cache miss per rule. Returns the first consistency-restoring rule, if any.
  const Rule* scanRules();

  /// The attribute of a term (its hint, else its name), UnknownSymbolError when undeclared.
  int attrId(const AttributeTerm& t, const SourceLocation& loc) const {
    const int a = attr_index_.of(t);
    if (a < 0) throw UnknownSymbolError(loc.str() + ": unknown attribute '" + t.name + "'");
    return a;
  }
  int attrId(const std::string& n, const SourceLocation& loc) const {
    const int a = attrLookup(n);
    if (a < 0) throw UnknownSymbolError(loc.str() + ": unknown attribute '" + n + "'");
    return a;
  }

  const std::vector<int>& sortValues(const std::string& s, const SourceLocation& loc) const {
    auto it = sort_index_.find(s);
    if (it == sort_index_.end())
      throw UnknownSymbolError(loc.str() + ": unknown sort '" + s + "'");
    return sort_vals_[static_cast<size_t>(it->second)];
  }

  // ---- compilation ----
  struct Stmt {
    std::vector<CLit> lits;
    std::vector<std::string> slot_names;
    std::vector<int> slot_sort;  // sort index or -1
    std::unordered_map<std::string, int> slots;
    SourceLocation loc;
  };

  int slotOf(Stmt& s, const std::string& name);

  CTerm compile(Stmt& s, const Term& t);

  static void termVars(const CTerm& t, std::vector<int>& out);

  CLit compileLit(Stmt& s, const Literal& l, int origin);

  void typeSlots(Stmt& s, const VariableSorts& vs);

  // ---- evaluation ----
  int evalTerm(const CTerm& t, const std::vector<int>& b);

  /// @brief Integer overflow is an error, never a wrapped value (which would silently give a
  /// wrong answer).
  [[noreturn]] void overflow(const CTerm& t) const;

  // ---- budgets ----
  /// @brief Count more ground atoms / statements and check the budgets (the time budget
  /// every 4096 calls, as reading the clock costs more than the rest).
  void spend(std::size_t atoms, std::size_t statements);

 public:
  void setLimits(const GroundingLimits& l) {
    limits_ = l;
    guard_ = std::make_unique<MemoryGuard>(l.memory_budget);
  }

 private:
  bool bound(const CTerm& t, const std::vector<int>& b) const {
    if (t.k == CTerm::Var) return b[static_cast<size_t>(t.slot)] >= 0;
    for (const auto& a : t.args)
      if (!bound(a, b)) return false;
    return true;
  }

  bool compare(CompareOp op, int a, int c) const;

  // Does the static atom hold?  (args, value bound)
  bool staticAtom(int attr, const std::vector<int>& args, int value, bool neg) const;

  std::string instanceName(int attr, const std::vector<int>& args) const;

  int instanceFor(int attr, const std::vector<int>& args);

  // Position of a symbol in a sort (-1: not a value of the sort).
  int posInSort(int sort, int sym) const {
    const std::vector<int>& v = sort_pos_[static_cast<size_t>(sort)];
    return sym >= 0 && static_cast<size_t>(sym) < v.size() ? v[static_cast<size_t>(sym)] : -1;
  }
  // Index of a value in an instance's domain (its attribute's range sort), -1 if absent.
  int valueIdx(int inst, int sym) const {
    const int s = attr_range_sort_[static_cast<size_t>(g_.instances[static_cast<size_t>(inst)].attr)];
    if (s < 0) return g_.instances[static_cast<size_t>(inst)].valueIndex(sym);
    return posInSort(s, sym);
  }

  // Join: enumerate bindings satisfying the literals; dynamic literals are collected as GLits.
  using Emit = std::function<void(const std::vector<int>&, const std::vector<GLit>&,
                                  const std::vector<int>&)>;

  /// The state of one join: the statement, which of its literals are used, the binding of its
  /// variable slots (-1: unbound), the dynamic literals collected (with their origins), the
  /// slots that must be bound at the end, and where complete bindings go.
  struct JoinState {
    Stmt& s;
    std::vector<char>& done;
    std::vector<int>& b;
    std::vector<GLit>& acc;
    std::vector<int>& acc_origin;
    const std::vector<int>& required;
    const Emit& emit;
  };

  void join(Stmt& s, std::vector<char>& done, std::vector<int>& b, std::vector<GLit>& acc,
            std::vector<int>& acc_origin, const std::vector<int>& required, const Emit& emit);

  /// Evaluate the cheapest ready literal and recurse on the rest (bindFromSort when none is
  /// ready); the literal is marked done for the recursion only.
  void joinStep(JoinState& j);

  /// The cheapest literal that the binding b lets us evaluate (cost 0: a test; else the number
  /// of candidate facts or values), -1 when none; best_pos: for a static atom, the argument
  /// position whose fact index gives the candidates (-1: all facts).
  int chooseLiteral(const Stmt& s, const std::vector<char>& done, const std::vector<int>& b,
                    int& best_pos);

  /// No literal is ready: bind the unbound variable with the smallest sort to each of its
  /// values (variables of the remaining literals first, then the required ones); with every
  /// variable bound and no literal left, the binding is complete and emitted.
  void bindFromSort(JoinState& j);

  /// A comparison: a test when both sides are bound, else `X = expr` binds X (within its sort).
  void joinComparison(JoinState& j, const CLit& l);

  /// An atom of an attribute that varies between worlds: collected as a ground literal (one per
  /// value of its instance when the value is an unbound variable).
  void joinDynamic(JoinState& j, const CLit& l);

  /// An atom of a static attribute: a test against the facts when bound (a guard atom is
  /// deferred to guard_acc_ instead), else one binding per matching fact (candidates from the
  /// index of argument position best_pos when >= 0).
  void joinStatic(JoinState& j, const CLit& l, int best_pos);

  void runJoin(Stmt& s, const std::vector<int>& required, const Emit& emit);
  /// runJoin from a partial binding b (slots >= 0 are bound).
  void runJoinFrom(Stmt& s, std::vector<int>& b, const std::vector<int>& required, const Emit& emit);

  // ---- static evaluation ----
  void evaluateStatic();

  /// @brief The static rules of one strongly connected component (attributes c, dependencies
  /// evaluated), to their fixpoint when it is recursive; refuses negation inside it.
  void evaluateComponent(const std::vector<int>& c, const std::vector<int>& comp,
                         const CompactGraph& edges, const CompactGraph& rules_of);

  // ---- dynamic grounding ----
  void groundDynamic();

  /// @brief One random selection rule of attribute a (in the cone): its ground selections, one
  /// per instance and dynamic body, with their dynamic ranges.
  void groundSelectionRule(const RandomRule& r, int a);

  /// @brief The dynamic range of selection sel_index of instance inst, for the body binding bb
  /// (the range literals are s.lits from nbody on).
  void groundRange(Stmt& s, size_t nbody, const std::vector<int>& bb, int range_slot, int inst,
                   int sel_index);

  /// @brief A rule with a dynamic head (attribute h) or a constraint (h < 0) touching the cone.
  void groundDynamicRule(const Rule& r, int h);

  /// @brief The ground rule `inst = v :- body` of a derived instance.
  void addDerivedRule(const Rule& r, int inst, int v, const std::vector<GLit>& body);

  // ---- instance-level relevance cone (groundProgram's cone_atoms) ----
  /// Instances of one attribute that the query's atoms reach: every one (`all`), or those
  /// matching one of `pats` (a symbol per argument, -1: any).
  struct Demand {
    bool all = false;
    std::vector<std::vector<int>> pats;
  };
  /// An attribute demanded at more patterns than this is ground entirely.
  static constexpr size_t kMaxDemandPatterns = 256;

  /// @brief The statements defining each attribute (heads and bodies), for the demand closure.
  struct Definition {
    const std::vector<Term>* head_args;
    std::vector<const std::vector<Literal>*> bodies;
  };

  std::vector<std::vector<Definition>> definitionsByHead() const;

  /// @brief head_demand_ from the query's atoms: attributes in every cone entirely, the rest
  /// closed over the statements whose heads unify with a demanded pattern.
  void computeInstancePatterns(const std::vector<AttributeTerm>& atoms);

  int attrLookupTerm(const AttributeTerm& t) const { return attr_index_.of(t); }

  /// @brief The pattern of atom arguments under `bind`: constants and bound variables give
  /// their symbol, anything else (free variables, arithmetic) -1.
  std::vector<int> patternOf(const std::vector<Term>& args,
                             const std::unordered_map<std::string, int>& bind);

  /// @brief Unifies head arguments with a demanded pattern (variables bound in `bind`); false
  /// when a constant or a repeated variable cannot match. Arithmetic matches anything.
  bool unifyHead(const std::vector<Term>& args, const std::vector<int>& pat,
                 std::unordered_map<std::string, int>& bind);

  static bool subsumes(const std::vector<int>& general, const std::vector<int>& p) {
    for (size_t i = 0; i < general.size() && i < p.size(); ++i)
      if (general[i] >= 0 && general[i] != p[i]) return false;
    return true;
  }

  /// @brief Demands the instances of attribute a matching pat (queued for the closure).
  void demand(int a, std::vector<int> pat);

  /// @brief The attribute's instances are restricted to patterns (not every instance).
  bool restrictedHead(int a) const {
    return restricted_ && !head_demand_[static_cast<size_t>(a)].all;
  }
  /// @brief Some instance of the attribute is to be ground.
  bool headDemanded(int a) const {
    return !restrictedHead(a) || !head_demand_[static_cast<size_t>(a)].pats.empty();
  }

  /// @brief Runs `join(b)` once per demanded pattern of attribute a, b being the statement's
  /// binding with the head variables bound to the pattern's values (patterns whose constants
  /// or sorts cannot match are skipped); once with nothing bound when a is not restricted, or
  /// when a head argument is arithmetic (headAdmitted then filters the emitted heads).
  template <class F>
  void forEachHeadPattern(const Stmt& s, int a, const std::vector<CTerm>& hargs, F join) {
    std::vector<int> b(s.slot_names.size(), -1);
    const bool simple = std::all_of(hargs.begin(), hargs.end(), [](const CTerm& t) {
      return t.k == CTerm::Const || t.k == CTerm::Var;
    });
    if (!restrictedHead(a) || !simple) {
      cur_pattern_ = restrictedHead(a) ? -2 : -1;
      join(b);
      cur_pattern_ = -1;
      return;
    }
    const auto& pats = head_demand_[static_cast<size_t>(a)].pats;
    for (size_t k = 0; k < pats.size(); ++k) {
      std::fill(b.begin(), b.end(), -1);
      if (!preBind(s, hargs, pats[k], b)) continue;
      cur_pattern_ = static_cast<int>(k);
      join(b);
    }
    cur_pattern_ = -1;
  }

  bool preBind(const Stmt& s, const std::vector<CTerm>& hargs, const std::vector<int>& pat,
               std::vector<int>& b) const;

  /// @brief The instance of head a(hargs) under binding b, or -1 when an argument does not
  /// evaluate, lies outside its declared sort, or is not demanded (headAdmitted): the one
  /// admission rule of selection rules, derived rules and pr-atoms.
  int admittedHead(int a, const std::vector<CTerm>& hargs, const std::vector<int>& b);

  /// @brief Whether a ground head a(args) is emitted in the current forEachHeadPattern run:
  /// every head when a is not restricted; else a demanded one, once (by the first pattern
  /// that matches it).
  bool headAdmitted(int a, const std::vector<int>& args) const;

  /// @brief A pr-atom added to a restricted grounding demands instances that were not ground:
  /// a dynamic atom of its body, under a demanded head pattern, outside every demanded one.
  bool demandsInstances(const PrAtom& p);

  /// @brief Every instance matching pat is demanded.
  bool demanded(int a, const std::vector<int>& pat) const;

  bool argsInSorts(int attr, const std::vector<int>& args) const;

  // One pr-atom statement: its ground instances are appended to their instances' lists.
  void groundPrAtom(const PrAtom& p, std::uint64_t id);

  bool guardHolds(const std::vector<int>& key) const;

  // Guard attributes: static, defined by ground facts only, and used only as `not f(t)=y`
  // in pr-atom bodies. Their literals are deferred (see IncrementalGrounder).
  void computeGuardAttributes();

  // Multiplicity of each guard fact (the same fact may be stated twice), for the guard
  // attributes in the cone: the facts of the others do not enter the grounding (changeFact).
  void countGuardFacts();

  std::vector<int> factKey(int attr, const Atom& head);

  // A guard fact added (+1) or removed (-1); false when outside the incremental path.
  bool changeFact(const Rule& r, int delta);

  static std::string litKey(const std::vector<GLit>& body);

  const Program& prog_;
  GroundProgram& g_;
  SymbolTable* syms_ = nullptr;
  /// Attribute names -> index into Program::attributes (the last declaration of a name wins).
  AttributeIndex attr_index_;
  /// Per rule of the program: its head's attribute (-1: a constraint). Made by run(), for
  /// the grounding it does (an incremental update receives another program).
  std::vector<int> rule_head_attr_;
  /// Per rule (with rule_head_attr_): kHasHead, kHasBody, kGroundHead (scanRules).
  std::vector<unsigned char> rule_flags_;
  int attrLookup(const std::string& n) const { return attr_index_.find(n); }
  std::unordered_map<std::string, int> sort_index_;
  std::vector<std::vector<int>> sort_vals_;
  /// Static facts per attribute, made when the first one is added: most attributes of a
  /// large program are never evaluated (outside the cone), and a FactSet is 120 bytes.
  std::vector<std::unique_ptr<FactSet>> facts_;
  /// @brief The static facts of attribute a (an empty set when it has none).
  const FactSet& factsOf(int a) const {
    static const FactSet kNone;
    const auto& f = facts_[static_cast<size_t>(a)];
    return f ? *f : kNone;
  }
  /// @brief The static facts of attribute a, to add to.
  FactSet& factsFor(int a) {
    auto& f = facts_[static_cast<size_t>(a)];
    if (!f) f = std::make_unique<FactSet>();
    return *f;
  }
  int true_ = 0, false_ = 0;
  int anon_ = 0;
  // fast lookups
  std::vector<std::vector<int>> sort_pos_;        // sort -> symbol id -> position (-1)
  std::vector<int> attr_range_sort_;              // attribute -> range sort (-1 unknown)
  std::vector<std::vector<int>> attr_arg_sorts_;  // attribute -> argument sorts (-1 untyped, -2 unknown)
  std::unordered_map<std::vector<int>, int, VecHash> inst_by_key_;  // [attr, args...] -> instance
  std::vector<int> inst_key_;
  // guards and incremental updates
  const std::vector<std::uint64_t>* pr_ids_ = nullptr;
  std::vector<char> guard_attr_;
  bool compiling_pr_ = false;
  std::vector<std::vector<int>> guard_acc_;  // guard facts of the binding being joined
  bool frozen_ = false;                      // updating: no new instances
  std::vector<std::pair<int, int>>* changed_ = nullptr;
  std::unordered_map<std::vector<int>, std::vector<std::pair<int, int>>, VecHash> guard_refs_;
  std::unordered_map<std::uint64_t, std::vector<std::pair<int, int>>> src_refs_;
  std::unordered_map<std::vector<int>, int, VecHash> fact_count_;
  // instance-level cone (computeInstancePatterns)
  bool restricted_ = false;
  std::vector<Demand> head_demand_;  // per attribute
  std::vector<std::pair<int, std::vector<int>>> demand_work_;
  int cur_pattern_ = -1;  // forEachHeadPattern: pattern index; -1 none; -2 any demanded head
  // budgets
  GroundingLimits limits_;
  std::unique_ptr<MemoryGuard> guard_;  // the grounding's memory budget (setLimits)
  SourceLocation cur_loc_;  // statement being ground, named by budget and overflow errors
  std::size_t atoms_spent_ = 0, statements_spent_ = 0;
  unsigned ticks_ = 0;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();

 public:
  std::size_t atoms_ = 0, removed_atoms_ = 0;  // ground pr-atoms / tombstones among them
};

}  // namespace grounder_detail
}  // namespace plog
}  // namespace krr
