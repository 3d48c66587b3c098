#pragma once
// When the gateway dies, the stages it drives must not keep moving: handlers for the fatal signals
// (SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT: on an alternate stack, so a stack overflow is handled too)
// and for std::terminate write HALT to every open controller port (devices/serial/emergency_halt.hpp,
// write(2) only), then let the process die as it would have (the signal's default action, a core
// dump where enabled). SIGKILL cannot be caught: the next start halts what was running first
// (gateway/jobs, restart recovery).

namespace gw {

// Installs the handlers; once per process, before the controllers start.
void install_crash_halt();

}  // namespace gw
