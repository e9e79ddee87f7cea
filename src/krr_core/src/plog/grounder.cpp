#include "krr_core/plog/grounder.h"

#include <algorithm>
#include <chrono>
#include <functional>
#include <limits>
#include <map>
#include <unordered_map>
#include <unordered_set>

#include "krr_core/plog/arith.h"
#include "krr_core/plog/name_table.h"

#include "scc.h"

namespace krr {
namespace plog {

int SymbolTable::intern(const std::string& text) {
  auto it = ids_.find(text);
  if (it != ids_.end()) return it->second;
  int id = static_cast<int>(texts_.size());
  texts_.push_back(text);
  long long v = 0;
  bool isint = !text.empty();
  size_t start = (text[0] == '-' && text.size() > 1) ? 1 : 0;
  for (size_t i = start; i < text.size() && isint; ++i)
    if (text[i] < '0' || text[i] > '9') isint = false;
  if (isint) {
    try {
      v = std::stoll(text);
    } catch (...) {
      isint = false;
    }
  }
  is_int_.push_back(isint ? 1 : 0);
  ints_.push_back(v);
  ids_.emplace(text, id);
  return id;
}

int SymbolTable::internInt(long long v) { return intern(std::to_string(v)); }

bool SymbolTable::isInt(int id, long long* v) const {
  if (id < 0 || static_cast<size_t>(id) >= texts_.size()) return false;
  if (!is_int_[static_cast<size_t>(id)]) return false;
  if (v) *v = ints_[static_cast<size_t>(id)];
  return true;
}

int GInstance::valueIndex(int sym) const {
  for (size_t i = 0; i < domain.size(); ++i)
    if (domain[i] == sym) return static_cast<int>(i);
  return -1;
}

int GroundProgram::findInstance(const std::string& printable) const {
  auto it = instance_ids.find(printable);
  return it == instance_ids.end() ? -1 : it->second;
}

bool GroundProgram::staticHolds(int attr, const std::string& printable_atom) const {
  if (attr < 0 || static_cast<size_t>(attr) >= static_atoms.size()) return false;
  return static_atoms[static_cast<size_t>(attr)].count(printable_atom) > 0;
}

namespace {

// -------------------------------------------------------------------------------------------
// Attribute dependency analysis
// -------------------------------------------------------------------------------------------

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
  Grounder(const Program& p, GroundProgram& g) : prog_(p), g_(g), attr_index_(p, true) {
    g_.symbols = std::make_shared<SymbolTable>();
    syms_ = g_.symbols.get();

    for (size_t i = 0; i < p.sorts.size(); ++i) {
      sort_index_[p.sorts[i].name] = int(i);
      std::vector<int> vals;
      for (const auto& v : p.sorts[i].values) vals.push_back(syms_->intern(toString(v)));
      sort_vals_.push_back(vals);
    }
    true_ = syms_->intern("true");
    false_ = syms_->intern("false");
    facts_.resize(p.attributes.size());  // (made for the attributes that get facts)
    // symbol -> position in each sort (membership and value indices in O(1))
    sort_pos_.resize(sort_vals_.size());
    for (size_t i = 0; i < sort_vals_.size(); ++i) {
      int top = -1;  // only up to the sort's largest symbol id: n sorts x m symbols stays O(sizes)
      for (int v : sort_vals_[i]) top = std::max(top, v);
      sort_pos_[i].assign(static_cast<size_t>(top + 1), -1);
      for (size_t k = 0; k < sort_vals_[i].size(); ++k)
        if (sort_pos_[i][static_cast<size_t>(sort_vals_[i][k])] < 0)
          sort_pos_[i][static_cast<size_t>(sort_vals_[i][k])] = static_cast<int>(k);
    }
    attr_range_sort_.assign(p.attributes.size(), -1);
    attr_arg_sorts_.resize(p.attributes.size());
    const std::string* last_range = nullptr;  // (most attributes share their range: boolean)
    int last_range_sort = -1;
    for (size_t a = 0; a < p.attributes.size(); ++a) {
      const AttributeDecl& d = p.attributes[a];
      if (!last_range || *last_range != d.range_sort) {
        auto it = sort_index_.find(d.range_sort);
        last_range = &d.range_sort;
        last_range_sort = it == sort_index_.end() ? -1 : it->second;
      }
      attr_range_sort_[a] = last_range_sort;
      for (const auto& s : d.arg_sorts) {
        if (s.empty()) {
          attr_arg_sorts_[a].push_back(-1);
        } else {
          auto jt = sort_index_.find(s);
          attr_arg_sorts_[a].push_back(jt == sort_index_.end() ? -2 : jt->second);
        }
      }
    }
  }

  // ---- incremental interface (IncrementalGrounder) ----
  void setPrIds(const std::vector<std::uint64_t>* ids) { pr_ids_ = ids; }
  bool isGuard(int attr) const {
    return attr >= 0 && static_cast<size_t>(attr) < guard_attr_.size() && guard_attr_[static_cast<size_t>(attr)];
  }
  int attrIndexOf(const std::string& n) const {
    return attrLookup(n);
  }
  const Program& program() const { return prog_; }

  bool applyDelta(const IncrementalGrounder::Delta& d, std::vector<std::pair<int, int>>* changed) {
    start_ = std::chrono::steady_clock::now();
    changed_ = changed;
    frozen_ = true;
    struct Reset {
      Grounder* gr;
      ~Reset() {
        gr->frozen_ = false;
        gr->changed_ = nullptr;
      }
    } reset{this};
    for (const auto& ap : d.added_prs)
      if (demandsInstances(*ap.first)) return false;
    try {
      for (std::uint64_t id : d.removed_prs) {
        auto it = src_refs_.find(id);
        if (it == src_refs_.end()) continue;  // produced no ground pr-atom
        for (const auto& ref : it->second) {
          g_.instances[static_cast<size_t>(ref.first)].prs[static_cast<size_t>(ref.second)].inactive +=
              kRemovedStatement;
          ++removed_atoms_;
          if (changed_) changed_->push_back(ref);
        }
        src_refs_.erase(it);
      }
      for (const Rule* r : d.removed_facts)
        if (!changeFact(*r, -1)) return false;
      for (const Rule* r : d.added_facts)
        if (!changeFact(*r, +1)) return false;
      for (const auto& ap : d.added_prs) {
        const int a = attrId(ap.first->atom.attr, ap.first->loc);
        if (!g_.attr_in_cone[static_cast<size_t>(a)]) continue;  // outside the grounding
        groundPrAtom(*ap.first, ap.second);
      }
    } catch (const NeedFullGrounding&) {
      return false;
    }
    return true;
  }

  /// @brief Ground the attributes `cone_names` (closed); with `atoms`, only the instances
  /// they reach (groundProgram's cone_atoms).
  void run(const std::set<std::string>& cone_names, const std::vector<AttributeTerm>* atoms) {
    start_ = std::chrono::steady_clock::now();
    // Consistency-restoring rules make the possible worlds depend on a global minimisation
    // over all answer sets, which the native engine does not do.
    if (const Rule* cr = scanRules())
      throw OutsideFragmentError(cr->loc.str() + ": consistency-restoring rule (':+') is outside "
                                 "the native reasoner's fragment (use the ASP back end)");
    for (const auto& r : prog_.random_rules)
      if (r.consistency_restoring)
        throw OutsideFragmentError(r.loc.str() + ": consistency-restoring rule (':+') is outside "
                                   "the native reasoner's fragment (use the ASP back end)");
    const size_t na = prog_.attributes.size();
    g_.attr_random.assign(na, false);
    g_.attr_dynamic.assign(na, false);
    g_.attr_in_cone.assign(na, false);
    for (const auto& r : prog_.random_rules) g_.attr_random[attrId(r.attr, r.loc)] = true;
    for (size_t i = 0; i < na; ++i) g_.attr_dynamic[i] = g_.attr_random[i];
    // Dynamic attributes: the random ones and those with a rule whose body has a dynamic
    // atom. One pass in program order (which also reports unknown attributes in that order),
    // then the rest propagates along body -> head edges: O(rules), where repeated passes cost
    // O(rules x chain length) on a chain b_i :- b_{i+1} that ends in a random attribute.
    for (size_t i = 0; i < prog_.rules.size(); ++i) {
      if (!(rule_flags_[i] & kHasHead)) continue;
      // (a rule is read only when its head is unknown, reported in rule order, or it has a
      // body: see scanRules)
      if (rule_head_attr_[i] < 0) attrId(prog_.rules[i].head->attr, prog_.rules[i].loc);
      const int h = rule_head_attr_[i];
      if (g_.attr_dynamic[h] || !(rule_flags_[i] & kHasBody)) continue;
      for (const auto& l : prog_.rules[i].body)
        if (l.kind == Literal::Kind::Atom && g_.attr_dynamic[attrId(l.atom.attr, l.loc)]) {
          g_.attr_dynamic[h] = true;
          break;
        }
    }
    {
      // (the pass looked up every body attribute of the rules whose head is still static)
      struct Use {
        int from, to;  // body attribute -> head attribute
        bool negative;
      };
      std::vector<Use> uses;
      for (size_t i = 0; i < prog_.rules.size(); ++i) {
        const int h = rule_head_attr_[i];
        if (h < 0 || g_.attr_dynamic[static_cast<size_t>(h)] || !(rule_flags_[i] & kHasBody))
          continue;
        for (const auto& l : prog_.rules[i].body)
          if (l.kind == Literal::Kind::Atom) uses.push_back({attr_index_.of(l.atom.attr), h, false});
      }
      const CompactGraph heads = CompactGraph::fromEdges(na, uses);
      std::vector<int> work;
      for (size_t a = 0; a < na; ++a)
        if (g_.attr_dynamic[a]) work.push_back(static_cast<int>(a));
      while (!work.empty()) {
        const size_t a = static_cast<size_t>(work.back());
        work.pop_back();
        for (size_t k = 0; k < heads.degree(a); ++k) {
          const size_t h = static_cast<size_t>(heads.to(a, k));
          if (!g_.attr_dynamic[h]) g_.attr_dynamic[h] = true, work.push_back(static_cast<int>(h));
        }
      }
    }
    for (size_t i = 0; i < prog_.rules.size(); ++i)
      if (rule_head_attr_[i] >= 0 && g_.attr_random[static_cast<size_t>(rule_head_attr_[i])])
        throw OutsideFragmentError(prog_.rules[i].loc.str() + ": rule defining random attribute '" +
                                   prog_.rules[i].head->attr.name +
                                   "' is outside the native reasoner's fast path (use the ASP back end)");
    for (const auto& n : cone_names) {
      const int a = attrLookup(n);
      if (a >= 0) g_.attr_in_cone[static_cast<size_t>(a)] = true;
    }
    computeGuardAttributes();
    evaluateStatic();
    countGuardFacts();
    if (atoms) computeInstancePatterns(*atoms);
    g_.instance_restricted = restricted_;
    groundDynamic();
    g_.static_atoms.assign(na, {});
    for (size_t a = 0; a < na; ++a) {
      if (g_.attr_dynamic[a] || !g_.attr_in_cone[a]) continue;
      for (const auto& t : factsOf(static_cast<int>(a)).tuples) {
        std::string s = prog_.attributes[a].name;
        if (t.size() > 1) {
          s += "(";
          for (size_t i = 0; i + 1 < t.size(); ++i) s += (i ? "," : "") + syms_->text(t[i]);
          s += ")";
        }
        s += "=" + syms_->text(t.back());
        g_.static_atoms[a].insert(s);
      }
    }
  }

