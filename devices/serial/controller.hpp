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

#include <array>
#include <chrono>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/any_completion_handler.hpp>
#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/async_result.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/system/error_code.hpp>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/line_framer.hpp"
#include "devices/ms2000/reply.hpp"
#include "devices/serial/command_queue.hpp"
#include "devices/serial/connection_problem.hpp"
#include "devices/serial/controller_observer.hpp"
#include "devices/serial/controller_settings.hpp"
#include "devices/serial/controller_snapshot.hpp"
#include "devices/serial/error_log_reader.hpp"
#include "devices/serial/event_outlet.hpp"
#include "devices/serial/log_limiter.hpp"
#include "devices/serial/poller.hpp"
#include "devices/serial/report_port.hpp"
#include "devices/serial/serial_port.hpp"

namespace spdlog {
class logger;
}

namespace gw::devices {

class controller : public std::enable_shared_from_this<controller>,
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
    std::uint64_t halts_accepted() const { return queue_.halts_accepted(); }

    // Delivers a copy of the current snapshot (from the strand) to `handler`, which runs on the strand.
    void get_snapshot(std::function<void(controller_snapshot)> handler);

  private:
    using pending = queued_command;

    struct in_flight {
        pending job;
        std::uint64_t sequence = 0;
        bool accepting = false;  // lines before the command is written are stale
        std::chrono::steady_clock::time_point started;
        bool write_done = false;  // the write completed (a reply may come first)
        // A reply identical to the previous answer, held for repeated_reply_window: it is this
        // command's answer if no other line follows, a copy of the previous one if one does.
        std::optional<ms2000::reply> held;
    };

    // A round asks "/" first and applies its answer with the positions read after it, so a snapshot
    // that says a move ended also says where it ended.

    // Whether replies can be matched to commands. in_step: yes. out_of_step: a fault was seen, a
    // resynchronisation starts at the next pump. draining: waiting for the line to stay quiet for
    // resync_quiet. probing: the V probe is in flight. confirming: the probe was answered, the line
    // must stay quiet once more (a second answer means the first was a late one).
    enum class link_sync : std::uint8_t { in_step, out_of_step, draining, probing, confirming };

    void submit(ms2000::command cmd, std::string request_id, completion_handler handler,
                std::optional<std::uint64_t> halts_seen = std::nullopt);
    void on_submit(pending job);

    // Connection life cycle.
    void do_connect();
    void do_stop();
    void schedule_reconnect();
    // The attempt failed: state unreachable, last_error = problem, the retry scheduled, published.
    void set_unreachable(const connection_problem& problem);
    void watch_for_node();
    void disconnect(boost::system::error_code ec, const char* what);
    void fail_all(boost::system::error_code ec);
    void arm_presence_check();

    // Main port I/O.
    void do_read(std::uint64_t generation);
    bool read_available(std::uint64_t generation);  // false: more may wait (read again later)
    void on_bytes(std::uint64_t generation, std::size_t bytes);
    void hand_over_answers();
    void on_line(const std::string& line);
    void pump();
    std::optional<pending> take_next();
    void start_in_flight(pending job);
    void hold_back_in_flight();
    // `input_just_flushed`: the port's input was dropped a moment ago (start_in_flight): no byte can
    // be waiting to be read yet, and asking the kernel again would only cost a system call.
    void do_write(std::uint64_t sequence, bool input_just_flushed = false);
    bool bytes_waiting_in_port();
    void note_line_pace(std::size_t characters, std::chrono::steady_clock::duration round_trip);
    void on_write(std::uint64_t sequence, boost::system::error_code ec);
    void on_timeout(std::uint64_t sequence);
    void finish(boost::system::error_code ec, std::optional<ms2000::reply> reply, const std::string& raw);
    void complete(pending& job, boost::system::error_code ec, ms2000::reply reply);

    // Resynchronisation (link_sync).
    void mark_out_of_step(link_fault::kind kind, const char* why);
    void start_drain();
    void arm_quiet_timer();
    void on_quiet_window();
    void send_probe();
    void on_probe_reply(boost::system::error_code ec, const ms2000::reply& reply);
    void retry_resync(const char* why);
    void reset_sync();

