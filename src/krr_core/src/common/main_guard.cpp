#include "krr_core/common/main_guard.h"

#include <cstdio>
#include <exception>
#include <new>

#include "krr_core/common/errors.h"

namespace krr {

int guardedMain(const char* program, int (*body)(int, char**), int argc, char** argv) {
  try {
    return body(argc, argv);
  } catch (const ParseError& e) {
    std::fprintf(stderr, "%s\n", e.what());
  } catch (const Error& e) {
    std::fprintf(stderr, "%s: %s\n", program, e.what());
  } catch (const std::bad_alloc&) {
    // No allocation here: the heap may be exhausted.
    std::fprintf(stderr, "%s: out of memory (the input needs more memory than is available; "
                 "see KRR_MEMORY_BUDGET_MIB)\n", program);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: internal error: %s\n", program, e.what());
  } catch (...) {
    std::fprintf(stderr, "%s: internal error: unknown exception\n", program);
  }
  return 1;
}

}  // namespace krr