 private:
  /// rule_flags_ bits.
  static constexpr unsigned char kHasHead = 1, kHasBody = 2, kGroundHead = 4;

  /// @brief One pass over the rules that records what the later passes need of each (its
  /// head's attribute in rule_head_attr_, -1 when unknown or absent, and rule_flags_), so
  /// that they do not read the rules again: 10^5 rules are 40 MB, and every pass over them
  /// cost a cache miss per rule. Returns the first consistency-restoring rule, if any.
  const Rule* scanRules() {
    const size_t nr = prog_.rules.size();
    rule_head_attr_.assign(nr, -1);
    rule_flags_.assign(nr, 0);
    const Rule* first_cr = nullptr;
    for (size_t i = 0; i < nr; ++i) {
      const Rule& r = prog_.rules[i];
      if (r.consistency_restoring && !first_cr) first_cr = &r;
      unsigned char f = r.body.empty() ? 0 : kHasBody;
      if (r.head) {
        f |= kHasHead;
        rule_head_attr_[i] = attr_index_.of(r.head->attr);
        if (!(f & kHasBody)) {
          bool ground = r.head->value.isGround();
          for (const auto& t : r.head->attr.args) ground = ground && t.isGround();
          if (ground) f |= kGroundHead;
        }
      }
      rule_flags_[i] = f;
    }
    return first_cr;
  }

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

  int slotOf(Stmt& s, const std::string& name) {
    auto it = s.slots.find(name);
    if (it != s.slots.end()) return it->second;
    int id = static_cast<int>(s.slot_names.size());
    s.slots.emplace(name, id);
    s.slot_names.push_back(name);
    s.slot_sort.push_back(-1);
    return id;
  }

  CTerm compile(Stmt& s, const Term& t) {
    CTerm c;
    switch (t.kind) {
      case Term::Kind::Symbol:
      case Term::Kind::Integer:
        c.k = CTerm::Const;
        c.sym = syms_->intern(toString(t));
        break;
      case Term::Kind::Variable:
        c.k = CTerm::Var;
        if (t.name == "_") {
          c.slot = slotOf(s, "_anon" + std::to_string(anon_++));
        } else {
          c.slot = slotOf(s, t.name);
        }
        break;
      case Term::Kind::Compound:
        if (t.isGround()) {
          c.k = CTerm::Const;
          c.sym = syms_->intern(toString(t));
          break;
        }
        c.k = CTerm::Comp;
        c.op = t.name;
        for (const auto& a : t.args) c.args.push_back(compile(s, a));
        break;
      case Term::Kind::Binary:
        c.k = CTerm::Bin;
        c.op = t.name;
        c.src = &t;
        for (const auto& a : t.args) c.args.push_back(compile(s, a));
        break;
      case Term::Kind::Negate:
        c.k = CTerm::Neg;
        c.src = &t;
        for (const auto& a : t.args) c.args.push_back(compile(s, a));
        break;
    }
    return c;
  }

  static void termVars(const CTerm& t, std::vector<int>& out) {
    if (t.k == CTerm::Var) out.push_back(t.slot);
    for (const auto& a : t.args) termVars(a, out);
  }

  CLit compileLit(Stmt& s, const Literal& l, int origin) {
    CLit c;
    c.loc = l.loc;
    c.origin = origin;
    c.naf = l.naf;
    if (l.kind == Literal::Kind::Atom) {
      c.is_atom = true;
      c.attr = attrId(l.atom.attr, l.loc);
      c.dynamic = g_.attr_dynamic[c.attr];
      c.neg = l.negated;
      for (const auto& a : l.atom.attr.args) c.args.push_back(compile(s, a));
      c.value = compile(s, l.atom.value);
      for (const auto& a : c.args) termVars(a, c.vars);
      termVars(c.value, c.vars);
      c.guard = compiling_pr_ && c.naf && !c.neg && isGuard(c.attr);
    } else {
      c.is_atom = false;
      c.op = l.op;
      c.lhs = compile(s, l.lhs);
      c.rhs = compile(s, l.rhs);
      termVars(c.lhs, c.vars);
      termVars(c.rhs, c.vars);
    }
    return c;
  }

  void typeSlots(Stmt& s, const VariableSorts& vs) {
    for (size_t i = 0; i < s.slot_names.size(); ++i) {
      auto it = vs.find(s.slot_names[i]);
      std::string sort = it != vs.end() ? it->second : prog_.domainSortOf(s.slot_names[i]);
      if (!sort.empty()) {
        auto si = sort_index_.find(sort);
        if (si == sort_index_.end())
          throw UnknownSymbolError(s.loc.str() + ": unknown sort '" + sort + "' of variable " +
                                   s.slot_names[i]);
        s.slot_sort[i] = si->second;
      }
    }
  }

  // ---- evaluation ----
  int evalTerm(const CTerm& t, const std::vector<int>& b) {
    switch (t.k) {
      case CTerm::Const: return t.sym;
      case CTerm::Var: return b[static_cast<size_t>(t.slot)];
      case CTerm::Neg: {
        int a = evalTerm(t.args[0], b);
        long long v, r;
        if (a < 0 || !syms_->isInt(a, &v)) return -1;
        if (checkedNegate(v, &r) != ArithStatus::Ok) overflow(t);
        return syms_->internInt(r);
      }
      case CTerm::Bin: {
        int a = evalTerm(t.args[0], b), c = evalTerm(t.args[1], b);
        long long x, y;
        if (a < 0 || c < 0 || !syms_->isInt(a, &x) || !syms_->isInt(c, &y)) return -1;
        long long r = 0;
        switch (checkedBinary(t.op, x, y, &r)) {
          case ArithStatus::Ok: return syms_->internInt(r);
          case ArithStatus::Overflow: overflow(t);
          // undefined, as in clingo: the term has no value and the binding is not ground
          default: return -1;
        }
      }
      case CTerm::Comp: {
        std::string s = t.op + "(";
        for (size_t i = 0; i < t.args.size(); ++i) {
          int a = evalTerm(t.args[i], b);
          if (a < 0) return -1;
          s += (i ? "," : "") + syms_->text(a);
        }
        return syms_->intern(s + ")");
      }
    }
    return -1;
  }

  /// @brief Integer overflow is an error, never a wrapped value (which would silently give a
  /// wrong answer).
  [[noreturn]] void overflow(const CTerm& t) const {
    const SourceLocation loc = t.src ? t.src->loc : cur_loc_;
    throw ParseError(loc, "integer overflow in '" + (t.src ? toString(*t.src) : t.op) +
                              "' while grounding the statement at " + cur_loc_.str());
  }

