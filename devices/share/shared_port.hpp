#pragma once
// One controller's shared port: the pseudo-terminal and the TCP listener through which programs that
// speak to an MS-2000 themselves use the controller the gateway owns. Each client line is one command in
// the controller's queue (devices::controller::async_command), so it interleaves with the gateway's
// own work and every reply goes back to the client that sent the command, byte for byte as the
// controller sent it. The rules: the port's role (share_rules.hpp), then the gateway's (share_gate:
// leases, jobs); a refused line gets a documented ":N-<code>" reply and never reaches the controller.
// While the controller is unplugged, lines get no reply (a real unplugged cable's silence) and the port
// stays open.
//
// Create with std::make_shared; start() and stop() from any thread; status() from any thread.

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>

#include "devices/serial/controller.hpp"
#include "devices/share/client_session.hpp"
#include "devices/share/pty_endpoint.hpp"
#include "devices/share/share_gate.hpp"
#include "devices/share/share_settings.hpp"
#include "devices/share/share_status.hpp"
#include "devices/share/shared_report_port.hpp"

namespace spdlog {
class logger;
}

namespace gw::devices::share {

class shared_port : public std::enable_shared_from_this<shared_port>, public client_session::owner {
  public:
    shared_port(const boost::asio::any_io_executor& executor, share_settings settings,
                std::shared_ptr<controller> controller, std::shared_ptr<share_gate> gate);
    ~shared_port();
    shared_port(const shared_port&) = delete;
    shared_port& operator=(const shared_port&) = delete;

    // Opens the pty and the listener. Returns "" or why one could not be opened.
    std::string start();
    // Closes both and every client. Idempotent.
    void stop();

    port_status status() const;
    const share_settings& settings() const { return settings_; }

  private:
    void run_line(const std::shared_ptr<client_session>& from, std::string line,
                  std::chrono::steady_clock::time_point arrived,
                  std::function<void(std::string)> answer) override;
    void session_ended(const std::shared_ptr<client_session>& session) override;

    void accept();
    void watch_pty();
    void refuse(client_session& from, const refusal& why, const std::string& line);
    void clients_changed();
    void publish();

    boost::asio::strand<boost::asio::any_io_executor> strand_;
    share_settings settings_;
    std::shared_ptr<controller> controller_;
    std::shared_ptr<share_gate> gate_;
    std::shared_ptr<spdlog::logger> log_;
    pty_endpoint pty_;
    std::optional<boost::asio::ip::tcp::acceptor> acceptor_;
    boost::asio::steady_timer pty_watch_;
    boost::asio::steady_timer accept_retry_;
    std::shared_ptr<client_session> pty_session_;
    std::vector<std::shared_ptr<client_session>> tcp_sessions_;
    std::shared_ptr<shared_report_port> reports_;
    bool stopped_ = false;
    bool holds_lease_ = false;
    std::uint64_t commands_ = 0;
    std::uint64_t refused_ = 0;
    std::uint64_t clients_refused_ = 0;
    std::uint64_t line_sequence_ = 0;

    mutable std::mutex status_mutex_;
    port_status published_;
};

}  // namespace gw::devices::share
