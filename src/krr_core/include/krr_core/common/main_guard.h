/**
 * @file main_guard.h
 * @brief The top-level error boundary of the command-line programs.
 *
 * A program must never die of an uncaught exception (abort, core dump, no message): hostile
 * input that slips past a budget can still end in std::bad_alloc. Every main() runs its body
 * through guardedMain, which turns such exceptions into a message on stderr and exit status 1.
 */
#pragma once

namespace krr {

/**
 * @brief Run body(argc, argv) and return its status; std::bad_alloc and any other escaping
 * std::exception are reported on stderr as "program: ..." and give status 1.
 */
int guardedMain(const char* program, int (*body)(int, char**), int argc, char** argv);

}  // namespace krr