  // ---- budgets ----
  /// @brief Count more ground atoms / statements and check the budgets (the time budget
  /// every 4096 calls, as reading the clock costs more than the rest).
  void spend(std::size_t atoms, std::size_t statements) {
    atoms_spent_ += atoms;
    statements_spent_ += statements;
    if (limits_.max_ground_atoms && atoms_spent_ > limits_.max_ground_atoms)
      throw BudgetExceededError(cur_loc_.str() + ": grounding budget exhausted: more than " +
                                std::to_string(limits_.max_ground_atoms) +
                                " ground atoms (GroundingLimits::max_ground_atoms) while "
                                "grounding this statement");
    if (limits_.max_ground_statements && statements_spent_ > limits_.max_ground_statements)
      throw BudgetExceededError(cur_loc_.str() + ": grounding budget exhausted: more than " +
                                std::to_string(limits_.max_ground_statements) +
                                " ground statements (GroundingLimits::max_ground_statements) "
                                "while grounding this statement");
    if ((ticks_ & 4095u) == 4095u && limits_.cancel &&
        limits_.cancel->load(std::memory_order_relaxed))
      throw CancelledError("grounding abandoned: another back end answered first");
    if ((ticks_ & 4095u) == 4095u && guard_) guard_->check("grounding", cur_loc_);
    if ((++ticks_ & 4095u) == 0 && limits_.max_ground_seconds > 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count() >
            limits_.max_ground_seconds)
      throw BudgetExceededError(cur_loc_.str() + ": grounding time budget of " +
                                std::to_string(limits_.max_ground_seconds) +
                                " s exhausted (GroundingLimits::max_ground_seconds) while "
                                "grounding this statement");
  }

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

  bool compare(CompareOp op, int a, int c) const {
    if (op == CompareOp::Eq) return a == c;
    if (op == CompareOp::Ne) return a != c;
    long long x, y;
    int r;
    bool ia = syms_->isInt(a, &x), ic = syms_->isInt(c, &y);
    if (ia && ic) r = x < y ? -1 : (x > y ? 1 : 0);
    else if (ia) r = -1;
    else if (ic) r = 1;
    else r = syms_->text(a).compare(syms_->text(c));
    switch (op) {
      case CompareOp::Lt: return r < 0;
      case CompareOp::Le: return r <= 0;
      case CompareOp::Gt: return r > 0;
      case CompareOp::Ge: return r >= 0;
      default: return false;
    }
  }

  // Does the static atom hold?  (args, value bound)
  bool staticAtom(int attr, const std::vector<int>& args, int value, bool neg) const {
    const FactSet& f = factsOf(attr);
    auto it = f.by_args.find(args);
    if (it == f.by_args.end()) return false;
    bool has = std::find(it->second.begin(), it->second.end(), value) != it->second.end();
    if (!neg) return has;
    for (int v : it->second)
      if (v != value) return true;
    return false;
  }

  std::string instanceName(int attr, const std::vector<int>& args) const {
    std::string s = prog_.attributes[static_cast<size_t>(attr)].name;
    if (!args.empty()) {
      s += "(";
      for (size_t i = 0; i < args.size(); ++i) s += (i ? "," : "") + syms_->text(args[i]);
      s += ")";
    }
    return s;
  }

  int instanceFor(int attr, const std::vector<int>& args) {
    inst_key_.clear();
    inst_key_.push_back(attr);
    inst_key_.insert(inst_key_.end(), args.begin(), args.end());
    auto kt = inst_by_key_.find(inst_key_);
    if (kt != inst_by_key_.end()) return kt->second;
    if (frozen_) throw NeedFullGrounding{};  // an update may not create instances
    std::string name = instanceName(attr, args);
    auto it = g_.instance_ids.find(name);
    if (it != g_.instance_ids.end()) {
      inst_by_key_.emplace(inst_key_, it->second);
      return it->second;
    }
    const AttributeDecl& d = prog_.attributes[static_cast<size_t>(attr)];
    GInstance inst;
    inst.attr = attr;
    inst.args = args;
    inst.name = name;
    inst.random = g_.attr_random[static_cast<size_t>(attr)];
    inst.domain = sortValues(d.range_sort, d.loc);
    spend(1, 0);
    int id = static_cast<int>(g_.instances.size());
    g_.instances.push_back(std::move(inst));
    g_.instance_ids.emplace(name, id);
    inst_by_key_.emplace(inst_key_, id);
    return id;
  }

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
            std::vector<int>& acc_origin, const std::vector<int>& required, const Emit& emit) {
    JoinState j{s, done, b, acc, acc_origin, required, emit};
    joinStep(j);
  }

  /// Evaluate the cheapest ready literal and recurse on the rest (bindFromSort when none is
  /// ready); the literal is marked done for the recursion only.
  void joinStep(JoinState& j) {
    spend(0, 0);
    int best_pos = -1;
    const int best = chooseLiteral(j.s, j.done, j.b, best_pos);
    if (best < 0) {
      bindFromSort(j);
      return;
    }
    const CLit& l = j.s.lits[static_cast<size_t>(best)];
    j.done[static_cast<size_t>(best)] = 1;
    if (!l.is_atom) joinComparison(j, l);
    else if (l.dynamic) joinDynamic(j, l);
    else joinStatic(j, l, best_pos);
    j.done[static_cast<size_t>(best)] = 0;
  }

  /// The cheapest literal that the binding b lets us evaluate (cost 0: a test; else the number
  /// of candidate facts or values), -1 when none; best_pos: for a static atom, the argument
  /// position whose fact index gives the candidates (-1: all facts).
  int chooseLiteral(const Stmt& s, const std::vector<char>& done, const std::vector<int>& b,
                    int& best_pos) {
    int best = -1;
    size_t best_cost = std::numeric_limits<size_t>::max();
    best_pos = -1;
    for (size_t i = 0; i < s.lits.size(); ++i) {
      if (done[i]) continue;
      const CLit& l = s.lits[i];
      size_t cost;
      int pos = -1;
      if (!l.is_atom) {
        bool lb = bound(l.lhs, b), rb = bound(l.rhs, b);
        if (lb && rb) cost = 0;
        else if (l.op == CompareOp::Eq && !l.naf &&
                 ((!lb && rb && l.lhs.k == CTerm::Var) || (lb && !rb && l.rhs.k == CTerm::Var)))
          cost = 1;
        else
          continue;
      } else {
        bool args_bound = true;
        for (const auto& a : l.args) args_bound = args_bound && bound(a, b);
        bool vb = bound(l.value, b);
        if (l.naf || l.neg) {
          if (!(args_bound && vb)) continue;
          cost = 0;
        } else if (l.dynamic) {
          if (!args_bound) continue;
          if (vb) cost = 0;
          else if (l.value.k == CTerm::Var)
            cost = sortValues(prog_.attributes[static_cast<size_t>(l.attr)].range_sort, l.loc).size();
          else
            continue;
        } else {
          const FactSet& f = factsOf(l.attr);
          if (args_bound && vb) {
            cost = 0;
          } else {
            cost = f.tuples.size();
            for (size_t p = 0; p <= l.args.size(); ++p) {
              const CTerm& t = p < l.args.size() ? l.args[p] : l.value;
              if (!bound(t, b)) continue;
              int v = evalTerm(t, b);
              size_t c = 0;
              const auto& pos_index = f.posIndex();
              if (p < pos_index.size()) {
                auto it = pos_index[p].find(v);
                if (it != pos_index[p].end()) c = it->second.size();
              }
              if (c < cost || pos < 0) {
                cost = c;
                pos = static_cast<int>(p);
              }
            }
          }
        }
      }
      if (cost < best_cost) {
        best_cost = cost;
        best = static_cast<int>(i);
        best_pos = pos;
      }
      if (cost == 0) break;
    }
    return best;
  }

  /// No literal is ready: bind the unbound variable with the smallest sort to each of its
  /// values (variables of the remaining literals first, then the required ones); with every
  /// variable bound and no literal left, the binding is complete and emitted.
  void bindFromSort(JoinState& j) {
    const Stmt& s = j.s;
    const std::vector<char>& done = j.done;
    std::vector<int>& b = j.b;
    const std::vector<int>& required = j.required;
    // no literal ready: enumerate a variable from its sort (remaining literals first)
    int var = -1;
    size_t vsize = std::numeric_limits<size_t>::max();
    auto consider = [&](int slot) {
      if (b[static_cast<size_t>(slot)] >= 0) return;
      int so = s.slot_sort[static_cast<size_t>(slot)];
      if (so < 0) return;
      size_t n = sort_vals_[static_cast<size_t>(so)].size();
      if (n < vsize) {
        vsize = n;
        var = slot;
      }
    };
    bool any_left = false;
    for (size_t i = 0; i < s.lits.size(); ++i) {
      if (done[i]) continue;
      any_left = true;
      for (int v : s.lits[i].vars) consider(v);
    }
    if (!any_left)
      for (int v : required) consider(v);
    if (var < 0) {
      for (size_t i = 0; i < s.lits.size() && any_left; ++i) {
        if (done[i]) continue;
        for (int v : s.lits[i].vars)
          if (b[static_cast<size_t>(v)] < 0)
            throw UnknownSymbolError(s.lits[i].loc.str() + ": cannot determine the sort of "
                                     "variable " + s.slot_names[static_cast<size_t>(v)] +
                                     " (declare it with #domain or use it as an attribute "
                                     "argument)");
      }
      for (int v : required)
        if (b[static_cast<size_t>(v)] < 0)
          throw UnknownSymbolError(s.loc.str() + ": cannot determine the sort of variable " +
                                   s.slot_names[static_cast<size_t>(v)]);
      j.emit(b, j.acc, j.acc_origin);
      return;
    }
    for (int val : sort_vals_[static_cast<size_t>(s.slot_sort[static_cast<size_t>(var)])]) {
      b[static_cast<size_t>(var)] = val;
      joinStep(j);
    }
    b[static_cast<size_t>(var)] = -1;
  }

