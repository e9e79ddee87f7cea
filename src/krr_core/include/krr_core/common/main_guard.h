/**
 * @file main_guard.h
 * @brief The top-level error boundary of the command-line programs.
 *
 * A program must never die of an uncaught exception (abort, core dump, no message): hostile
 * input that slips past a budget can still end in std::bad_alloc. Every main() runs its body
 * through guardedMain, which turns such exceptions into a message on stderr and exit status 1.
 * It is also the one place that reports the core's own errors (krr::Error), so a program's
 * body lets them escape instead of repeating a catch block of its own.
 */
#pragma once

namespace krr {

/**
 * @brief Run body(argc, argv) and return its status. An escaping exception gives status 1 and
 * one line on stderr:
 *  - krr::ParseError: its text as is, "file:line:col: message" (the format editors jump to);
 *  - any other krr::Error: "program: message" (the message names what and where);
 *  - std::bad_alloc: "program: out of memory ...";
 *  - any other exception: "program: internal error: ...".
 */
int guardedMain(const char* program, int (*body)(int, char**), int argc, char** argv);

}  // namespace krr
