#include "devices/serial/controller.hpp"

#include <algorithm>
#include <utility>

#include <boost/asio/append.hpp>
#include <boost/asio/bind_executor.hpp>
#include <boost/asio/buffer.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>
#include <spdlog/spdlog.h>

#include "devices/ms2000/build_info.hpp"
#include "devices/ms2000/error.hpp"
#include "devices/serial/escape.hpp"

namespace gw::devices {
namespace net = boost::asio;
using boost::system::error_code;
using std::chrono::steady_clock;
using std::chrono::system_clock;

namespace {

std::shared_ptr<spdlog::logger> make_logger(const std::string& name) {
    if (auto existing = spdlog::get(name)) return existing;
    auto fallback = spdlog::default_logger();
    auto logger = std::make_shared<spdlog::logger>(name, fallback->sinks().begin(), fallback->sinks().end());
    logger->set_level(fallback->level());
    try {
        spdlog::register_logger(logger);
    } catch (const spdlog::spdlog_ex&) {
        // Another controller with the same id registered it first.
        if (auto existing = spdlog::get(name)) return existing;
    }
    return logger;
}

// Errors that mean "the command never got an answer because the port or the controller went away";
// the driver's own continuations stop there.
bool aborted(error_code ec) {
    return ec == ms2000::error::disconnected || ec == ms2000::error::cancelled ||
           ec == ms2000::error::not_connected;
}

std::optional<double> axis_number(const ms2000::reply& r, char axis) {
    if (const auto* a = r.axis(axis)) return a->number;
    return std::nullopt;
}

}  // namespace

controller::controller(const net::any_io_executor& ex, controller_settings settings,
                       std::weak_ptr<controller_observer> observer)
    : settings_(std::move(settings)),
      strand_(net::make_strand(ex)),
      observer_(std::move(observer)),
      log_(make_logger("ms2000." + settings_.id)),
      port_(strand_),
      command_timer_(strand_),
      resync_timer_(strand_),
      reconnect_timer_(strand_),
      poll_timer_(strand_),
      presence_timer_(strand_),
      backoff_(settings_.reconnect_min),
      report_port_(strand_) {
    snapshot_.id = settings_.id;
    snapshot_.port = settings_.port;
    snapshot_.report = settings_.report_port.empty() ? report_port_state::none : report_port_state::closed;
}

controller::~controller() = default;

void controller::start() {
    net::post(strand_, [self = shared_from_this()] {
        if (self->snapshot_.state != connection_state::stopped) return;
        self->stopped_ = false;
        self->backoff_ = self->settings_.reconnect_min;
        self->snapshot_.state = connection_state::disconnected;
        self->do_connect();
    });
}

void controller::stop() {
    net::post(strand_, [self = shared_from_this()] { self->do_stop(); });
}

void controller::set_observer(std::weak_ptr<controller_observer> observer) {
    net::post(strand_, [self = shared_from_this(), observer = std::move(observer)]() mutable {
        self->observer_ = std::move(observer);
    });
}

void controller::get_snapshot(std::function<void(controller_snapshot)> handler) {
    net::post(strand_,
              [self = shared_from_this(), handler = std::move(handler)] { handler(self->snapshot_); });
}

// ---- commands ---------------------------------------------------------------------------------

void controller::submit(ms2000::command cmd, std::string request_id, completion_handler handler) {
    // Post to the strand: all state lives there.
    net::post(strand_,
              [self = shared_from_this(),
               job = pending{std::move(cmd), std::move(request_id), std::move(handler), {}}]() mutable {
                  self->on_submit(std::move(job));
              });
}

void controller::on_submit(pending job) {
    if (stopped_) return complete(job, ms2000::error::cancelled, {});
    if (!port_.is_open()) return complete(job, ms2000::error::not_connected, {});
    if (job.cmd.is_halt) {
        if (halts_.size() >= settings_.queue_limit) return complete(job, ms2000::error::queue_full, {});
        halts_.push_back(std::move(job));
    } else if (user_queue_.size() >= settings_.queue_limit) {
        return complete(job, ms2000::error::queue_full, {});
    } else {
        user_queue_.push_back(std::move(job));
    }
    pump();
}

void controller::enqueue_internal(ms2000::command cmd, const char* tag, internal_handler handler) {
    internal_queue_.push_back(pending{std::move(cmd), tag, {}, std::move(handler)});
}

std::optional<controller::pending> controller::take_next() {
    // HALT first, then the driver's identification, then user commands, then the poll's next step.
    for (auto* queue : {&halts_, &internal_queue_, &user_queue_}) {
        if (!queue->empty()) {
            auto job = std::move(queue->front());
            queue->pop_front();
            return job;
        }
    }
    return next_poll_command();
}

void controller::pump() {
    if (in_flight_ || resyncing_ || !port_.is_open()) return;
    auto next = take_next();
    if (!next) return;

    const auto sequence = next_sequence_++;
    in_flight_.emplace(in_flight{std::move(*next), sequence, false, steady_clock::now()});

    // Stale input (a late reply, noise) must not be taken for this command's reply: drop what the
    // kernel holds now, then let read completions that are already queued run (through the
    // io_context queue and back to the strand) while the command is not yet accepting lines.
    framer_.reset();
    port_.flush_input();
    net::post(strand_.get_inner_executor(), [self = shared_from_this(), sequence] {
        net::post(self->strand_, [self, sequence] { self->do_write(sequence); });
    });
}

void controller::do_write(std::uint64_t sequence) {
    if (!in_flight_ || in_flight_->sequence != sequence || !port_.is_open()) return;
    framer_.reset();
    in_flight_->accepting = true;
    in_flight_->started = steady_clock::now();

    // The deadline covers the write too: a port that stops draining is caught as well.
    const auto timeout =
        in_flight_->job.cmd.long_reply ? settings_.long_reply_timeout : settings_.command_timeout;
    command_timer_.expires_after(timeout);
    command_timer_.async_wait([self = shared_from_this(), sequence](error_code ec) {
        if (!ec) self->on_timeout(sequence);
    });

    // The buffer is shared with the handler: it outlives the command if the port is closed meanwhile.
    auto wire = std::make_shared<std::string>(in_flight_->job.cmd.wire);
    if (log_->should_log(spdlog::level::trace)) log_->trace("TX {}", escape_control(*wire));
    net::async_write(
        port_.stream(), net::buffer(*wire),
        net::bind_executor(strand_, [self = shared_from_this(), sequence, wire](error_code ec, std::size_t) {
            self->on_write(sequence, ec);
        }));
}

void controller::on_write(std::uint64_t sequence, error_code ec) {
    if (ec && ec != net::error::operation_aborted) return disconnect(ec, "write");
    if (in_flight_ && in_flight_->sequence == sequence) in_flight_->write_done = true;
}

void controller::on_timeout(std::uint64_t sequence) {
    // An expired timer cannot be cancelled: the sequence number tells a stale one apart.
    if (!in_flight_ || in_flight_->sequence != sequence) return;
    if (!in_flight_->write_done) {
        // Not even the command left: the port is stuck (a hung adapter). Start over.
        return disconnect(ms2000::error::timeout, "write stalled");
    }
    log_error("command timed out", ms2000::error::timeout);

    // Wait a moment before the next command so a late reply lands while nothing is in flight.
    resyncing_ = true;
    resync_timer_.expires_after(settings_.resync_delay);
    resync_timer_.async_wait([self = shared_from_this(), generation = generation_](error_code ec) {
        if (ec || generation != self->generation_) return;
        self->resyncing_ = false;
        self->framer_.reset();
        self->port_.flush_input();
        self->pump();
    });
    finish(ms2000::error::timeout, std::nullopt, std::string(framer_.partial()));
}

void controller::on_line(const std::string& line) {
    if (log_->should_log(spdlog::level::trace)) log_->trace("RX {}", escape_control(line));

    // Unsolicited position report (TTL IN0 mode 5): "T:   400    0.0    0.1".
    if (auto report = ms2000::parse_position_report(line)) {
        ttl_event event;
        event.controller_id = settings_.id;
        event.sequence = ++ttl_sequence_;
        event.steady_time = steady_clock::now();
        event.system_time = system_clock::now();
        event.controller_ms = report->milliseconds;
        const auto axes = motor_axes();
        for (std::size_t i = 0; i < report->positions.size(); ++i) {
            const char letter = i < axes.size() ? axes[i] : '?';
            event.axes.push_back({letter, report->positions[i] / 10.0});
        }
        if (auto obs = observer_.lock()) obs->on_ttl(event);
        return;
    }

    if (!in_flight_ || !in_flight_->accepting) {
        ++stale_lines_;
        log_->debug("discarded stale line \"{}\" ({} so far)", escape_control(line), stale_lines_);
        return;
    }

    const auto& cmd = in_flight_->job.cmd;
    auto parsed = ms2000::parse_reply(cmd.expect, line);
    if (!parsed) return finish(parsed.error(), std::nullopt, line);
    if (parsed->what == ms2000::reply::kind::error) {
        // HALT answers ":N-21" when it stopped a move: that is what HALT is for.
        if (cmd.is_halt && parsed->error_code == ms2000::halted) return finish({}, std::move(*parsed), line);
        return finish(ms2000::error::controller_rejected, std::move(*parsed), line);
    }
    finish({}, std::move(*parsed), line);
}

void controller::finish(error_code ec, std::optional<ms2000::reply> reply, const std::string& raw) {
    command_timer_.cancel();
    auto done = std::move(*in_flight_);
    in_flight_.reset();

    const auto latency =
        std::chrono::duration_cast<std::chrono::microseconds>(steady_clock::now() - done.started);
    trace(done.job, latency, ec, reply, raw);

    if (ec && !done.job.internal) {
        if (ec == ms2000::error::controller_rejected && reply) {
            note_error(reply->error_code, std::string(ms2000::controller_error_name(reply->error_code)),
                       std::string(ms2000::controller_error_description(reply->error_code)));
        } else {
            note_error(0, ec.message(), "command \"" + escape_control(done.job.cmd.wire) + "\" failed");
        }
    }

    ms2000::reply result;
    if (reply) {
        result = std::move(*reply);
    } else {
        result.raw = raw;
    }
    complete(done.job, ec, std::move(result));
    publish_snapshot();
    pump();
}

void controller::complete(pending& job, error_code ec, ms2000::reply reply) {
    if (job.internal) {
        job.internal(ec, reply);
    } else if (job.user) {
        // Never call user code inline: post to the handler's associated executor (or our strand).
        net::post(strand_, net::append(std::move(job.user), ec, std::move(reply)));
    }
}

void controller::fail_all(error_code ec) {
    std::vector<pending> jobs;
    if (in_flight_) {
        trace(
            in_flight_->job,
            std::chrono::duration_cast<std::chrono::microseconds>(steady_clock::now() - in_flight_->started),
            ec, std::nullopt, {});
        jobs.push_back(std::move(in_flight_->job));
        in_flight_.reset();
    }
    for (auto* queue : {&halts_, &internal_queue_, &user_queue_}) {
        for (auto& job : *queue)
            jobs.push_back(std::move(job));
        queue->clear();
    }
    for (auto& job : jobs)
        complete(job, ec, {});
}

// ---- connection -------------------------------------------------------------------------------

void controller::do_connect() {
    if (stopped_ || port_.is_open()) return;
    if (auto ec = port_.open(settings_.port, settings_.baud)) {
        log_error("cannot open port", ec);
        return schedule_reconnect();
    }
    ++generation_;
    framer_.reset();
    resyncing_ = false;
    log_->info("port {} open at {} baud, identifying", settings_.port, settings_.baud);
    snapshot_.state = connection_state::identifying;
    snapshot_.identity.reset();
    snapshot_.axes.clear();
    snapshot_.busy = false;
    publish_snapshot();

    do_read(generation_);
    arm_presence_check();
    identify();
    pump();
}

void controller::schedule_reconnect() {
    if (stopped_) return;
    reconnect_timer_.expires_after(backoff_);
    backoff_ = std::min(backoff_ * 2, settings_.reconnect_max);
    reconnect_timer_.async_wait([self = shared_from_this()](error_code ec) {
        if (!ec) self->do_connect();
    });
}

void controller::disconnect(error_code ec, const char* what) {
    if (!port_.is_open()) return;
    log_->warn("{}: {}; port closed, reconnecting", what, ec.message());
    ++generation_;
    port_.close();
    close_report_port();
    command_timer_.cancel();
    resync_timer_.cancel();
    poll_timer_.cancel();
    presence_timer_.cancel();
    resyncing_ = false;
    poll_step_ = poll_step::idle;
    poll_due_ = false;

    fail_all(ms2000::error::disconnected);

    snapshot_.state = connection_state::disconnected;
    snapshot_.busy = false;
    for (auto& a : snapshot_.axes)
        a.busy = false;
    note_error(0, "disconnected", std::string(what) + ": " + ec.message());
    publish_snapshot();
    schedule_reconnect();
}

void controller::do_stop() {
    if (stopped_ && snapshot_.state == connection_state::stopped) return;
    stopped_ = true;
    ++generation_;
    port_.close();
    close_report_port();
    for (auto* timer : {&command_timer_, &resync_timer_, &reconnect_timer_, &poll_timer_, &presence_timer_})
        timer->cancel();
    resyncing_ = false;
    poll_step_ = poll_step::idle;
    poll_due_ = false;
    fail_all(ms2000::error::cancelled);
    snapshot_.state = connection_state::stopped;
    snapshot_.busy = false;
    log_->info("stopped");
    publish_snapshot();
}

void controller::arm_presence_check() {
    presence_timer_.expires_after(settings_.presence_check);
    presence_timer_.async_wait([self = shared_from_this(), generation = generation_](error_code ec) {
        if (ec || generation != self->generation_) return;
        // A vanished node (unplugged adapter, removed link) is not always seen by a pending read.
        if (!self->port_.still_present(self->settings_.port))
            return self->disconnect(boost::system::errc::make_error_code(boost::system::errc::no_such_device),
                                    "device node vanished");
        if (self->snapshot_.state == connection_state::connected && !self->report_port_.is_open())
            self->open_report_port();
        self->arm_presence_check();
    });
}

void controller::do_read(std::uint64_t generation) {
    port_.stream().async_read_some(
        net::buffer(read_buffer_),
        net::bind_executor(strand_, [self = shared_from_this(), generation](error_code ec, std::size_t n) {
            self->on_read(generation, ec, n);
        }));
}

void controller::on_read(std::uint64_t generation, error_code ec, std::size_t bytes) {
    if (generation != generation_) return;
    if (ec) return disconnect(ec, "read");  // EOF, EIO (pty master closed), ENXIO (USB gone)
    lines_.clear();
    if (auto framing = framer_.feed(std::string_view(read_buffer_.data(), bytes), lines_))
        log_error("framing", framing);
    for (const auto& line : lines_) {
        on_line(line);
        if (generation != generation_) return;  // a handler closed the port
    }
    do_read(generation);
}

// ---- identification and polling ---------------------------------------------------------------

std::string controller::motor_axes() const {
    std::string axes;
    for (const auto& a : snapshot_.axes)
        axes += a.axis;
    return axes;
}

void controller::identify() {
    auto self = shared_from_this();
    // reply: ":A Version: USB-9.52 "
    enqueue_internal(ms2000::version(), "identify", [this, self](error_code ec, const ms2000::reply& r) {
        if (aborted(ec)) return;
        if (ec && ec != ms2000::error::controller_rejected) return disconnect(ec, "identify (V)");
        controller_identity identity;
        identity.version_raw = r.raw;
        auto version = ms2000::parse_version(r);
        identity.version = version ? *version : r.raw;
        snapshot_.identity = std::move(identity);
    });
    // reply: "STD_XYZ\rMotor Axes: X Y Z\r...\r\n"
    enqueue_internal(ms2000::build_x(), "identify", [this, self](error_code ec, const ms2000::reply& r) {
        if (aborted(ec) || !snapshot_.identity) return;
        if (ec == ms2000::error::timeout) return disconnect(ec, "identify (BU X)");
        if (!ec) {
            if (auto build = ms2000::parse_build_x(r.raw)) snapshot_.identity->build = std::move(*build);
        }
        auto& build = snapshot_.identity->build;
        if (build.motor_axes.empty()) {
            // Firmware without BU X: the smallest MS-2000, an XY stage.
            log_->warn("no motor axes from BU X, assuming XY");
            build.motor_axes = "XY";
        }
        snapshot_.axes.clear();
        for (const char letter : build.motor_axes) {
            axis_state a;
            a.axis = letter;
            snapshot_.axes.push_back(a);
        }
        const auto axes = motor_axes();

        // reply: ":A X=10000.000000 Y=10000.000000"
        enqueue_internal(ms2000::query("CNTS", axes), "identify",
                         [this](error_code ec, const ms2000::reply& r) {
                             if (ec) return;
                             for (auto& a : snapshot_.axes)
                                 a.counts_per_mm = axis_number(r, a.axis);
                         });
        enqueue_internal(ms2000::query("SL", axes), "identify",
                         [this](error_code ec, const ms2000::reply& r) {
                             if (ec) return;
                             for (auto& a : snapshot_.axes)
                                 a.lower_limit_mm = axis_number(r, a.axis);
                         });
        enqueue_internal(ms2000::query("SU", axes), "identify",
                         [this](error_code ec, const ms2000::reply& r) {
                             if (ec) return;
                             for (auto& a : snapshot_.axes)
                                 a.upper_limit_mm = axis_number(r, a.axis);
                         });
        // reply: ":A X=0 Y=0"
        enqueue_internal(ms2000::query("TTL", "XY"), "identify",
                         [this](error_code ec, const ms2000::reply& r) {
                             if (aborted(ec)) return;
                             if (!ec) {
                                 auto mode = [&](char axis, std::size_t index) -> std::optional<int> {
                                     auto n = axis_number(r, axis);
                                     if (!n) n = r.number(index);
                                     if (!n) return std::nullopt;
                                     return static_cast<int>(*n);
                                 };
                                 snapshot_.ttl_in0_mode = mode('X', 0);
                                 snapshot_.ttl_out0_mode = mode('Y', 1);
                             }
                             on_identified();
                         });
    });
}

void controller::on_identified() {
    backoff_ = settings_.reconnect_min;
    snapshot_.state = connection_state::connected;
    const auto& id = *snapshot_.identity;
    log_->info("identified: version {}, build {}, axes {}", id.version, id.build.name, id.build.motor_axes);
    open_report_port();
    poll_due_ = settings_.poll_interval.count() > 0;
    arm_poll_timer();
    publish_snapshot();
}

void controller::arm_poll_timer() {
    if (settings_.poll_interval.count() <= 0) return;
    poll_timer_.expires_after(settings_.poll_interval);
    poll_timer_.async_wait([self = shared_from_this(), generation = generation_](error_code ec) {
        if (ec || generation != self->generation_) return;
        // At most one poll round: a round still running absorbs this tick.
        if (self->poll_step_ == poll_step::idle) self->poll_due_ = true;
        self->pump();
        self->arm_poll_timer();
    });
}

std::optional<controller::pending> controller::next_poll_command() {
    if (snapshot_.state != connection_state::connected) return std::nullopt;
    if (poll_step_ == poll_step::idle) {
        if (!poll_due_) return std::nullopt;
        poll_due_ = false;
        poll_step_ = poll_step::where;
    }
    const auto axes = motor_axes();
    const auto step = poll_step_;
    const auto index = poll_axis_;
    auto handler = [this, self = shared_from_this(), step, index](error_code ec, const ms2000::reply& r) {
        on_poll_reply(step, index, ec, r);
    };
    switch (step) {
        case poll_step::where:
            return pending{ms2000::where(axes), "poll", {}, std::move(handler)};
        case poll_step::status:
            return pending{ms2000::status(), "poll", {}, std::move(handler)};
        case poll_step::axis_status:
            return pending{ms2000::query("RS", axes.substr(index, 1)), "poll", {}, std::move(handler)};
        case poll_step::idle:
            break;
    }
    return std::nullopt;
}

void controller::on_poll_reply(poll_step step, std::size_t axis_index, error_code ec,
                               const ms2000::reply& r) {
    if (ec) {
        // Give up this round; the next tick starts a new one.
        poll_step_ = poll_step::idle;
        if (!aborted(ec)) log_error("poll", ec);
        return;
    }
    switch (step) {
        case poll_step::where:
            // reply: ":A 1234.5 432.1 0" in hardware order, tenths of a micron.
            for (std::size_t i = 0; i < snapshot_.axes.size(); ++i) {
                if (auto n = r.number(i)) snapshot_.axes[i].position_um = *n / 10.0;
            }
            poll_step_ = poll_step::status;
            return;
        case poll_step::status:
            // reply: "B" or "N"
            snapshot_.busy = r.busy;
            if (r.busy && !snapshot_.axes.empty()) {
                poll_step_ = poll_step::axis_status;
                poll_axis_ = 0;
                return;
            }
            for (auto& a : snapshot_.axes)
                a.busy = false;
            break;
        case poll_step::axis_status: {
            // reply: ":A B" or ":A N"
            if (axis_index < snapshot_.axes.size()) {
                auto& a = snapshot_.axes[axis_index];
                const auto* v = r.axis(a.axis);
                const std::string& text = v ? v->text : (r.values.empty() ? std::string() : r.values.front());
                a.busy = text == "B";
            }
            poll_axis_ = axis_index + 1;
            if (poll_axis_ < snapshot_.axes.size()) return;
            break;
        }
        case poll_step::idle:
            break;
    }
    poll_step_ = poll_step::idle;
    snapshot_.updated = system_clock::now();
}

// ---- report port ------------------------------------------------------------------------------

void controller::open_report_port() {
    if (settings_.report_port.empty() || report_port_.is_open()) return;
    if (auto ec = report_port_.open(settings_.report_port, settings_.baud)) {
        log_error("cannot open report port", ec);
        snapshot_.report = report_port_state::closed;
        return;
    }
    decoder_.emplace(ms2000::report_format::binary, snapshot_.axes.size());
    snapshot_.report = report_port_state::open;
    log_->info("report port {} open", settings_.report_port);
    do_report_read(++report_generation_);
    publish_snapshot();
}

void controller::close_report_port() {
    ++report_generation_;
    report_port_.close();
    if (!settings_.report_port.empty()) snapshot_.report = report_port_state::closed;
}

void controller::do_report_read(std::uint64_t generation) {
    report_port_.stream().async_read_some(
        net::buffer(report_buffer_),
        net::bind_executor(strand_, [self = shared_from_this(), generation](error_code ec, std::size_t n) {
            self->on_report_read(generation, ec, n);
        }));
}

void controller::on_report_read(std::uint64_t generation, error_code ec, std::size_t bytes) {
    if (generation != report_generation_) return;
    if (ec) {
        log_error("report port read", ec);
        close_report_port();
        publish_snapshot();
        return;
    }
    const auto steady_now = steady_clock::now();
    const auto system_now = system_clock::now();
    frames_.clear();
    decoder_->feed(std::span<const std::uint8_t>(report_buffer_.data(), bytes), frames_);
    auto obs = observer_.lock();
    for (const auto& frame : frames_) {
        report_event event;
        event.controller_id = settings_.id;
        event.sequence = ++report_sequence_;
        event.steady_time = steady_now;
        event.system_time = system_now;
        event.bytes_skipped = decoder_->bytes_skipped();
        for (const auto& count : frame.axes) {
            report_event::axis a{count.axis, count.count, std::nullopt};
            if (const auto* state = snapshot_.axis(count.axis);
                state && state->counts_per_mm && *state->counts_per_mm != 0) {
                a.position_um = count.count / *state->counts_per_mm * 1000.0;
            }
            event.axes.push_back(a);
        }
        if (log_->should_log(spdlog::level::trace)) log_->trace("report #{}", event.sequence);
        if (obs) obs->on_report(event);
    }
    do_report_read(generation);
}

// ---- events -----------------------------------------------------------------------------------

void controller::publish_snapshot() {
    if (published_ && same_content(*published_, snapshot_)) return;
    if (!published_ || published_->state != snapshot_.state)
        log_->info("state {}", to_string(snapshot_.state));
    snapshot_.updated = system_clock::now();
    published_ = snapshot_;
    if (auto obs = observer_.lock()) obs->on_snapshot(snapshot_);
}

void controller::note_error(int code, std::string name, std::string text) {
    snapshot_.last_error = controller_error_info{code, std::move(name), std::move(text), system_clock::now()};
}

void controller::trace(const pending& job, std::chrono::microseconds latency, error_code ec,
                       const std::optional<ms2000::reply>& reply, const std::string& raw) {
    auto obs = observer_.lock();
    if (!obs) return;
    command_trace t;
    t.controller_id = settings_.id;
    t.request_id = job.request_id;
    t.internal = static_cast<bool>(job.internal);
    t.wire = escape_control(job.cmd.wire);
    t.raw_reply = escape_control(raw);
    t.error = ec;
    t.reply = reply;
    t.latency = latency;
    obs->on_trace(t);
}

void controller::log_error(const char* what, error_code ec) {
    std::uint64_t suppressed = 0;
    if (!error_limiter_.allow(steady_clock::now(), suppressed)) return;
    if (suppressed > 0)
        log_->error("{}: {} ({} similar messages suppressed)", what, ec.message(), suppressed);
    else
        log_->error("{}: {}", what, ec.message());
}

}  // namespace gw::devices
