#include "devices/serial/tty_mode.hpp"

#include <cerrno>
#include <termios.h>

#include "devices/serial/custom_baud.hpp"

namespace gw::devices {
namespace {

speed_t speed_constant(unsigned baud) {
    switch (baud) {
        case 9600:
            return B9600;
        case 19200:
            return B19200;
        case 38400:
            return B38400;
        case 57600:
            return B57600;
        case 115200:
            return B115200;
        case 230400:
            return B230400;
        default:
            return B0;
    }
}

}  // namespace

bool supported_tty_baud(unsigned baud) {
    // 28800 (an MS-2000 DIP switch setting) has no Bxxx constant; it is set through termios2.
    return baud == 28800 || speed_constant(baud) != B0;
}

int set_raw_mode(int fd, unsigned baud) {
    if (!supported_tty_baud(baud)) return EINVAL;
    termios tio{};
    if (::tcgetattr(fd, &tio) != 0) return errno;
    ::cfmakeraw(&tio);
    tio.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | PARENB | CSIZE | CRTSCTS);
    tio.c_cflag |= CS8 | CLOCAL | CREAD;
    tio.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
    tio.c_cc[VMIN] = 1;
    tio.c_cc[VTIME] = 0;
    // 28800 has no Bxxx constant: set a standard rate first, then the real one through termios2.
    const speed_t speed = baud == 28800 ? B38400 : speed_constant(baud);
    if (::cfsetispeed(&tio, speed) != 0 || ::cfsetospeed(&tio, speed) != 0) return errno;
    if (::tcsetattr(fd, TCSANOW, &tio) != 0) return errno;
    if (baud == 28800) return set_custom_baud(fd, baud);
    return 0;
}

}  // namespace gw::devices
