#include "krr_core/plog/grounder.h"

#include <algorithm>
#include <chrono>
#include <functional>
#include <limits>
#include <map>
#include <unordered_map>
#include <unordered_set>

#include "krr_core/plog/arith.h"

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

void attrsOfBody(const std::vector<Literal>& b, std::set<std::string>& out) {
  for (const auto& l : b)
    if (l.kind == Literal::Kind::Atom) out.insert(l.atom.attr.name);
}

/// @brief Attributes on a cycle through default negation (attribute-level strongly connected
/// components of the rule dependency graph that contain a `not` edge) and attributes chosen
/// by a random selection with a dynamic range.
std::set<std::string> worldChangingAttributes(const Program& p) {
  std::unordered_map<std::string, int> id;
  auto idOf = [&](const std::string& a) { return id.emplace(a, static_cast<int>(id.size())).first->second; };
  std::vector<std::vector<std::pair<int, bool>>> edges;  // child -> (parent, through not)
  auto addEdges = [&](const std::string& head, const std::vector<Literal>& body) {
    const int h = idOf(head);
    for (const auto& l : body) {
      if (l.kind != Literal::Kind::Atom) continue;
      const int b = idOf(l.atom.attr.name);
      if (edges.size() < id.size()) edges.resize(id.size());
      edges[static_cast<size_t>(h)].push_back({b, l.naf});
    }
    if (edges.size() < id.size()) edges.resize(id.size());
  };
  std::set<std::string> out;
  for (const auto& r : p.rules)
    if (r.head) addEdges(r.head->attr.name, r.body);
  for (const auto& r : p.random_rules) {
    addEdges(r.attr.name, r.body);
    addEdges(r.attr.name, r.range_body);
    if (r.has_range) out.insert(r.attr.name);
  }
  const int n = static_cast<int>(id.size());
  edges.resize(static_cast<size_t>(n));
  std::vector<std::string> name(static_cast<size_t>(n));
  for (const auto& kv : id) name[static_cast<size_t>(kv.second)] = kv.first;
  // Tarjan's algorithm, iterative (programs may have long dependency chains).
  std::vector<int> index(static_cast<size_t>(n), -1), low(static_cast<size_t>(n), 0),
      comp(static_cast<size_t>(n), -1), stack;
  std::vector<char> on_stack(static_cast<size_t>(n), 0);
  int counter = 0, ncomp = 0;
  for (int root = 0; root < n; ++root) {
    if (index[static_cast<size_t>(root)] >= 0) continue;
    std::vector<std::pair<int, size_t>> call{{root, 0}};
    index[static_cast<size_t>(root)] = low[static_cast<size_t>(root)] = counter++;
    stack.push_back(root);
    on_stack[static_cast<size_t>(root)] = 1;
    while (!call.empty()) {
      const int v = call.back().first;
      size_t& next = call.back().second;
      const auto& ev = edges[static_cast<size_t>(v)];
      if (next < ev.size()) {
        const int w = ev[next++].first;
        if (index[static_cast<size_t>(w)] < 0) {
          index[static_cast<size_t>(w)] = low[static_cast<size_t>(w)] = counter++;
          stack.push_back(w);
          on_stack[static_cast<size_t>(w)] = 1;
          call.push_back({w, 0});
        } else if (on_stack[static_cast<size_t>(w)]) {
          low[static_cast<size_t>(v)] = std::min(low[static_cast<size_t>(v)], index[static_cast<size_t>(w)]);
        }
        continue;
      }
      if (low[static_cast<size_t>(v)] == index[static_cast<size_t>(v)]) {
        int w;
        do {
          w = stack.back();
          stack.pop_back();
          on_stack[static_cast<size_t>(w)] = 0;
          comp[static_cast<size_t>(w)] = ncomp;
        } while (w != v);
        ++ncomp;
      }
      call.pop_back();
      if (!call.empty()) {
        const int u = call.back().first;
        low[static_cast<size_t>(u)] = std::min(low[static_cast<size_t>(u)], low[static_cast<size_t>(v)]);
      }
    }
  }
  std::vector<char> negative(static_cast<size_t>(ncomp), 0);
  for (int v = 0; v < n; ++v)
    for (const auto& e : edges[static_cast<size_t>(v)])
      if (e.second && comp[static_cast<size_t>(e.first)] == comp[static_cast<size_t>(v)])
        negative[static_cast<size_t>(comp[static_cast<size_t>(v)])] = 1;
  for (int v = 0; v < n; ++v)
    if (negative[static_cast<size_t>(comp[static_cast<size_t>(v)])]) out.insert(name[static_cast<size_t>(v)]);
  return out;
}

