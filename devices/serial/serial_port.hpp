#pragma once
// A tty opened raw (8N1, no flow control: tty_mode.hpp), locked (port_lock.hpp) and wrapped in an
// Asio stream_descriptor so that reads and writes are asynchronous. Opening never blocks (O_NONBLOCK) and the
// descriptor is not made the controlling terminal (O_NOCTTY). Owned by one controller and used only on its
// strand.

#include <cstddef>
#include <cstdint>
#include <string>
#include <sys/types.h>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/posix/stream_descriptor.hpp>
#include <boost/system/error_code.hpp>

namespace gw::devices {

class serial_port {
  public:
    explicit serial_port(const boost::asio::any_io_executor& ex) : stream_(ex) {}
    ~serial_port() { close(); }
    serial_port(const serial_port&) = delete;
    serial_port& operator=(const serial_port&) = delete;

    // Opens `path` at `baud` (9600 .. 115200, also 230400). Closes a previous descriptor first.
    // Takes an exclusive advisory lock (port_lock.hpp) before touching any setting.
    // Errors: the errno of open/tcsetattr, EBUSY when another program holds the lock, or
    // invalid_argument for an unsupported baud rate.
    boost::system::error_code open(const std::string& path, unsigned baud);
    void close();
    // A controller's command port: if the process dies, a fatal-signal handler writes HALT here
    // (emergency_halt.hpp) until the port is closed. False when the crash table is full.
    bool halt_on_crash();
    bool is_open() const { return stream_.is_open(); }

    // Drops bytes received by the kernel but not read yet (tcflush TCIFLUSH); returns how many there
    // were (FIONREAD just before), so a caller can tell a quiet line from one that was talking.
    std::size_t flush_input();

    // True while the node that was opened still exists under `path` (same device number and inode):
    // a vanished or re-created node (an unplugged USB adapter, a re-made pty link) returns false.
    bool still_present(const std::string& path) const;
    // True when `path` names an existing node (a symlink is followed): something to try to open.
    static bool node_exists(const std::string& path);

    boost::asio::posix::stream_descriptor& stream() { return stream_; }

    static bool supported_baud(unsigned baud);

  private:
    boost::asio::posix::stream_descriptor stream_;
    dev_t device_ = 0;
    ino_t inode_ = 0;
    bool in_crash_table_ = false;
};

}  // namespace gw::devices
