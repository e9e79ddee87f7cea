/**
 * @file parallel.h
 * @brief Independent trials on a pool of threads. Results are stored by trial index, so the
 * output does not depend on the number of threads (each trial seeds itself from its index).
 */
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace krr {

/**
 * @brief Run trials 0..count-1 on up to `threads` threads and return their results in order.
 * @param make_worker called once per thread (inside it, so per-thread state such as a parsed
 *        knowledge base is built in parallel and its errors are caught); returns a callable
 *        `Result(std::size_t k)` that runs trial k.
 * The first exception thrown by any thread stops the others and is rethrown here.
 */
template <class Result, class MakeWorker>
std::vector<Result> runParallelTrials(std::size_t count, std::size_t threads,
                                      MakeWorker make_worker) {
  std::vector<Result> out(count);
  if (count == 0) return out;
  threads = std::max<std::size_t>(1, std::min(threads, count));
  std::atomic<std::size_t> next{0};
  std::exception_ptr failure;
  std::mutex mu;
  auto body = [&]() {
    try {
      auto run = make_worker();
      for (std::size_t k = next++; k < count; k = next++) out[k] = run(k);
    } catch (...) {
      std::lock_guard<std::mutex> lock(mu);
      if (!failure) failure = std::current_exception();
      next = count;
    }
  };
  if (threads == 1) {
    body();
  } else {
    std::vector<std::thread> pool;
    for (std::size_t t = 0; t < threads; ++t) pool.emplace_back(body);
    for (auto& t : pool) t.join();
  }
  if (failure) std::rethrow_exception(failure);
  return out;
}

}  // namespace krr
