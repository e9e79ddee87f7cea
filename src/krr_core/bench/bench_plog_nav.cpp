/**
 * @file bench_plog_nav.cpp
 * @brief Benchmark of the native P-log reasoner on the grid-navigation program of the paper:
 * the full transition table P(next_cell | do(curr_cell), do(act_move)) with the exogenous
 * attributes (time of day, walkers in blocking areas) marginalised, and one single query.
 *
 * Usage: bench_plog_nav [SIZE...]   (default sizes 30 and 50: SIZExSIZE grids)
 */
#include <cstdio>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/errors.h"
#include "krr_core/common/main_guard.h"
#include "krr_core/common/resources.h"
#include "krr_core/examples/grid_program.h"
#include "krr_core/plog/reasoner.h"

namespace {

krr::examples::GridNavigationSpec spec(int n) {
  krr::examples::GridNavigationSpec s;
  s.width = n;
  s.height = n;
  // four blocking areas (corridors near the quarter lines), different rates
  int q = n / 4, k = q > 1 ? q - 1 : 1;
  s.areas = {{"a0", q, q, q + k - 1, q + k - 1, 0.3, 0.7},
             {"a1", 3 * q, q, 3 * q + k - 1, q + k - 1, 0.2, 0.6},
             {"a2", q, 3 * q, q + k - 1, 3 * q + k - 1, 0.4, 0.8},
             {"a3", 2 * q, 2 * q, 2 * q + k - 1, 2 * q + k - 1, 0.1, 0.5}};
  return s;
}

}  // namespace

/// @brief The benchmark; main() runs it under guardedMain, which reports a bad option or file.
static int mainBody(int argc, char** argv) {
  std::vector<int> sizes;
  krr::OptionParser cli("bench_plog_nav",
                        "The native P-log reasoner on the paper's grid-navigation program: the full\n"
                        "transition table and one single query, on SIZE x SIZE grids.");
  cli.positional("SIZE", "grid sides, at least 20 (default 30 50)", [&](const std::string& v) {
    const std::size_t n = krr::parseCountOption("SIZE", v);
    // Smaller grids put the learned batch (cells 0..100) inside a blocking area.
    if (n < 20 || n > 100000) throw krr::ConfigError("SIZE " + v + ": must be 20 to 100000");
    sizes.push_back(static_cast<int>(n));
  }, true);
  if (const auto status = cli.parse(argc, argv)) return *status;
  if (sizes.empty()) sizes = {30, 50};
  for (int n : sizes) {
    krr::examples::GridNavigationSpec s = spec(n);
    std::string text = krr::examples::makeGridNavigationProgram(s);
    krr::Stopwatch sw;
    krr::plog::Reasoner r;
    r.loadString(text, "grid" + std::to_string(n));
    double t_load = sw.seconds();
    sw.reset();
    // single query: first call grounds the cone (ground time), second is the query time
    int c = krr::examples::gridCell(s, s.areas[0].x0, s.areas[0].y0);
    std::string q = "?{next_cell=" + std::to_string(c + 1) + "} | do(curr_cell=" +
                    std::to_string(c) + "), do(act_move=right)";
    double p1 = r.probability(q);
    double t_first = sw.seconds();
    double t_ground = r.stats().ground_seconds;
    sw.reset();
    double p2 = r.probability(q);
    double t_single = sw.seconds();
    sw.reset();
    krr::plog::Table t = r.tableQuery("next_cell", {"curr_cell", "act_move"});
    double t_table = sw.seconds();
    size_t entries = 0;
    for (const auto& row : t.rows) entries += row.distribution.size();
    std::printf("grid %dx%d: cells %zu, table rows %zu, nonzero entries %zu\n", n, n,
                r.sortValues("cell").size(), t.rows.size(), entries);
    std::printf("  load+parse %.4f s, ground %.4f s (%zu instances, %zu ground statements)\n",
                t_load, t_ground, r.stats().ground_instances, r.stats().ground_statements);
    std::printf("  table P(next_cell | do curr_cell, do act_move) %.4f s\n", t_table);
    std::printf("  single query %s = %.6f: first (incl. grounding) %.4f s, cached %.6f s\n",
                q.c_str(), p1, t_first, t_single);
    // learned knowledge: one batch of 100 learned pr-atoms, then re-learning one of them
    std::string learned;
    for (int k = 0; k < 100; ++k)
      learned += "pr(next_cell=" + std::to_string(k + 1) + " | curr_cell=" + std::to_string(k) +
                 ", act_move=right, curr_time=morning) = 0.83.\n";
    sw.reset();
    r.addStatements(learned, "learned");
    double t_add = sw.seconds();
    sw.reset();
    r.addStatements("pr(next_cell=1 | curr_cell=0, act_move=right, curr_time=morning) = 0.8.",
                    "learned");
    double t_relearn = sw.seconds();
    sw.reset();
    krr::plog::Table t2 = r.tableQuery("next_cell", {"curr_cell", "act_move"});
    double t_table2 = sw.seconds();
    std::printf("  addStatements: batch of 100 learned pr-atoms %.4f s, re-learn one %.4f s; "
                "table after learning (re-ground + table) %.4f s (%zu rows)\n",
                t_add, t_relearn, t_table2, t2.rows.size());
    std::printf("  peak RSS %.1f MiB\n", krr::peakRssMiB());
    (void)p2;
  }
  return 0;
}

int main(int argc, char** argv) {
  return krr::guardedMain("bench_plog_nav", mainBody, argc, argv);
}
