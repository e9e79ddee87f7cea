/**
 * @file run_command.h
 * @brief A program run by the shell with its status, stdout and stderr captured: the tests
 * that check programs as a user runs them (exit status, what goes to which stream).
 */
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <string>

#include "krr_core/common/files.h"

namespace krr {
namespace test {

struct CommandOutcome {
  int status = -1;  ///< exit status (-1: killed by a signal)
  std::string out, err;
};

/// @brief Run `command` through the shell with stdout and stderr redirected to
/// `logStem`.out / .err (outside any directory the command works in) and read back.
inline CommandOutcome runCommand(const std::string& command, const std::string& logStem) {
  const std::string cmd = command + " >'" + logStem + ".out' 2>'" + logStem + ".err'";
  CommandOutcome r;
  const int st = std::system(cmd.c_str());
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  r.out = readFile(logStem + ".out");
  r.err = readFile(logStem + ".err");
  return r;
}

}  // namespace test
}  // namespace krr
