// ODE's error and debug handlers for the command line. ODE reports a state it
// cannot handle (an internal assertion) by calling these, and aborts if they
// return. The scene reader's bounds (scene/limits.hpp) and the run guard are
// meant to keep every run away from them; should one still be reached, the run
// ends with the simulation-failed exit code and ODE's message instead of a
// SIGABRT and a core dump.
// Trade-off: the process exits from inside ODE (possibly on an OpenMP worker),
// so no report is written and nothing is unwound; that is all a handler that
// must not return can do.
#include <ode/ode.h>
#include <unistd.h>

#include <cstdarg>
#include <cstdio>

#include "cli_common.hpp"
#include "progress.hpp"

namespace parode::cli {
namespace {

[[noreturn]] void stop(int errnum, const char* msg, va_list ap) {
    end_progress_line();
    std::fprintf(stderr, "parode: simulation failed: ODE stopped on an internal check (%d: ", errnum);
    std::vfprintf(stderr, msg, ap);
    std::fprintf(stderr, "); the state left what ODE can integrate; please report the scene\n");
    std::fflush(stderr);
    _exit(kExitSimulation);
}

}  // namespace

void install_ode_handlers() {
    dSetErrorHandler(stop);
    dSetDebugHandler(stop);
}

}  // namespace parode::cli
