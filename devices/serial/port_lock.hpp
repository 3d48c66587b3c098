#pragma once
// Who else holds a serial port. The driver and the port probe take an advisory exclusive lock
// (flock, as pyserial's exclusive=True and other gateways do) on every port they open, so a second
// gateway or a probe never talks into a link that is in use; the probe also honours the other ways a
// program claims a tty: exclusive mode (TIOCEXCL, e.g. minicom, screen), a UUCP lock file
// (/run/lock/LCK..ttyUSB0) and, for hardware ports, any other process that has the node open.

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace gw::devices {

// flock(LOCK_EX | LOCK_NB) on `fd`: 0, EBUSY when another open file holds the lock, or the errno.
// Released when the descriptor is closed (also when the process dies).
int lock_port(int fd);

// True when another program put the tty into exclusive mode (TIOCEXCL): root may still open it, but
// must not use it.
bool tty_in_exclusive_mode(int fd);

// A live UUCP-style lock file for the device (/run/lock/LCK..ttyUSB0, /var/lock/LCK..ttyUSB0):
// "lock file /run/lock/LCK..ttyUSB0 (pid 123)"; nullopt when there is none or its process is gone.
std::optional<std::string> uucp_lock_holder(const std::string& device_path);

// For each of `devices` (canonical node paths) that another process has open: "pid 123 (screen)".
// Reads /proc/<pid>/fd (as far as this user may: root sees every process). Pseudo-terminal slaves
// are left out: the program that made one (a simulator) holds it open by design.
std::map<std::string, std::string> open_elsewhere(const std::vector<std::string>& devices);

}  // namespace gw::devices
