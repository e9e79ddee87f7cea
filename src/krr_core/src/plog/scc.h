/**
 * @file scc.h
 * @brief Private to the P-log reasoner: strongly connected components of a dependency graph,
 * shared by the ground check of the native engine (engine.cpp), the check of the program
 * text before grounding (negationLoopReason in reasoner_auto.cpp), the relevance cone's loops
 * through negation (relevance_cone.cpp) and the grounder's order of the static attributes
 * (grounder_static.cpp).
 */
#pragma once

#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

namespace krr {
namespace plog {

/// @brief Edges of a dependency graph: per node, (target node, through negation?).
using DependencyEdges = std::vector<std::vector<std::pair<int, bool>>>;

/// @brief A dependency graph in compressed rows: the edges of node v are
/// target[start[v] .. start[v + 1]) with their flags (through negation?). One allocation for
/// all the edges instead of one per node: a program of 10^5 attributes has that many nodes.
struct CompactGraph {
  std::vector<int> start{0};  ///< size nodes + 1
  std::vector<int> target;
  std::vector<char> negative;
  std::size_t size() const { return start.size() - 1; }
  std::size_t degree(std::size_t v) const {
    return static_cast<std::size_t>(start[v + 1] - start[v]);
  }
  int to(std::size_t v, std::size_t k) const { return target[static_cast<std::size_t>(start[v]) + k]; }
  /// @brief Built from (from, to, negative) edges over nodes 0 .. nodes - 1 (counting sort:
  /// the edges of a node keep their order).
  template <class Edge>
  static CompactGraph fromEdges(std::size_t nodes, const std::vector<Edge>& edges) {
    CompactGraph g;
    g.start.assign(nodes + 1, 0);
    for (const auto& e : edges) ++g.start[static_cast<std::size_t>(e.from) + 1];
    for (std::size_t v = 0; v < nodes; ++v) g.start[v + 1] += g.start[v];
    g.target.resize(edges.size());
    g.negative.resize(edges.size());
    std::vector<int> fill(g.start.begin(), g.start.end() - 1);
    for (const auto& e : edges) {
      const std::size_t k = static_cast<std::size_t>(fill[static_cast<std::size_t>(e.from)]++);
      g.target[k] = e.to;
      g.negative[k] = e.negative ? 1 : 0;
    }
    return g;
  }
};

/// @brief Tarjan's algorithm over any graph with size(), degree(v) and to(v, k) (see
/// stronglyConnectedComponents).
template <class Graph>
std::vector<int> componentsOf(const Graph& g, int& count) {
  const std::size_t n = g.size();
  std::vector<int> index(n, -1), low(n, 0), comp(n, -1), stack;
  std::vector<char> on(n, 0);
  int counter = 0;
  count = 0;
  struct Frame {
    std::size_t v, next;
  };
  std::vector<Frame> call;
  for (std::size_t root = 0; root < n; ++root) {
    if (index[root] >= 0) continue;
    call.push_back({root, 0});
    index[root] = low[root] = counter++;
    stack.push_back(static_cast<int>(root));
    on[root] = 1;
    while (!call.empty()) {
      Frame& f = call.back();
      const std::size_t v = f.v;
      if (f.next < g.degree(v)) {
        const std::size_t w = static_cast<std::size_t>(g.to(v, f.next++));
        if (index[w] < 0) {
          index[w] = low[w] = counter++;
          stack.push_back(static_cast<int>(w));
          on[w] = 1;
          call.push_back({w, 0});
        } else if (on[w]) {
          low[v] = std::min(low[v], index[w]);
        }
        continue;
      }
      if (low[v] == index[v]) {
        std::size_t w;
        do {
          w = static_cast<std::size_t>(stack.back());
          stack.pop_back();
          on[w] = 0;
          comp[w] = count;
        } while (w != v);
        ++count;
      }
      call.pop_back();
      if (!call.empty()) {
        const std::size_t p = call.back().v;
        low[p] = std::min(low[p], low[v]);
      }
    }
  }
  return comp;
}

/// @brief Component of every node, numbered in the order Tarjan's algorithm closes them: a
/// component's number is larger than that of every component it depends on. Iterative,
/// because ground dependency chains can be longer than the call stack allows.
/// @param count set to the number of components.
inline std::vector<int> stronglyConnectedComponents(const DependencyEdges& edges, int& count) {
  struct View {
    const DependencyEdges& e;
    std::size_t size() const { return e.size(); }
    std::size_t degree(std::size_t v) const { return e[v].size(); }
    int to(std::size_t v, std::size_t k) const { return e[v][k].first; }
  };
  return componentsOf(View{edges}, count);
}

inline std::vector<int> stronglyConnectedComponents(const CompactGraph& g, int& count) {
  return componentsOf(g, count);
}

}  // namespace plog
}  // namespace krr
