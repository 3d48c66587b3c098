#include "api/app/crash_halt.hpp"

#include <csignal>
#include <cstdlib>
#include <exception>
#include <vector>

#include "devices/serial/emergency_halt.hpp"

namespace gw {

namespace {

constexpr int fatal_signals[] = {SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT};

extern "C" void on_fatal_signal(int signal) {
    devices::emergency_halt::halt_every_open_port();
    // Die as the signal would have: the default action, raised again once this handler returns.
    std::signal(signal, SIG_DFL);
    std::raise(signal);
}

[[noreturn]] void on_terminate() {
    devices::emergency_halt::halt_every_open_port();
    std::abort();  // SIGABRT's handler writes HALT once more: harmless
}

}  // namespace

void install_crash_halt() {
    // An alternate stack, so that a stack overflow (SIGSEGV on a guard page) still runs the handler.
    static std::vector<char> alt_stack(static_cast<std::size_t>(SIGSTKSZ) * 4);
    stack_t ss{};
    ss.ss_sp = alt_stack.data();
    ss.ss_size = alt_stack.size();
    ::sigaltstack(&ss, nullptr);
    struct sigaction sa {};
    sa.sa_handler = on_fatal_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_ONSTACK | SA_RESETHAND;
    for (const int s : fatal_signals)
        ::sigaction(s, &sa, nullptr);
    std::set_terminate(on_terminate);
}

}  // namespace gw