struct Deps {
  std::map<std::string, std::set<std::string>> parents;  // attr -> attrs it depends on
};

Deps dependencies(const Program& p) {
  Deps d;
  for (const auto& r : p.random_rules) {
    auto& s = d.parents[r.attr.name];
    attrsOfBody(r.body, s);
    attrsOfBody(r.range_body, s);
  }
  for (const auto& pr : p.pr_atoms)
    if (!pr.body.empty()) attrsOfBody(pr.body, d.parents[pr.atom.attr.name]);
  for (const auto& r : p.rules)  // (facts have no parents: no entry, so n facts cost O(n))
    if (r.head && !r.body.empty()) attrsOfBody(r.body, d.parents[r.head->attr.name]);
  return d;
}

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
  std::vector<std::unordered_map<int, std::vector<int>>> pos_index;        // pos -> sym -> tuple
  bool add(const std::vector<int>& args, int value) {
    auto& vals = by_args[args];
    for (int v : vals)
      if (v == value) return false;
    vals.push_back(value);
    std::vector<int> t = args;
    t.push_back(value);
    int id = static_cast<int>(tuples.size());
    if (pos_index.size() < t.size()) pos_index.resize(t.size());
    for (size_t i = 0; i < t.size(); ++i) pos_index[i][t[i]].push_back(id);
    tuples.push_back(std::move(t));
    return true;
  }
};

// Thrown inside an incremental update that needs a full grounding.
struct NeedFullGrounding {};

constexpr int kRemovedStatement = 1 << 20;  // GPr::inactive of a removed statement's atoms

