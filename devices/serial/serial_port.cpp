#include "devices/serial/serial_port.hpp"

#include <cerrno>
#include <fcntl.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include "devices/serial/emergency_halt.hpp"
#include "devices/serial/port_lock.hpp"
#include "devices/serial/tty_mode.hpp"

namespace gw::devices {
namespace {

boost::system::error_code errno_code(int err) {
    return {err, boost::system::system_category()};
}

}  // namespace

bool serial_port::supported_baud(unsigned baud) {
    return supported_tty_baud(baud);
}

boost::system::error_code serial_port::open(const std::string& path, unsigned baud) {
    close();
    if (!supported_baud(baud))
        return boost::system::errc::make_error_code(boost::system::errc::invalid_argument);

    const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return errno_code(errno);
    auto fail = [fd](int err) {
        ::close(fd);
        return errno_code(err);
    };
    // Before any setting changes: a port another gateway or a probe holds is left alone (EBUSY).
    if (const int err = lock_port(fd); err != 0) return fail(err);
    if (const int err = set_raw_mode(fd, baud); err != 0) return fail(err);
    ::tcflush(fd, TCIOFLUSH);

    struct stat st {};
    if (::fstat(fd, &st) == 0) {
        device_ = st.st_rdev;
        inode_ = st.st_ino;
    }

    boost::system::error_code ec;
    stream_.assign(fd, ec);
    if (ec) {
        ::close(fd);
        return ec;
    }
    return ec;
}

bool serial_port::halt_on_crash() {
    if (!stream_.is_open() || in_crash_table_) return in_crash_table_;
    in_crash_table_ = emergency_halt::add_port(stream_.native_handle());
    return in_crash_table_;
}

void serial_port::close() {
    boost::system::error_code ignored;
    if (!stream_.is_open()) return;
    if (in_crash_table_) emergency_halt::remove_port(stream_.native_handle());  // before the number is free
    in_crash_table_ = false;
    stream_.close(ignored);
}

std::size_t serial_port::flush_input() {
    if (!stream_.is_open()) return 0;
    // Flushed even when FIONREAD counts nothing: bytes still in the tty's flip buffer (a pty's, a
    // UART driver's) are not counted yet, but the flush drops them too.
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
