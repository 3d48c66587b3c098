#pragma once
// One MS-2000 controller behind one serial port (plus its optional report port).
//
// Thread safety: every public member may be called from any thread; it posts to the controller's
// own strand (made from the executor given to the constructor), where all state lives. Observer
// callbacks run on that strand. Create it with std::make_shared; handlers keep it alive until
// stop() has failed every pending command and its timers and reads have ended.
//
// Protocol discipline: exactly one command in flight; a reply is taken as its command's answer only
// if it is printable ASCII, has the command's shape and fits its reply_form; after a timeout, a reply
// that does not fit, or bytes nobody asked for, the link is out of step and no command is released
// until it is resynchronised (devices/serial/README.md, "Reply matching"); HALT jumps the queue; polls
// never pile up (at most one poll round, and user commands go ahead of the poll's next step).
//
// Inside, the controller is a facade over parts with one job each, plain objects on its strand that
// talk to it through their owner interfaces: command_link (the port, the queue, reply matching,
// resynchronisation), poller, error_log_reader, report_port, and event_outlet (the way out to the
// observer). The controller itself keeps the connection's life cycle (open, identify, reconnect,
// stop) and what crosses between the parts.

#include <chrono>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <boost/asio/any_completion_handler.hpp>
#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/async_result.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/system/error_code.hpp>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/reply.hpp"
#include "devices/serial/command_link.hpp"
#include "devices/serial/command_queue.hpp"
#include "devices/serial/connection_problem.hpp"
#include "devices/serial/controller_observer.hpp"
#include "devices/serial/controller_settings.hpp"
#include "devices/serial/controller_snapshot.hpp"
#include "devices/serial/error_log_reader.hpp"
#include "devices/serial/event_outlet.hpp"
#include "devices/serial/poller.hpp"
#include "devices/serial/report_port.hpp"

namespace spdlog {
class logger;
}

namespace gw::devices {

class controller : public std::enable_shared_from_this<controller>,
                   private command_link::owner,
                   private poller::owner,
                   private report_port::owner {
  public:
    using completion_signature = void(boost::system::error_code, ms2000::reply);
    using completion_handler = boost::asio::any_completion_handler<completion_signature>;

    controller(const boost::asio::any_io_executor& ex, controller_settings settings,
               std::weak_ptr<controller_observer> observer = {});
    ~controller();

    controller(const controller&) = delete;
    controller& operator=(const controller&) = delete;

    // Opens the port and identifies the controller; reconnects by itself after a disconnect.
    void start();
    // Closes the ports and fails every pending command with error::cancelled.
    void stop();
    void set_observer(std::weak_ptr<controller_observer> observer);

    const std::string& id() const { return settings_.id; }
    const controller_settings& settings() const { return settings_; }

    // Sends one command and completes with its parsed reply. Errors: error::not_connected,
    // error::queue_full, error::timeout, error::disconnected, error::cancelled,
    // error::unrecognized_reply, and error::controller_rejected with the parsed ":N-<code>" reply.
    // HALT's ":N-21" completes with success. The completion runs on the handler's associated
    // executor (the controller's strand if it has none). Works with callbacks, use_future and
    // use_awaitable.
    template <typename CompletionToken>
    auto async_command(ms2000::command cmd, std::string request_id, CompletionToken&& token) {
        return boost::asio::async_initiate<CompletionToken, completion_signature>(
            [self = shared_from_this()](auto handler, ms2000::command c, std::string rid) {
                self->submit(std::move(c), std::move(rid), completion_handler(std::move(handler)));
            },
            token, std::move(cmd), std::move(request_id));
    }

    // As async_command, for a caller that must not act after a HALT it did not see (a job's run): the
    // command fails with error::halted, never reaching the wire, when a HALT was accepted since the
    // caller read halts_accepted() == `halts_seen`, whether the HALT came before the command or while
    // it waited in the queue. Decided on the strand, so no command of such a caller follows a HALT.
    template <typename CompletionToken>
    auto async_guarded_command(ms2000::command cmd, std::string request_id, std::uint64_t halts_seen,
                               CompletionToken&& token) {
        return boost::asio::async_initiate<CompletionToken, completion_signature>(
            [self = shared_from_this(), halts_seen](auto handler, ms2000::command c, std::string rid) {
                self->submit(std::move(c), std::move(rid), completion_handler(std::move(handler)),
                             halts_seen);
            },
            token, std::move(cmd), std::move(request_id));
    }

    // HALT commands this controller accepted (queued for the wire, or refused for a closed port: the
    // intent to stop counts), since it was made. Any thread.
    std::uint64_t halts_accepted() const { return link_.halts_accepted(); }

    // Every byte of the report port, unchanged, to `tap` on the controller's strand (a shared report
    // port carries them to programs that read the report stream themselves); empty: none.
    void set_report_tap(report_port::byte_tap tap);

    // Delivers a copy of the current snapshot (from the strand) to `handler`, which runs on the strand.
    void get_snapshot(std::function<void(controller_snapshot)> handler);

  private:
    void submit(ms2000::command cmd, std::string request_id, completion_handler handler,
                std::optional<std::uint64_t> halts_seen = std::nullopt);

    // Connection life cycle.
    void do_connect();
    void do_stop();
    void schedule_reconnect();
    // The attempt failed: state unreachable, last_error = problem, the retry scheduled, published.
    void set_unreachable(const connection_problem& problem);
    void watch_for_node();
    void arm_presence_check();
    void disconnect(boost::system::error_code ec, const char* what) override;

    // Identification, and the settings read back after a client changed them.
    void identify();
    void on_identified();
    void refresh_ttl_modes();
    void refresh_soft_limits();  // SL/SU after a client set one
    // Reads one motion setting (S, AC, PC, B or OS) of every axis into the snapshot, at identification
    // and after a client set it; an error leaves it unset (the job planner then uses its defaults).
    void read_motion_setting(std::string_view verb, const char* tag);
    // After a reset or a recalibration (ms2000::resets_or_recalibrates): everything identification
    // read may be stale, so it is read again; commands wait behind it.
    void reidentify(const ms2000::command& cause);

    // What the parts ask of the controller (their owner interfaces).
    std::shared_ptr<void> keep_alive() override { return shared_from_this(); }
    std::optional<queued_command> next_background_command() override;
    void client_command_finished(const ms2000::command& cmd, boost::system::error_code ec,
                                 const ms2000::reply* reply) override;
    void client_answered(boost::system::error_code ec) override;
    void position_report(const ms2000::position_report_line& report) override;
    bool identified() const override { return snapshot_.state == connection_state::connected; }
    void contain(const char* where, const std::exception& e) override;
    void poll_tick() override;
    void move_ended() override;
    void report_bytes_arrived(std::chrono::steady_clock::time_point at) override;

    void note_error(int code, std::string name, std::string text);

    controller_settings settings_;
    boost::asio::strand<boost::asio::any_io_executor> strand_;
    std::shared_ptr<spdlog::logger> log_;
    controller_snapshot snapshot_;
    event_outlet outlet_;
    command_link link_;
    poller poller_;
    error_log_reader error_log_;
    report_port report_;

    boost::asio::steady_timer reconnect_timer_;
    boost::asio::steady_timer presence_timer_;
    std::chrono::milliseconds backoff_;
    bool node_gone_ = false;  // the device node vanished since the last connection attempt
    std::uint64_t ttl_sequence_ = 0;
    bool stopped_ = false;
};

}  // namespace gw::devices
