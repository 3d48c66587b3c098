#include "tests/support/sim_serial_client.hpp"

#include <cerrno>
#include <fcntl.h>
#include <poll.h>
#include <system_error>
#include <termios.h>
#include <unistd.h>

namespace gw::tests {

using clock = std::chrono::steady_clock;

sim_serial_client::sim_serial_client(const std::string& path) {
    fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) throw std::system_error(errno, std::generic_category(), "open " + path);
    termios tio{};
    if (::tcgetattr(fd_, &tio) == 0) {
        ::cfmakeraw(&tio);
        ::cfsetispeed(&tio, B115200);
        ::cfsetospeed(&tio, B115200);
        tio.c_cflag |= CLOCAL | CREAD;
        ::tcsetattr(fd_, TCSANOW, &tio);
    }
}

sim_serial_client::~sim_serial_client() {
    if (fd_ >= 0) ::close(fd_);
}

void sim_serial_client::write(const std::string& bytes) {
    std::size_t done = 0;
    const auto deadline = clock::now() + std::chrono::seconds(5);
    while (done < bytes.size() && clock::now() < deadline) {
        const auto n = ::write(fd_, bytes.data() + done, bytes.size() - done);
        if (n > 0) {
            done += static_cast<std::size_t>(n);
        } else if (n < 0 && errno != EAGAIN && errno != EINTR) {
            throw std::system_error(errno, std::generic_category(), "write");
        } else {
            pollfd p{fd_, POLLOUT, 0};
            ::poll(&p, 1, 50);
        }
    }
}

std::optional<std::string> sim_serial_client::read_until(const std::string& terminator,
                                                         std::chrono::milliseconds timeout) {
    const auto deadline = clock::now() + timeout;
    while (true) {
        if (const auto pos = buffer_.find(terminator); pos != std::string::npos) {
            auto out = buffer_.substr(0, pos + terminator.size());
            buffer_.erase(0, pos + terminator.size());
            return out;
        }
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - clock::now());
        if (left.count() <= 0) return std::nullopt;
        pollfd p{fd_, POLLIN, 0};
        const int r = ::poll(&p, 1, static_cast<int>(left.count()));
        if (r <= 0) continue;
        char chunk[512];
        const auto n = ::read(fd_, chunk, sizeof chunk);
        if (n > 0)
            buffer_.append(chunk, static_cast<std::size_t>(n));
        else if (n < 0 && errno != EAGAIN && errno != EINTR)
            return std::nullopt;
        else if (n == 0)
            return std::nullopt;
    }
}

std::optional<std::string> sim_serial_client::command(const std::string& line,
                                                      std::chrono::milliseconds timeout) {
    write(line + "\r");
    return read_until("\r\n", timeout);
}

std::string sim_serial_client::drain(std::chrono::milliseconds window) {
    const auto deadline = clock::now() + window;
    while (true) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - clock::now());
        if (left.count() <= 0) break;
        pollfd p{fd_, POLLIN, 0};
        if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) continue;
        char chunk[512];
        const auto n = ::read(fd_, chunk, sizeof chunk);
        if (n > 0)
            buffer_.append(chunk, static_cast<std::size_t>(n));
        else if (n <= 0 && errno != EAGAIN && errno != EINTR)
            break;
    }
    std::string out;
    out.swap(buffer_);
    return out;
}

bool sim_serial_client::wait_for_hangup(std::chrono::milliseconds timeout) {
    const auto deadline = clock::now() + timeout;
    while (clock::now() < deadline) {
        pollfd p{fd_, POLLIN, 0};
        const int r = ::poll(&p, 1, 100);
        if (r > 0 && (p.revents & (POLLHUP | POLLERR))) return true;
        if (r > 0 && (p.revents & POLLIN)) {
            char chunk[512];
            const auto n = ::read(fd_, chunk, sizeof chunk);
            if (n == 0 || (n < 0 && errno == EIO)) return true;
        }
    }
    return false;
}

}  // namespace gw::tests
