/**
 * @file bench_value_iteration.cpp
 * @brief State-action updates per second (one thread) of value iteration on random navigation
 * grids, for the general SparseModel layout and the grid layouts (double and float storage),
 * and time to converge (gamma 0.95, epsilon 1e-6) on 50x50 and 500x500.
 *
 * Usage: bench_value_iteration [max_side=1000] [seed=1]
 */
#include <algorithm>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "krr_core/common/random.h"
#include "krr_core/common/resources.h"
#include "krr_core/mdp/navigation_task.h"
#include "krr_core/mdp/solvers.h"

using namespace krr;
using namespace krr::mdp;

namespace {

/// CPU seconds of this thread: the machine is shared, so wall time over-states the cost.
double cpuSeconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
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

/// Runs exactly `sweeps` sweeps and returns seconds. Solves restart from zeros every 100 sweeps,
/// long before the values reach their floating-point fixed point (which would stop early).
template <class M>
double timeSweeps(const M& m, std::size_t sweeps, Solution* out, double* cpu) {
  SolverOptions o;
  o.epsilon = 1e-300;
  const double c0 = cpuSeconds();
  Stopwatch sw;
  for (std::size_t done = 0; done < sweeps; done += o.max_iterations) {
    o.max_iterations = std::min<std::size_t>(100, sweeps - done);
    *out = valueIteration(m, o);
    if (out->iterations != o.max_iterations) std::printf("# warning: stopped early\n");
  }
  *cpu = cpuSeconds() - c0;
  return sw.seconds();
}

template <class M>
void reportRate(const char* layout, std::uint32_t side, const M& m, std::size_t pairs) {
  // About 3e8 updates per measurement (at least 3 sweeps), after one warm-up sweep.
  const std::size_t sweeps = std::max<std::size_t>(3, 300000000 / pairs);
  Solution sol;
  double cpu = 0.0;
  timeSweeps(m, 1, &sol, &cpu);
  const double t = timeSweeps(m, sweeps, &sol, &cpu);
  const double n = static_cast<double>(pairs) * static_cast<double>(sweeps);
  std::printf("%-12s %5ux%-5u sweeps %5zu  wall %7.3f s %6.2f e9/s   cpu %7.3f s %6.2f e9 "
              "state-action updates/s\n",
              layout, side, side, sweeps, t, n / t / 1e9, cpu, n / cpu / 1e9);
}

template <class M>
void reportConvergence(const char* layout, std::uint32_t side, const M& m, StateId start) {
  SolverOptions o;
  o.epsilon = 1e-6;
  Solution sol;
  valueIteration(m, o);  // warm caches
  const int reps = side <= 100 ? 20 : 1;
  const double c0 = cpuSeconds();
  Stopwatch sw;
  for (int r = 0; r < reps; ++r) sol = valueIteration(m, o);
  const double t = sw.seconds() / reps, cpu = (cpuSeconds() - c0) / reps;
  std::printf("%-12s %5ux%-5u converged=%d sweeps %4zu residual %.2e  wall %9.3f ms  cpu %9.3f "
              "ms  V(start)=%.6f\n",
              layout, side, side, sol.converged ? 1 : 0, sol.iterations, sol.residual, t * 1e3,
              cpu * 1e3, sol.values[start]);
}

}  // namespace

int main(int argc, char** argv) {
  const std::uint32_t max_side = argc > 1 ? static_cast<std::uint32_t>(std::atoi(argv[1])) : 1000;
  const std::uint64_t seed = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 1;
  const NavigationReward reward;
  std::printf("# value iteration throughput, one thread; 4 actions, <= 6 outcomes per action\n");
  std::printf("# updates counted over non-terminal (cell, action) pairs\n");
  for (std::uint32_t side : {30u, 50u, 200u, 500u, 1000u}) {
    if (side > max_side) break;
    Instance in = makeInstance(side, seed);
    GridModel g = makeNavigationGridModel(in.dyn, {in.goal}, reward, 0.95);
    GridModelF gf = makeNavigationGridModelF(in.dyn, {in.goal}, reward, 0.95);
    std::size_t pairs = 0;
    for (StateId c = 0; c < g.numCells(); ++c) pairs += g.isTerminal(c) ? 0 : 4;
    reportRate("grid<double>", side, g, pairs);
    reportRate("grid<float>", side, gf, pairs);
    {
      SparseModel s = g.toSparse();
      std::printf("# sparse nnz %zu\n", s.numTransitions());
      reportRate("sparse", side, s, pairs);
      if (side == 50 || side == 500) {
        reportConvergence("sparse", side, s, 0);
        reportConvergence("grid<double>", side, g, 0);
        reportConvergence("grid<float>", side, gf, 0);
      }
    }
  }
  std::printf("# peak RSS %.0f MiB\n", peakRssMiB());
  return 0;
}
