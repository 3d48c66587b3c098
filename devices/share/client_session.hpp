#pragma once
// One program connected to a shared port (a TCP connection, or whoever has the shared pty open): reads
// its bytes (through RFC 2217 for TCP), frames them into lines, and hands its owner one line at a time
// in arrival order, so that every client gets exactly the replies to its own commands and no client
// holds more than one place in the controller's queue. A HALT line goes out at once, ahead of the
// client's waiting lines. Everything a client can do is bounded: its waiting lines (reading pauses
// beyond max_queued_lines), its unread replies (dropped beyond max_output_bytes, as a serial line
// drops what nobody reads), its line length. Used on its shared port's strand only.

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "devices/share/client_line_reader.hpp"
#include "devices/share/client_stream.hpp"
#include "devices/share/share_settings.hpp"
#include "devices/share/share_status.hpp"
#include "devices/share/telnet_codec.hpp"

namespace gw::devices::share {

class client_session : public std::enable_shared_from_this<client_session> {
  public:
    // What the session asks of its shared port.
    class owner {
      public:
        // Runs one line of the client, whose answer it has awaited since `arrived` (when it sent it, or
        // got the answer to the line before), and calls `answer` (on the port's strand) with the bytes to
        // send back, or "" when the controller gave no answer (a serial line's silence).
        virtual void run_line(const std::shared_ptr<client_session>& from, std::string line,
                              std::chrono::steady_clock::time_point arrived,
                              std::function<void(std::string)> answer) = 0;
        // The client is gone (its connection closed, or the pty's last holder closed it).
        virtual void session_ended(const std::shared_ptr<client_session>& session) = 0;

      protected:
        ~owner() = default;
    };

    // `telnet`: the stream speaks RFC 2217 as well as raw bytes (TCP); a pty carries raw bytes only.
    client_session(std::unique_ptr<client_stream> stream, std::shared_ptr<owner> owner, std::string name,
                   const share_settings& settings, bool telnet);

    void start();
    // Ends the session: pending reads and writes stop, later answers are dropped. session_ended follows.
    void close();

    const std::string& name() const { return status_.name; }
    client_status status() const { return status_; }
    void count_refused() { ++status_.refused; }
    void count_sent() { ++status_.commands; }
    void count_late() { ++status_.late; }

  private:
    void read();
    void on_read(boost::system::error_code ec, std::size_t bytes);
    void take_lines(std::string_view data);
    void pump();
    // Queues bytes for the client; `escape`: controller data, escaped for a Telnet client.
    void send(std::string bytes, bool escape = true);
    void write();
    void end();

    std::unique_ptr<client_stream> stream_;
    std::shared_ptr<owner> owner_;
    const share_settings& settings_;
    std::optional<telnet_codec> telnet_;
    client_line_reader reader_;
    std::array<char, 1024> read_buffer_{};
    bool reading_ = false;
    struct waiting_line {
        client_line line;
        std::chrono::steady_clock::time_point arrived;
    };
    std::deque<waiting_line> waiting_;
    bool line_out_ = false;  // a line of this client is with the controller
    // When the client's previous line was answered, and whether with silence: its next line's answer
    // is due within the command timeout of the later of that and the line's arrival.
    std::chrono::steady_clock::time_point last_answered_{};
    bool previous_silent_ = false;
    std::string writing_;  // bytes being written
    std::string next_;     // bytes to write once writing_ is done
    bool closed_ = false;
    bool ended_ = false;  // session_ended was reported
    client_status status_;
};

}  // namespace gw::devices::share