  /// A comparison: a test when both sides are bound, else `X = expr` binds X (within its sort).
  void joinComparison(JoinState& j, const CLit& l) {
    const Stmt& s = j.s;
    std::vector<int>& b = j.b;
    auto recurse = [&]() { joinStep(j); };
    bool lb = bound(l.lhs, b), rb = bound(l.rhs, b);
    if (lb && rb) {
      int x = evalTerm(l.lhs, b), y = evalTerm(l.rhs, b);
      bool ok = x >= 0 && y >= 0 && compare(l.op, x, y);
      if (l.naf) ok = !ok && x >= 0 && y >= 0;
      if (ok) recurse();
    } else {
      const CTerm& var = lb ? l.rhs : l.lhs;
      int v = evalTerm(lb ? l.lhs : l.rhs, b);
      if (v >= 0) {
        int so = s.slot_sort[static_cast<size_t>(var.slot)];
        bool in_sort = so < 0;
        if (!in_sort) {
          const auto& sv = sort_vals_[static_cast<size_t>(so)];
          in_sort = std::find(sv.begin(), sv.end(), v) != sv.end();
        }
        if (in_sort) {
          b[static_cast<size_t>(var.slot)] = v;
          recurse();
          b[static_cast<size_t>(var.slot)] = -1;
        }
      }
    }
  }

  /// An atom of an attribute that varies between worlds: collected as a ground literal (one per
  /// value of its instance when the value is an unbound variable).
  void joinDynamic(JoinState& j, const CLit& l) {
    std::vector<int>& b = j.b;
    std::vector<GLit>& acc = j.acc;
    std::vector<int>& acc_origin = j.acc_origin;
    auto recurse = [&]() { joinStep(j); };
    std::vector<int> args;
    bool ok = true;
    for (const auto& a : l.args) {
      int v = evalTerm(a, b);
      if (v < 0) ok = false;
      args.push_back(v);
    }
    if (ok) {
      ok = argsInSorts(l.attr, args);
      if (!ok) {
        // instance outside its sorts: the atom is false
        if (l.naf) recurse();
      } else {
        int inst = instanceFor(l.attr, args);
        if (bound(l.value, b)) {
          int v = evalTerm(l.value, b);
          int vi = v < 0 ? -1 : valueIdx(inst, v);
          if (vi < 0 && !l.naf && !l.neg) {
            // impossible value: literal false
          } else if (vi < 0 && l.naf && !l.neg) {
            recurse();
          } else {
            acc.push_back(GLit{inst, vi, l.naf, l.neg});
            acc_origin.push_back(l.origin);
            recurse();
            acc.pop_back();
            acc_origin.pop_back();
          }
        } else {
          const std::vector<int> dom = g_.instances[static_cast<size_t>(inst)].domain;
          for (size_t vi = 0; vi < dom.size(); ++vi) {
            b[static_cast<size_t>(l.value.slot)] = dom[vi];
            acc.push_back(GLit{inst, static_cast<int>(vi), false, false});
            acc_origin.push_back(l.origin);
            recurse();
            acc.pop_back();
            acc_origin.pop_back();
          }
          b[static_cast<size_t>(l.value.slot)] = -1;
        }
      }
    }
  }

  /// An atom of a static attribute: a test against the facts when bound (a guard atom is
  /// deferred to guard_acc_ instead), else one binding per matching fact (candidates from the
  /// index of argument position best_pos when >= 0).
  void joinStatic(JoinState& j, const CLit& l, int best_pos) {
    std::vector<int>& b = j.b;
    auto recurse = [&]() { joinStep(j); };
    const FactSet& f = factsOf(l.attr);
    bool all = true;
    for (const auto& a : l.args) all = all && bound(a, b);
    all = all && bound(l.value, b);
    if (all) {
      std::vector<int> args;
      bool ok = true;
      for (const auto& a : l.args) {
        args.push_back(evalTerm(a, b));
        if (args.back() < 0) ok = false;
      }
      int v = evalTerm(l.value, b);
      if (l.guard && ok && v >= 0) {
        // deferred: the ground statement is in force while the fact does not hold
        std::vector<int> key;
        key.reserve(args.size() + 2);
        key.push_back(l.attr);
        key.insert(key.end(), args.begin(), args.end());
        key.push_back(v);
        guard_acc_.push_back(std::move(key));
        recurse();
        guard_acc_.pop_back();
        return;
      }
      bool holds = ok && v >= 0 && staticAtom(l.attr, args, v, l.neg);
      if (l.naf) holds = !holds;
      if (holds) recurse();
    } else {
      // iterate candidate tuples (copy the id list: facts may grow during static fixpoint)
      std::vector<int> cand;
      if (best_pos >= 0) {
        const CTerm& t = static_cast<size_t>(best_pos) < l.args.size() ? l.args[best_pos] : l.value;
        int v = evalTerm(t, b);
        const auto& pos_index = f.posIndex();
        if (static_cast<size_t>(best_pos) < pos_index.size()) {
          auto it = pos_index[best_pos].find(v);
          if (it != pos_index[best_pos].end()) cand = it->second;
        }
      } else {
        cand.resize(f.tuples.size());
        for (size_t i = 0; i < cand.size(); ++i) cand[i] = static_cast<int>(i);
      }
      std::vector<int> set_slots;
      for (int ti : cand) {
        const std::vector<int>& tuple = f.tuples[static_cast<size_t>(ti)];
        if (tuple.size() != l.args.size() + 1) continue;
        bool ok = true;
        set_slots.clear();
        for (size_t p = 0; p < tuple.size() && ok; ++p) {
          const CTerm& t = p < l.args.size() ? l.args[p] : l.value;
          if (t.k == CTerm::Var && b[static_cast<size_t>(t.slot)] < 0) {
            b[static_cast<size_t>(t.slot)] = tuple[p];
            set_slots.push_back(t.slot);
          } else if (bound(t, b)) {
            if (evalTerm(t, b) != tuple[p]) ok = false;
          } else {
            ok = false;  // compound pattern with unbound variables: unsupported match
          }
        }
        if (ok) recurse();
        for (int sl : set_slots) b[static_cast<size_t>(sl)] = -1;
      }
    }
  }

  void runJoin(Stmt& s, const std::vector<int>& required, const Emit& emit) {
    std::vector<int> b(s.slot_names.size(), -1);
    runJoinFrom(s, b, required, emit);
  }
  /// runJoin from a partial binding b (slots >= 0 are bound).
  void runJoinFrom(Stmt& s, std::vector<int>& b, const std::vector<int>& required, const Emit& emit) {
    std::vector<char> done(s.lits.size(), 0);
    std::vector<GLit> acc;
    std::vector<int> origin;
    join(s, done, b, acc, origin, required, emit);
  }

  // ---- static evaluation ----
  void evaluateStatic() {
    const size_t na = prog_.attributes.size();
    // Static rules grouped by head attribute; dependency graph among static attributes (in
    // compressed rows: one array for all, a 10^5-rule program has 10^5 attributes).
    struct Ref {
      int from, to;
      bool negative;
    };
    std::vector<Ref> rule_refs, edge_list, stat_list;  // head -> rule; head -> body attribute
    for (size_t r = 0; r < prog_.rules.size(); ++r) {
      const int h = rule_head_attr_[r];  // (every head is known by now: -1 is a constraint)
      if (h < 0 || g_.attr_dynamic[h]) continue;
      rule_refs.push_back({h, static_cast<int>(r), false});
      if (!(rule_flags_[r] & kHasBody)) continue;
      const Rule& rule = prog_.rules[r];
      for (const auto& l : rule.body)
        if (l.kind == Literal::Kind::Atom) {
          const Ref e{h, attrId(l.atom.attr, l.loc), l.naf || l.negated};
          edge_list.push_back(e);
          if (!g_.attr_dynamic[static_cast<size_t>(e.to)]) stat_list.push_back(e);
        }
    }
    const CompactGraph rules_of = CompactGraph::fromEdges(na, rule_refs);
    const CompactGraph edges = CompactGraph::fromEdges(na, edge_list);
    // Needed static attributes: cone attributes and everything they depend on (edges into
    // dynamic attributes are not followed), grouped in strongly connected components,
    // dependencies first (scc.h: iterative, a 100000-rule chain is that deep).
    const CompactGraph statEdges = CompactGraph::fromEdges(na, stat_list);
    std::vector<char> needed(na, 0);
    std::vector<int> todo;
    for (size_t a = 0; a < na; ++a)
      if (!g_.attr_dynamic[a] && g_.attr_in_cone[a]) needed[a] = 1, todo.push_back(static_cast<int>(a));
    while (!todo.empty()) {
      const size_t v = static_cast<size_t>(todo.back());
      todo.pop_back();
      for (size_t k = 0; k < statEdges.degree(v); ++k) {
        const int w = statEdges.to(v, k);
        if (!needed[static_cast<size_t>(w)]) needed[static_cast<size_t>(w)] = 1, todo.push_back(w);
      }
    }
    int ncomp = 0;
    const std::vector<int> comp = stronglyConnectedComponents(statEdges, ncomp);
    // the needed attributes by component (in attribute order within one)
    std::vector<Ref> members;
    for (size_t a = 0; a < na; ++a)
      if (needed[a]) members.push_back({comp[a], static_cast<int>(a), false});
    const CompactGraph comps = CompactGraph::fromEdges(static_cast<size_t>(ncomp), members);
    std::vector<int> c;
    for (size_t ci = 0; ci < comps.size(); ++ci) {
      if (comps.degree(ci) == 0) continue;
      c.assign(comps.target.begin() + comps.start[ci], comps.target.begin() + comps.start[ci + 1]);
      evaluateComponent(c, comp, edges, rules_of);
    }
  }

