#pragma once
// A test that plays the controller: the master side of a real pseudo-terminal, served by a thread.
// The driver opens the slave through a stable symlink, as it would a USB adapter. Each CR-terminated
// command is recorded and answered by a responder (the default one answers identification like a
// small XY stage). unplug()/replug() close the master and re-point the link to a fresh pty.
// Header-only so that unit tests can use it without linking gw_test_support.

#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <fcntl.h>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <poll.h>
#include <stdexcept>
#include <stdlib.h>
#include <string>
#include <string_view>
#include <termios.h>
#include <thread>
#include <unistd.h>
#include <vector>

namespace gw::test {

class drv_pty_controller {
  public:
    // Reply chunks written one after the other (a short pause between them splits the reply over
    // several reads); an empty vector means "no reply".
    using responder = std::function<std::vector<std::string>(const std::string& command)>;

    drv_pty_controller() {
        char dir[] = "/tmp/drv-pty-XXXXXX";
        if (!::mkdtemp(dir)) throw std::runtime_error("mkdtemp failed");
        dir_ = dir;
        link_ = dir_ + "/port";
        open_pair();
        thread_ = std::thread([this] { run(); });
    }

    ~drv_pty_controller() {
        stop_ = true;
        thread_.join();
        close_pair();
        std::error_code ignored;
        std::filesystem::remove_all(dir_, ignored);
    }

    drv_pty_controller(const drv_pty_controller&) = delete;
    drv_pty_controller& operator=(const drv_pty_controller&) = delete;

    const std::string& link() const { return link_; }

    void set_responder(responder r) {
        std::lock_guard lock(mu_);
        responder_ = std::move(r);
    }

    // Bytes sent to the driver at once, outside any command (noise, late replies, reports).
    void write_raw(std::string_view bytes) {
        std::lock_guard lock(mu_);
        write_all(bytes);
    }

    // While held, commands are recorded but their replies wait for release().
    void hold() {
        std::lock_guard lock(mu_);
        held_ = true;
    }
    // Holds from the next arrival of `command` on (its own reply is the first one held).
    void hold_on(std::string command) {
        std::lock_guard lock(mu_);
        hold_on_ = std::move(command);
    }
    void release() {
        std::lock_guard lock(mu_);
        held_ = false;
    }

    void unplug() {
        std::lock_guard lock(mu_);
        close_pair();
        std::filesystem::remove(link_);
    }
    // The device node disappears but the pty stays open (no I/O error on the driver's side).
    void remove_link() {
        std::lock_guard lock(mu_);
        std::filesystem::remove(link_);
    }
    void replug() {
        std::lock_guard lock(mu_);
        close_pair();
        open_pair();
    }

    std::vector<std::string> commands() const {
        std::lock_guard lock(mu_);
        return commands_;
    }

    // Forgets the commands recorded so far (the identification), so a test sees only its own.
    void clear_commands() {
        std::lock_guard lock(mu_);
        commands_.clear();
    }

    // Waits until at least `n` commands arrived; false on timeout.
    bool wait_for_commands(std::size_t n, std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
        std::unique_lock lock(mu_);
        return cv_.wait_for(lock, timeout, [&] { return commands_.size() >= n; });
    }

    // Replies waiting for release().
    std::size_t deferred() const {
        std::lock_guard lock(mu_);
        return deferred_.size();
    }

    // Waits until `n` replies are held; false on timeout.
    bool wait_deferred(std::size_t n, std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
        std::unique_lock lock(mu_);
        return cv_.wait_for(lock, timeout, [&] { return deferred_.size() >= n; });
    }

    std::size_t count(const std::string& command) const {
        std::lock_guard lock(mu_);
        std::size_t n = 0;
        for (const auto& c : commands_)
            n += c == command ? 1 : 0;
        return n;
    }

    // Identification of a small XY stage; ":A" for anything else.
    static std::vector<std::string> default_reply(const std::string& command) {
        if (command == "V") return {":A Version: USB-9.50 \r\n"};
        if (command == "BU X") return {"STD_XY\rMotor Axes: X Y\rCMDs: XY\rRING BUFFER\r\n"};
        if (command == "CNTS X? Y?") return {":A X=10000 Y=20000\r\n"};
        if (command == "SL X? Y?") return {":A X=-50 Y=-25\r\n"};
        if (command == "SU X? Y?") return {":A X=50 Y=25\r\n"};
        if (command == "TTL X? Y?") return {":A X=0 Y=2\r\n"};
        // The motion settings (S, AC, PC, B, OS): the firmware's defaults of a B lead screw.
        if (command == "S X? Y?") return {":A X=5.5 Y=5.5\r\n"};
        if (command == "AC X? Y?") return {":X=20 Y=20 A\r\n"};
        if (command == "PC X? Y?") return {":A X=0.000022 Y=0.000022\r\n"};
        if (command == "B X? Y?") return {":X=0.04 Y=0.04 A\r\n"};
        if (command == "OS X? Y?") return {":A X=0 Y=0\r\n"};
        if (command == "W X Y") return {":A 100.0 -20.0 \r\n"};
        if (command == "/") return {"N\r\n"};
        return {":A\r\n"};
    }