class Grounder {
 public:
  Grounder(const Program& p, GroundProgram& g) : prog_(p), g_(g) {
    g_.symbols = std::make_shared<SymbolTable>();
    syms_ = g_.symbols.get();
    for (size_t i = 0; i < p.attributes.size(); ++i) attr_index_[p.attributes[i].name] = int(i);
    for (size_t i = 0; i < p.sorts.size(); ++i) {
      sort_index_[p.sorts[i].name] = int(i);
      std::vector<int> vals;
      for (const auto& v : p.sorts[i].values) vals.push_back(syms_->intern(toString(v)));
      sort_vals_.push_back(vals);
    }
    true_ = syms_->intern("true");
    false_ = syms_->intern("false");
    facts_.resize(p.attributes.size());
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
    for (size_t a = 0; a < p.attributes.size(); ++a) {
      const AttributeDecl& d = p.attributes[a];
      auto it = sort_index_.find(d.range_sort);
      if (it != sort_index_.end()) attr_range_sort_[a] = it->second;
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
    auto it = attr_index_.find(n);
    return it == attr_index_.end() ? -1 : it->second;
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
        const int a = attrId(ap.first->atom.attr.name, ap.first->loc);
        if (!g_.attr_in_cone[static_cast<size_t>(a)]) continue;  // outside the grounding
        groundPrAtom(*ap.first, ap.second);
      }
    } catch (const NeedFullGrounding&) {
      return false;
    }
    return true;
  }

  void run(const std::set<std::string>& cone_names) {
    start_ = std::chrono::steady_clock::now();
    // Consistency-restoring rules make the possible worlds depend on a global minimisation
    // over all answer sets, which the native engine does not do.
    for (const auto& r : prog_.rules)
      if (r.consistency_restoring)
        throw OutsideFragmentError(r.loc.str() + ": consistency-restoring rule (':+') is outside "
                                   "the native reasoner's fragment (use the ASP back end)");
    for (const auto& r : prog_.random_rules)
      if (r.consistency_restoring)
        throw OutsideFragmentError(r.loc.str() + ": consistency-restoring rule (':+') is outside "
                                   "the native reasoner's fragment (use the ASP back end)");
    const size_t na = prog_.attributes.size();
    g_.attr_random.assign(na, false);
    g_.attr_dynamic.assign(na, false);
    g_.attr_in_cone.assign(na, false);
    for (const auto& r : prog_.random_rules) g_.attr_random[attrId(r.attr.name, r.loc)] = true;
    for (size_t i = 0; i < na; ++i) g_.attr_dynamic[i] = g_.attr_random[i];
    bool changed = true;
    while (changed) {
      changed = false;
      for (const auto& r : prog_.rules) {
        if (!r.head) continue;
        int h = attrId(r.head->attr.name, r.loc);
        if (g_.attr_dynamic[h]) continue;
        for (const auto& l : r.body)
          if (l.kind == Literal::Kind::Atom && g_.attr_dynamic[attrId(l.atom.attr.name, l.loc)]) {
            g_.attr_dynamic[h] = true;
            changed = true;
            break;
          }
      }
    }
    for (const auto& r : prog_.rules)
      if (r.head && g_.attr_random[attrId(r.head->attr.name, r.loc)])
        throw OutsideFragmentError(r.loc.str() + ": rule defining random attribute '" + r.head->attr.name +
                    "' is outside the native reasoner's fast path (use the ASP back end)");
    for (const auto& n : cone_names) {
      auto it = attr_index_.find(n);
      if (it != attr_index_.end()) g_.attr_in_cone[it->second] = true;
    }
    computeGuardAttributes();
    evaluateStatic();
    countGuardFacts();
    groundDynamic();
    g_.static_atoms.assign(na, {});
    for (size_t a = 0; a < na; ++a) {
      if (g_.attr_dynamic[a] || !g_.attr_in_cone[a]) continue;
      for (const auto& t : facts_[a].tuples) {
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
  int attrId(const std::string& n, const SourceLocation& loc) const {
    auto it = attr_index_.find(n);
    if (it == attr_index_.end())
      throw UnknownSymbolError(loc.str() + ": unknown attribute '" + n + "'");
    return it->second;
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
      c.attr = attrId(l.atom.attr.name, l.loc);
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
    const FactSet& f = facts_[static_cast<size_t>(attr)];
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
          const FactSet& f = facts_[static_cast<size_t>(l.attr)];
          if (args_bound && vb) {
            cost = 0;
          } else {
            cost = f.tuples.size();
            for (size_t p = 0; p <= l.args.size(); ++p) {
              const CTerm& t = p < l.args.size() ? l.args[p] : l.value;
              if (!bound(t, b)) continue;
              int v = evalTerm(t, b);
              size_t c = 0;
              if (p < f.pos_index.size()) {
                auto it = f.pos_index[p].find(v);
                if (it != f.pos_index[p].end()) c = it->second.size();
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
    const FactSet& f = facts_[static_cast<size_t>(l.attr)];
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
        if (static_cast<size_t>(best_pos) < f.pos_index.size()) {
          auto it = f.pos_index[best_pos].find(v);
          if (it != f.pos_index[best_pos].end()) cand = it->second;
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
    std::vector<char> done(s.lits.size(), 0);
    std::vector<int> b(s.slot_names.size(), -1);
    std::vector<GLit> acc;
    std::vector<int> origin;
    join(s, done, b, acc, origin, required, emit);
  }

  // ---- static evaluation ----
  void evaluateStatic() {
    const size_t na = prog_.attributes.size();
    // static rules grouped by head attribute; dependency graph among static attributes
    std::vector<std::vector<int>> rules_of(na);
    std::vector<std::vector<std::pair<int, bool>>> edges(na);  // head -> (body attr, negative)
    for (size_t r = 0; r < prog_.rules.size(); ++r) {
      const Rule& rule = prog_.rules[r];
      if (!rule.head) continue;
      int h = attrId(rule.head->attr.name, rule.loc);
      if (g_.attr_dynamic[h]) continue;
      rules_of[h].push_back(static_cast<int>(r));
      for (const auto& l : rule.body)
        if (l.kind == Literal::Kind::Atom)
          edges[h].push_back({attrId(l.atom.attr.name, l.loc), l.naf || l.negated});
    }
    // Needed static attributes: cone attributes and everything they depend on (edges into
    // dynamic attributes are not followed), grouped in strongly connected components,
    // dependencies first (scc.h: iterative, a 100000-rule chain is that deep).
    DependencyEdges statEdges(na);
    for (size_t a = 0; a < na; ++a)
      for (const auto& e : edges[a])
        if (!g_.attr_dynamic[e.first]) statEdges[a].push_back(e);
    std::vector<char> needed(na, 0);
    std::vector<int> todo;
    for (size_t a = 0; a < na; ++a)
      if (!g_.attr_dynamic[a] && g_.attr_in_cone[a]) needed[a] = 1, todo.push_back(static_cast<int>(a));
    while (!todo.empty()) {
      const int v = todo.back();
      todo.pop_back();
      for (const auto& e : statEdges[static_cast<size_t>(v)])
        if (!needed[static_cast<size_t>(e.first)]) needed[static_cast<size_t>(e.first)] = 1, todo.push_back(e.first);
    }
    int ncomp = 0;
    const std::vector<int> comp = stronglyConnectedComponents(statEdges, ncomp);
    std::vector<std::vector<int>> comps(static_cast<size_t>(ncomp));
    for (size_t a = 0; a < na; ++a)
      if (needed[a]) comps[static_cast<size_t>(comp[a])].push_back(static_cast<int>(a));
    for (const auto& c : comps) {
      if (c.empty()) continue;
      for (int a : c)
        for (auto& e : edges[a])
          if (e.second && !g_.attr_dynamic[e.first] && comp[e.first] == comp[a])
            throw OutsideFragmentError(prog_.attributes[a].loc.str() + ": attribute '" +
                        prog_.attributes[a].name +
                        "' depends on itself through negation (non-stratified); this is "
                        "outside the native reasoner's fast path (use the ASP back end)");
      bool recursive = c.size() > 1;
      for (int a : c)
        for (auto& e : edges[a])
          if (e.first == a) recursive = true;
      std::vector<Stmt> stmts;
      std::vector<const Rule*> srcs;
      for (int a : c)
        for (int r : rules_of[a]) {
          const Rule& rule = prog_.rules[static_cast<size_t>(r)];
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
          int h = attrId(rule.head->attr.name, rule.loc);
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
            FactSet& f = facts_[static_cast<size_t>(h)];
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
  }

  // ---- dynamic grounding ----
  void groundDynamic() {
    // random selection rules
    for (const auto& r : prog_.random_rules) {
      int a = attrId(r.attr.name, r.loc);
      if (!g_.attr_in_cone[a]) continue;
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
      std::vector<int> b(s.slot_names.size(), -1);
      std::vector<GLit> acc;
      std::vector<int> origin;
      join(s, done, b, acc, origin, required, [&](const std::vector<int>& bb,
                                                  const std::vector<GLit>& body,
                                                  const std::vector<int>&) {
        std::vector<int> args;
        for (const auto& t : hargs) {
          int v = evalTerm(t, bb);
          if (v < 0) return;
          args.push_back(v);
        }
        if (!argsInSorts(a, args)) return;
        int inst = instanceFor(a, args);
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
        if (range_slot < 0) return;
        // ground the dynamic range for this body binding
        std::vector<char> done2(s.lits.size(), 1);
        for (size_t i = nbody; i < s.lits.size(); ++i) done2[i] = 0;
        std::vector<int> b2 = bb;
        std::vector<GLit> acc2;
        std::vector<int> origin2;
        const int sel_index = it->second.second;
        join(s, done2, b2, acc2, origin2, {range_slot}, [&](const std::vector<int>& b3,
                                                            const std::vector<GLit>& cond,
                                                            const std::vector<int>&) {
          GInstance& gi = g_.instances[static_cast<size_t>(inst)];
          int vi = valueIdx(inst, b3[static_cast<size_t>(range_slot)]);
          if (vi >= 0) gi.selections[static_cast<size_t>(sel_index)].range.push_back({vi, cond});
        });
      });
    }
    // pr-atoms
    for (size_t i = 0; i < prog_.pr_atoms.size(); ++i) {
      const PrAtom& p = prog_.pr_atoms[i];
      int a = attrId(p.atom.attr.name, p.loc);
      if (!g_.attr_in_cone[a]) continue;
      groundPrAtom(p, pr_ids_ ? (*pr_ids_)[i] : static_cast<std::uint64_t>(i + 1));
    }
    // dynamic derived rules and constraints
    for (const auto& r : prog_.rules) {
      int h = -1;
      if (r.head) {
        h = attrId(r.head->attr.name, r.loc);
        if (!g_.attr_dynamic[h] || !g_.attr_in_cone[h]) continue;
      } else {
        bool touches = false;
        for (const auto& l : r.body)
          if (l.kind == Literal::Kind::Atom && g_.attr_in_cone[attrId(l.atom.attr.name, l.loc)])
            touches = true;
        if (!touches && !r.body.empty()) continue;
      }
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
      runJoin(s, required, [&](const std::vector<int>& b, const std::vector<GLit>& acc,
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
        std::vector<int> args;
        for (const auto& t : hargs) {
          int v = evalTerm(t, b);
          if (v < 0) return;
          args.push_back(v);
        }
        if (!argsInSorts(h, args)) return;
        int inst = instanceFor(h, args);
        GInstance& gi = g_.instances[static_cast<size_t>(inst)];
        int v = evalTerm(hval, b);
        int vi = v < 0 ? -1 : valueIdx(inst, v);
        if (vi < 0)
          throw UnknownSymbolError(r.loc.str() + ": value '" + (v < 0 ? "?" : syms_->text(v)) +
                                   "' is not in the range of " + gi.name);
        gi.rules.push_back({vi, acc});
        ++g_.ground_statements;
        if (!gi.random) ++g_.derived_rules;
        spend(0, 1);
      });
    }
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
    int a = attrId(p.atom.attr.name, p.loc);
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
    runJoin(s, required, [&](const std::vector<int>& b, const std::vector<GLit>& acc,
                             const std::vector<int>&) {
      std::vector<int> args;
      for (const auto& t : hargs) {
        int v = evalTerm(t, b);
        if (v < 0) return;
        args.push_back(v);
      }
      if (!argsInSorts(a, args)) return;
      int inst = instanceFor(a, args);
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
    });
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
    auto off = [&](const std::string& n) {
      auto it = attr_index_.find(n);
      if (it != attr_index_.end()) guard_attr_[static_cast<size_t>(it->second)] = 0;
    };
    auto offBody = [&](const std::vector<Literal>& body) {
      for (const auto& l : body)
        if (l.kind == Literal::Kind::Atom) off(l.atom.attr.name);
    };
    for (const auto& r : prog_.rules) {
      if (r.head) {
        bool ground = r.head->value.isGround();
        for (const auto& t : r.head->attr.args) ground = ground && t.isGround();
        if (!r.body.empty() || !ground) off(r.head->attr.name);
      }
      offBody(r.body);
    }
    for (const auto& r : prog_.random_rules) {
      offBody(r.body);
      offBody(r.range_body);
    }
    for (const auto& p : prog_.pr_atoms)
      for (const auto& l : p.body)
        if (l.kind == Literal::Kind::Atom && !(l.naf && !l.negated)) off(l.atom.attr.name);
  }

  // Multiplicity of each guard fact (the same fact may be stated twice).
  void countGuardFacts() {
    for (const auto& r : prog_.rules) {
      if (!r.head || !r.body.empty()) continue;
      const int a = attrIndexOf(r.head->attr.name);
      if (!isGuard(a)) continue;
      ++fact_count_[factKey(a, *r.head)];
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
    const int a = attrIndexOf(r.head->attr.name);
    if (!isGuard(a)) return false;
    bool ground = r.head->value.isGround();
    for (const auto& t : r.head->attr.args) ground = ground && t.isGround();
    if (!ground) return false;
    const std::vector<int> key = factKey(a, *r.head);
    int& count = fact_count_[key];
    const int before = count;
    count += delta;
    if (count < 0) return false;  // removing a fact that was never counted
    if ((before > 0) == (count > 0)) return true;  // truth unchanged
    const std::vector<int> args(key.begin() + 1, key.end() - 1);
    const int value = key.back();
    FactSet& f = facts_[static_cast<size_t>(a)];
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
  std::unordered_map<std::string, int> attr_index_;
  std::unordered_map<std::string, int> sort_index_;
  std::vector<std::vector<int>> sort_vals_;
  std::vector<FactSet> facts_;
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

std::set<std::string> relevanceCone(const Program& program, const std::set<std::string>& names) {
  Deps d = dependencies(program);
  std::set<std::string> cone;
  std::vector<std::string> work(names.begin(), names.end());
  auto close = [&]() {
    while (!work.empty()) {
      std::string a = work.back();
      work.pop_back();
      if (!cone.insert(a).second) continue;
      auto it = d.parents.find(a);
      if (it == d.parents.end()) continue;
      for (const auto& p : it->second)
        if (!cone.count(p)) work.push_back(p);
    }
  };
  close();
  // Rules outside the query's dependencies can still change the set of possible worlds: a
  // loop through default negation (odd: `e :- not e.` removes worlds; even: `b :- not c.
  // c :- not b.` splits one into several) and a random selection over a dynamic range (a
  // world where the range is empty has no answer set). Their attributes join every cone, so
  // the native engine either handles them exactly (locally stratified ground rules, ranges
  // that are never empty) or refuses the program as outside its fragment.
  for (const auto& a : worldChangingAttributes(program))
    if (!cone.count(a)) work.push_back(a);
  close();
  // Constraints, and derived attributes that may get two values in a world (an inconsistency),
  // act as evidence: a world violating them is not a possible world. Even when independent of
  // the query they matter if they can never be satisfied (then the program has no possible
  // world at all), so they are always part of the cone.
  std::set<std::string> random_attrs;
  for (const auto& r : program.random_rules) random_attrs.insert(r.attr.name);
  // derived attribute -> (first head value, may it get two values: two values or a variable)
  std::unordered_map<std::string, std::pair<std::string, bool>> head_values;
  for (const auto& r : program.rules) {
    if (!r.head || random_attrs.count(r.head->attr.name)) continue;
    const bool var = r.head->value.kind == Term::Kind::Variable;
    const std::string v = var ? std::string() : toString(r.head->value);
    auto it = head_values.find(r.head->attr.name);
    if (it == head_values.end()) head_values.emplace(r.head->attr.name, std::make_pair(v, var));
    else if (var || it->second.first != v) it->second.second = true;
  }
  bool changed = true;
  while (changed) {
    changed = false;
    for (const auto& r : program.rules) {
      if (r.head) continue;
      std::set<std::string> as;
      attrsOfBody(r.body, as);
      bool all = true;
      for (const auto& a : as)
        if (!cone.count(a)) all = false;
      if (all) continue;
      for (const auto& a : as)
        if (!cone.count(a)) work.push_back(a);
      close();
      changed = true;
    }
    for (const auto& hv : head_values) {
      if (cone.count(hv.first)) continue;
      if (!hv.second.second) continue;
      work.push_back(hv.first);
      close();
      changed = true;
    }
  }
  return cone;
}

GroundProgram groundProgram(const Program& program, const std::set<std::string>& cone_attributes,
                            const GroundingLimits& limits) {
  GroundProgram g;
  Grounder gr(program, g);
  gr.setLimits(limits);
  gr.run(relevanceCone(program, cone_attributes));
  return g;
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
    : ground_(std::make_shared<GroundProgram>()) {
  impl_ = std::make_unique<Impl>(program, *ground_);
  impl_->grounder.setLimits(limits);
  impl_->grounder.setPrIds(pr_ids);
  impl_->grounder.run(relevanceCone(program, cone_attributes));
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