  /// @brief The static rules of one strongly connected component (attributes c, dependencies
  /// evaluated), to their fixpoint when it is recursive; refuses negation inside it.
  void evaluateComponent(const std::vector<int>& c, const std::vector<int>& comp,
                         const CompactGraph& edges, const CompactGraph& rules_of) {
    for (int a : c)
      for (size_t k = 0; k < edges.degree(static_cast<size_t>(a)); ++k)
        if (edges.negative[static_cast<size_t>(edges.start[static_cast<size_t>(a)]) + k] &&
            !g_.attr_dynamic[static_cast<size_t>(edges.to(static_cast<size_t>(a), k))] &&
            comp[static_cast<size_t>(edges.to(static_cast<size_t>(a), k))] == comp[static_cast<size_t>(a)])
          throw OutsideFragmentError(prog_.attributes[a].loc.str() + ": attribute '" +
                      prog_.attributes[a].name +
                      "' depends on itself through negation (non-stratified); this is "
                      "outside the native reasoner's fast path (use the ASP back end)");
    bool recursive = c.size() > 1;
    for (int a : c)
      for (size_t k = 0; k < edges.degree(static_cast<size_t>(a)); ++k)
        if (edges.to(static_cast<size_t>(a), k) == a) recursive = true;
    std::vector<Stmt> stmts;
    std::vector<const Rule*> srcs;
    for (int a : c)
      for (size_t k = 0; k < rules_of.degree(static_cast<size_t>(a)); ++k) {
        const Rule& rule = prog_.rules[static_cast<size_t>(rules_of.to(static_cast<size_t>(a), k))];
        Stmt s;
        s.loc = rule.loc;
        for (const auto& l : rule.body) s.lits.push_back(compileLit(s, l, 0));
        stmts.push_back(std::move(s));
        srcs.push_back(&rule);
      }
    for (;;) {
      bool added = false;
      for (size_t k = 0; k < stmts.size(); ++k) {
        Stmt& s = stmts[k];
        const Rule& rule = *srcs[k];
        cur_loc_ = rule.loc;
        int h = rule_head_attr_[static_cast<size_t>(&rule - prog_.rules.data())];
        std::vector<CTerm> hargs;
        for (const auto& a : rule.head->attr.args) hargs.push_back(compile(s, a));
        CTerm hval = compile(s, rule.head->value);
        typeSlots(s, rule.variable_sorts);
        std::vector<int> required;
        for (const auto& a : hargs) termVars(a, required);
        termVars(hval, required);
        std::vector<std::pair<std::vector<int>, int>> news;
        runJoin(s, required, [&](const std::vector<int>& b, const std::vector<GLit>&,
                                 const std::vector<int>&) {
          std::vector<int> args;
          for (const auto& a : hargs) {
            int v = evalTerm(a, b);
            if (v < 0) return;
            args.push_back(v);
          }
          int v = evalTerm(hval, b);
          if (v < 0) return;
          // ground only within the declared sorts: `p(X + 1) :- p(X).` stops at the end of
          // p's argument sort instead of counting forever
          if (!argsInSorts(h, args)) return;
          const int rs = attr_range_sort_[static_cast<size_t>(h)];
          if (rs >= 0 && posInSort(rs, v) < 0) return;
          news.push_back({args, v});
          spend(0, 0);
        });
        for (auto& nv : news) {
          FactSet& f = factsFor(h);
          if (f.add(nv.first, nv.second)) {
            added = true;
            spend(1, 0);
            auto it = f.by_args.find(nv.first);
            if (it->second.size() > 1)
              throw IncoherentError(rule.loc.str() + ": attribute " + instanceName(h, nv.first) +
                                    " gets two values (" + syms_->text(it->second[0]) + " and " +
                                    syms_->text(it->second[1]) + ")");
          }
        }
      }
      if (!recursive || !added) break;
    }
  }

  // ---- dynamic grounding ----
  void groundDynamic() {
    for (const auto& r : prog_.random_rules) {
      const int a = attrId(r.attr, r.loc);
      if (g_.attr_in_cone[static_cast<size_t>(a)] && headDemanded(a)) groundSelectionRule(r, a);
    }
    for (size_t i = 0; i < prog_.pr_atoms.size(); ++i) {
      const PrAtom& p = prog_.pr_atoms[i];
      const int a = attrId(p.atom.attr, p.loc);
      // (a pr-atom of an attribute that is not random is refused by groundPrAtom)
      if (!g_.attr_in_cone[static_cast<size_t>(a)] || (g_.attr_random[a] && !headDemanded(a))) continue;
      groundPrAtom(p, pr_ids_ ? (*pr_ids_)[i] : static_cast<std::uint64_t>(i + 1));
    }
    for (size_t ri = 0; ri < prog_.rules.size(); ++ri) {
      const int h = rule_head_attr_[ri];  // (-1: a constraint)
      if (h >= 0 && (!g_.attr_dynamic[h] || !g_.attr_in_cone[h] || !headDemanded(h))) continue;
      const Rule& r = prog_.rules[ri];
      if (!r.head) {
        bool touches = false;
        for (const auto& l : r.body)
          if (l.kind == Literal::Kind::Atom && g_.attr_in_cone[attrId(l.atom.attr, l.loc)])
            touches = true;
        if (!touches && !r.body.empty()) continue;
      }
      groundDynamicRule(r, h);
    }
  }

  /// @brief One random selection rule of attribute a (in the cone): its ground selections, one
  /// per instance and dynamic body, with their dynamic ranges.
  void groundSelectionRule(const RandomRule& r, int a) {
    cur_loc_ = r.loc;
    Stmt s;
    s.loc = r.loc;
    for (const auto& l : r.body) s.lits.push_back(compileLit(s, l, 0));
    int range_slot = -1;
    if (r.has_range) {
      range_slot = slotOf(s, r.range_var);
      for (const auto& l : r.range_body) s.lits.push_back(compileLit(s, l, 1));
    }
    std::vector<CTerm> hargs;
    for (const auto& t : r.attr.args) hargs.push_back(compile(s, t));
    typeSlots(s, r.variable_sorts);
    std::vector<int> required;
    for (const auto& t : hargs) termVars(t, required);
    const size_t nbody = r.body.size();
    std::unordered_map<std::string, std::pair<int, int>> groups;  // key -> (inst, sel idx)
    std::vector<char> done(s.lits.size(), 0);
    for (size_t i = nbody; i < s.lits.size(); ++i) done[i] = 1;  // range literals later
    std::vector<GLit> acc;
    std::vector<int> origin;
    const Emit emit = [&](const std::vector<int>& bb, const std::vector<GLit>& body,
                          const std::vector<int>&) {
      const int inst = admittedHead(a, hargs, bb);
      if (inst < 0) return;
      std::string key = std::to_string(inst) + ":" + litKey(body);
      auto it = groups.find(key);
      if (it == groups.end()) {
        GSelection sel;
        sel.label = r.label;
        sel.body = body;
        sel.dynamic_range = r.has_range;
        sel.loc = r.loc;
        GInstance& gi = g_.instances[static_cast<size_t>(inst)];
        gi.selections.push_back(sel);
        it = groups.emplace(key, std::make_pair(inst, int(gi.selections.size()) - 1)).first;
        ++g_.ground_statements;
        spend(0, 1);
      }
      if (range_slot >= 0) groundRange(s, nbody, bb, range_slot, inst, it->second.second);
    };
    forEachHeadPattern(s, a, hargs, [&](std::vector<int>& b) {
      join(s, done, b, acc, origin, required, emit);
    });
  }

  /// @brief The dynamic range of selection sel_index of instance inst, for the body binding bb
  /// (the range literals are s.lits from nbody on).
  void groundRange(Stmt& s, size_t nbody, const std::vector<int>& bb, int range_slot, int inst,
                   int sel_index) {
    std::vector<char> done2(s.lits.size(), 1);
    for (size_t i = nbody; i < s.lits.size(); ++i) done2[i] = 0;
    std::vector<int> b2 = bb;
    std::vector<GLit> acc2;
    std::vector<int> origin2;
    join(s, done2, b2, acc2, origin2, {range_slot}, [&](const std::vector<int>& b3,
                                                        const std::vector<GLit>& cond,
                                                        const std::vector<int>&) {
      GInstance& gi = g_.instances[static_cast<size_t>(inst)];
      int vi = valueIdx(inst, b3[static_cast<size_t>(range_slot)]);
      if (vi >= 0) gi.selections[static_cast<size_t>(sel_index)].range.push_back({vi, cond});
    });
  }

  /// @brief A rule with a dynamic head (attribute h) or a constraint (h < 0) touching the cone.
  void groundDynamicRule(const Rule& r, int h) {
    cur_loc_ = r.loc;
    Stmt s;
    s.loc = r.loc;
    for (const auto& l : r.body) s.lits.push_back(compileLit(s, l, 0));
    std::vector<CTerm> hargs;
    CTerm hval;
    if (r.head) {
      for (const auto& t : r.head->attr.args) hargs.push_back(compile(s, t));
      hval = compile(s, r.head->value);
    }
    typeSlots(s, r.variable_sorts);
    std::vector<int> required;
    for (const auto& t : hargs) termVars(t, required);
    if (r.head) termVars(hval, required);
    const Emit emit = [&](const std::vector<int>& b, const std::vector<GLit>& acc,
                          const std::vector<int>&) {
      if (!r.head) {
        if (acc.empty())
          throw IncoherentError(r.loc.str() + ": constraint is violated by the facts of the "
                                "program (no possible world)");
        g_.constraints.push_back({acc, r.loc});
        ++g_.ground_statements;
        spend(0, 1);
        return;
      }
      const int inst = admittedHead(h, hargs, b);
      if (inst < 0) return;
      addDerivedRule(r, inst, evalTerm(hval, b), acc);
    };
    if (!r.head) {
      runJoin(s, required, emit);
      return;
    }
    forEachHeadPattern(s, h, hargs, [&](std::vector<int>& b) { runJoinFrom(s, b, required, emit); });
  }