  private:
    void open_pair() {
        master_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
        if (master_ < 0 || ::grantpt(master_) != 0 || ::unlockpt(master_) != 0)
            throw std::runtime_error("posix_openpt failed");
        char name[128];
        if (::ptsname_r(master_, name, sizeof name) != 0) throw std::runtime_error("ptsname_r failed");
        // Keep one raw slave descriptor open: no echo before the driver opens it, and no HUP spin
        // while the driver is between connections.
        keep_slave_ = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
        if (keep_slave_ < 0) throw std::runtime_error("cannot open pty slave");
        termios tio{};
        ::tcgetattr(keep_slave_, &tio);
        ::cfmakeraw(&tio);
        ::tcsetattr(keep_slave_, TCSANOW, &tio);
        const std::string tmp = link_ + ".new";
        std::filesystem::remove(tmp);
        std::filesystem::create_symlink(name, tmp);
        std::filesystem::rename(tmp, link_);  // atomic re-point
        buffer_.clear();
    }

    void close_pair() {
        if (master_ >= 0) ::close(master_);
        if (keep_slave_ >= 0) ::close(keep_slave_);
        master_ = keep_slave_ = -1;
    }

    void write_all(std::string_view bytes) {
        while (!bytes.empty() && master_ >= 0) {
            const auto n = ::write(master_, bytes.data(), bytes.size());
            if (n < 0) {
                if (errno == EINTR || errno == EAGAIN) continue;
                return;
            }
            bytes.remove_prefix(static_cast<std::size_t>(n));
        }
    }

    void run() {
        using namespace std::chrono_literals;
        while (!stop_) {
            std::unique_lock lock(mu_);
            if (!held_ && !deferred_.empty()) {
                for (auto& chunks : deferred_)
                    send(chunks, lock);
                deferred_.clear();
            }
            if (master_ < 0) {
                lock.unlock();
                std::this_thread::sleep_for(5ms);
                continue;
            }
            pollfd p{master_, POLLIN, 0};
            const int ready = ::poll(&p, 1, 10);
            if (ready <= 0 || !(p.revents & POLLIN)) {
                lock.unlock();
                if (ready > 0) std::this_thread::sleep_for(5ms);  // HUP without data
                continue;
            }
            char bytes[512];
            const auto n = ::read(master_, bytes, sizeof bytes);
            if (n <= 0) continue;
            for (ssize_t i = 0; i < n; ++i) {
                const char c = bytes[i];
                if (c == '\n') continue;
                if (c != '\r') {
                    buffer_ += c;
                    continue;
                }
                std::string command = std::move(buffer_);
                buffer_.clear();
                commands_.push_back(command);
                cv_.notify_all();
                if (!hold_on_.empty() && command == hold_on_) {
                    held_ = true;
                    hold_on_.clear();
                }
                auto chunks = responder_ ? responder_(command) : default_reply(command);
                if (held_) {
                    deferred_.push_back(std::move(chunks));
                    cv_.notify_all();
                } else
                    send(chunks, lock);
            }
        }
    }

    void send(const std::vector<std::string>& chunks, std::unique_lock<std::mutex>&) {
        for (std::size_t i = 0; i < chunks.size(); ++i) {
            if (i > 0) std::this_thread::sleep_for(std::chrono::milliseconds(3));
            write_all(chunks[i]);
        }
    }

    std::string dir_;
    std::string link_;
    int master_ = -1;
    int keep_slave_ = -1;
    mutable std::mutex mu_;
    std::condition_variable cv_;
    responder responder_;
    bool held_ = false;
    std::string hold_on_;
    std::deque<std::vector<std::string>> deferred_;
    std::vector<std::string> commands_;
    std::string buffer_;
    std::atomic<bool> stop_{false};
    std::thread thread_;
};

}  // namespace gw::test