    // Identification and polling.
    void enqueue_internal(ms2000::command cmd, const char* tag, internal_handler handler);
    void identify();
    void on_identified();
    void refresh_ttl_modes();
    void refresh_soft_limits();  // SL/SU after a client set one

    // What the parts ask of the controller.
    std::shared_ptr<void> keep_alive() override { return shared_from_this(); }
    void report_bytes_arrived(std::chrono::steady_clock::time_point at) override;
    void poll_tick() override;
    void move_ended() override;
    // A client's command finished on the wire: settings it changed are read back, the poller and the
    // snapshot's last error told.
    void client_command_finished(const ms2000::command& cmd, boost::system::error_code ec,
                                 const ms2000::reply* reply);

    // Events.
    template <typename Body>
    void guarded(const char* where, Body&& body);
    void contain(const char* where, const std::exception& e) override;
    void note_error(int code, std::string name, std::string text);
    void trace(const pending& job, std::chrono::microseconds latency, boost::system::error_code ec,
               const std::string& raw);

    controller_settings settings_;
    boost::asio::strand<boost::asio::any_io_executor> strand_;
    std::shared_ptr<spdlog::logger> log_;
    controller_snapshot snapshot_;
    event_outlet outlet_;

    serial_port port_;
    std::uint64_t generation_ = 0;  // bumped on every close, so old read handlers are ignored
    std::array<char, 512> read_buffer_{};
    std::uint64_t read_wait_generation_ = 0;         // the generation whose readiness wait is armed; 0: none
    bool handling_read_ = false;                     // inside do_read: a command's write waits for its end
    std::optional<std::uint64_t> write_after_read_;  // that command's sequence
    struct answer {
        completion_handler handler;
        boost::system::error_code ec;
        ms2000::reply reply;
    };
    std::vector<answer> answered_in_read_;  // user commands answered inside do_read, handed over at its end
    ms2000::line_framer framer_;
    std::vector<std::string> lines_;

    boost::asio::steady_timer command_timer_;
    boost::asio::steady_timer resync_timer_;
    boost::asio::steady_timer reconnect_timer_;
    boost::asio::steady_timer presence_timer_;
    boost::asio::steady_timer guard_timer_;
    // One character on the line (10 bits): the configured baud rate's, or less once an answer has
    // proven the line faster (a pty, a USB device that ignores the baud rate). The guard before a
    // write is one and a half of them after the last byte read.
    std::chrono::steady_clock::duration char_time_;
    std::chrono::steady_clock::time_point last_read_{};
    // The last reply taken as an answer: a repeat of it soon after, for another command, is suspect.
    struct answered {
        std::string line;
        std::string wire;  // the command it answered
        std::chrono::steady_clock::time_point at{};
    };
    answered last_answer_;
    bool repeats_last_answer(const ms2000::command& cmd, const ms2000::reply& r,
                             const std::string& line) const;
    void arm_command_timer(std::chrono::steady_clock::duration after, std::uint64_t sequence);
    void accept(ms2000::reply r, const std::string& line);
    std::chrono::milliseconds backoff_;
    bool node_gone_ = false;  // the device node vanished since the last connection attempt
    // Bytes received since the port was opened, until identified, and the first of them.
    static constexpr std::size_t attempt_sample_limit = 48;
    std::uint64_t attempt_bytes_ = 0;
    std::string attempt_sample_;

    std::optional<in_flight> in_flight_;
    std::uint64_t next_sequence_ = 1;
    link_sync sync_ = link_sync::in_step;
    bool line_noise_ = false;  // bytes arrived while draining or confirming
    std::size_t probe_attempts_ = 0;
    std::uint64_t quiet_round_ = 0;  // bumped on every quiet-window timer, so an old expiry is ignored
    std::chrono::steady_clock::time_point resync_started_;
    command_queue queue_;
    poller poller_;

    error_log_reader error_log_;

    report_port report_;
    std::uint64_t ttl_sequence_ = 0;

    log_limiter sync_limiter_;
    std::uint64_t stale_lines_ = 0;
    bool stopped_ = false;
};

}  // namespace gw::devices
