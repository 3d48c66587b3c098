#pragma once
// Puts an open tty into the MS-2000's line mode: raw (cfmakeraw), 8N1, no flow control (no CRTSCTS,
// IXON, IXOFF), CLOCAL/CREAD, VMIN 1 / VTIME 0, at a given baud rate (28800 through termios2). Shared
// by serial_port (the driver) and port_probe (discovery), so both talk to a controller the same way.

namespace gw::devices {

// 9600, 19200, 28800, 38400, 57600, 115200 and 230400.
bool supported_tty_baud(unsigned baud);

// The errno on failure (EINVAL for an unsupported rate, ENOTTY for a file that is not a tty), else 0.
int set_raw_mode(int fd, unsigned baud);

}  // namespace gw::devices
