#pragma once
// A controller's report stream (TTL_REPORT frames from its SERIAL OUT port) shared unchanged: every byte
// the gateway reads from the report port also goes to each program that has the shared report pty open
// or is connected to the shared report TCP port, while WebSocket and MQTT keep streaming the decoded
// frames. Output only: what the programs send is read and dropped. A program that does not read loses
// bytes beyond max_output_bytes (counted), as it would on a serial line; nobody else waits for it.
// Used on its shared port's strand.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>

#include "devices/share/client_stream.hpp"
#include "devices/share/pty_endpoint.hpp"
#include "devices/share/share_settings.hpp"
#include "devices/share/share_status.hpp"

namespace gw::devices::share {

class shared_report_port : public std::enable_shared_from_this<shared_report_port> {
  public:
    shared_report_port(const boost::asio::strand<boost::asio::any_io_executor>& strand,
                       const share_settings& settings);

    // Opens the pty and the listener the settings name; "" or why not. `changed` runs (on the strand)
    // whenever a reader comes or goes.
    std::string start(std::function<void()> changed);
    void stop();
    // Bytes read from the controller's report port: to every reader. On the strand.
    void deliver(std::string_view bytes);

    std::vector<client_status> readers() const;
    std::string pty() const { return settings_.report_pty; }
    std::string tcp() const;

  private:
    struct reader;
    void accept();
    void watch_pty();
    void start_reader(const std::shared_ptr<reader>& r);
    void drain(const std::shared_ptr<reader>& r);
    void write(const std::shared_ptr<reader>& r);
    void remove(const std::shared_ptr<reader>& r);

    boost::asio::strand<boost::asio::any_io_executor> strand_;
    const share_settings& settings_;
    pty_endpoint pty_;
    std::optional<boost::asio::ip::tcp::acceptor> acceptor_;
    boost::asio::steady_timer pty_watch_;
    std::shared_ptr<reader> pty_reader_;
    std::vector<std::shared_ptr<reader>> tcp_readers_;
    std::function<void()> changed_;
    bool stopped_ = false;
};

}  // namespace gw::devices::share
