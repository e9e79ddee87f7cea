/**
 * @file resources.h
 * @brief Wall-clock timing and peak memory, for the benchmarks.
 */
#pragma once

#include <chrono>
#include <cstddef>

namespace krr {

/// @brief Seconds since construction, on a monotonic clock.
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  void reset() { start_ = std::chrono::steady_clock::now(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

/// @brief CPU seconds of the calling thread: on a shared machine the figure that does not
/// depend on the load (wall time over-states the cost).
double threadCpuSeconds();

/// @brief Peak resident set size of this process so far, in MiB (from getrusage).
double peakRssMiB();

/// @brief Bytes of the C++ heap in use by this process now (glibc mallinfo2: allocated chunks
/// of every arena plus mmapped blocks). Cheap enough to call every thousand statements; the
/// memory budgets of the loaders measure their growth with it.
std::size_t heapBytesInUse();

}  // namespace krr