  /// @brief The ground rule `inst = v :- body` of a derived instance.
  void addDerivedRule(const Rule& r, int inst, int v, const std::vector<GLit>& body) {
    GInstance& gi = g_.instances[static_cast<size_t>(inst)];
    int vi = v < 0 ? -1 : valueIdx(inst, v);
    if (vi < 0)
      throw UnknownSymbolError(r.loc.str() + ": value '" + (v < 0 ? "?" : syms_->text(v)) +
                               "' is not in the range of " + gi.name);
    gi.rules.push_back({vi, body});
    ++g_.ground_statements;
    if (!gi.random) ++g_.derived_rules;
    spend(0, 1);
  }

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

  std::vector<std::vector<Definition>> definitionsByHead() const {
    std::vector<std::vector<Definition>> defs(prog_.attributes.size());
    for (const auto& r : prog_.random_rules) {
      const int a = attrLookupTerm(r.attr);
      if (a >= 0) defs[static_cast<size_t>(a)].push_back({&r.attr.args, {&r.body, &r.range_body}});
    }
    for (const auto& p : prog_.pr_atoms) {
      const int a = attrLookupTerm(p.atom.attr);
      if (a >= 0) defs[static_cast<size_t>(a)].push_back({&p.atom.attr.args, {&p.body}});
    }
    for (size_t i = 0; i < prog_.rules.size(); ++i)
      if (rule_head_attr_[i] >= 0)
        defs[static_cast<size_t>(rule_head_attr_[i])].push_back(
            {&prog_.rules[i].head->attr.args, {&prog_.rules[i].body}});
    return defs;
  }

  /// @brief head_demand_ from the query's atoms: attributes in every cone entirely, the rest
  /// closed over the statements whose heads unify with a demanded pattern.
  void computeInstancePatterns(const std::vector<AttributeTerm>& atoms) {
    restricted_ = true;
    head_demand_.assign(prog_.attributes.size(), Demand());
    demand_work_.clear();
    for (const auto& n : relevanceCone(prog_, {})) {
      const int a = attrLookup(n);
      if (a >= 0) demand(a, std::vector<int>(prog_.attributes[static_cast<size_t>(a)].arg_sorts.size(), -1));
    }
    const std::unordered_map<std::string, int> none;
    for (const auto& t : atoms) {
      const int a = attrLookupTerm(t);
      if (a >= 0) demand(a, patternOf(t.args, none));
    }
    const std::vector<std::vector<Definition>> defs = definitionsByHead();
    std::unordered_map<std::string, int> bind;
    while (!demand_work_.empty()) {
      const std::pair<int, std::vector<int>> item = std::move(demand_work_.back());
      demand_work_.pop_back();
      for (const Definition& d : defs[static_cast<size_t>(item.first)]) {
        bind.clear();
        if (!unifyHead(*d.head_args, item.second, bind)) continue;
        for (const std::vector<Literal>* body : d.bodies)
          for (const auto& l : *body) {
            if (l.kind != Literal::Kind::Atom) continue;
            const int b = attrLookupTerm(l.atom.attr);
            if (b >= 0 && g_.attr_dynamic[static_cast<size_t>(b)]) demand(b, patternOf(l.atom.attr.args, bind));
          }
      }
    }
  }

  int attrLookupTerm(const AttributeTerm& t) const { return attr_index_.of(t); }

  /// @brief The pattern of atom arguments under `bind`: constants and bound variables give
  /// their symbol, anything else (free variables, arithmetic) -1.
  std::vector<int> patternOf(const std::vector<Term>& args,
                             const std::unordered_map<std::string, int>& bind) {
    std::vector<int> pat;
    pat.reserve(args.size());
    for (const auto& t : args) {
      int v = -1;
      if (t.kind == Term::Kind::Symbol || t.kind == Term::Kind::Integer ||
          (t.kind == Term::Kind::Compound && t.isGround())) {
        v = syms_->intern(toString(t));
      } else if (t.kind == Term::Kind::Variable) {
        auto it = bind.find(t.name);
        if (it != bind.end()) v = it->second;
      }
      pat.push_back(v);
    }
    return pat;
  }

  /// @brief Unifies head arguments with a demanded pattern (variables bound in `bind`); false
  /// when a constant or a repeated variable cannot match. Arithmetic matches anything.
  bool unifyHead(const std::vector<Term>& args, const std::vector<int>& pat,
                 std::unordered_map<std::string, int>& bind) {
    for (size_t i = 0; i < args.size() && i < pat.size(); ++i) {
      if (pat[i] < 0) continue;
      const Term& t = args[i];
      if (t.kind == Term::Kind::Symbol || t.kind == Term::Kind::Integer ||
          (t.kind == Term::Kind::Compound && t.isGround())) {
        if (syms_->intern(toString(t)) != pat[i]) return false;
      } else if (t.kind == Term::Kind::Variable && t.name != "_") {
        auto ins = bind.emplace(t.name, pat[i]);
        if (!ins.second && ins.first->second != pat[i]) return false;
      }
    }
    return true;
  }

  static bool subsumes(const std::vector<int>& general, const std::vector<int>& p) {
    for (size_t i = 0; i < general.size() && i < p.size(); ++i)
      if (general[i] >= 0 && general[i] != p[i]) return false;
    return true;
  }

  /// @brief Demands the instances of attribute a matching pat (queued for the closure).
  void demand(int a, std::vector<int> pat) {
    Demand& d = head_demand_[static_cast<size_t>(a)];
    if (d.all) return;
    bool any = std::all_of(pat.begin(), pat.end(), [](int v) { return v < 0; });
    if (!any) {
      for (const auto& p : d.pats)
        if (subsumes(p, pat)) return;
      if (d.pats.size() >= kMaxDemandPatterns) any = true, pat.assign(pat.size(), -1);
    }
    if (any) {
      d.all = true;
      d.pats.clear();
    } else {
      d.pats.erase(std::remove_if(d.pats.begin(), d.pats.end(),
                                  [&](const std::vector<int>& p) { return subsumes(pat, p); }),
                   d.pats.end());
      d.pats.push_back(pat);
    }
    demand_work_.push_back({a, std::move(pat)});
  }

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
               std::vector<int>& b) const {
    for (size_t i = 0; i < hargs.size() && i < pat.size(); ++i) {
      if (pat[i] < 0) continue;
      const CTerm& t = hargs[i];
      if (t.k == CTerm::Const) {
        if (t.sym != pat[i]) return false;
        continue;
      }
      int& slot = b[static_cast<size_t>(t.slot)];
      if (slot >= 0 && slot != pat[i]) return false;
      const int sort = s.slot_sort[static_cast<size_t>(t.slot)];
      if (sort >= 0 && posInSort(sort, pat[i]) < 0) return false;  // never a binding
      slot = pat[i];
    }
    return true;
  }

  /// @brief The instance of head a(hargs) under binding b, or -1 when an argument does not
  /// evaluate, lies outside its declared sort, or is not demanded (headAdmitted): the one
  /// admission rule of selection rules, derived rules and pr-atoms.
  int admittedHead(int a, const std::vector<CTerm>& hargs, const std::vector<int>& b) {
    std::vector<int> args;
    args.reserve(hargs.size());
    for (const auto& t : hargs) {
      const int v = evalTerm(t, b);
      if (v < 0) return -1;
      args.push_back(v);
    }
    if (!argsInSorts(a, args) || !headAdmitted(a, args)) return -1;
    return instanceFor(a, args);
  }

  /// @brief Whether a ground head a(args) is emitted in the current forEachHeadPattern run:
  /// every head when a is not restricted; else a demanded one, once (by the first pattern
  /// that matches it).
  bool headAdmitted(int a, const std::vector<int>& args) const {
    if (cur_pattern_ == -1 || !restrictedHead(a)) return true;
    const auto& pats = head_demand_[static_cast<size_t>(a)].pats;
    for (size_t k = 0; k < pats.size(); ++k)
      if (subsumes(pats[k], args)) return cur_pattern_ == -2 || static_cast<int>(k) == cur_pattern_;
    return false;
  }

  /// @brief A pr-atom added to a restricted grounding demands instances that were not ground:
  /// a dynamic atom of its body, under a demanded head pattern, outside every demanded one.
  bool demandsInstances(const PrAtom& p) {
    if (!restricted_) return false;
    const int a = attrLookupTerm(p.atom.attr);
    if (a < 0) return true;
    const Demand& d = head_demand_[static_cast<size_t>(a)];
    const std::vector<std::vector<int>> heads =
        d.all ? std::vector<std::vector<int>>{std::vector<int>(p.atom.attr.args.size(), -1)} : d.pats;
    std::unordered_map<std::string, int> bind;
    for (const auto& pat : heads) {
      bind.clear();
      if (!unifyHead(p.atom.attr.args, pat, bind)) continue;
      for (const auto& l : p.body) {
        if (l.kind != Literal::Kind::Atom) continue;
        const int b = attrLookupTerm(l.atom.attr);
        if (b < 0) return true;
        if (g_.attr_dynamic[static_cast<size_t>(b)] && !demanded(b, patternOf(l.atom.attr.args, bind)))
          return true;
      }
    }
    return false;
  }

