#pragma once
// A controller's command port, one command at a time: the port's I/O, the queue and the one command in
// flight, the proof that a reply is its command's answer, and the resynchronisation after any doubt
// (devices/serial/README.md, "Reply matching"). A HALT goes first and does not wait for the link to be
// in step. What is not the link's to decide (the background work, what a client's answer changes, a
// lost port) it asks of its owner, the controller. Used on the controller's strand only.

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/system/error_code.hpp>

#include "devices/ms2000/command.hpp"
#include "devices/ms2000/line_framer.hpp"
#include "devices/ms2000/reply.hpp"
#include "devices/serial/command_queue.hpp"
#include "devices/serial/controller_events.hpp"
#include "devices/serial/controller_settings.hpp"
#include "devices/serial/event_outlet.hpp"
#include "devices/serial/log_limiter.hpp"
#include "devices/serial/serial_port.hpp"

namespace spdlog {
class logger;
}

namespace gw::devices {

class command_link {
  public:
    // What the link asks of the controller that owns it.
    class owner {
      public:
        // A strong reference for the link's pending reads and timers: the controller outlives them.
        virtual std::shared_ptr<void> keep_alive() = 0;
        // Work for an idle link once no queued command waits (the error log's next step, then the
        // poll's), if any.
        virtual std::optional<queued_command> next_background_command() = 0;
        // A client's command finished on the wire (answered, refused by the controller, timed out, its
        // answer unfit), before its handler is called; `reply` is null when no answer was taken.
        virtual void client_command_finished(const ms2000::command& cmd, boost::system::error_code ec,
                                             const ms2000::reply* reply) = 0;
        // A client's command completed, whatever ended it (a refusal before the wire too).
        virtual void client_answered(boost::system::error_code ec) = 0;
        // An unsolicited position report on the command port ("T: ...", TTL IN0 mode 5).
        virtual void position_report(const ms2000::position_report_line& report) = 0;
        // Whether this connection's controller was identified: before that, the unreachable state says
        // what a timeout means, and each one is only detail.
        virtual bool identified() const = 0;
        // The port is lost (a read or write error, a write that stalled, a failed resynchronisation).
        virtual void disconnect(boost::system::error_code ec, const char* what) = 0;
        // Handling its input threw: logged and counted, and the connection reset.
        virtual void contain(const char* where, const std::exception& e) = 0;

      protected:
        ~owner() = default;
    };

    command_link(const boost::asio::strand<boost::asio::any_io_executor>& strand,
                 const controller_settings& settings, event_outlet& outlet, spdlog::logger& log,
                 owner& owner);

    // Opens the port (locked, raw, in the crash table) and reads it. The link starts out of step: a
    // reply to the previous owner's last command may still come, so the first command waits for a
    // resynchronisation.
    boost::system::error_code open();
    // Closes the port; everything in flight or queued fails with `ec`.
    void close(boost::system::error_code ec);
    bool is_open() const { return port_.is_open(); }
    // The node that was opened is still there (not unplugged, not re-created).
    bool still_present() const { return port_.still_present(settings_.port); }
    // Bumped on every open and close, so that handlers of an older connection are ignored.
    std::uint64_t generation() const { return generation_; }
    // What came back since the port was opened: how many bytes and the first of them, for the verdict on
    // an attempt that did not identify a controller (silence, or another device or baud rate).
    std::uint64_t bytes_heard() const { return bytes_heard_; }
    const std::string& first_bytes_heard() const { return first_bytes_; }

    // A client's command: refused with `when_closed` while the port is closed, with queue_full beyond
    // queue_limit. A HALT is counted first and drops the guarded commands still queued; a guarded command
    // that missed a HALT fails with error::halted.
    void submit(queued_command job, boost::system::error_code when_closed);
    // One of the driver's own commands (identification, a setting read back), written at the next pump.
    void enqueue_internal(ms2000::command cmd, const char* tag, internal_handler handler);
    // Writes the next command, if none is in flight and the link is in step (a HALT does not wait).
    void pump();
    std::uint64_t halts_accepted() const { return queue_.halts_accepted(); }

