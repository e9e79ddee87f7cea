/**
 * @file bench_value_iteration.cpp
 * @brief State-action updates per second (one thread) of value iteration on random navigation
 * grids, and time to converge (gamma 0.95, epsilon 1e-6), for every model layout:
 *  - sparse        valueIteration(SparseModel): CSR input, sweep layout built on each call
 *  - sweep<double> valueIteration(SweepModel) on a prebuilt layout, double storage
 *  - sweep<float>  the same with float storage
 *  - grid<double>, grid<float>  the grid-specialised layout
 * Each figure is measured `repeats` times; the best and the median are printed (the machine is
 * shared, so the best is the closest to the code's own speed). Rates use this thread's CPU
 * time (wall time is printed too). Convergence is timed on 50x50 and 500x500 (and any size
 * given with --converge). Ends with the peak resident set size.
 *
 * Usage: bench_value_iteration [--max-side N=1000] [--seed S=1] [--repeats R=3]
 *                              [--sizes 30,50,200,500,1000] [--converge 50,500]
 * KRR_MDP_ISA=generic in the environment selects the portable kernels.
 */
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "krr_core/common/cli.h"
#include "krr_core/common/random.h"
#include "krr_core/common/resources.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/solvers.h"

using namespace krr;
using namespace krr::mdp;

