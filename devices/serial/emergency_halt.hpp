#pragma once
// The last resort when the process dies: every open controller port, by file descriptor, in a fixed
// table that a fatal-signal handler can walk. serial_port registers a port once it is open and
// removes it before it is closed (so a descriptor number reused by something else is never written).
// halt_every_open_port() writes HALT ("\" CR) to each with write(2): async-signal-safe, no locks, no
// allocation. api/app installs the handlers (crash_halt.hpp).

namespace gw::devices::emergency_halt {

// At most this many ports at once; beyond it a port is not covered (logged by serial_port).
inline constexpr int max_ports = 256;

// False when the table is full.
bool add_port(int fd);
void remove_port(int fd);
// From a signal handler (or anywhere): HALT to every open port. Returns how many writes went out.
int halt_every_open_port();

}  // namespace gw::devices::emergency_halt