  /// @brief Every instance matching pat is demanded.
  bool demanded(int a, const std::vector<int>& pat) const {
    const Demand& d = head_demand_[static_cast<size_t>(a)];
    if (d.all) return true;
    for (const auto& p : d.pats)
      if (subsumes(p, pat)) return true;
    return false;
  }

  bool argsInSorts(int attr, const std::vector<int>& args) const {
    const AttributeDecl& d = prog_.attributes[static_cast<size_t>(attr)];
    const std::vector<int>& sorts = attr_arg_sorts_[static_cast<size_t>(attr)];
    for (size_t i = 0; i < args.size() && i < sorts.size(); ++i) {
      if (sorts[i] == -1) continue;
      if (sorts[i] == -2) sortValues(d.arg_sorts[i], d.loc);  // throws: unknown sort
      if (posInSort(sorts[i], args[i]) < 0) return false;
    }
    return true;
  }

  // One pr-atom statement: its ground instances are appended to their instances' lists.
  void groundPrAtom(const PrAtom& p, std::uint64_t id) {
    int a = attrId(p.atom.attr, p.loc);
    if (!g_.attr_random[a]) {
      throw UnknownSymbolError(p.loc.str() + ": pr-atom for attribute '" + p.atom.attr.name +
                               "' which has no random selection rule");
    }
    cur_loc_ = p.loc;
    Stmt s;
    s.loc = p.loc;
    compiling_pr_ = true;
    for (const auto& l : p.body) s.lits.push_back(compileLit(s, l, 0));
    compiling_pr_ = false;
    std::vector<CTerm> hargs;
    for (const auto& t : p.atom.attr.args) hargs.push_back(compile(s, t));
    CTerm hval = compile(s, p.atom.value);
    typeSlots(s, p.variable_sorts);
    std::vector<int> required;
    for (const auto& t : hargs) termVars(t, required);
    termVars(hval, required);
    guard_acc_.clear();
    const Emit emit = [&](const std::vector<int>& b, const std::vector<GLit>& acc,
                          const std::vector<int>&) {
      const int inst = admittedHead(a, hargs, b);
      if (inst < 0) return;
      GInstance& gi = g_.instances[static_cast<size_t>(inst)];
      int v = evalTerm(hval, b);
      int vi = v < 0 ? -1 : valueIdx(inst, v);
      if (vi < 0) return;
      GPr pr;
      pr.value = vi;
      pr.probability = p.probability;
      pr.label = p.label;
      pr.body = acc;
      pr.loc = p.loc;
      pr.priority = p.priority;
      pr.src = id;
      const std::pair<int, int> ref{inst, static_cast<int>(gi.prs.size())};
      for (const auto& key : guard_acc_) {
        guard_refs_[key].push_back(ref);
        if (guardHolds(key)) ++pr.inactive;
      }
      gi.prs.push_back(std::move(pr));
      ++atoms_;
      src_refs_[id].push_back(ref);
      if (changed_) changed_->push_back(ref);
      ++g_.ground_statements;
      spend(0, 1);
    };
    forEachHeadPattern(s, a, hargs, [&](std::vector<int>& b) { runJoinFrom(s, b, required, emit); });
  }

  bool guardHolds(const std::vector<int>& key) const {
    const std::vector<int> args(key.begin() + 1, key.end() - 1);
    return staticAtom(key.front(), args, key.back(), false);
  }

  // Guard attributes: static, defined by ground facts only, and used only as `not f(t)=y`
  // in pr-atom bodies. Their literals are deferred (see IncrementalGrounder).
  void computeGuardAttributes() {
    const size_t na = prog_.attributes.size();
    guard_attr_.assign(na, 0);
    for (size_t a = 0; a < na; ++a) guard_attr_[a] = g_.attr_dynamic[a] ? 0 : 1;
    auto off = [&](const AttributeTerm& t) {
      const int a = attr_index_.of(t);
      if (a >= 0) guard_attr_[static_cast<size_t>(a)] = 0;
    };
    auto offBody = [&](const std::vector<Literal>& body) {
      for (const auto& l : body)
        if (l.kind == Literal::Kind::Atom) off(l.atom.attr);
    };
    for (size_t i = 0; i < prog_.rules.size(); ++i) {
      const unsigned char f = rule_flags_[i];
      // (a head's attribute is rule_head_attr_: a rule is read only when it has a body)
      if ((f & kHasHead) && ((f & kHasBody) || !(f & kGroundHead)))
        guard_attr_[static_cast<size_t>(rule_head_attr_[i])] = 0;
      if (f & kHasBody) offBody(prog_.rules[i].body);
    }
    for (const auto& r : prog_.random_rules) {
      offBody(r.body);
      offBody(r.range_body);
    }
    for (const auto& p : prog_.pr_atoms)
      for (const auto& l : p.body)
        if (l.kind == Literal::Kind::Atom && !(l.naf && !l.negated)) off(l.atom.attr);
  }

  // Multiplicity of each guard fact (the same fact may be stated twice), for the guard
  // attributes in the cone: the facts of the others do not enter the grounding (changeFact).
  void countGuardFacts() {
    for (size_t i = 0; i < prog_.rules.size(); ++i) {
      if (!(rule_flags_[i] & kHasHead) || (rule_flags_[i] & kHasBody)) continue;
      const int a = rule_head_attr_[i];
      if (!isGuard(a) || !g_.attr_in_cone[static_cast<size_t>(a)]) continue;
      ++fact_count_[factKey(a, *prog_.rules[i].head)];
    }
  }

  std::vector<int> factKey(int attr, const Atom& head) {
    std::vector<int> key{attr};
    for (const auto& t : head.attr.args) key.push_back(syms_->intern(toString(t)));
    key.push_back(syms_->intern(toString(head.value)));
    return key;
  }

  // A guard fact added (+1) or removed (-1); false when outside the incremental path.
  bool changeFact(const Rule& r, int delta) {
    if (!r.head || !r.body.empty()) return false;
    const int a = attr_index_.of(r.head->attr);
    if (!isGuard(a)) return false;
    bool ground = r.head->value.isGround();
    for (const auto& t : r.head->attr.args) ground = ground && t.isGround();
    if (!ground) return false;
    // Outside the cone: nothing of the grounding depends on the attribute (its facts are
    // neither evaluated nor counted).
    if (!g_.attr_in_cone[static_cast<size_t>(a)]) return true;
    const std::vector<int> key = factKey(a, *r.head);
    int& count = fact_count_[key];
    const int before = count;
    count += delta;
    if (count < 0) return false;  // removing a fact that was never counted
    if ((before > 0) == (count > 0)) return true;  // truth unchanged
    const std::vector<int> args(key.begin() + 1, key.end() - 1);
    const int value = key.back();
    FactSet& f = factsFor(a);
    if (delta > 0) {
      auto it = f.by_args.find(args);
      if (it != f.by_args.end() && !it->second.empty() && it->second[0] != value) {
        count = before;
        throw IncoherentError(r.loc.str() + ": attribute " + instanceName(a, args) +
                              " gets two values (" + syms_->text(it->second[0]) + " and " +
                              syms_->text(value) + ")");
      }
      f.add(args, value);
    } else {
      auto it = f.by_args.find(args);
      if (it != f.by_args.end()) {
        it->second.erase(std::remove(it->second.begin(), it->second.end(), value), it->second.end());
        if (it->second.empty()) f.by_args.erase(it);
      }
    }
    if (g_.attr_in_cone[static_cast<size_t>(a)] && static_cast<size_t>(a) < g_.static_atoms.size()) {
      std::string printable = instanceName(a, args) + "=" + syms_->text(value);
      if (delta > 0) g_.static_atoms[static_cast<size_t>(a)].insert(printable);
      else g_.static_atoms[static_cast<size_t>(a)].erase(printable);
    }
    auto rt = guard_refs_.find(key);
    if (rt != guard_refs_.end()) {
      for (const auto& ref : rt->second) {
        g_.instances[static_cast<size_t>(ref.first)].prs[static_cast<size_t>(ref.second)].inactive +=
            delta > 0 ? 1 : -1;
        if (changed_) changed_->push_back(ref);
      }
    }
    return true;
  }

  static std::string litKey(const std::vector<GLit>& body) {
    std::string k;
    for (const auto& l : body)
      k += std::to_string(l.inst) + "/" + std::to_string(l.value) + (l.naf ? "n" : "") +
           (l.neg ? "-" : "") + ";";
    return k;
  }

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

}  // namespace

