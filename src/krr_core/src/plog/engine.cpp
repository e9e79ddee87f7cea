#include "krr_core/plog/engine.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <sstream>

#include "scc.h"

namespace krr {
namespace plog {

namespace {
constexpr size_t kMaxFactor = size_t(1) << kMaxFactorLog2;
/// @brief Probability sums off by more than this (relative to 1) are errors; within it they
/// are rounding and are renormalised (with a warning, see ExactEngine::warnings).
constexpr double kSumTolerance = 1e-9;
/// @brief Per assigned value, the floating-point noise of adding exact decimals (0.1 + 0.2 +
/// 0.7 = 1 + 2.2e-16): sums within it of 1 are kept as written, without a warning.
constexpr double kSumNoise = 8 * 2.220446049250313e-16;

/// @brief The pr-atoms that assign the values of gi in one row, as " file:line:col" each.
std::string assigningAtoms(const GInstance& gi, const std::vector<double>& assigned,
                           const std::vector<int>& assigned_by, size_t nv) {
  std::string at;
  for (size_t k = 0; k < nv; ++k)
    if (assigned[k] >= 0) at += " " + gi.prs[static_cast<size_t>(assigned_by[k])].loc.str();
  return at;
}

/// @brief The one rule for probability sums (the .pomdp reader's, checkDistributionSum): off by
/// more than rounding (kSumTolerance) is an error naming the pr-atoms, above 1 or, when every
/// possible value is assigned, below 1 (the mass would be lost, not given to other values);
/// within it, but more than the noise of adding exact decimals, the assigned probabilities are
/// renormalised and the repair is reported in warnings.
/// @return the sum after any renormalisation. @throws IncoherentError
double checkProbabilitySum(const GInstance& gi, std::vector<double>& assigned,
                           const std::vector<int>& assigned_by, size_t nv, bool all_assigned,
                           double sum, int nassigned, std::vector<std::string>& warnings) {
  const double dev = std::fabs(sum - 1.0);
  if ((sum > 1.0 || all_assigned) && dev > kSumNoise * nassigned && dev <= kSumTolerance) {
    std::ostringstream os;
    os.precision(17);
    for (size_t k = 0; k < nv; ++k)
      if (assigned[k] >= 0) {
        os << gi.prs[static_cast<size_t>(assigned_by[k])].loc.str() << ": warning: ";
        break;
      }
    os << "probabilities assigned to the values of " << gi.name << " sum to " << sum
       << ", within rounding of 1: renormalised (pr-atoms at"
       << assigningAtoms(gi, assigned, assigned_by, nv) << ")";
    if (std::find(warnings.begin(), warnings.end(), os.str()) == warnings.end())
      warnings.push_back(os.str());
    for (size_t k = 0; k < nv; ++k)
      if (assigned[k] >= 0) assigned[k] /= sum;
    return 1.0;
  }
  if (sum > 1.0 + kSumTolerance || (all_assigned && sum < 1.0 - kSumTolerance)) {
    std::ostringstream os;
    os << "probabilities assigned to " << (sum > 1.0 ? "the values" : "all the possible values")
       << " of " << gi.name << " sum to " << sum << (sum > 1.0 ? " > 1" : " < 1")
       << " in a possible world (pr-atoms at" << assigningAtoms(gi, assigned, assigned_by, nv)
       << ")";
    throw IncoherentError(os.str());
  }
  return sum;
}
}  // namespace

ExactEngine::ExactEngine(const GroundProgram& g) : g_(g) {
  const size_t n = g.instances.size();
  fixed_.assign(n, -1);
  assign_.assign(n, -1);
  atom_offset_.resize(n + 1);
  int off = 0;
  for (size_t i = 0; i < n; ++i) {
    atom_offset_[i] = off;
    off += static_cast<int>(g.instances[i].domain.size());
  }
  atom_offset_[n] = off;
  atom_stamp_.assign(static_cast<size_t>(off), 0);
  atom_state_.assign(static_cast<size_t>(off), 0);
  scope_stamp_.assign(n, 0);
  scope_cache_.resize(n);
  scope_busy_.assign(n, 0);
  rel_stamp_.assign(n, 0);
  cond_pos_.assign(n, -1);
  states_.resize(n);
  live_rules_.resize(n);
  live_stamp_.assign(n, 0);
  live_cache_.resize(n);
  buildAtomSccs();
  for (size_t i = 0; i < n; ++i) {
    const GInstance& gi = g.instances[i];
    if (gi.random) {
      // Only ranges that may be empty matter: one with an unconditional value (a static
      // fact such as nbr(C, C)) is never empty.
      bool may_be_empty = false;
      for (const auto& sel : gi.selections) {
        if (!sel.dynamic_range) continue;
        bool always = false;
        for (const auto& r : sel.range) always = always || r.second.empty();
        may_be_empty = may_be_empty || !always;
      }
      if (may_be_empty) dynamic_range_.push_back(static_cast<int>(i));
      continue;
    }
    for (const auto& r : gi.rules)
      if (r.first != gi.rules[0].first) {
        conflict_derived_.push_back(static_cast<int>(i));
        break;
      }
  }
}

void ExactEngine::setFixed(int inst, int value) { fixed_[static_cast<size_t>(inst)] = value; }

void ExactEngine::clearFixed() { std::fill(fixed_.begin(), fixed_.end(), -1); }

int ExactEngine::card(int inst) const {
  return static_cast<int>(states_[static_cast<size_t>(inst)].size());
}

void ExactEngine::computeStates(int inst) {
  const GInstance& gi = g_.instances[static_cast<size_t>(inst)];
  const int D = static_cast<int>(gi.domain.size());
  std::vector<int>& st = states_[static_cast<size_t>(inst)];
  st.clear();
  const std::vector<Item>& items = liveItemsCached(inst);
  bool full = false;
  for (const auto& it : items) {
    if (it.kind != 0) continue;
    const GSelection& sel = gi.selections[static_cast<size_t>(it.index)];
    if (!sel.dynamic_range) {
      full = true;
      break;
    }
    for (const auto& r : sel.range) st.push_back(r.first);
  }
  if (full) {
    st.resize(static_cast<size_t>(D));
    for (int v = 0; v < D; ++v) st[static_cast<size_t>(v)] = v;
  } else {
    std::sort(st.begin(), st.end());
    st.erase(std::unique(st.begin(), st.end()), st.end());
  }
  // "undefined" is a state unless some selection rule always applies in this context
  // (its body is empty or made of literals on do()-fixed instances that hold).
  bool always = false;
  for (const auto& it : items) {
    if (it.kind != 0) continue;
    bool all_fixed = true;
    for (const auto& l : gi.selections[static_cast<size_t>(it.index)].body)
      if (fixed_[static_cast<size_t>(l.inst)] < 0) all_fixed = false;
    if (all_fixed) always = true;  // live, so its fixed literals hold
  }
  if (!always) st.push_back(D);  // undefined
  if (st.empty()) {
    // A selection rule applies in every world of this context and no value is ever possible:
    // without this check the factor would have zero states (and zero rows: a division by zero).
    for (const auto& it : items)
      if (it.kind == 0)
        throw IncoherentError(gi.selections[static_cast<size_t>(it.index)].loc.str() +
                              ": random attribute " + gi.name +
                              " has an empty dynamic range in every possible world where its "
                              "selection rule applies");
    throw IncoherentError("random attribute " + gi.name + " has no possible value");
  }
}

void ExactEngine::setTimeBudget(double seconds) {
  budget_seconds_ = seconds;
  budget_start_ = std::chrono::steady_clock::now();
}

void ExactEngine::setMemoryBudget(std::size_t bytes, const SourceLocation& where) {
  memory_ = std::make_shared<MemoryGuard>(bytes);
  memory_where_ = where;
}

void ExactEngine::checkMemory(std::size_t bytes) const {
  if (memory_) memory_->check("filling the inference tables", memory_where_, bytes);
}

void ExactEngine::checkTime(unsigned mask) {
  if ((++budget_ticks_ & mask) != 0) return;
  if (memory_ && (budget_ticks_ & 65535u) == 0) checkMemory(0);
  if (cancel_ && cancel_->load(std::memory_order_relaxed))
    throw CancelledError("inference abandoned: another back end answered first");
  if (budget_seconds_ <= 0) return;
  if (std::chrono::duration<double>(std::chrono::steady_clock::now() - budget_start_).count() >
      budget_seconds_)
    throw BudgetExceededError("inference time budget of " + std::to_string(budget_seconds_) +
                              " s exhausted (GroundingLimits::max_inference_seconds)");
}

void ExactEngine::newStamp() {
  ++stamp_;
  if (stamp_ == 0) {
    std::fill(atom_stamp_.begin(), atom_stamp_.end(), 0);
    stamp_ = 1;
  }
}

int ExactEngine::valueOf(int inst) {
  int f = fixed_[static_cast<size_t>(inst)];
  if (f >= 0) return f;
  const GInstance& gi = g_.instances[static_cast<size_t>(inst)];
  const int undef = static_cast<int>(gi.domain.size());
  if (gi.random) {
    int a = assign_[static_cast<size_t>(inst)];
    return a < 0 ? undef : a;
  }
  for (int v = 0; v < undef; ++v)
    if (atomHolds(inst, v)) return v;
  return undef;
}

bool ExactEngine::atomHolds(int inst, int value) {
  const GInstance& gi = g_.instances[static_cast<size_t>(inst)];
  if (gi.random || fixed_[static_cast<size_t>(inst)] >= 0) return valueOf(inst) == value;
  size_t k = static_cast<size_t>(atom_offset_[static_cast<size_t>(inst)] + value);
  if (atom_stamp_[k] == stamp_) {
    if (atom_state_[k] == 2)
      throw OutsideFragmentError("atom " + gi.name + "=" + g_.symbols->text(gi.domain[static_cast<size_t>(value)]) +
                  " depends on itself (cyclic rules); this is outside the native reasoner's "
                  "fast path (use the ASP back end)");
    return atom_state_[k] == 1;
  }
  if (atom_scc_[k] >= 0) {
    evaluateScc(atom_scc_[k]);
    return atom_state_[k] == 1;
  }
  atom_stamp_[k] = stamp_;
  atom_state_[k] = 2;
  bool r = false;
  if (scope_stamp_[static_cast<size_t>(inst)] == rel_counter_) {
    for (int ri : live_rules_[static_cast<size_t>(inst)]) {
      const auto& rule = gi.rules[static_cast<size_t>(ri)];
      if (rule.first == value && bodyHolds(rule.second)) {
        r = true;
        break;
      }
    }
  } else {
    for (const auto& rule : gi.rules) {
      if (rule.first != value) continue;
      if (bodyHolds(rule.second)) {
        r = true;
        break;
      }
    }
  }
  atom_state_[k] = r ? 1 : 0;
  return r;
}

void ExactEngine::evaluateScc(int c) {
  const std::vector<int>& atoms = scc_atoms_[static_cast<size_t>(c)];
  if (scc_negative_[static_cast<size_t>(c)]) {
    int a = atoms[0];
    const GInstance& gi = g_.instances[static_cast<size_t>(atom_inst_[static_cast<size_t>(a)])];
    throw OutsideFragmentError("atom " + gi.name + "=" +
                g_.symbols->text(gi.domain[static_cast<size_t>(a - atom_offset_[static_cast<size_t>(
                                                                     atom_inst_[static_cast<size_t>(a)])])]) +
                " depends on itself through negation (non-stratified, cyclic rules); this is "
                "outside the native reasoner's fast path (use the ASP back end)");
  }
  // least fixpoint of a positive cycle: all members start false
  for (int a : atoms) {
    atom_stamp_[static_cast<size_t>(a)] = stamp_;
    atom_state_[static_cast<size_t>(a)] = 0;
  }
  bool changed = true;
  while (changed) {
    changed = false;
    for (int a : atoms) {
      if (atom_state_[static_cast<size_t>(a)] == 1) continue;
      int inst = atom_inst_[static_cast<size_t>(a)];
      int value = a - atom_offset_[static_cast<size_t>(inst)];
      for (const auto& rule : g_.instances[static_cast<size_t>(inst)].rules) {
        if (rule.first != value || bodyDead(rule.second)) continue;
        if (bodyHolds(rule.second)) {
          atom_state_[static_cast<size_t>(a)] = 1;
          changed = true;
          break;
        }
      }
    }
  }
}

void ExactEngine::buildAtomSccs() {
  const size_t na = atom_state_.size();
  atom_inst_.assign(na, 0);
  for (size_t i = 0; i < g_.instances.size(); ++i)
    for (int k = atom_offset_[i]; k < atom_offset_[i + 1]; ++k) atom_inst_[static_cast<size_t>(k)] = static_cast<int>(i);
  // dependency edges between atoms of derived instances: (target atom, negative?)
  std::vector<std::vector<std::pair<int, bool>>> edges(na);
  for (size_t i = 0; i < g_.instances.size(); ++i) {
    const GInstance& gi = g_.instances[i];
    if (gi.random) continue;
    for (const auto& r : gi.rules) {
      size_t from = static_cast<size_t>(atom_offset_[i] + r.first);
      for (const auto& l : r.second) {
        const GInstance& t = g_.instances[static_cast<size_t>(l.inst)];
        if (t.random) continue;
        int D = static_cast<int>(t.domain.size());
        for (int v = 0; v < D; ++v) {
          bool dep = l.neg ? v != l.value : v == l.value;
          if (dep) edges[from].push_back({atom_offset_[static_cast<size_t>(l.inst)] + v, l.naf});
        }
      }
    }
  }
  atom_scc_.assign(na, -1);
  int ncomp = 0;
  const std::vector<int> comp = stronglyConnectedComponents(edges, ncomp);
  std::vector<std::vector<int>> members(static_cast<size_t>(ncomp));
  for (size_t a = 0; a < na; ++a)
    if (!edges[a].empty()) members[static_cast<size_t>(comp[a])].push_back(static_cast<int>(a));
  for (int c = 0; c < ncomp; ++c) {
    const std::vector<int>& m = members[static_cast<size_t>(c)];
    if (m.empty()) continue;  // atoms without dependencies are on no cycle
    bool cyclic = m.size() > 1;
    bool negative = false;
    for (int a : m)
      for (const auto& e : edges[static_cast<size_t>(a)])
        if (comp[static_cast<size_t>(e.first)] == c) {
          cyclic = true;  // a self-loop, or an edge inside a larger component
          negative = negative || e.second;
        }
    if (!cyclic) continue;
    const int id = static_cast<int>(scc_atoms_.size());
    for (int a : m) atom_scc_[static_cast<size_t>(a)] = id;
    scc_atoms_.push_back(m);
    scc_negative_.push_back(negative ? 1 : 0);
  }
  // A loop through `not` anywhere in the grounding (every attribute on such a loop is in the
  // cone, see relevanceCone) removes or splits possible worlds whether or not the query reads
  // it: refuse the program as outside the fragment before answering anything.
  for (size_t c = 0; c < scc_negative_.size(); ++c)
    if (scc_negative_[c]) evaluateScc(static_cast<int>(c));
}

bool ExactEngine::holds(const GLit& l) {
  const GInstance& gi = g_.instances[static_cast<size_t>(l.inst)];
  const int undef = static_cast<int>(gi.domain.size());
  bool r;
  if (gi.random || fixed_[static_cast<size_t>(l.inst)] >= 0) {
    int v = valueOf(l.inst);
    if (l.neg) r = v < undef && v != l.value;
    else r = l.value >= 0 && v == l.value;
  } else if (l.neg) {
    r = false;
    for (int v = 0; v < undef && !r; ++v)
      if (v != l.value && atomHolds(l.inst, v)) r = true;
  } else {
    r = l.value >= 0 && atomHolds(l.inst, l.value);
  }
  return l.naf ? !r : r;
}

bool ExactEngine::bodyHolds(const std::vector<GLit>& body) {
  for (const auto& l : body)
    if (!holds(l)) return false;
  return true;
}

bool ExactEngine::litDeadFixed(const GLit& l) const {
  int f = fixed_[static_cast<size_t>(l.inst)];
  if (f < 0) return false;
  const int undef = static_cast<int>(g_.instances[static_cast<size_t>(l.inst)].domain.size());
  bool r = l.neg ? (f < undef && f != l.value) : (l.value >= 0 && f == l.value);
  if (l.naf) r = !r;
  return !r;
}

bool ExactEngine::bodyDead(const std::vector<GLit>& body) const {
  for (const auto& l : body)
    if (litDeadFixed(l)) return true;
  return false;
}

namespace {

/// The conditioning literal that keys a body: its positive literal on a conditioning instance
/// with the largest domain (the most selective), or nullptr.
const GLit* keyLiteral(const GroundProgram& g, const std::vector<int>& cond_pos,
                       const std::vector<GLit>& body) {
  const GLit* best = nullptr;
  size_t best_size = 0;
  for (const auto& l : body) {
    int k = cond_pos[static_cast<size_t>(l.inst)];
    if (k >= 0 && !l.naf && !l.neg && l.value >= 0) {
      size_t sz = g.instances[static_cast<size_t>(l.inst)].domain.size();
      if (!best || sz > best_size) {
        best = &l;
        best_size = sz;
      }
    }
  }
  return best;
}

/// [first, last) of the entries of `v` (sorted by (k, value)) with this k and value.
template <class E>
std::pair<typename std::vector<E>::const_iterator, typename std::vector<E>::const_iterator>
keyedRange(const std::vector<E>& v, int k, int value) {
  return std::equal_range(v.begin(), v.end(), E{k, value, {}}, [](const E& a, const E& b) {
    return a.k != b.k ? a.k < b.k : a.value < b.value;
  });
}

}  // namespace

void ExactEngine::indexBy(const std::vector<int>& conditioning) {
  indexed_ = true;
  index_inst_ = conditioning;
  std::fill(cond_pos_.begin(), cond_pos_.end(), -1);
  for (size_t k = 0; k < conditioning.size(); ++k)
    cond_pos_[static_cast<size_t>(conditioning[k])] = static_cast<int>(k);
  const size_t n = g_.instances.size();
  index_has_.assign(n, 0);
  keyed_.assign(n, {});
  unkeyed_.assign(n, {});
  rule_keyed_.assign(n, {});
  rule_unkeyed_.assign(n, {});
  auto byKey = [](const auto& a, const auto& b) {
    return a.k != b.k ? a.k < b.k : a.value < b.value;
  };
  for (size_t i = 0; i < n; ++i) {
    const GInstance& gi = g_.instances[i];
    if (gi.random || gi.rules.empty()) continue;
    index_has_[i] = 1;
    for (size_t ri = 0; ri < gi.rules.size(); ++ri) {
      if (const GLit* best = keyLiteral(g_, cond_pos_, gi.rules[ri].second))
        rule_keyed_[i].push_back({cond_pos_[static_cast<size_t>(best->inst)], best->value,
                                  static_cast<int>(ri)});
      else
        rule_unkeyed_[i].push_back(static_cast<int>(ri));
    }
    std::stable_sort(rule_keyed_[i].begin(), rule_keyed_[i].end(), byKey);
  }
  for (size_t i = 0; i < n; ++i) {
    const GInstance& gi = g_.instances[i];
    if (!gi.random) continue;
    index_has_[i] = 1;
    // key each body by its most selective literal on a conditioning instance
    auto place = [&](const std::vector<GLit>& body, Item it) {
      if (const GLit* best = keyLiteral(g_, cond_pos_, body))
        keyed_[i].push_back({cond_pos_[static_cast<size_t>(best->inst)], best->value, it});
      else
        unkeyed_[i].push_back(it);
    };
    for (size_t s = 0; s < gi.selections.size(); ++s)
      place(gi.selections[s].body, Item{0, static_cast<int>(s)});
    for (size_t p = 0; p < gi.prs.size(); ++p)
      if (gi.prs[p].inactive == 0) place(gi.prs[p].body, Item{1, static_cast<int>(p)});
    std::stable_sort(keyed_[i].begin(), keyed_[i].end(), byKey);
  }
}

const std::vector<ExactEngine::Item>& ExactEngine::liveItemsCached(int inst) {
  // The live items of an instance depend only on the do()-fixed values, which do not change
  // during one inference (epoch rel_counter_).
  const size_t i = static_cast<size_t>(inst);
  if (live_stamp_[i] != rel_counter_) {
    liveItems(inst, live_cache_[i]);
    live_stamp_[i] = rel_counter_;
  }
  return live_cache_[i];
}

void ExactEngine::liveItems(int inst, std::vector<Item>& out) const {
  out.clear();
  const GInstance& gi = g_.instances[static_cast<size_t>(inst)];
  auto consider = [&](const Item& it) {
    const std::vector<GLit>& body =
        it.kind == 0 ? gi.selections[static_cast<size_t>(it.index)].body
                     : gi.prs[static_cast<size_t>(it.index)].body;
    if (!bodyDead(body)) out.push_back(it);
  };
  if (indexed_ && index_has_[static_cast<size_t>(inst)]) {
    for (const auto& it : unkeyed_[static_cast<size_t>(inst)]) consider(it);
    const auto& keyed = keyed_[static_cast<size_t>(inst)];
    for (size_t k = 0; k < index_inst_.size(); ++k) {
      int f = fixed_[static_cast<size_t>(index_inst_[k])];
      if (f >= 0) {
        const auto r = keyedRange(keyed, static_cast<int>(k), f);
        for (auto e = r.first; e != r.second; ++e) consider(e->item);
      } else {
        for (const auto& e : keyed)
          if (e.k == static_cast<int>(k)) consider(e.item);
      }
    }
    // keep the program order: selection rules first, then pr-atoms, each by index
    std::sort(out.begin(), out.end(), [](const Item& a, const Item& b) {
      return a.kind != b.kind ? a.kind < b.kind : a.index < b.index;
    });
    return;
  }
  for (size_t s = 0; s < gi.selections.size(); ++s) consider(Item{0, static_cast<int>(s)});
  for (size_t p = 0; p < gi.prs.size(); ++p)
    if (gi.prs[p].inactive == 0) consider(Item{1, static_cast<int>(p)});
}

void ExactEngine::scopeOfLit(const GLit& l, std::vector<int>& out) {
  if (fixed_[static_cast<size_t>(l.inst)] >= 0) return;
  const GInstance& gi = g_.instances[static_cast<size_t>(l.inst)];
  if (gi.random) {
    out.push_back(l.inst);
    return;
  }
  scopeOfInstance(l.inst, out);
}

void ExactEngine::scopeOfInstance(int inst, std::vector<int>& out) {
  size_t i = static_cast<size_t>(inst);
  if (fixed_[i] >= 0) return;
  if (g_.instances[i].random) {
    out.push_back(inst);
    return;
  }
  if (scope_stamp_[i] != rel_counter_) {
    if (scope_busy_[i]) return;  // cycle: its scope is being collected further up
    scope_busy_[i] = 1;
    std::vector<int> s;
    std::vector<int> live;
    const auto& rules = g_.instances[i].rules;
    auto consider = [&](size_t ri) {
      if (bodyDead(rules[ri].second)) return;
      live.push_back(static_cast<int>(ri));
      for (const auto& l : rules[ri].second) scopeOfLit(l, s);
    };
    if (indexed_ && index_has_[i]) {
      for (int ri : rule_unkeyed_[i]) consider(static_cast<size_t>(ri));
      const auto& keyed = rule_keyed_[i];
      for (size_t k = 0; k < index_inst_.size(); ++k) {
        int f = fixed_[static_cast<size_t>(index_inst_[k])];
        if (f >= 0) {
          const auto r = keyedRange(keyed, static_cast<int>(k), f);
          for (auto e = r.first; e != r.second; ++e) consider(static_cast<size_t>(e->item));
        } else {
          for (const auto& e : keyed)
            if (e.k == static_cast<int>(k)) consider(static_cast<size_t>(e.item));
        }
      }
      std::sort(live.begin(), live.end());
    } else {
      for (size_t ri = 0; ri < rules.size(); ++ri) consider(ri);
    }
    live_rules_[i] = std::move(live);
    std::sort(s.begin(), s.end());
    s.erase(std::unique(s.begin(), s.end()), s.end());
    scope_busy_[i] = 0;
    scope_cache_[i] = s;
    scope_stamp_[i] = rel_counter_;
    touched_derived_.push_back(inst);
  }
  out.insert(out.end(), scope_cache_[i].begin(), scope_cache_[i].end());
}

void ExactEngine::scopeOfItems(int inst, std::vector<int>& out) {
  const GInstance& gi = g_.instances[static_cast<size_t>(inst)];
  for (const auto& it : liveItemsCached(inst)) {
    if (it.kind == 0) {
      const GSelection& sel = gi.selections[static_cast<size_t>(it.index)];
      for (const auto& l : sel.body) scopeOfLit(l, out);
      for (const auto& r : sel.range)
        for (const auto& l : r.second) scopeOfLit(l, out);
    } else {
      for (const auto& l : gi.prs[static_cast<size_t>(it.index)].body) scopeOfLit(l, out);
    }
  }
}

/// @brief buildCpt's state for the rows of one instance's table: where each value's state is
/// and, per row, which values are possible and which pr-atom assigned each (the vectors are
/// reused from row to row, so a row allocates nothing).
struct ExactEngine::CptRow {
  CptRow(const std::vector<int>& xs, int domain_size)
      : states(xs.size()), has_undef(!xs.empty() && xs.back() == domain_size),
        nv(has_undef ? states - 1 : states), pos_of(static_cast<size_t>(domain_size), -1),
        possible(states), assigned(states), assigned_by(states) {
    for (size_t k = 0; k < nv; ++k) pos_of[static_cast<size_t>(xs[k])] = static_cast<int>(k);
  }
  size_t states;                ///< states of the instance (its values, then "undefined")
  bool has_undef;               ///< the last state is "undefined"
  size_t nv;                    ///< number of value states
  std::vector<int> pos_of;      ///< value index -> its state, -1 when not a state
  std::vector<char> possible;   ///< per state: possible in this row
  std::vector<double> assigned;  ///< per state: assigned probability, -1 when none
  std::vector<int> assigned_by;  ///< per state: the pr-atom that assigned it
  double* out = nullptr;        ///< the row's entries in the table
};

std::vector<int> ExactEngine::cptParents(int inst) {
  std::vector<int> parents;
  scopeOfItems(inst, parents);
  std::sort(parents.begin(), parents.end());
  parents.erase(std::unique(parents.begin(), parents.end()), parents.end());
  if (std::binary_search(parents.begin(), parents.end(), inst))
    throw OutsideFragmentError("random attribute " + g_.instances[static_cast<size_t>(inst)].name +
                " depends on itself (cyclic pr-atom or selection "
                "rule); this is outside the native reasoner's fast path (use the ASP back end)");
  return parents;
}

size_t ExactEngine::cptScope(int inst, const std::vector<int>& parents, Factor& f) {
  const size_t S = states_[static_cast<size_t>(inst)].size();
  f.vars.assign(1, inst);
  f.card.assign(1, static_cast<int>(S));
  size_t total = S;
  for (int p : parents) {
    f.vars.push_back(p);
    f.card.push_back(card(p));
    total *= static_cast<size_t>(card(p));
    if (total > kMaxFactor)
      throw OutsideFragmentError("factor for " + g_.instances[static_cast<size_t>(inst)].name +
                  " is too large (" + std::to_string(parents.size()) +
                  " parents); this is outside the native reasoner's fast path");
  }
  return total;
}

void ExactEngine::buildCpt(int inst, Factor& f) {
  const GInstance& gi = g_.instances[static_cast<size_t>(inst)];
  const std::vector<Item>& items = liveItemsCached(inst);
  const std::vector<int> parents = cptParents(inst);
  const size_t total = cptScope(inst, parents, f);
  checkMemory(total * sizeof(double));
  f.t.assign(total, 0.0);
  std::vector<int> cur(parents.size(), 0);
  CptRow r(states_[static_cast<size_t>(inst)], static_cast<int>(gi.domain.size()));
  const size_t S = r.states;
  const size_t nrows = total / S;
  for (size_t row = 0; row < nrows; ++row) {
    checkTime(63);
    for (size_t k = 0; k < parents.size(); ++k)
      assign_[static_cast<size_t>(parents[k])] =
          states_[static_cast<size_t>(parents[k])][static_cast<size_t>(cur[k])];
    newStamp();
    r.out = &f.t[row * S];
    try {
      fillCptRow(gi, items, r);
    } catch (const IncoherentError& e) {
      // Only an error if this parent configuration occurs in a possible world: checked after
      // all factors are built (see checkPendingErrors).
      std::fill(r.out, r.out + S, 0.0);
      pending_errors_.push_back(PendingError{pending_factor_, row, e.what()});
    }
    for (size_t k = 0; k < cur.size(); ++k) {
      if (++cur[k] < f.card[k + 1]) break;
      cur[k] = 0;
    }
  }
  for (int p : parents) assign_[static_cast<size_t>(p)] = -1;
}

void ExactEngine::fillCptRow(const GInstance& gi, const std::vector<Item>& items, CptRow& r) {
  const int fired = firedSelection(gi, items);
  if (fired < 0) {
    if (r.has_undef) r.out[r.states - 1] = 1.0;
    return;
  }
  const GSelection& sel = gi.selections[static_cast<size_t>(fired)];
  const int npossible = markPossibleValues(sel, r);
  if (npossible == 0)
    throw IncoherentError(sel.loc.str() + ": random attribute " + gi.name +
                          " has an empty dynamic range in a possible world where its "
                          "selection rule applies");
  double sum = 0;
  const int nassigned = assignProbabilities(gi, items, sel, r, sum);
  sum = checkProbabilitySum(gi, r.assigned, r.assigned_by, r.nv,
                            nassigned == npossible && nassigned > 0, sum, std::max(1, nassigned),
                            warnings_);
  int rest = npossible - nassigned;
  double share = rest > 0 ? std::max(0.0, 1.0 - sum) / rest : 0.0;
  for (size_t k = 0; k < r.nv; ++k) {
    if (!r.possible[k]) continue;
    r.out[k] = r.assigned[k] >= 0 ? r.assigned[k] : share;
  }
}

int ExactEngine::firedSelection(const GInstance& gi, const std::vector<Item>& items) {
  int fired = -1;
  for (const auto& it : items) {
    if (it.kind != 0) continue;
    if (bodyHolds(gi.selections[static_cast<size_t>(it.index)].body)) {
      if (fired >= 0)
        throw IncoherentError(gi.selections[static_cast<size_t>(it.index)].loc.str() +
                              ": two random selection rules for " + gi.name +
                              " apply in the same possible world");
      fired = it.index;
    }
  }
  return fired;
}

int ExactEngine::markPossibleValues(const GSelection& sel, CptRow& r) {
  if (!sel.dynamic_range) {
    std::fill(r.possible.begin(), r.possible.end(), 1);
    if (r.has_undef) r.possible[r.states - 1] = 0;
    return static_cast<int>(r.nv);
  }
  int npossible = 0;
  std::fill(r.possible.begin(), r.possible.end(), 0);
  for (const auto& rg : sel.range) {
    size_t k = static_cast<size_t>(r.pos_of[static_cast<size_t>(rg.first)]);
    if (!r.possible[k] && bodyHolds(rg.second)) {
      r.possible[k] = 1;
      ++npossible;
    }
  }
  return npossible;
}

int ExactEngine::assignProbabilities(const GInstance& gi, const std::vector<Item>& items,
                                     const GSelection& sel, CptRow& r, double& sum) {
  std::fill(r.assigned.begin(), r.assigned.end(), -1.0);
  int nassigned = 0;
  for (const auto& it : items) {
    if (it.kind != 1) continue;
    const GPr& pr = gi.prs[static_cast<size_t>(it.index)];
    int kp = r.pos_of[static_cast<size_t>(pr.value)];
    if (kp < 0) continue;
    size_t k = static_cast<size_t>(kp);
    if (!r.possible[k]) continue;
    if (!pr.label.empty() && pr.label != sel.label) continue;
    if (!bodyHolds(pr.body)) continue;
    if (r.assigned[k] >= 0) {
      const GPr& old = gi.prs[static_cast<size_t>(r.assigned_by[k])];
      if (pr.priority > old.priority) {  // newer knowledge overrides
        sum += pr.probability - r.assigned[k];
        r.assigned[k] = pr.probability;
        r.assigned_by[k] = it.index;
        continue;
      }
      if (pr.priority < old.priority) continue;
      if (std::fabs(r.assigned[k] - pr.probability) > 1e-12)
        throw IncoherentError(pr.loc.str() + ": conflicting probabilities for " + gi.name +
                              "=" + g_.symbols->text(gi.domain[static_cast<size_t>(pr.value)]) +
                              " (" + std::to_string(r.assigned[k]) + " from " +
                              gi.prs[static_cast<size_t>(r.assigned_by[k])].loc.str() +
                              " and " + std::to_string(pr.probability) + ")");
      continue;
    }
    r.assigned[k] = pr.probability;
    r.assigned_by[k] = it.index;
    sum += pr.probability;
    ++nassigned;
  }
  return nassigned;
}

ExactEngine::Factor ExactEngine::indicatorFactor(std::vector<int> scope,
                                                 const std::string& too_large,
                                                 const std::function<bool()>& holds) {
  std::sort(scope.begin(), scope.end());
  scope.erase(std::unique(scope.begin(), scope.end()), scope.end());
  Factor f;
  f.vars = scope;
  size_t total = 1;
  for (int v : scope) {
    f.card.push_back(card(v));
    total *= static_cast<size_t>(card(v));
    if (total > kMaxFactor) throw OutsideFragmentError(too_large);
  }
  checkMemory(total * sizeof(double));
  f.t.assign(total, 0.0);
  std::vector<int> cur(scope.size(), 0);
  for (size_t row = 0; row < total; ++row) {
    checkTime(63);
    for (size_t k = 0; k < scope.size(); ++k)
      assign_[static_cast<size_t>(scope[k])] =
          states_[static_cast<size_t>(scope[k])][static_cast<size_t>(cur[k])];
    newStamp();
    f.t[row] = holds() ? 1.0 : 0.0;
    for (size_t k = 0; k < cur.size(); ++k) {
      if (++cur[k] < f.card[k]) break;
      cur[k] = 0;
    }
  }
  for (int v : scope) assign_[static_cast<size_t>(v)] = -1;
  return f;
}

void ExactEngine::buildIndicator(const std::vector<GCondition>& conds, bool constraint_style,
                                 const std::vector<GLit>* constraint_body,
                                 std::vector<Factor>& out) {
  static const std::string kTooLarge =
      "condition spans too many random attributes for the native reasoner";
  std::vector<int> scope;
  if (constraint_style) {
    for (const auto& l : *constraint_body) scopeOfLit(l, scope);
    out.push_back(indicatorFactor(std::move(scope), kTooLarge,
                                  [&]() { return !bodyHolds(*constraint_body); }));
    return;
  }
  // The conditions must all hold: one indicator per condition, and a condition that is a
  // conjunction required true is one indicator per literal (a query over 30 independent
  // attributes is 30 tables of 2 rows, not one of 2^30). Negated conjunctions stay whole.
  for (const auto& c : conds) {
    if (splitsIntoLiterals(c)) {
      for (const auto& l : c.lits) {
        scope.clear();
        scopeOfLit(l, scope);
        out.push_back(indicatorFactor(std::move(scope), kTooLarge, [&]() { return holds(l); }));
      }
      continue;
    }
    scope.clear();
    for (const auto& l : c.lits) scopeOfLit(l, scope);
    out.push_back(indicatorFactor(std::move(scope), kTooLarge, [&]() {
      const bool v = c.constant && bodyHolds(c.lits);
      return v == c.truth;
    }));
  }
}

ExactEngine::Factor ExactEngine::multiply(const Factor& a, const Factor& b) {
  Factor r;
  r.vars = a.vars;
  r.card = a.card;
  for (size_t i = 0; i < b.vars.size(); ++i)
    if (std::find(r.vars.begin(), r.vars.end(), b.vars[i]) == r.vars.end()) {
      r.vars.push_back(b.vars[i]);
      r.card.push_back(b.card[i]);
    }
  size_t total = 1;
  for (int c : r.card) {
    total *= static_cast<size_t>(c);
    if (total > kMaxFactor)
      throw OutsideFragmentError("intermediate factor too large for the native reasoner (treewidth too high)");
  }
  // strides of r's vars in a and b
  std::vector<size_t> sa(r.vars.size(), 0), sb(r.vars.size(), 0);
  {
    size_t s = 1;
    for (size_t i = 0; i < a.vars.size(); ++i) {
      sa[i] = s;  // a's vars are the first ones of r, same order
      s *= static_cast<size_t>(a.card[i]);
    }
    s = 1;
    for (size_t i = 0; i < b.vars.size(); ++i) {
      size_t pos = static_cast<size_t>(std::find(r.vars.begin(), r.vars.end(), b.vars[i]) - r.vars.begin());
      sb[pos] = s;
      s *= static_cast<size_t>(b.card[i]);
    }
  }
  r.t.assign(total, 0.0);
  std::vector<int> cur(r.vars.size(), 0);
  size_t ia = 0, ib = 0;
  for (size_t row = 0; row < total; ++row) {
    r.t[row] = a.t[ia] * b.t[ib];
    for (size_t k = 0; k < cur.size(); ++k) {
      if (++cur[k] < r.card[k]) {
        ia += sa[k];
        ib += sb[k];
        break;
      }
      ia -= sa[k] * static_cast<size_t>(r.card[k] - 1);
      ib -= sb[k] * static_cast<size_t>(r.card[k] - 1);
      cur[k] = 0;
    }
  }
  return r;
}

ExactEngine::Factor ExactEngine::sumOut(const Factor& f, int var) {
  size_t pos = static_cast<size_t>(std::find(f.vars.begin(), f.vars.end(), var) - f.vars.begin());
  Factor r;
  size_t inner = 1;
  for (size_t i = 0; i < pos; ++i) inner *= static_cast<size_t>(f.card[i]);
  size_t c = static_cast<size_t>(f.card[pos]);
  size_t outer = f.t.size() / (inner * c);
  for (size_t i = 0; i < f.vars.size(); ++i)
    if (i != pos) {
      r.vars.push_back(f.vars[i]);
      r.card.push_back(f.card[i]);
    }
  r.t.assign(inner * outer, 0.0);
  for (size_t o = 0; o < outer; ++o)
    for (size_t k = 0; k < c; ++k) {
      const double* src = &f.t[(o * c + k) * inner];
      double* dst = &r.t[o * inner];
      for (size_t i = 0; i < inner; ++i) dst[i] += src[i];
    }
  return r;
}

std::vector<double> ExactEngine::eliminate(std::vector<Factor> factors, int keep) {
  last_factors_ = factors.size();
  last_max_factor_ = 0;
  for (const auto& f : factors) last_max_factor_ = std::max(last_max_factor_, f.t.size());
  for (;;) {
    // candidate variables
    std::vector<int> vars;
    for (const auto& f : factors)
      for (int v : f.vars)
        if (v != keep) vars.push_back(v);
    if (vars.empty()) break;
    checkTime();
    std::sort(vars.begin(), vars.end());
    vars.erase(std::unique(vars.begin(), vars.end()), vars.end());
    int best = -1;
    double best_cost = 0;
    for (int v : vars) {
      std::vector<std::pair<int, int>> u;
      for (const auto& f : factors)
        if (std::find(f.vars.begin(), f.vars.end(), v) != f.vars.end())
          for (size_t i = 0; i < f.vars.size(); ++i) u.push_back({f.vars[i], f.card[i]});
      std::sort(u.begin(), u.end());
      u.erase(std::unique(u.begin(), u.end()), u.end());
      double cost = 1;
      for (auto& p : u) cost *= p.second;
      if (best < 0 || cost < best_cost) {
        best = v;
        best_cost = cost;
      }
    }
    std::vector<Factor> rest;
    Factor prod;
    bool have = false;
    for (auto& f : factors) {
      if (std::find(f.vars.begin(), f.vars.end(), best) != f.vars.end()) {
        if (!have) {
          prod = std::move(f);
          have = true;
        } else {
          prod = multiply(prod, f);
        }
      } else {
        rest.push_back(std::move(f));
      }
    }
    Factor s = sumOut(prod, best);
    last_max_factor_ = std::max(last_max_factor_, prod.t.size());
    rest.push_back(std::move(s));
    factors = std::move(rest);
  }
  Factor r;
  r.t.assign(1, 1.0);
  for (const auto& f : factors) r = multiply(r, f);
  return r.t;
}

namespace {
void pushUnique(std::vector<int>& v, int x) {
  if (std::find(v.begin(), v.end(), x) == v.end()) v.push_back(x);
}
}  // namespace

/// @brief What a query's factors are built for: the random instances it depends on, the
/// constraints and the derived instances that may get two values (buildFactors).
struct ExactEngine::Relevance {
  std::vector<int> rel;          ///< random instances, in the order found (one CPT each)
  std::vector<int> queue;        ///< instances of rel whose parents are still to be added
  std::vector<int> constraints;  ///< indices in g_.constraints (one indicator each)
  std::vector<int> derived;      ///< derived instances that may get two values
  std::vector<int> scope;        ///< scratch for the scopes being added
};

void ExactEngine::addRelevant(Relevance& r, const std::vector<int>& scope) {
  for (int v : scope)
    if (rel_stamp_[static_cast<size_t>(v)] != rel_counter_) {
      rel_stamp_[static_cast<size_t>(v)] = rel_counter_;
      r.rel.push_back(v);
      r.queue.push_back(v);
      computeStates(v);
    }
}

void ExactEngine::closeRelevant(Relevance& r) {
  while (!r.queue.empty()) {
    int x = r.queue.back();
    r.queue.pop_back();
    r.scope.clear();
    scopeOfItems(x, r.scope);
    addRelevant(r, r.scope);
  }
}

void ExactEngine::buildFactors(const std::vector<const std::vector<GCondition>*>& seeds,
                               int seed_inst, std::vector<Factor>& factors) {
  Relevance r;
  collectRelevant(seeds, seed_inst, r);
  collectEvidence(r);
  planFactors(seeds, r);
  pending_errors_.clear();
  fillFactors(r, factors);
}

void ExactEngine::collectRelevant(const std::vector<const std::vector<GCondition>*>& seeds,
                                  int seed_inst, Relevance& r) {
  // Relevance: random instances reachable from the conditions, constraints touching them.
  ++rel_counter_;
  touched_derived_.clear();
  if (seed_inst >= 0) addRelevant(r, {seed_inst});
  for (const auto* cs : seeds)
    for (const auto& c : *cs)
      for (const auto& l : c.lits) {
        r.scope.clear();
        scopeOfLit(l, r.scope);
        addRelevant(r, r.scope);
      }
  closeRelevant(r);
  // A selection over a dynamic range has no possible world where the range is empty, so it
  // conditions every query like a constraint (checkPendingErrors reports it when such a world
  // has positive measure).
  for (int x : dynamic_range_)
    if (fixed_[static_cast<size_t>(x)] < 0) addRelevant(r, {x});
  closeRelevant(r);
}

void ExactEngine::collectEvidence(Relevance& r) {
  // Constraints (and derived instances that may get two values, which make a world
  // inconsistent) act as evidence. They are all included: one independent of the query scales
  // both measures by the same constant (its ratio is unchanged), but when it can never be
  // satisfied the program has no possible world, which must be reported.
  std::vector<char> used(g_.constraints.size(), 0);
  std::vector<char> dused(conflict_derived_.size(), 0);
  bool changed = true;
  while (changed) {
    changed = false;
    for (size_t c = 0; c < g_.constraints.size(); ++c) {
      if (used[c] || bodyDead(g_.constraints[c].first)) continue;
      r.scope.clear();
      for (const auto& l : g_.constraints[c].first) scopeOfLit(l, r.scope);
      used[c] = 1;
      r.constraints.push_back(static_cast<int>(c));
      addRelevant(r, r.scope);
      closeRelevant(r);
      changed = true;
    }
    for (size_t k = 0; k < conflict_derived_.size(); ++k) {
      int d = conflict_derived_[k];
      if (dused[k] || fixed_[static_cast<size_t>(d)] >= 0) continue;
      r.scope.clear();
      scopeOfInstance(d, r.scope);
      dused[k] = 1;
      r.derived.push_back(d);
      addRelevant(r, r.scope);
      closeRelevant(r);
      changed = true;
    }
  }
}

void ExactEngine::planFactors(const std::vector<const std::vector<GCondition>*>& seeds,
                              Relevance& r) {
  // The plan: rows of every table about to be filled (log2). Over the cost cap, stop before
  // any row is evaluated.
  double largest = 0, rows = 0;
  std::vector<int>& s = r.scope;
  auto scopeLog2 = [&](std::vector<int>& scope) {
    std::sort(scope.begin(), scope.end());
    scope.erase(std::unique(scope.begin(), scope.end()), scope.end());
    double l = 0;
    for (int v : scope) l += std::log2(std::max(1, card(v)));
    largest = std::max(largest, l);
    rows += std::exp2(l);
  };
  for (int x : r.rel) {
    s.clear();
    scopeOfItems(x, s);
    s.push_back(x);
    scopeLog2(s);
  }
  for (int c : r.constraints) {
    s.clear();
    for (const auto& l : g_.constraints[static_cast<size_t>(c)].first) scopeOfLit(l, s);
    scopeLog2(s);
  }
  for (int d : r.derived) {
    s.clear();
    scopeOfInstance(d, s);
    scopeLog2(s);
  }
  for (const auto* cs : seeds)  // the indicators of buildIndicator
    for (const auto& c : *cs) {
      if (splitsIntoLiterals(c)) {
        for (const auto& l : c.lits) {
          s.clear();
          scopeOfLit(l, s);
          scopeLog2(s);
        }
        continue;
      }
      s.clear();
      for (const auto& l : c.lits) scopeOfLit(l, s);
      scopeLog2(s);
    }
  reportPlan(largest, rows);
}

void ExactEngine::reportPlan(double largest, double rows) {
  last_planned_log2_ = largest;
  const bool recursive = !scc_atoms_.empty();
  last_plan_ = EnginePlan();
  last_plan_.largest_log2 = largest;
  last_plan_.rows = rows;
  last_plan_.recursive = recursive;
  // Counted by the grounder (O(1) per query: summing the instances' rules here made every
  // query linear in the whole grounding, 4x on nav_transfer).
  last_plan_.derived_rules = g_.derived_rules;
  if (on_plan_) on_plan_(last_plan_);
  const double cap = recursive ? cost_cap_recursive_log2_ : cost_cap_log2_;
  if (largest > cap) {
    throw CostlierError("the native engine's largest table has 2^" + std::to_string(largest) +
                        " rows, over its cost cap of 2^" + std::to_string(cap) +
                        (recursive ? " (recursive derived atoms)" : ""));
  }
}

void ExactEngine::fillFactors(const Relevance& r, std::vector<Factor>& factors) {
  for (int x : r.rel) {
    Factor f;
    pending_factor_ = factors.size();
    buildCpt(x, f);
    factors.push_back(std::move(f));
  }
  for (int c : r.constraints)
    buildIndicator({}, true, &g_.constraints[static_cast<size_t>(c)].first, factors);
  for (int d : r.derived) {
    const GInstance& gi = g_.instances[static_cast<size_t>(d)];
    std::vector<int> vals;
    for (const auto& rule : gi.rules)
      if (!bodyDead(rule.second)) pushUnique(vals, rule.first);
    if (vals.size() < 2) continue;
    // factor: at most one value of d holds
    std::vector<int> scope;
    scopeOfInstance(d, scope);
    factors.push_back(indicatorFactor(std::move(scope),
                                      "derived attribute " + gi.name + " has too many causes",
                                      [&]() {
                                        int n = 0;
                                        for (int v : vals)
                                          if (atomHolds(d, v)) ++n;
                                        return n <= 1;
                                      }));
  }
}

void ExactEngine::checkPendingErrors(const std::vector<Factor>& factors) {
  if (pending_errors_.empty()) return;
  // For each factor with error rows: the mass of the worlds whose parent configuration is an
  // error row (the factor replaced by the indicator of its error rows). Positive mass means a
  // possible world violates P-log's coherence conditions.
  std::vector<PendingError> errs;
  errs.swap(pending_errors_);
  size_t i = 0;
  while (i < errs.size()) {
    size_t fi = errs[i].factor;
    std::vector<Factor> fs = factors;
    Factor& f = fs[fi];
    const size_t S = static_cast<size_t>(f.card[0]);
    std::fill(f.t.begin(), f.t.end(), 0.0);
    size_t j = i;
    for (; j < errs.size() && errs[j].factor == fi; ++j)
      std::fill(f.t.begin() + static_cast<long>(errs[j].row * S),
                f.t.begin() + static_cast<long>((errs[j].row + 1) * S), 1.0);
    double z = eliminate(std::move(fs), -1).at(0);
    if (z > 0) throw IncoherentError(errs[i].message);
    i = j;
  }
}

std::pair<double, double> ExactEngine::measure(const std::vector<GCondition>& formula,
                                               const std::vector<GCondition>& evidence) {
  std::vector<Factor> factors;
  buildFactors({&formula, &evidence}, -1, factors);
  std::vector<Factor> with_evidence = factors;
  if (!evidence.empty()) buildIndicator(evidence, false, nullptr, with_evidence);
  checkPendingErrors(with_evidence);
  double ze = eliminate(with_evidence, -1).at(0);
  double zqe = 0;
  if (ze > 0) {
    if (!formula.empty()) buildIndicator(formula, false, nullptr, with_evidence);
    zqe = eliminate(std::move(with_evidence), -1).at(0);
  }
  return {zqe, ze};
}

std::vector<double> ExactEngine::unnormalisedMarginal(int inst,
                                                      const std::vector<GCondition>& evidence) {
  std::vector<Factor> factors;
  buildFactors({&evidence}, inst, factors);
  if (!evidence.empty()) buildIndicator(evidence, false, nullptr, factors);
  checkPendingErrors(factors);
  return eliminate(std::move(factors), inst);
}

std::vector<std::pair<int, double>> ExactEngine::marginalSparse(
    int inst, const std::vector<GCondition>& evidence) {
  const GInstance& gi = g_.instances[static_cast<size_t>(inst)];
  std::vector<std::pair<int, double>> out;
  if (gi.random && fixed_[static_cast<size_t>(inst)] < 0) {
    std::vector<double> t = unnormalisedMarginal(inst, evidence);
    const std::vector<int>& st = states_[static_cast<size_t>(inst)];
    if (t.size() == st.size()) {
      for (size_t k = 0; k < st.size(); ++k) out.push_back({st[k], t[k]});
    } else {
      out.push_back({static_cast<int>(gi.domain.size()), t.empty() ? 0.0 : t[0]});
    }
    return out;
  }
  std::vector<double> m = marginal(inst, evidence);
  for (size_t v = 0; v < m.size(); ++v)
    if (m[v] != 0) out.push_back({static_cast<int>(v), m[v]});
  return out;
}

std::vector<double> ExactEngine::marginal(int inst, const std::vector<GCondition>& evidence) {
  const GInstance& gi = g_.instances[static_cast<size_t>(inst)];
  const size_t D = gi.domain.size();
  std::vector<double> out(D + 1, 0.0);
  if (gi.random && fixed_[static_cast<size_t>(inst)] < 0) {
    std::vector<double> t = unnormalisedMarginal(inst, evidence);
    const std::vector<int>& st = states_[static_cast<size_t>(inst)];
    if (t.size() == st.size()) {
      for (size_t k = 0; k < st.size(); ++k) out[static_cast<size_t>(st[k])] = t[k];
    } else {
      out[D] = t.empty() ? 0.0 : t[0];
    }
    return out;
  }
  // fixed or derived instance: one measure per value
  for (size_t v = 0; v <= D; ++v) {
    GCondition c;
    if (v < D) c.lits.push_back(GLit{inst, static_cast<int>(v), false, false});
    else c.lits.push_back(GLit{inst, -1, true, true});
    out[v] = measure({c}, evidence).first;
  }
  return out;
}

}  // namespace plog
}  // namespace krr
