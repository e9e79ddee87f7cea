/**
 * @file scc.h
 * @brief Private to the P-log reasoner: strongly connected components of a dependency graph,
 * shared by the ground check of the native engine (engine.cpp), the check of the program
 * text before grounding (negationLoopReason in reasoner.cpp) and the grounder's order of the
 * static attributes (grounder.cpp).
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

/// @brief Component of every node, numbered in the order Tarjan's algorithm closes them: a
/// component's number is larger than that of every component it depends on. Iterative,
/// because ground dependency chains can be longer than the call stack allows.
/// @param count set to the number of components.
inline std::vector<int> stronglyConnectedComponents(const DependencyEdges& edges, int& count) {
  const std::size_t n = edges.size();
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
      if (f.next < edges[v].size()) {
        const std::size_t w = static_cast<std::size_t>(edges[v][f.next++].first);
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

}  // namespace plog
}  // namespace krr