namespace {

/// A dependency of the relevance cone: attribute `from` depends on `to` (through `not`: negative).
struct ConeEdge {
  int from, to;
  bool negative;
};

/// @brief Every attribute of a strongly connected component with a `not` edge inside joins the
/// seeds (see relevanceCone).
void addNegativeLoopSeeds(size_t n, const std::vector<ConeEdge>& loops, std::vector<int>& seeds) {
  const CompactGraph g = CompactGraph::fromEdges(n, loops);
  int ncomp = 0;
  const std::vector<int> comp = stronglyConnectedComponents(g, ncomp);
  std::vector<char> negative(static_cast<size_t>(ncomp), 0);
  for (size_t v = 0; v < n; ++v)
    for (size_t k = 0; k < g.degree(v); ++k)
      if (g.negative[static_cast<size_t>(g.start[v]) + k] &&
          comp[static_cast<size_t>(g.to(v, k))] == comp[v])
        negative[static_cast<size_t>(comp[v])] = 1;
  for (size_t v = 0; v < n; ++v)
    if (negative[static_cast<size_t>(comp[v])]) seeds.push_back(static_cast<int>(v));
}

/// @brief The cone: every attribute the seeds depend on (a flag per attribute id).
std::vector<char> closeCone(size_t n, const std::vector<ConeEdge>& deps, const std::vector<int>& seeds) {
  const CompactGraph parents = CompactGraph::fromEdges(n, deps);
  std::vector<char> in(n, 0);
  std::vector<int> work;
  for (int s : seeds) {
    if (in[static_cast<size_t>(s)]) continue;
    in[static_cast<size_t>(s)] = 1;
    work.push_back(s);
    while (!work.empty()) {
      const size_t v = static_cast<size_t>(work.back());
      work.pop_back();
      for (size_t k = 0; k < parents.degree(v); ++k) {
        const int p = parents.to(v, k);
        if (!in[static_cast<size_t>(p)]) in[static_cast<size_t>(p)] = 1, work.push_back(p);
      }
    }
  }
  return in;
}

}  // namespace

std::set<std::string> relevanceCone(const Program& program, const std::set<std::string>& names) {
  // Attributes as dense ids (their declaration index; names that no declaration has come
  // after them), edges as one array each: the cone of a 10^5-rule program costs no set of
  // strings, and no name lookup for the atoms the parser resolved (AttributeTerm::index).
  const AttributeIndex index(program);
  const int na = static_cast<int>(program.attributes.size());
  NameTable undeclared;
  auto idOfName = [&](const std::string& n) {
    const int a = index.find(n);
    return a >= 0 ? a : na + undeclared.intern(n);
  };
  auto idOf = [&](const AttributeTerm& t) {
    const int a = index.of(t);
    return a >= 0 ? a : na + undeclared.intern(t.name);
  };
  auto nameOf = [&](int id) -> const std::string& {
    return id < na ? program.attributes[static_cast<size_t>(id)].name : undeclared.name(id - na);
  };
  auto count = [&]() { return static_cast<size_t>(na) + undeclared.size(); };
  using Edge = ConeEdge;
  // Relevance: an attribute depends on the attributes in the bodies of its random selection
  // rules (dynamic ranges included), of its pr-atoms and of the rules defining it.
  std::vector<Edge> deps;
  // Loops through default negation: the same edges without the pr-atoms', with their `not`.
  std::vector<Edge> loops;
  auto edges = [&](int from, const std::vector<Literal>& body, bool loop) {
    for (const auto& l : body) {
      if (l.kind != Literal::Kind::Atom) continue;
      const Edge e{from, idOf(l.atom.attr), l.naf};
      deps.push_back(e);
      if (loop) loops.push_back(e);
    }
  };
  std::vector<int> seeds;
  for (const auto& n : names) seeds.push_back(idOfName(n));
  std::vector<int> random_attrs;
  for (const auto& r : program.random_rules) {
    const int a = idOf(r.attr);
    random_attrs.push_back(a);
    edges(a, r.body, true);
    edges(a, r.range_body, true);
    // A random selection over a dynamic range: a world where the range is empty has no
    // answer set.
    if (r.has_range) seeds.push_back(a);
  }
  for (const auto& pr : program.pr_atoms)
    if (!pr.body.empty()) edges(idOf(pr.atom.attr), pr.body, false);
  // Derived attribute -> may it get two values in a world (two head values or a variable)?
  // (the first head value as an id of `values`: 8 bytes per attribute, not a string)
  struct HeadValue {
    int first = -1;  ///< -1: no head yet; kVarValue: a variable
    bool multi = false;
  };
  constexpr int kVarValue = -2;
  NameTable values;
  std::vector<HeadValue> head_values(count());
  // (every random attribute has an id by now: ids made later are not random)
  std::vector<char> is_random(count(), 0);
  for (int a : random_attrs) is_random[static_cast<size_t>(a)] = 1;
  for (const auto& r : program.rules) {
    if (!r.head) {
      // Constraints act as evidence: every attribute they mention is in every cone.
      for (const auto& l : r.body)
        if (l.kind == Literal::Kind::Atom) seeds.push_back(idOf(l.atom.attr));
      continue;
    }
    const int h = idOf(r.head->attr);
    edges(h, r.body, true);
    if (static_cast<size_t>(h) < is_random.size() && is_random[static_cast<size_t>(h)]) continue;
    if (head_values.size() <= static_cast<size_t>(h)) head_values.resize(count());
    HeadValue& hv = head_values[static_cast<size_t>(h)];
    const bool var = r.head->value.kind == Term::Kind::Variable;
    if (hv.first == -1) {
      hv.multi = var;
      hv.first = var ? kVarValue : values.intern(toString(r.head->value));
    } else if (!hv.multi && (var || hv.first == kVarValue ||
                             values.intern(toString(r.head->value)) != hv.first)) {
      hv.multi = true;
    }
  }
  // Derived attributes that may get two values in a world (an inconsistency) act as evidence
  // too. Even when independent of the query, such evidence matters if it can never be
  // satisfied (then the program has no possible world at all).
  for (size_t a = 0; a < head_values.size(); ++a)
    if (head_values[a].multi) seeds.push_back(static_cast<int>(a));
  const size_t n = count();
  // Rules outside the query's dependencies can still change the set of possible worlds: a
  // loop through default negation (odd: `e :- not e.` removes worlds; even: `b :- not c.
  // c :- not b.` splits one into several). The attributes of a strongly connected component
  // with a `not` edge inside join every cone, so the native engine either handles them
  // exactly (locally stratified ground rules) or refuses the program as outside its fragment.
  addNegativeLoopSeeds(n, loops, seeds);
  const std::vector<char> in = closeCone(n, deps, seeds);
  std::vector<const std::string*> out;
  for (size_t v = 0; v < n; ++v)
    if (in[v]) out.push_back(&nameOf(static_cast<int>(v)));
  std::sort(out.begin(), out.end(),
            [](const std::string* a, const std::string* b) { return *a < *b; });
  std::set<std::string> cone;
  for (const std::string* a : out) cone.emplace_hint(cone.end(), *a);
  return cone;
}

GroundProgram groundProgram(const Program& program, const std::set<std::string>& cone_attributes,
                            const GroundingLimits& limits,
                            const std::vector<AttributeTerm>* cone_atoms) {
  GroundProgram g;
  Grounder gr(program, g);
  gr.setLimits(limits);
  gr.run(relevanceCone(program, cone_attributes), cone_atoms);
  return g;
}

bool instanceConePays(const Program& program, const std::set<std::string>& cone,
                      std::size_t min_instances) {
  if (min_instances == 0) return true;
  if (min_instances == std::numeric_limits<std::size_t>::max()) return false;
  std::unordered_map<std::string, std::size_t> sort_size;
  for (const auto& so : program.sorts) sort_size[so.name] = so.values.size();
  std::size_t total = 0;
  for (const auto& d : program.attributes) {
    if (!cone.count(d.name)) continue;
    std::size_t n = 1;
    for (const auto& so : d.arg_sorts) {
      auto it = sort_size.find(so);
      const std::size_t k = it == sort_size.end() ? min_instances : it->second;  // untyped: many
      if (k != 0 && n > min_instances / k) return true;  // the product alone reaches the bound
      n *= k;
    }
    total += n;
    if (total >= min_instances) return true;
  }
  return false;
}

class IncrementalGrounder::Impl {
 public:
  Impl(const Program& p, GroundProgram& g) : grounder(p, g) {}
  Grounder grounder;
};

IncrementalGrounder::IncrementalGrounder(const Program& program,
                                         const std::set<std::string>& cone_attributes,
                                         const std::vector<std::uint64_t>* pr_ids,
                                         const GroundingLimits& limits)
    : IncrementalGrounder(program, ClosedCone{relevanceCone(program, cone_attributes)}, pr_ids,
                          limits) {}

IncrementalGrounder::IncrementalGrounder(const Program& program, ClosedCone cone,
                                         const std::vector<std::uint64_t>* pr_ids,
                                         const GroundingLimits& limits)
    : ground_(std::make_shared<GroundProgram>()) {
  impl_ = std::make_unique<Impl>(program, *ground_);
  impl_->grounder.setLimits(limits);
  impl_->grounder.setPrIds(pr_ids);
  impl_->grounder.run(cone.attributes, cone.atoms);
  impl_->grounder.setPrIds(nullptr);
}

IncrementalGrounder::~IncrementalGrounder() = default;

bool IncrementalGrounder::apply(const Program& program, const Delta& delta,
                                std::vector<std::pair<int, int>>* changed) {
  if (&program != &impl_->grounder.program()) return false;
  return impl_->grounder.applyDelta(delta, changed);
}

std::size_t IncrementalGrounder::atoms() const { return impl_->grounder.atoms_; }
std::size_t IncrementalGrounder::removedAtoms() const { return impl_->grounder.removed_atoms_; }

bool IncrementalGrounder::isGuardAttribute(const std::string& attribute) const {
  return impl_->grounder.isGuard(impl_->grounder.attrIndexOf(attribute));
}

}  // namespace plog
}  // namespace krr
