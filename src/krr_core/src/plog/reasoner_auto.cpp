/**
 * @file reasoner_auto.cpp
 * @brief The auto back end's cost model and decision (clingo's and the native engine's
 * estimates, decideAuto) and the check of the program text for loops through negation
 * (negationLoopReason), on which a raced query starts clingo at once.
 */
#include "krr_core/plog/reasoner.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "krr_core/plog/engine.h"
#include "krr_core/plog/name_table.h"
#include "scc.h"

namespace krr {
namespace plog {

namespace {

// Calls f(ground instances, |range|) for each random selection rule; false when a sort is
// unknown (no bound).
template <class F>
bool forRandomRules(const Program& program, F f) {
  for (const auto& r : program.random_rules) {
    const AttributeDecl* d = program.findAttribute(r.attr.name);
    const SortDecl* range = d ? program.findSort(d->range_sort) : nullptr;
    if (range == nullptr) return false;
    std::vector<std::string> vars;
    for (const auto& t : r.attr.args) t.collectVariables(vars);
    std::sort(vars.begin(), vars.end());
    vars.erase(std::unique(vars.begin(), vars.end()), vars.end());
    double instances = 1;
    for (const auto& v : vars) {
      auto it = r.variable_sorts.find(v);
      std::string sort = it != r.variable_sorts.end() ? it->second : program.domainSortOf(v);
      const SortDecl* sd = sort.empty() ? nullptr : program.findSort(sort);
      if (sd == nullptr) return false;
      instances *= static_cast<double>(sd->values.size());
    }
    f(instances, static_cast<double>(range->values.size()));
  }
  return true;
}

}  // namespace

double aspWorldsLog2(const Program& program) {
  double total = 0;
  if (!forRandomRules(program, [&](double instances, double range) {
        total += instances * std::log2(std::max(1.0, range));
      }))
    return std::numeric_limits<double>::infinity();
  return total;
}

double aspWorkAtoms(const Program& program) {
  // per world: each selected instance with its possible values (val, sel, poss), every rule
  // and pr-atom at least once
  double per_world = 1 + static_cast<double>(program.rules.size() + program.pr_atoms.size());
  if (!forRandomRules(program, [&](double instances, double range) {
        per_world += instances * (range + 2);
      }))
    return std::numeric_limits<double>::infinity();
  return std::exp2(aspWorldsLog2(program)) * per_world;
}

double aspCostSeconds(const Program& program) {
  return AutoCostModel::kAspStartSeconds + aspWorkAtoms(program) * AutoCostModel::kAspSecondsPerAtom;
}

double nativeCostSeconds(const EnginePlan& plan) {
  return plan.rows * (1.0 + static_cast<double>(plan.derived_rules)) *
         AutoCostModel::kNativeSecondsPerRow;
}

AutoDecision decideAuto(const AutoEstimate& e, double race_delay) {
  using M = AutoCostModel;
  const double inf = std::numeric_limits<double>::infinity();
  AutoDecision d;
  if (e.native_refuses) {
    d.choice = AutoChoice::Asp;
    d.asp_join_seconds = 0;
    return d;
  }
  race_delay = std::max(0.0, race_delay);
  if (std::isnan(e.native_seconds)) {
    // Grounding, no plan yet: clingo (which grounds the whole program) joins when the
    // grounding has taken a while, later if its own estimate is larger.
    d.choice = AutoChoice::Native;
    d.asp_join_seconds = std::max(M::kGroundingRaceFactor * race_delay, e.asp_seconds / 2);
    return d;
  }
  const double native = std::max(e.native_seconds, 0.0);
  if (!(e.asp_seconds >= M::kSureRatio * native)) {  // NaN estimates race too
    d.choice = AutoChoice::Race;
    d.asp_join_seconds = 0;
    return d;
  }
  d.choice = AutoChoice::Native;
  if (e.asp_seconds >= M::kHopelessRatio * native) {
    d.asp_join_seconds = inf;
    return d;
  }
  d.asp_join_seconds = std::min(race_delay, std::max(M::kOverrun * native, e.asp_seconds / 2));
  return d;
}

const char* autoChoiceName(AutoChoice choice) {
  switch (choice) {
    case AutoChoice::Native: return "native";
    case AutoChoice::Race: return "race";
    case AutoChoice::Asp: return "asp";
  }
  return "?";
}

std::string negationLoopReason(const Program& program) {
  for (const auto& r : program.rules)
    if (r.consistency_restoring)
      return r.loc.str() + ": consistency-restoring rule (':+')";
  for (const auto& r : program.random_rules)
    if (r.consistency_restoring)
      return r.loc.str() + ": consistency-restoring random selection (':+')";
  // Nodes: (attribute, head value) for constant head values, (attribute, *) for the others.
  // Attributes and values are interned ids (the parser's hints give most attributes without
  // a lookup), a node is the pair of ids: no string is built per rule.
  const AttributeIndex index(program);
  const int na = static_cast<int>(program.attributes.size());
  NameTable undeclared, values;
  auto attrOf = [&](const AttributeTerm& t) {
    const int a = index.of(t);
    return a >= 0 ? a : na + undeclared.intern(t.name);
  };
  auto attrKnown = [&](const AttributeTerm& t) {  // -1: no rule has it as its head
    const int a = index.of(t);
    if (a >= 0) return a;
    const int u = undeclared.find(t.name);
    return u < 0 ? -1 : na + u;
  };
  constexpr int kAny = -1;  // the value "*"
  auto constantValue = [&](const Term& t) {  // value id, or kAny
    if (!t.isGround() || t.kind == Term::Kind::Binary || t.kind == Term::Kind::Negate) return kAny;
    return t.kind == Term::Kind::Symbol ? values.intern(t.name) : values.intern(toString(t));
  };
  auto key = [](int attr, int value) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(attr)) << 32) |
           static_cast<std::uint32_t>(value);
  };
  std::unordered_map<std::uint64_t, int> node_id;  // (attribute, value) -> node
  std::vector<std::pair<int, int>> node_of;        // node -> (attribute, value)
  std::vector<int> first_node, last_node, next_node;  // nodes of an attribute, in order
  node_id.reserve(program.rules.size());
  auto nodeOf = [&](const Atom& head) {
    const int a = attrOf(head.attr);
    const int v = constantValue(head.value);
    auto [it, added] = node_id.emplace(key(a, v), static_cast<int>(node_of.size()));
    if (added) {
      const int n = it->second;
      node_of.push_back({a, v});
      next_node.push_back(-1);
      if (first_node.size() <= static_cast<size_t>(a)) {
        first_node.resize(static_cast<size_t>(a) + 1, -1);
        last_node.resize(static_cast<size_t>(a) + 1, -1);
      }
      if (first_node[static_cast<size_t>(a)] < 0) first_node[static_cast<size_t>(a)] = n;
      else next_node[static_cast<size_t>(last_node[static_cast<size_t>(a)])] = n;
      last_node[static_cast<size_t>(a)] = n;
    }
    return it->second;
  };
  auto nodeName = [&](int n) {
    const auto& av = node_of[static_cast<size_t>(n)];
    const std::string& attr = av.first < na ? program.attributes[static_cast<size_t>(av.first)].name
                                            : undeclared.name(av.first - na);
    return attr + "=" + (av.second == kAny ? std::string("*") : values.name(av.second));
  };
  std::vector<int> head_node(program.rules.size(), -1);
  for (size_t i = 0; i < program.rules.size(); ++i)
    if (program.rules[i].head) head_node[i] = nodeOf(*program.rules[i].head);
  // Edges (target, negative): `not` and `!=` count as negative, as the grounder's check of
  // static attributes does; a body atom with a constant value depends on that value's rules
  // and on the rules with a variable value, any other atom on every rule of its attribute.
  struct Edge {
    int from, to;
    bool negative;
  };
  std::vector<Edge> edge_list;
  for (size_t i = 0; i < program.rules.size(); ++i) {
    if (head_node[i] < 0) continue;
    const int from = head_node[i];
    for (const auto& l : program.rules[i].body) {
      if (l.kind != Literal::Kind::Atom) continue;
      const int a = attrKnown(l.atom.attr);
      if (a < 0 || static_cast<size_t>(a) >= first_node.size() ||
          first_node[static_cast<size_t>(a)] < 0)
        continue;
      const bool negative = l.naf || l.negated;
      const int v = l.negated ? kAny : constantValue(l.atom.value);
      if (!l.negated && v != kAny) {
        for (const int value : {v, kAny}) {
          auto n = node_id.find(key(a, value));
          if (n != node_id.end()) edge_list.push_back({from, n->second, negative});
        }
      } else {
        for (int n = first_node[static_cast<size_t>(a)]; n >= 0; n = next_node[static_cast<size_t>(n)])
          edge_list.push_back({from, n, negative});
      }
    }
  }
  // A negative edge inside a strongly connected component is a loop through negation.
  const CompactGraph edges = CompactGraph::fromEdges(node_of.size(), edge_list);
  int ncomp = 0;
  const std::vector<int> comp = stronglyConnectedComponents(edges, ncomp);
  for (size_t m = 0; m < edges.size(); ++m)
    for (size_t k = 0; k < edges.degree(m); ++k) {
      const int to = edges.to(m, k);
      if (edges.negative[static_cast<size_t>(edges.start[m]) + k] &&
          comp[static_cast<size_t>(to)] == comp[m])
        return nodeName(static_cast<int>(m)) + " may depend on " + nodeName(to) +
               " through negation, and " + nodeName(to) + " on " + nodeName(static_cast<int>(m));
    }
  return "";
}

}  // namespace plog
}  // namespace krr