  private:
    struct in_flight {
        queued_command job;
        std::uint64_t sequence = 0;
        bool accepting = false;  // lines before the command is written are stale
        std::chrono::steady_clock::time_point started;
        bool write_done = false;  // the write completed (a reply may come first)
        // A reply identical to the previous answer, held for repeated_reply_window: it is this
        // command's answer if no other line follows, a copy of the previous one if one does.
        std::optional<ms2000::reply> held{};
    };

    // Whether replies can be matched to commands. in_step: yes. out_of_step: a fault was seen, a
    // resynchronisation starts at the next pump. draining: waiting for the line to stay quiet for
    // resync_delay. probing: the V probe is in flight. confirming: the probe was answered, the line
    // must stay quiet once more (a second answer means the first was a late one).
    enum class link_sync : std::uint8_t { in_step, out_of_step, draining, probing, confirming };

    // Reading: on the strand, never by async_read_some (do_read says why).
    void do_read(std::uint64_t generation);
    bool read_available(std::uint64_t generation);  // false: more may wait (read again later)
    void on_bytes(std::uint64_t generation, std::size_t bytes);
    void hand_over_answers();
    void on_line(const std::string& line);

    // Writing and answering.
    void start_in_flight(queued_command job);
    void hold_back_in_flight();
    // `input_just_flushed`: the port's input was dropped a moment ago (start_in_flight): no byte can
    // be waiting to be read yet, and asking the kernel again would only cost a system call.
    void do_write(std::uint64_t sequence, bool input_just_flushed = false);
    bool bytes_waiting_in_port();
    void note_line_pace(std::size_t characters, std::chrono::steady_clock::duration round_trip);
    void arm_command_timer(std::chrono::steady_clock::duration after, std::uint64_t sequence);
    void on_write(std::uint64_t sequence, boost::system::error_code ec);
    void on_timeout(std::uint64_t sequence);
    bool repeats_last_answer(const ms2000::command& cmd, const ms2000::reply& r,
                             const std::string& line) const;
    void accept(ms2000::reply r, const std::string& line);
    void finish(boost::system::error_code ec, std::optional<ms2000::reply> reply, const std::string& raw);
    void complete(queued_command& job, boost::system::error_code ec, ms2000::reply reply);
    void fail_all(boost::system::error_code ec);
    void trace(const queued_command& job, std::chrono::steady_clock::time_point started,
               boost::system::error_code ec, const std::string& raw);

    // Resynchronisation (link_sync).
    void mark_out_of_step(link_fault::kind kind, const char* why);
    void start_drain();
    void arm_quiet_timer();
    void on_quiet_window();
    void send_probe();
    void on_probe_reply(boost::system::error_code ec);
    void retry_resync(const char* why);
    void reset_sync();

    template <typename Body>
    void guarded(const char* where, Body&& body);

    boost::asio::strand<boost::asio::any_io_executor> strand_;
    const controller_settings& settings_;
    event_outlet& outlet_;
    spdlog::logger& log_;
    owner& owner_;

    serial_port port_;
    std::uint64_t generation_ = 0;
    std::array<char, 512> read_buffer_{};
    std::uint64_t read_wait_generation_ = 0;         // the generation whose readiness wait is armed; 0: none
    bool handling_read_ = false;                     // inside do_read: a command's write waits for its end
    std::optional<std::uint64_t> write_after_read_;  // that command's sequence
    struct answer {
        command_completion handler;
        boost::system::error_code ec;
        ms2000::reply reply;
    };
    std::vector<answer> answered_in_read_;  // client commands answered inside do_read, handed over at its end
    ms2000::line_framer framer_;
    std::vector<std::string> lines_;
    static constexpr std::size_t first_bytes_limit = 48;
    std::uint64_t bytes_heard_ = 0;
    std::string first_bytes_;

    command_queue queue_;
    std::optional<in_flight> in_flight_;
    std::uint64_t next_sequence_ = 1;
    boost::asio::steady_timer command_timer_;
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

    boost::asio::steady_timer resync_timer_;
    link_sync sync_ = link_sync::in_step;
    bool line_noise_ = false;  // bytes arrived while draining or confirming
    std::size_t probe_attempts_ = 0;
    std::uint64_t quiet_round_ = 0;  // bumped on every quiet-window timer, so an old expiry is ignored
    std::chrono::steady_clock::time_point resync_started_;
    log_limiter sync_limiter_;
    std::uint64_t stale_lines_ = 0;
};

}  // namespace gw::devices
