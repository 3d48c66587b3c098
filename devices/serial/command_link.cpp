#include "devices/serial/command_link.hpp"

#include <algorithm>
#include <sys/ioctl.h>
#include <unistd.h>
#include <utility>

#include <boost/asio/append.hpp>
#include <boost/asio/bind_executor.hpp>
#include <boost/asio/buffer.hpp>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/posix/descriptor_base.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>
#include <spdlog/spdlog.h>

#include "devices/ms2000/error.hpp"
#include "devices/ms2000/reply_check.hpp"
#include "devices/serial/emergency_halt.hpp"
#include "devices/serial/escape.hpp"

namespace gw::devices {
namespace net = boost::asio;
using boost::system::error_code;
using std::chrono::steady_clock;

namespace {

// Ten bits (8N1) at the baud rate.
steady_clock::duration configured_char_time(unsigned baud) {
    return std::chrono::microseconds(10'000'000 / std::max(baud, 1u));
}

}  // namespace

command_link::command_link(const net::strand<net::any_io_executor>& strand,
                           const controller_settings& settings, event_outlet& outlet, spdlog::logger& log,
                           owner& owner)
    : strand_(strand),
      settings_(settings),
      outlet_(outlet),
      log_(log),
      owner_(owner),
      port_(strand),
      queue_(settings.queue_limit),
      command_timer_(strand),
      guard_timer_(strand),
      char_time_(configured_char_time(settings.baud)),
      resync_timer_(strand) {}

template <typename Body>
void command_link::guarded(const char* where, Body&& body) {
    try {
        body();
    } catch (const std::exception& e) {
        owner_.contain(where, e);
    }
}

// ---- the port ---------------------------------------------------------------------------------

error_code command_link::open() {
    if (auto ec = port_.open(settings_.port, settings_.baud)) return ec;
    // Should the process die, its fatal-signal handler halts the stage through this port.
    if (!port_.halt_on_crash())
        log_.warn("port {}: more than {} ports open: a crash would not halt this stage", settings_.port,
                  emergency_halt::max_ports);
    ++generation_;
    char_time_ = configured_char_time(settings_.baud);  // another device may be on the port now
    bytes_heard_ = 0;
    first_bytes_.clear();
    framer_.reset();
    reset_sync();
    last_answer_ = {};
    // A fresh port is not yet proven in step: a reply to a command of the program that had it before
    // (a crashed gateway, another client) may still come. The first command waits for the resync.
    sync_ = link_sync::out_of_step;
    resync_started_ = steady_clock::now();
    // Read from the next turn on, as before any command: what the port holds now is stale anyway.
    net::post(strand_, [this, alive = owner_.keep_alive(), generation = generation_] {
        if (generation == generation_) do_read(generation);
    });
    return {};
}

void command_link::close(error_code ec) {
    ++generation_;
    port_.close();
    command_timer_.cancel();
    resync_timer_.cancel();
    guard_timer_.cancel();
    reset_sync();
    fail_all(ec);
}

void command_link::do_read(std::uint64_t generation) {
    // The port is read here, on the strand, not by async_read_some: a read that completed could wait
    // in the io_context's queue while a command is written, and its stale bytes would then be taken
    // for that command's answer. The readiness wait is armed before reading, so a byte that arrives
    // after the last read wakes it, and one that arrived before is read now.
    if (read_wait_generation_ != generation) {
        read_wait_generation_ = generation;
        port_.stream().async_wait(
            net::posix::descriptor_base::wait_read,
            net::bind_executor(strand_, [this, alive = owner_.keep_alive(), generation](error_code ec) {
                if (generation != generation_) return;
                read_wait_generation_ = 0;
                if (ec) return owner_.disconnect(ec, "read");
                do_read(generation);
            }));
    }
    handling_read_ = true;
    const bool drained = read_available(generation);
    handling_read_ = false;
    if (generation != generation_) {
        write_after_read_.reset();  // the port closed: nothing to write
        return hand_over_answers();
    }
    if (!drained) {
        // A line that keeps talking must not hold the strand: the rest is read in a later turn.
        net::post(strand_, [this, alive = owner_.keep_alive(), generation] {
            if (generation == generation_) do_read(generation);
        });
    }
    if (auto sequence = std::exchange(write_after_read_, std::nullopt)) do_write(*sequence);
    hand_over_answers();
}

void command_link::hand_over_answers() {
    // Nothing of this read is left on the stack: the first handler runs as if it had been posted, on
    // its own associated executor (dispatched: at once when that executor allows). Any others (a
    // disconnect fails every queued command) are posted first, so that a handler that throws cannot
    // take the answers after it with it.
    auto answers = std::move(answered_in_read_);
    answered_in_read_.clear();
    if (answers.empty()) return;
    for (std::size_t i = 1; i < answers.size(); ++i)
        net::post(strand_,
                  net::append(std::move(answers[i].handler), answers[i].ec, std::move(answers[i].reply)));
    net::dispatch(strand_,
                  net::append(std::move(answers[0].handler), answers[0].ec, std::move(answers[0].reply)));
}

bool command_link::read_available(std::uint64_t generation) {
    constexpr int reads_per_turn = 16;
    for (int i = 0; i < reads_per_turn; ++i) {
        const auto n = ::read(port_.stream().native_handle(), read_buffer_.data(), read_buffer_.size());
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return true;
        if (n <= 0) {
            owner_.disconnect(
                n == 0 ? error_code(net::error::eof) : error_code(errno, boost::system::system_category()),
                "read");
            return true;
        }
        on_bytes(generation, static_cast<std::size_t>(n));
        if (generation != generation_) return true;
        // A tty's read returns all it holds, up to the buffer: a shorter read emptied it.
        if (static_cast<std::size_t>(n) < read_buffer_.size()) return true;
    }
    return false;
}

void command_link::on_bytes(std::uint64_t generation, std::size_t bytes) {
    last_read_ = steady_clock::now();
    bytes_heard_ += bytes;
    if (first_bytes_.size() < first_bytes_limit)
        first_bytes_.append(read_buffer_.data(), std::min(bytes, first_bytes_limit - first_bytes_.size()));
    guarded("reading the port", [&] {
        lines_.clear();
        if (auto framing = framer_.feed(std::string_view(read_buffer_.data(), bytes), lines_)) {
            outlet_.log_error("framing", framing);
            mark_out_of_step(link_fault::kind::noise, "an overlong line");
        }
        for (const auto& line : lines_) {
            on_line(line);
            if (generation != generation_) return;  // a handler closed the port
        }
    });
}

void command_link::on_line(const std::string& line) {
    if (log_.should_log(spdlog::level::trace)) log_.trace("RX {}", escape_control(line));
    // Controller bytes are data: a line with a byte that no MS-2000 reply has is noise, and from here
    // on only printable ASCII lines reach a reply, a snapshot or an event.
    const bool text = ms2000::is_reply_text(line);

    // Unsolicited position report (TTL IN0 mode 5): "T:   400    0.0    0.1".
    if (auto report = text ? ms2000::parse_position_report(line) : std::nullopt) {
        return owner_.position_report(*report);
    }

    if (sync_ == link_sync::draining || sync_ == link_sync::confirming) {
        // What the resynchronisation waits to see the end of.
        line_noise_ = true;
        ++stale_lines_;
        log_.debug("drained line \"{}\" ({} so far)", escape_control(line), stale_lines_);
        return;
    }
    if (!in_flight_ || !in_flight_->accepting) {
        ++stale_lines_;
        log_.debug("discarded stale line \"{}\" ({} so far)", escape_control(line), stale_lines_);
        if (sync_ == link_sync::probing) {
            line_noise_ = true;
            return;
        }
        mark_out_of_step(text ? link_fault::kind::unexpected : link_fault::kind::noise,
                         "a line nobody asked for");
        return pump();
    }

    if (in_flight_->held) {
        // A line after a reply identical to the previous answer: that reply was the copy.
        const auto copy = in_flight_->held->raw;
        mark_out_of_step(link_fault::kind::mismatch, "a reply that repeats the previous one");
        return finish(ms2000::error::unrecognized_reply, std::nullopt, copy);
    }

    const auto& cmd = in_flight_->job.cmd;
    auto parsed = ms2000::accept_reply(cmd, line);
    if (!parsed) {
        // Noise, or the right shape for another command (a late reply): never an answer.
        if (!text) {
            mark_out_of_step(link_fault::kind::noise, "a reply with bytes that are not ASCII");
            return finish(parsed.error(), std::nullopt, escape_control(line));
        }
        mark_out_of_step(link_fault::kind::mismatch, "a reply that does not fit its command");
        return finish(parsed.error(), std::nullopt, line);
    }
    if (repeats_last_answer(cmd, *parsed, line)) {
        // It fits, but it may be the previous answer sent again (an adapter that repeats a buffer),
        // with this command's own answer still on its way. Different commands may also share an
        // answer ("RS Y?" and "RS Z?" both ":A N"), so only a line that follows proves a copy.
        log_.debug("holding \"{}\": identical to the previous answer", line);
        in_flight_->held = std::move(*parsed);
        return arm_command_timer(settings_.repeated_reply_window, in_flight_->sequence);
    }
    accept(std::move(*parsed), line);
}

// ---- commands ---------------------------------------------------------------------------------

void command_link::submit(queued_command job, error_code when_closed) {
    if (job.cmd.is_halt) {
        // Counted before anything can refuse it, and guarded commands still waiting are dropped: their
        // callers decided on them before this HALT, and nothing of theirs may follow it.
        for (auto& dropped : queue_.accept_halt())
            complete(dropped, ms2000::error::halted, {});
    } else if (queue_.missed_halt(job)) {
        return complete(job, ms2000::error::halted, {});
    }
    if (!port_.is_open()) return complete(job, when_closed, {});
    if (!queue_.push(job)) return complete(job, ms2000::error::queue_full, {});
    pump();
}

void command_link::enqueue_internal(ms2000::command cmd, const char* tag, internal_handler handler) {
    queued_command job;
    job.cmd = std::move(cmd);
    job.request_id = tag;
    job.internal = std::move(handler);
    queue_.push_internal(std::move(job));
}

void command_link::pump() {
    if (in_flight_ || !port_.is_open()) return;
    // Bytes that arrived since the last reply and end no line: nobody asked for them.
    if (sync_ == link_sync::in_step && !framer_.partial().empty())
        mark_out_of_step(link_fault::kind::unexpected, "bytes nobody asked for");
    if (sync_ != link_sync::in_step) {
        // A HALT does not wait for the link: the stage must stop. If its answer cannot be proven its
        // own, it is sent once more after the resynchronisation (a second HALT is harmless).
        const bool halt_now = queue_.unsent_halt_waiting() && sync_ != link_sync::probing;
        if (!halt_now) {
            if (sync_ == link_sync::out_of_step) start_drain();
            return;
        }
        ++quiet_round_;
        resync_timer_.cancel();
        sync_ = link_sync::out_of_step;
    }
    // HALT first, then the driver's own commands, then the clients', then the background work.
    auto next = queue_.pop();
    if (!next) next = owner_.next_background_command();
    if (next) start_in_flight(std::move(*next));
}

void command_link::start_in_flight(queued_command job) {
    const auto sequence = next_sequence_++;
    in_flight_.emplace(in_flight{std::move(job), sequence, false, steady_clock::now()});

    // Stale input (a late reply, noise) must not be taken for this command's reply: what the kernel
    // holds now is dropped and, unless a resynchronisation is dropping it anyway, puts the link out of
    // step. Then read completions that are already queued run (through the io_context queue and back
    // to the strand) while the command is not yet accepting lines.
    framer_.reset();
    if (port_.flush_input() > 0 && sync_ == link_sync::in_step)
        mark_out_of_step(link_fault::kind::unexpected, "bytes nobody asked for");
    // Every byte read so far has been handled (the port is read only here, on the strand: do_read),
    // except the rest of the read being handled now, if that read's answer started this command: it
    // is written once that rest is handled, as any line after an answer is nobody's.
    if (handling_read_) {
        write_after_read_ = sequence;
        return;
    }
    do_write(sequence, true);
}

void command_link::hold_back_in_flight() {
    auto job = std::move(in_flight_->job);
    in_flight_.reset();
    if (job.held_back)
        job.held_back();  // background work is offered again in its turn, after the clients' commands
    else
        queue_.push_front(std::move(job));
    pump();
}

void command_link::do_write(std::uint64_t sequence, bool input_just_flushed) {
    if (!in_flight_ || in_flight_->sequence != sequence || !port_.is_open()) return;
    // A stale line still queued when the command was taken put the link out of step: it waits.
    const auto& waiting = in_flight_->job;
    const bool may_wait = !waiting.cmd.is_halt && !waiting.probe;
    if (sync_ == link_sync::in_step && !framer_.partial().empty())
        mark_out_of_step(link_fault::kind::unexpected, "bytes nobody asked for");
    if (sync_ == link_sync::out_of_step && may_wait) return hold_back_in_flight();
    // A reply repeated at once (an echoing adapter, a duplicated frame) would arrive just as the next
    // command goes out and could be taken for its answer. Its first byte follows the last one read
    // within a character time: wait one and a half, then for any byte already in the port's buffer to
    // be read, so that such bytes land while nothing accepts them.
    const auto guard = char_time_ + char_time_ / 2;
    const auto quiet_for = steady_clock::now() - last_read_;
    if (may_wait && (quiet_for < guard || (!input_just_flushed && bytes_waiting_in_port()))) {
        guard_timer_.expires_after(quiet_for < guard ? guard - quiet_for : guard);
        guard_timer_.async_wait([this, alive = owner_.keep_alive(), sequence](error_code ec) {
            if (!ec) do_write(sequence);
        });
        return;
    }
    framer_.reset();
    if (const auto& cmd = in_flight_->job.cmd; cmd.expect == ms2000::reply_shape::status_bytes)
        framer_.expect_status_bytes(cmd.form.axes.size());
    in_flight_->accepting = true;
    in_flight_->started = steady_clock::now();

    // The deadline covers the write too: a port that stops draining is caught as well.
    arm_command_timer(
        in_flight_->job.cmd.long_reply ? settings_.long_reply_timeout : settings_.command_timeout, sequence);

    const auto& command = in_flight_->job.cmd.wire;
    if (log_.should_log(spdlog::level::trace)) log_.trace("TX {}", escape_control(command));
    // A command is a few bytes and the tty's output buffer is nearly always free: written at once, it
    // costs no trip through the io_context's queue. Whatever the port does not take now (or an error)
    // goes the asynchronous way.
    auto written = ::write(port_.stream().native_handle(), command.data(), command.size());
    if (written == static_cast<ssize_t>(command.size())) return on_write(sequence, {});
    // The buffer is shared with the handler: it outlives the command if the port is closed meanwhile.
    auto wire =
        std::make_shared<std::string>(command.substr(written > 0 ? static_cast<std::size_t>(written) : 0));
    net::async_write(
        port_.stream(), net::buffer(*wire),
        net::bind_executor(strand_, [this, alive = owner_.keep_alive(), sequence, wire](
                                        error_code ec, std::size_t) { on_write(sequence, ec); }));
}

bool command_link::bytes_waiting_in_port() {
    int waiting = 0;
    return ::ioctl(port_.stream().native_handle(), FIONREAD, &waiting) == 0 && waiting > 0;
}

void command_link::note_line_pace(std::size_t characters, steady_clock::duration round_trip) {
    // A command and its answer crossed the line within the round trip: no character took longer
    // than round_trip / characters. Only ever shortens the configured character time.
    if (characters == 0) return;
    char_time_ = std::min(char_time_, round_trip / static_cast<long>(characters));
}

void command_link::arm_command_timer(steady_clock::duration after, std::uint64_t sequence) {
    command_timer_.expires_after(after);
    command_timer_.async_wait([this, alive = owner_.keep_alive(), sequence](error_code ec) {
        if (!ec) guarded("handling a timeout", [&] { on_timeout(sequence); });
    });
}

void command_link::on_write(std::uint64_t sequence, error_code ec) {
    if (ec && ec != net::error::operation_aborted) return owner_.disconnect(ec, "write");
    if (in_flight_ && in_flight_->sequence == sequence) in_flight_->write_done = true;
}

void command_link::on_timeout(std::uint64_t sequence) {
    // An expired timer cannot be cancelled: the sequence number tells a stale one apart.
    if (!in_flight_ || in_flight_->sequence != sequence) return;
    if (in_flight_->held) {
        // Nothing followed the held reply: it was this command's own answer, identical by chance.
        auto r = std::move(*in_flight_->held);
        const auto line = r.raw;
        return accept(std::move(r), line);
    }
    if (!in_flight_->write_done) {
        // Not even the command left: the port is stuck (a hung adapter). Start over.
        return owner_.disconnect(ms2000::error::timeout, "write stalled");
    }
    if (owner_.identified())
        outlet_.log_error("command timed out", ms2000::error::timeout);
    else
        log_.debug("command \"{}\" timed out", escape_control(in_flight_->job.cmd.wire));
    // Its reply may still come, and would then be taken for the next command's.
    mark_out_of_step(link_fault::kind::timeout, "a command timed out");
    finish(ms2000::error::timeout, std::nullopt, escape_control(framer_.partial()));
}

bool command_link::repeats_last_answer(const ms2000::command& cmd, const ms2000::reply& r,
                                       const std::string& line) const {
    // Replies that carry no more than a flag repeat legitimately from command to command: bare ":A"
    // acks (every move), ":N-<code>" errors (a HALT's ":N-21", then the next move's), "/"'s "B" and
    // one-character values (":A B" to "RS X?", "RS Y?" and "RS Z?" alike while the stage moves; ":A 0"
    // to "TTL X?" and "TTL Y?"). Holding them would add the window to every poll round of a moving
    // stage; a copy of one is still caught when the command's own answer arrives as a stray line.
    const bool flag_only =
        r.what == ms2000::reply::kind::error || r.what == ms2000::reply::kind::status ||
        (r.what == ms2000::reply::kind::ack && r.axes.empty() &&
         std::all_of(r.values.begin(), r.values.end(), [](const std::string& v) { return v.size() <= 1; }));
    return !flag_only && line == last_answer_.line && cmd.wire != last_answer_.wire &&
           steady_clock::now() - last_answer_.at < settings_.repeated_reply_window;
}

void command_link::accept(ms2000::reply r, const std::string& line) {
    const auto& cmd = in_flight_->job.cmd;
    last_answer_ = {line, cmd.wire, steady_clock::now()};
    // Only an answer taken in step proves the pace: a HALT's (written at once, even out of step) or the
    // resynchronisation probe's may be an older reply that was already on its way. The line's end
    // ("\r\n") was read too.
    if (sync_ == link_sync::in_step && !cmd.is_halt && !in_flight_->job.probe)
        note_line_pace(cmd.wire.size() + line.size() + 2, last_answer_.at - in_flight_->started);
    if (r.what == ms2000::reply::kind::error) {
        // HALT answers ":N-21" when it stopped a move: that is what HALT is for.
        if (cmd.is_halt && r.error_code == ms2000::halted) return finish({}, std::move(r), line);
        return finish(ms2000::error::controller_rejected, std::move(r), line);
    }
    finish({}, std::move(r), line);
}

void command_link::finish(error_code ec, std::optional<ms2000::reply> reply, const std::string& raw) {
    command_timer_.cancel();
    auto done = std::move(*in_flight_);
    in_flight_.reset();
    trace(done.job, done.started, ec, raw);

    const bool unproven = ec == ms2000::error::unrecognized_reply || ec == ms2000::error::timeout;
    if (done.job.cmd.is_halt && unproven && !done.job.resent) {
        // The HALT reached the controller; send it again once the link is in step, for a proven answer.
        done.job.resent = true;
        queue_.push_front(std::move(done.job));
        outlet_.publish_snapshot();
        return pump();
    }
    if (!done.job.internal) owner_.client_command_finished(done.job.cmd, ec, reply ? &*reply : nullptr);

    ms2000::reply result;
    if (reply) {
        result = std::move(*reply);
    } else {
        result.raw = raw;
    }
    complete(done.job, ec, std::move(result));
    outlet_.publish_snapshot();
    pump();
}

void command_link::complete(queued_command& job, error_code ec, ms2000::reply reply) {
    if (job.internal) {
        job.internal(ec, reply);
    } else if (job.user) {
        owner_.client_answered(ec);
        // Never call a client's code inline. An answer read by do_read is handed over when that read is
        // done, as a posted handler would be but without the queue's round trip; otherwise posted.
        if (handling_read_)
            answered_in_read_.push_back({std::move(job.user), ec, std::move(reply)});
        else
            net::post(strand_, net::append(std::move(job.user), ec, std::move(reply)));
    }
}

void command_link::fail_all(error_code ec) {
    std::vector<queued_command> jobs;
    if (in_flight_) {
        trace(in_flight_->job, in_flight_->started, ec, {});
        jobs.push_back(std::move(in_flight_->job));
        in_flight_.reset();
    }
    for (auto& job : queue_.take_all())
        jobs.push_back(std::move(job));
    for (auto& job : jobs)
        complete(job, ec, {});
}

void command_link::trace(const queued_command& job, steady_clock::time_point started, error_code ec,
                         const std::string& raw) {
    const auto latency = std::chrono::duration_cast<std::chrono::microseconds>(steady_clock::now() - started);
    outlet_.trace(job.request_id, static_cast<bool>(job.internal), job.cmd.wire, raw, ec, latency);
}

// ---- resynchronisation ------------------------------------------------------------------------

void command_link::mark_out_of_step(link_fault::kind kind, const char* why) {
    outlet_.fault(kind);
    if (sync_ == link_sync::draining || sync_ == link_sync::confirming) {
        line_noise_ = true;
        return;
    }
    if (sync_ != link_sync::in_step) return;  // already resynchronising (a probe's failure is its own)
    sync_ = link_sync::out_of_step;
    probe_attempts_ = 0;
    resync_started_ = steady_clock::now();
    std::uint64_t suppressed = 0;
    if (sync_limiter_.allow(resync_started_, suppressed))
        log_.warn("{}: link out of step, resynchronising ({} similar suppressed)", why, suppressed);
}

void command_link::start_drain() {
    sync_ = link_sync::draining;
    line_noise_ = false;
    framer_.reset();
    port_.flush_input();
    arm_quiet_timer();
}

void command_link::arm_quiet_timer() {
    resync_timer_.expires_after(settings_.resync_delay);
    resync_timer_.async_wait(
        [this, alive = owner_.keep_alive(), generation = generation_, round = ++quiet_round_](error_code ec) {
            if (ec || generation != generation_ || round != quiet_round_) return;
            guarded("resynchronising", [&] { on_quiet_window(); });
        });
}

void command_link::on_quiet_window() {
    const bool noisy = line_noise_ || !framer_.partial().empty();
    if (sync_ == link_sync::draining) {
        if (!noisy) return send_probe();
        if (steady_clock::now() - resync_started_ > settings_.resync_timeout)
            return retry_resync("the line never went quiet");
        // Still talking: drop what came and wait for another quiet window.
        line_noise_ = false;
        framer_.reset();
        port_.flush_input();
        return arm_quiet_timer();
    }
    if (sync_ != link_sync::confirming) return;
    // A second answer after the probe's means the first was a late reply to an earlier V.
    if (noisy) return retry_resync("more bytes followed the probe's answer");
    sync_ = link_sync::in_step;
    outlet_.fault(link_fault::kind::resynced);
    log_.info(
        "link back in step after {} ms",
        std::chrono::duration_cast<std::chrono::milliseconds>(steady_clock::now() - resync_started_).count());
    pump();
}

void command_link::send_probe() {
    // V is harmless and its answer ("Version: USB-9.52") has a shape no other command's reply has.
    sync_ = link_sync::probing;
    line_noise_ = false;
    queued_command probe;
    probe.cmd = ms2000::version();
    probe.request_id = "resync";
    probe.internal = [this](error_code ec, const ms2000::reply&) { on_probe_reply(ec); };
    probe.probe = true;
    start_in_flight(std::move(probe));
}

void command_link::on_probe_reply(error_code ec) {
    if (command_aborted(ec)) return;
    if (ec || line_noise_)
        return retry_resync(ec ? "the probe got no fitting answer" : "noise around the probe");
    sync_ = link_sync::confirming;
    line_noise_ = false;
    arm_quiet_timer();
}

void command_link::retry_resync(const char* why) {
    ++probe_attempts_;
    const bool too_long = steady_clock::now() - resync_started_ > settings_.resync_timeout;
    if (probe_attempts_ < settings_.resync_attempts && !too_long) {
        log_.debug("resynchronisation: {}; trying again", why);
        return start_drain();
    }
    outlet_.fault(link_fault::kind::resync_failed);
    owner_.disconnect(ms2000::error::unrecognized_reply, "resynchronisation failed");
}

void command_link::reset_sync() {
    sync_ = link_sync::in_step;
    line_noise_ = false;
    probe_attempts_ = 0;
    ++quiet_round_;
}

}  // namespace gw::devices
