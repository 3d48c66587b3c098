#include "devices/serial/port_probe.hpp"

#include <cerrno>
#include <fcntl.h>
#include <filesystem>
#include <poll.h>
#include <termios.h>
#include <thread>
#include <unistd.h>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/identify_answer.hpp"
#include "devices/serial/connection_problem.hpp"
#include "devices/serial/escape.hpp"
#include "devices/serial/port_lock.hpp"
#include "devices/serial/tty_mode.hpp"

namespace gw::devices {

namespace {

using status = port_report::status;
using std::chrono::steady_clock;

constexpr std::size_t max_answer_bytes = 8192;  // BU X is a few hundred bytes; noise is cut here
constexpr std::size_t sample_bytes = 48;        // of a non-MS-2000 answer, for the report

void apply(port_report& r, status what, const connection_problem& p) {
    r.what = what;
    r.text = p.text;
    r.hint = p.hint;
}

status status_of_open_error(int err) {
    switch (err) {
        case ENOENT:
        case ENODEV:
        case ENXIO:
            return status::not_found;
        case EACCES:
        case EPERM:
            return status::permission_denied;
        case EBUSY:
        case EWOULDBLOCK:
            return status::busy;
        case ENOTTY:
            return status::not_a_tty;
        default:
            return status::error;
    }
}

// Writes all of `bytes` (a few bytes: a tty takes them at once); false when the port refuses them.
bool write_all(int fd, std::string_view bytes) {
    while (!bytes.empty()) {
        const auto n = ::write(fd, bytes.data(), bytes.size());
        if (n < 0) {
            if (errno == EINTR) continue;
            return false;
        }
        bytes.remove_prefix(static_cast<std::size_t>(n));
    }
    return true;
}

// What arrives until a whole line did, or `timeout` passed.
std::string read_answer(int fd, std::chrono::milliseconds timeout) {
    std::string bytes;
    const auto deadline = steady_clock::now() + timeout;
    char buffer[512];
    while (bytes.size() < max_answer_bytes && !ms2000::has_complete_line(bytes)) {
        const auto left =
            std::chrono::duration_cast<std::chrono::milliseconds>(deadline - steady_clock::now());
        if (left.count() <= 0) break;
        pollfd p{fd, POLLIN, 0};
        const int ready = ::poll(&p, 1, static_cast<int>(left.count()));
        if (ready < 0 && errno == EINTR) continue;
        if (ready <= 0) break;
        const auto n = ::read(fd, buffer, sizeof buffer);
        if (n < 0 && (errno == EAGAIN || errno == EINTR)) continue;
        if (n <= 0) break;  // EOF or EIO (a pty whose master closed, an adapter pulled)
        bytes.append(buffer, static_cast<std::size_t>(n));
    }
    return bytes;
}

std::string rate_list(const std::vector<unsigned>& bauds) {
    std::string out;
    for (const auto b : bauds)
        out += (out.empty() ? "" : ", ") + std::to_string(b);
    return out;
}

// Closes the descriptor on every path out, with the port's own settings back and nothing left queued
// (a close would otherwise wait for output a UART without hardware never sends).
class probe_fd {
  public:
    explicit probe_fd(int fd) : fd_(fd) {}
    probe_fd(const probe_fd&) = delete;
    probe_fd& operator=(const probe_fd&) = delete;
    ~probe_fd() {
        ::tcflush(fd_, TCIOFLUSH);
        if (saved_) ::tcsetattr(fd_, TCSANOW, &*saved_);
        ::close(fd_);
    }
    int get() const { return fd_; }
    void keep_settings(const termios& t) { saved_ = t; }

  private:
    int fd_;
    std::optional<termios> saved_;
};

}  // namespace

std::string_view to_string(port_report::status s) {
    switch (s) {
        case status::ms2000:
            return "ms2000";
        case status::not_ms2000:
            return "not_ms2000";
        case status::no_answer:
            return "no_answer";
        case status::busy:
            return "busy";
        case status::permission_denied:
            return "permission_denied";
        case status::not_found:
            return "not_found";
        case status::not_a_tty:
            return "not_a_tty";
        case status::in_use:
            return "in_use";
        case status::error:
            return "error";
    }
    return "error";
}

port_report probe_port(const std::string& path, const probe_settings& settings, const std::string& held_by) {
    port_report r;
    r.path = path;
    std::error_code fs_error;
    const auto canonical = std::filesystem::canonical(path, fs_error);
    if (!fs_error) r.device = canonical.string();

    auto busy = [&](const std::string& how) {
        auto p = open_problem(path, EBUSY);
        p.text = path + " is held by another program: " + how;
        apply(r, status::busy, p);
        return r;
    };
    if (!held_by.empty()) return busy(held_by);
    if (!r.device.empty()) {
        if (auto lock = uucp_lock_holder(r.device)) return busy(*lock);
    }

    const int raw_fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (raw_fd < 0) {
        const int err = errno;
        apply(r, status_of_open_error(err), open_problem(path, err));
        return r;
    }
    probe_fd fd(raw_fd);
    termios saved{};
    if (::tcgetattr(fd.get(), &saved) != 0) {
        // Not a tty (a regular file, a socket): nothing is written to it.
        const int err = errno;
        apply(r, status_of_open_error(err), open_problem(path, err));
        return r;
    }
    if (const int err = lock_port(fd.get()); err != 0) {
        if (err == EBUSY) return busy("it holds an exclusive lock (flock) on the port");
        apply(r, status::error, open_problem(path, err));
        return r;
    }
    if (tty_in_exclusive_mode(fd.get())) return busy("the port is in exclusive mode (TIOCEXCL)");
    fd.keep_settings(saved);

    std::string sample;
    unsigned sample_baud = 0;
    std::string what;
    for (const unsigned baud : settings.bauds) {
        if (set_raw_mode(fd.get(), baud) != 0) continue;
        ::tcflush(fd.get(), TCIOFLUSH);
        if (!write_all(fd.get(), "\r")) break;
        std::this_thread::sleep_for(settings.settle);
        ::tcflush(fd.get(), TCIFLUSH);
        if (!write_all(fd.get(), ms2000::version().wire)) break;
        const std::string bytes = read_answer(fd.get(), settings.answer_timeout);
        const auto answer = ms2000::classify_version_answer(bytes);
        if (answer.what == ms2000::version_answer::kind::ms2000) {
            r.what = status::ms2000;
            r.baud = baud;
            r.version = answer.version;
            r.version_raw = escape_control(answer.line);
            ::tcflush(fd.get(), TCIFLUSH);
            if (write_all(fd.get(), ms2000::build_x().wire))
                r.build = ms2000::parse_build_answer(read_answer(fd.get(), settings.build_timeout));
            r.text = "an MS-2000 answers on " + path + " at " + std::to_string(baud) + " baud";
            return r;
        }
        // The first rate that got anything keeps its sample; a printable line beats noise.
        const bool better =
            answer.what == ms2000::version_answer::kind::tiger || (sample.empty() && !bytes.empty());
        if (better) {
            sample = escape_control(bytes.substr(0, sample_bytes));
            sample_baud = baud;
            if (answer.what == ms2000::version_answer::kind::tiger) {
                what = "an ASI Tiger controller, version " + answer.version;
                break;
            }
        }
    }
    if (sample_baud != 0) {
        r.baud = sample_baud;
        apply(r, status::not_ms2000, not_ms2000_problem(path, sample_baud, sample, what));
        return r;
    }
    apply(r, status::no_answer, no_reply_problem(path, rate_list(settings.bauds)));
    return r;
}

}  // namespace gw::devices
