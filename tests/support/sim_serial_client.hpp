#pragma once
// A blocking serial client for integration tests of the simulator: opens a port path (the pty
// symlink) raw, 8N1, like pyserial or Micro-Manager would, and reads with generous timeouts.

#include <chrono>
#include <optional>
#include <string>

namespace gw::tests {

class sim_serial_client {
  public:
    // Throws std::system_error when the path cannot be opened.
    explicit sim_serial_client(const std::string& path);
    ~sim_serial_client();
    sim_serial_client(const sim_serial_client&) = delete;
    sim_serial_client& operator=(const sim_serial_client&) = delete;

    void write(const std::string& bytes);
    // Reads until `terminator` has been received (inclusive) or the timeout passes; nullopt on
    // timeout. Bytes after the terminator stay buffered for the next call.
    std::optional<std::string> read_until(const std::string& terminator,
                                          std::chrono::milliseconds timeout = std::chrono::seconds(5));
    // "CMD" -> writes "CMD\r", returns the reply line with its CR LF (nullopt on timeout).
    std::optional<std::string> command(const std::string& line,
                                       std::chrono::milliseconds timeout = std::chrono::seconds(5));
    // Whatever arrives within `window` (may be empty).
    std::string drain(std::chrono::milliseconds window);
    // Waits for the port to report hang-up/EIO (after unplug); true if it did within the timeout.
    bool wait_for_hangup(std::chrono::milliseconds timeout = std::chrono::seconds(5));

    int fd() const { return fd_; }

  private:
    int fd_ = -1;
    std::string buffer_;
};

}  // namespace gw::tests
