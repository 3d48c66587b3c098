#include "devices/serial/serial_port.hpp"

#include <cerrno>
#include <fcntl.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

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

boost::system::error_code last_errno() {
    return {errno, boost::system::system_category()};
}

}  // namespace

bool serial_port::supported_baud(unsigned baud) {
    // 28800 (an MS-2000 DIP switch setting) has no Bxxx constant; it is set through termios2.
    return baud == 28800 || speed_constant(baud) != B0;
}

boost::system::error_code serial_port::open(const std::string& path, unsigned baud) {
    close();
    if (!supported_baud(baud))
        return boost::system::errc::make_error_code(boost::system::errc::invalid_argument);

    const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return last_errno();

    auto fail = [fd] {
        auto ec = last_errno();
        ::close(fd);
        return ec;
    };

    termios tio{};
    if (::tcgetattr(fd, &tio) != 0) return fail();
    ::cfmakeraw(&tio);
    tio.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | PARENB | CSIZE | CRTSCTS);
    tio.c_cflag |= CS8 | CLOCAL | CREAD;
    tio.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
    tio.c_cc[VMIN] = 1;
    tio.c_cc[VTIME] = 0;
    // 28800 has no Bxxx constant: set a standard rate first, then the real one through termios2.
    const speed_t speed = baud == 28800 ? B38400 : speed_constant(baud);
    if (::cfsetispeed(&tio, speed) != 0 || ::cfsetospeed(&tio, speed) != 0) return fail();
    if (::tcsetattr(fd, TCSANOW, &tio) != 0) return fail();
    if (baud == 28800) {
        if (const int err = set_custom_baud(fd, baud); err != 0) {
            ::close(fd);
            return {err, boost::system::system_category()};
        }
    }
    ::tcflush(fd, TCIOFLUSH);

    struct stat st {};
    if (::fstat(fd, &st) == 0) {
        device_ = st.st_rdev;
        inode_ = st.st_ino;
    }

    boost::system::error_code ec;
    stream_.assign(fd, ec);
    if (ec) ::close(fd);
    return ec;
}

void serial_port::close() {
    boost::system::error_code ignored;
    if (stream_.is_open()) stream_.close(ignored);
}

std::size_t serial_port::flush_input() {
    if (!stream_.is_open()) return 0;
    int pending = 0;
    if (::ioctl(stream_.native_handle(), FIONREAD, &pending) != 0) pending = 0;
    ::tcflush(stream_.native_handle(), TCIFLUSH);
    return pending > 0 ? static_cast<std::size_t>(pending) : 0;
}

bool serial_port::node_exists(const std::string& path) {
    struct stat st {};
    return ::stat(path.c_str(), &st) == 0;
}

bool serial_port::still_present(const std::string& path) const {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return false;
    return st.st_rdev == device_ && st.st_ino == inode_;
}

}  // namespace gw::devices
