/**
 * @file grounder_join.cpp
 * @brief Grounder: evaluating compiled terms and literals under a binding and joining a
 * statement's literals over the fact store (the bindings that satisfy its static part), with
 * the grounding budgets and the ground instances the joins create.
 */
#include <algorithm>
#include <chrono>
#include <limits>
#include <string>
#include <vector>

#include "krr_core/plog/arith.h"

#include "grounder_internal.h"

namespace krr {
namespace plog {
namespace grounder_detail {

int Grounder::evalTerm(const CTerm& t, const std::vector<int>& b) {
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

void Grounder::overflow(const CTerm& t) const {
  const SourceLocation loc = t.src ? t.src->loc : cur_loc_;
  throw ParseError(loc, "integer overflow in '" + (t.src ? toString(*t.src) : t.op) +
                            "' while grounding the statement at " + cur_loc_.str());
}

void Grounder::spend(std::size_t atoms, std::size_t statements) {
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

bool Grounder::compare(CompareOp op, int a, int c) const {
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

bool Grounder::staticAtom(int attr, const std::vector<int>& args, int value, bool neg) const {
  const FactSet& f = factsOf(attr);
  auto it = f.by_args.find(args);
  if (it == f.by_args.end()) return false;
  bool has = std::find(it->second.begin(), it->second.end(), value) != it->second.end();
  if (!neg) return has;
  for (int v : it->second)
    if (v != value) return true;
  return false;
}

std::string Grounder::instanceName(int attr, const std::vector<int>& args) const {
  std::string s = prog_.attributes[static_cast<size_t>(attr)].name;
  if (!args.empty()) {
    s += "(";
    for (size_t i = 0; i < args.size(); ++i) s += (i ? "," : "") + syms_->text(args[i]);
    s += ")";
  }
  return s;
}

int Grounder::instanceFor(int attr, const std::vector<int>& args) {
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

void Grounder::join(Stmt& s, std::vector<char>& done, std::vector<int>& b, std::vector<GLit>& acc,
                    std::vector<int>& acc_origin, const std::vector<int>& required, const Emit& emit) {
  JoinState j{s, done, b, acc, acc_origin, required, emit};
  joinStep(j);
}

void Grounder::joinStep(JoinState& j) {
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

int Grounder::chooseLiteral(const Stmt& s, const std::vector<char>& done, const std::vector<int>& b,
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

void Grounder::bindFromSort(JoinState& j) {
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

void Grounder::joinComparison(JoinState& j, const CLit& l) {
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

void Grounder::joinDynamic(JoinState& j, const CLit& l) {
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

void Grounder::joinStatic(JoinState& j, const CLit& l, int best_pos) {
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

void Grounder::runJoin(Stmt& s, const std::vector<int>& required, const Emit& emit) {
  std::vector<int> b(s.slot_names.size(), -1);
  runJoinFrom(s, b, required, emit);
}

void Grounder::runJoinFrom(Stmt& s, std::vector<int>& b, const std::vector<int>& required,
                           const Emit& emit) {
  std::vector<char> done(s.lits.size(), 0);
  std::vector<GLit> acc;
  std::vector<int> origin;
  join(s, done, b, acc, origin, required, emit);
}

bool Grounder::argsInSorts(int attr, const std::vector<int>& args) const {
  const AttributeDecl& d = prog_.attributes[static_cast<size_t>(attr)];
  const std::vector<int>& sorts = attr_arg_sorts_[static_cast<size_t>(attr)];
  for (size_t i = 0; i < args.size() && i < sorts.size(); ++i) {
    if (sorts[i] == -1) continue;
    if (sorts[i] == -2) sortValues(d.arg_sorts[i], d.loc);  // throws: unknown sort
    if (posInSort(sorts[i], args[i]) < 0) return false;
  }
  return true;
}

}  // namespace grounder_detail
}  // namespace plog
}  // namespace krr