namespace {

struct Stats {
  double best = 0.0, median = 0.0;
};

/// Best (lowest) and median of a set of times.
Stats stats(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return Stats{v.front(), v[v.size() / 2]};
}

struct Instance {
  GridDynamics dyn;
  StateId goal;
};

Instance makeInstance(std::uint32_t side, std::uint64_t seed) {
  Rng rng = makeRng(seed, "bench_vi", side);
  RandomGridOptions o;
  o.obstacle_density = 0.1;
  o.trap_areas = std::max<std::uint32_t>(4, side * side / 2500);
  o.trap_size = std::max<std::uint32_t>(3, side / 20);
  const StateId goal = side * side - 1;
  Instance in{makeRandomGridDynamics(side, side, o, {0, goal}, rng), goal};
  return in;
}

/// Runs exactly `sweeps` sweeps (in solves of at most 100 sweeps, restarted from the cold
/// start long before the values reach their floating-point fixed point) and returns
/// {cpu seconds, wall seconds}.
template <class M>
std::pair<double, double> timeSweeps(const M& m, std::size_t sweeps) {
  SolverOptions o;
  o.epsilon = 1e-300;
  const double c0 = threadCpuSeconds();
  Stopwatch sw;
  for (std::size_t done = 0; done < sweeps; done += o.max_iterations) {
    o.max_iterations = std::min<std::size_t>(100, sweeps - done);
    Solution s = valueIteration(m, o);
    if (s.iterations != o.max_iterations) std::printf("# warning: stopped early\n");
  }
  return {threadCpuSeconds() - c0, sw.seconds()};
}

template <class M>
void reportRate(const char* layout, std::uint32_t side, const M& m, std::size_t pairs,
                int repeats) {
  // About 3e8 updates per measurement (at least 8 sweeps), after one warm-up solve.
  const std::size_t sweeps = std::max<std::size_t>(8, 300000000 / pairs);
  timeSweeps(m, std::min<std::size_t>(sweeps, 8));
  std::vector<double> cpu, wall;
  for (int r = 0; r < repeats; ++r) {
    auto t = timeSweeps(m, sweeps);
    cpu.push_back(t.first);
    wall.push_back(t.second);
  }
  const double n = static_cast<double>(pairs) * static_cast<double>(sweeps) / 1e9;
  const Stats c = stats(cpu), w = stats(wall);
  std::printf("rate     %-14s %5ux%-5u sweeps %6zu  cpu best %6.2f median %6.2f e9 updates/s"
              "  (wall best %6.2f median %6.2f)\n",
              layout, side, side, sweeps, n / c.best, n / c.median, n / w.best, n / w.median);
  std::fflush(stdout);
}

template <class M>
void reportConvergence(const char* layout, std::uint32_t side, const M& m, int repeats) {
  SolverOptions o;
  o.epsilon = 1e-6;
  Solution sol = valueIteration(m, o);  // warm the caches
  const int inner = side <= 100 ? 20 : 1;
  std::vector<double> cpu, wall;
  for (int r = 0; r < repeats; ++r) {
    const double c0 = threadCpuSeconds();
    Stopwatch sw;
    for (int i = 0; i < inner; ++i) sol = valueIteration(m, o);
    cpu.push_back((threadCpuSeconds() - c0) / inner);
    wall.push_back(sw.seconds() / inner);
  }
  const Stats c = stats(cpu), w = stats(wall);
  std::printf("converge %-14s %5ux%-5u converged=%d sweeps %4zu  cpu best %9.3f median %9.3f ms"
              "  (wall best %9.3f median %9.3f ms)  V(start)=%.6f\n",
              layout, side, side, sol.converged ? 1 : 0, sol.iterations, c.best * 1e3,
              c.median * 1e3, w.best * 1e3, w.median * 1e3, sol.values[0]);
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  std::uint32_t max_side = 1000;
  std::uint64_t seed = 1;
  int repeats = 3;
  std::vector<std::uint32_t> sizes = {30, 50, 200, 500, 1000}, converge = {50, 500};
  const auto sideList = [](std::vector<std::uint32_t>* target, const char* option) {
    return [target, option](const std::string& v) {
      target->clear();
      for (std::size_t n : parseCountListOption(option, v))
        target->push_back(static_cast<std::uint32_t>(n));
    };
  };
  OptionParser cli("bench_value_iteration",
                   "State-action updates per second of value iteration on random navigation\n"
                   "grids, and time to converge, for every model layout. KRR_MDP_ISA=generic in\n"
                   "the environment selects the portable kernels.");
  cli.add("--max-side", "N", "skip grids with a larger side", &max_side);
  cli.add("--seed", "S", "seed of the random grids", &seed);
  cli.add("--repeats", "R", "measurements per figure (best and median printed)", &repeats);
  cli.add("--sizes", "a,b,..", "grid sides", sideList(&sizes, "--sizes"), "30,50,200,500,1000");
  cli.add("--converge", "a,b,..", "sides whose convergence is timed",
          sideList(&converge, "--converge"), "50,500");
  if (const auto status = cli.parse(argc, argv)) return *status;
  repeats = std::max(1, repeats);
  const NavigationReward reward;
  const char* isa = std::getenv("KRR_MDP_ISA");
  std::printf("# value iteration, one thread; 4 actions, <= 6 outcomes per action; kernels: %s\n",
              isa != nullptr ? isa : "default (AVX2+FMA when available)");
  std::printf("# updates counted over non-terminal (cell, action) pairs; %d repeats\n", repeats);
  for (std::uint32_t side : sizes) {
    if (side > max_side) continue;
    Instance in = makeInstance(side, seed);
    GridModel g = makeNavigationGridModel(in.dyn, {in.goal}, reward, 0.95);
    GridModelF gf = makeNavigationGridModelF(in.dyn, {in.goal}, reward, 0.95);
    std::size_t pairs = 0;
    for (StateId c = 0; c < g.numCells(); ++c) pairs += g.isTerminal(c) ? 0 : 4;
    const bool conv = std::find(converge.begin(), converge.end(), side) != converge.end();
    reportRate("grid<double>", side, g, pairs, repeats);
    reportRate("grid<float>", side, gf, pairs, repeats);
    if (conv) {
      reportConvergence("grid<double>", side, g, repeats);
      reportConvergence("grid<float>", side, gf, repeats);
    }
    {
      SparseModel s = g.toSparse();
      Stopwatch sw;
      SweepModel sd(s);
      const double build_d = sw.seconds();
      sw.reset();
      SweepModelF sf(s);
      const double build_f = sw.seconds();
      std::printf("# %ux%u: CSR nnz %zu (%.1f MiB); sweep layout K=%zu bandwidth %zu, "
                  "%.1f MiB double (built in %.1f ms) / %.1f MiB float (%.1f ms)\n",
                  side, side, s.numTransitions(),
                  s.numTransitions() * (sizeof(double) + sizeof(StateId)) / 1048576.0,
                  sd.successorsPerState(), sd.bandwidth(), sd.bytes() / 1048576.0,
                  build_d * 1e3, sf.bytes() / 1048576.0, build_f * 1e3);
      reportRate("sparse", side, s, pairs, repeats);
      reportRate("sweep<double>", side, sd, pairs, repeats);
      reportRate("sweep<float>", side, sf, pairs, repeats);
      if (conv) {
        reportConvergence("sparse", side, s, repeats);
        reportConvergence("sweep<double>", side, sd, repeats);
        reportConvergence("sweep<float>", side, sf, repeats);
      }
    }
  }
  std::printf("# peak RSS %.0f MiB\n", peakRssMiB());
  return 0;
}
