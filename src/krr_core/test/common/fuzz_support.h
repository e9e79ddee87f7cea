/**
 * @file fuzz_support.h
 * @brief Seeded, bounded fuzzing of the file loaders in a forked, memory-limited child.
 *
 * A loader bug can be a signal (SIGSEGV, SIGFPE), a hang or a runaway allocation; none of these
 * may take the test binary down with it. So the mutants run in a child process with an
 * RLIMIT_AS cap; the child reports the index of each mutant before it tries it, and the parent
 * turns a signal, an unexpected exception or a mutant that makes no progress within its time
 * budget into a test failure that names the mutant and saves it for replay.
 */
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

namespace krr {
namespace fuzz {

/// @brief Numbers that stress size checks and arithmetic when spliced into a file.
inline const std::vector<std::string>& hostileNumbers() {
  static const std::vector<std::string> v = {
      "0", "-1", "1", "2", "65535", "65536", "100000", "50000", "12000", "99999999",
      "4294967296", "9223372036854775807", "18446744073709551616", "1e308", "-0", "nan",
      "0.5", "1.0000001", "2147483648", "-2147483649"};
  return v;
}

/// @brief A deterministic mutant of `seed_text`: one to four byte-, token- or line-level edits.
inline std::string mutate(const std::string& seed_text, std::mt19937_64& rng,
                          const std::vector<std::string>& dictionary) {
  std::string s = seed_text;
  auto pick = [&](std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(rng() % n); };
  const int edits = 1 + static_cast<int>(rng() % 4);
  for (int e = 0; e < edits; ++e) {
    const std::size_t pos = pick(s.size() + 1);
    switch (rng() % 8) {
      case 0:  // flip a byte
        if (!s.empty()) s[pick(s.size())] = static_cast<char>(rng() & 0xff);
        break;
      case 1:  // delete a range
        if (!s.empty()) s.erase(pick(s.size()), 1 + pick(16));
        break;
      case 2:  // duplicate a range (repeats statements, grows lists)
        if (!s.empty()) {
          const std::size_t from = pick(s.size());
          s.insert(pos, s.substr(from, 1 + pick(64)));
        }
        break;
      case 3: {  // replace a digit run with a hostile number
        const std::size_t d = s.find_first_of("0123456789", pos);
        if (d != std::string::npos) {
          const std::size_t end = s.find_first_not_of("0123456789.", d);
          const auto& h = hostileNumbers();
          s.replace(d, (end == std::string::npos ? s.size() : end) - d, h[pick(h.size())]);
        }
        break;
      }
      case 4:  // insert a dictionary token
        if (!dictionary.empty()) s.insert(pos, dictionary[pick(dictionary.size())]);
        break;
      case 5:  // insert a hostile number
        s.insert(pos, " " + hostileNumbers()[pick(hostileNumbers().size())] + " ");
        break;
      case 6: {  // swap two lines' worth of text by moving a chunk
        if (s.size() > 2) {
          const std::size_t a = pick(s.size()), n = 1 + pick(40);
          const std::string chunk = s.substr(a, n);
          s.erase(a, n);
          s.insert(pick(s.size() + 1), chunk);
        }
        break;
      }
      default:  // truncate
        s.resize(pick(s.size() + 1));
        break;
    }
  }
  return s;
}

/// @brief Outcome of a fuzz campaign.
struct Report {
  std::size_t mutants = 0;   ///< mutants tried
  int failed_index = -1;     ///< index of the mutant that crashed / hung / escaped, or -1
  std::string failure;       ///< what happened to it
};

/**
 * @brief Run check(i) for i in [0, count) in forked children capped at `extra_as_bytes` of
 * address space above the parent's current size. check must return normally (typed errors are
 * caught inside it); an escaping exception, a signal or more than `mutant_seconds` without
 * progress ends the campaign with failed_index set.
 */
inline Report runIsolated(std::size_t count, const std::function<void(std::size_t)>& check,
                          std::size_t extra_as_bytes, double mutant_seconds) {
  Report rep;
  std::size_t next = 0;
  long vm_pages = 0;
  {
    std::ifstream statm("/proc/self/statm");
    statm >> vm_pages;
  }
  const rlim_t page = static_cast<rlim_t>(::sysconf(_SC_PAGESIZE));
  const rlim_t as_cap = static_cast<rlim_t>(vm_pages) * page + static_cast<rlim_t>(extra_as_bytes);
  while (next < count) {
    int fds[2];
    if (::pipe(fds) != 0) {
      rep.failure = "pipe failed";
      rep.failed_index = static_cast<int>(next);
      return rep;
    }
    std::fflush(nullptr);
    const pid_t pid = ::fork();
    if (pid == 0) {
      ::close(fds[0]);
      struct rlimit rl {as_cap, as_cap};
      ::setrlimit(RLIMIT_AS, &rl);
      for (std::size_t i = next; i < count; ++i) {
        const std::uint32_t idx = static_cast<std::uint32_t>(i);
        if (::write(fds[1], &idx, sizeof idx) != sizeof idx) ::_exit(4);
        try {
          check(i);
        } catch (const std::exception& e) {
          std::fprintf(stderr, "mutant %zu: escaped exception: %s\n", i, e.what());
          ::_exit(3);
        } catch (...) {
          ::_exit(3);
        }
      }
      ::_exit(0);
    }
    ::close(fds[1]);
    std::size_t current = next;
    bool started = false, hung = false;
    for (;;) {
      struct pollfd p {fds[0], POLLIN, 0};
      const int r = ::poll(&p, 1, static_cast<int>(mutant_seconds * 1000.0));
      if (r == 0) {  // no progress: the current mutant hangs
        hung = true;
        ::kill(pid, SIGKILL);
        break;
      }
      std::uint32_t idx = 0;
      const ssize_t n = ::read(fds[0], &idx, sizeof idx);
      if (n != static_cast<ssize_t>(sizeof idx)) break;  // child finished or died
      current = idx;
      started = true;
      ++rep.mutants;
    }
    ::close(fds[0]);
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (!hung && WIFEXITED(status) && WEXITSTATUS(status) == 0) return rep;
    rep.failed_index = started ? static_cast<int>(current) : static_cast<int>(next);
    if (hung) {
      rep.failure = "no result within " + std::to_string(mutant_seconds) + " s (hang)";
    } else if (WIFSIGNALED(status)) {
      rep.failure = "killed by signal " + std::to_string(WTERMSIG(status));
    } else {
      rep.failure = "exit status " + std::to_string(WEXITSTATUS(status)) +
                    " (exception escaped, see stderr)";
    }
    return rep;
  }
  return rep;
}

}  // namespace fuzz
}  // namespace krr
