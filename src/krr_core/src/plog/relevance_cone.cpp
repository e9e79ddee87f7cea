/**
 * @file relevance_cone.cpp
 * @brief The attribute-level relevance cone of a P-log program (relevanceCone) and whether
 * grounding only a query's instances of it pays (instanceConePays).
 */
#include "krr_core/plog/grounder.h"

#include <algorithm>
#include <limits>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "krr_core/plog/name_table.h"

#include "scc.h"

namespace krr {
namespace plog {

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

}  // namespace plog
}  // namespace krr
