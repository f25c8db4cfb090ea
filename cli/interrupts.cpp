// Signal handling for runs (see interrupts.hpp).
#include "interrupts.hpp"

#include <csignal>

namespace parode::cli {
namespace {

volatile std::sig_atomic_t g_signal = 0;

extern "C" void on_signal(int sig) {
    g_signal = sig;
    std::signal(sig, SIG_DFL);  // a second one ends the process
}

using Handler = void (*)(int);
Handler g_old_term = SIG_DFL, g_old_int = SIG_DFL;

}  // namespace

Interrupts::Interrupts() {
    g_signal = 0;
    g_old_term = std::signal(SIGTERM, on_signal);
    g_old_int = std::signal(SIGINT, on_signal);
}

Interrupts::~Interrupts() {
    std::signal(SIGTERM, g_old_term);
    std::signal(SIGINT, g_old_int);
}

bool Interrupts::requested(const Collectives& domain) const {
    double got = g_signal;
    if (domain.distributed()) got = domain.max(got);
    return got != 0;
}

std::string Interrupts::name() const { return g_signal == SIGINT ? "SIGINT" : "SIGTERM"; }

}  // namespace parode::cli
