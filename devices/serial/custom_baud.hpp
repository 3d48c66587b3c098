#pragma once
// Sets a baud rate that has no Bxxx constant (the MS-2000's 28800) through Linux's termios2/BOTHER.
// Kept apart from serial_port.cpp because <asm/termbits.h> and <termios.h> cannot share a file.

namespace gw::devices {

// Applies `baud` to the open tty `fd` on top of its current settings; the errno on failure, else 0.
int set_custom_baud(int fd, unsigned baud);

}  // namespace gw::devices
