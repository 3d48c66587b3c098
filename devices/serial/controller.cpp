#include "devices/serial/controller.hpp"

#include <algorithm>
#include <utility>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/post.hpp>
#include <spdlog/spdlog.h>

#include "devices/ms2000/error.hpp"
#include "devices/ms2000/error_log.hpp"
#include "devices/serial/escape.hpp"
#include "devices/serial/serial_port.hpp"
#include "devices/serial/snapshot_update.hpp"

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

// A failure of one identification step: the controller refused the command (an older firmware
// without it), or something else (timeout, a reply that did not fit) that calls for starting over.
bool identify_failed(error_code ec) {
    return ec && ec != ms2000::error::controller_rejected;
}

// The errno behind an open failure, when there is one (the lock's EBUSY included).
connection_problem problem_of_open_error(const std::string& path, error_code ec) {
    if (ec.category() == boost::system::system_category() ||
        ec.category() == boost::system::generic_category())
        return open_problem(path, ec.value());
    return {"open_failed", "cannot open " + path + ": " + ec.message(),
            "check the device and its driver (dmesg)"};
}

// "TTL X=7", "TTL Y=1": a command that changes the TTL modes the snapshot shows.
bool sets_ttl_mode(const ms2000::command& cmd) {
    return cmd.verb == "TTL" && cmd.wire.find('=') != std::string::npos;
}

bool sets_soft_limit(const ms2000::command& cmd) {
    const bool limit_verb =
        cmd.verb == "SL" || cmd.verb == "SETLOW" || cmd.verb == "SU" || cmd.verb == "SETUP";
    return limit_verb && cmd.wire.find('=') != std::string::npos;
}

}  // namespace

controller::controller(const net::any_io_executor& ex, controller_settings settings,
                       std::weak_ptr<controller_observer> observer)
    : settings_(std::move(settings)),
      strand_(net::make_strand(ex)),
      log_(make_logger("ms2000." + settings_.id)),
      outlet_(settings_.id, snapshot_, *log_, std::move(observer)),
      link_(strand_, settings_, outlet_, *log_, *this),
      poller_(strand_, settings_, snapshot_, outlet_, *log_, *this),
      error_log_(settings_, snapshot_, outlet_, *log_),
      report_(strand_, settings_, snapshot_, outlet_, *log_, *this),
      reconnect_timer_(strand_),
      presence_timer_(strand_),
      backoff_(settings_.reconnect_min) {
    snapshot_.id = settings_.id;
    snapshot_.port = settings_.port;
}

controller::~controller() = default;

void controller::start() {
    net::post(strand_, [self = shared_from_this()] {
        if (self->snapshot_.state != connection_state::stopped) return;
        self->stopped_ = false;
        self->backoff_ = self->settings_.reconnect_min;
        self->snapshot_.state = connection_state::connecting;
        self->outlet_.publish_snapshot();
        self->do_connect();
    });
}

void controller::stop() {
    net::post(strand_, [self = shared_from_this()] { self->do_stop(); });
}

void controller::set_observer(std::weak_ptr<controller_observer> observer) {
    net::post(strand_, [self = shared_from_this(), observer = std::move(observer)]() mutable {
        self->outlet_.set_observer(std::move(observer));
    });
}

void controller::set_report_tap(report_port::byte_tap tap) {
    net::post(strand_, [self = shared_from_this(), tap = std::move(tap)]() mutable {
        self->report_.set_tap(std::move(tap));
    });
}

void controller::get_snapshot(std::function<void(controller_snapshot)> handler) {
    net::post(strand_,
              [self = shared_from_this(), handler = std::move(handler)] { handler(self->snapshot_); });
}

// ---- commands ---------------------------------------------------------------------------------

void controller::submit(ms2000::command cmd, std::string request_id, completion_handler handler,
                        std::optional<std::uint64_t> halts_seen) {
    queued_command job{.cmd = std::move(cmd),
                       .request_id = std::move(request_id),
                       .user = std::move(handler),
                       .halts_seen = halts_seen};
    // Onto the strand: all state lives there. Dispatched: on the strand's own thread it is taken at
    // once (a queue hop less per command); the link never completes a handler inline.
    net::dispatch(strand_, [self = shared_from_this(), job = std::move(job)]() mutable {
        // A closed port refuses it: for good after stop(), until reconnected otherwise.
        self->link_.submit(std::move(job),
                           self->stopped_ ? ms2000::error::cancelled : ms2000::error::not_connected);
    });
}

// ---- connection -------------------------------------------------------------------------------

void controller::do_connect() {
    if (stopped_ || link_.is_open()) return;
    snapshot_.last_attempt = system_clock::now();
    if (auto ec = link_.open()) {
        log_->debug("cannot open port {}: {}", settings_.port, ec.message());
        return set_unreachable(problem_of_open_error(settings_.port, ec));
    }
    log_->info("port {} open at {} baud, identifying", settings_.port, settings_.baud);
    // After a failed attempt the state stays unreachable until an identification succeeds.
    if (snapshot_.state != connection_state::unreachable) snapshot_.state = connection_state::identifying;
    snapshot_.next_retry.reset();
    snapshot_.identity.reset();
    snapshot_.axes.clear();
    snapshot_.busy = false;
    outlet_.publish_snapshot();

    arm_presence_check();
    // The link is out of step on a fresh port: identification waits for its resynchronisation.
    identify();
    link_.pump();
}

void controller::set_unreachable(const connection_problem& problem) {
    snapshot_.state = connection_state::unreachable;
    snapshot_.last_error =
        controller_error_info{0, problem.name, problem.text, problem.hint, system_clock::now()};
    schedule_reconnect();
    outlet_.publish_snapshot();
}

void controller::schedule_reconnect() {
    if (stopped_) return;
    snapshot_.next_retry = system_clock::now() + std::chrono::duration_cast<system_clock::duration>(backoff_);
    reconnect_timer_.expires_after(backoff_);
    backoff_ = std::min(backoff_ * 2, settings_.reconnect_max);
    reconnect_timer_.async_wait([self = shared_from_this()](error_code ec) {
        if (!ec) self->do_connect();
    });
    node_gone_ = !serial_port::node_exists(settings_.port);
    watch_for_node();
}

void controller::watch_for_node() {
    // The backoff paces retries of a node that exists but cannot be opened or identified. A node that
    // went away (an unplugged adapter) and is back is tried at once, however far the backoff has grown.
    presence_timer_.expires_after(settings_.presence_check);
    presence_timer_.async_wait([self = shared_from_this(), generation = link_.generation()](error_code ec) {
        if (ec || generation != self->link_.generation() || self->stopped_ || self->link_.is_open()) return;
        if (!serial_port::node_exists(self->settings_.port)) {
            self->node_gone_ = true;
        } else if (self->node_gone_) {
            self->node_gone_ = false;
            self->reconnect_timer_.cancel();
            return self->do_connect();
        }
        self->watch_for_node();
    });
}

void controller::disconnect(error_code ec, const char* what) {
    if (!link_.is_open()) return;
    if (snapshot_.state == connection_state::connected)
        log_->warn("{}: {}; port closed, reconnecting", what, ec.message());
    else
        log_->debug("{}: {}; port closed, trying again", what, ec.message());  // see set_unreachable
    report_.close();
    presence_timer_.cancel();
    poller_.stop();
    link_.close(ms2000::error::disconnected);

    apply_busy(snapshot_, false);
    if (snapshot_.state != connection_state::connected) {
        // The attempt never got as far as an identified controller: say why, as a person can act on it.
        const bool unanswered = ec == ms2000::error::timeout || ec == ms2000::error::unrecognized_reply;
        if (!unanswered)
            return set_unreachable(
                {"disconnected", std::string(what) + " on " + settings_.port + ": " + ec.message(), ""});
        if (link_.bytes_heard() == 0)
            return set_unreachable(no_reply_problem(settings_.port, std::to_string(settings_.baud)));
        return set_unreachable(
            not_ms2000_problem(settings_.port, settings_.baud, escape_control(link_.first_bytes_heard())));
    }
    snapshot_.state = connection_state::disconnected;
    note_error(0, "disconnected", std::string(what) + ": " + ec.message());
    schedule_reconnect();
    outlet_.publish_snapshot();
}

void controller::do_stop() {
    if (stopped_ && snapshot_.state == connection_state::stopped) return;
    stopped_ = true;
    report_.close();
    reconnect_timer_.cancel();
    presence_timer_.cancel();
    poller_.stop();
    link_.close(ms2000::error::cancelled);
    snapshot_.state = connection_state::stopped;
    snapshot_.busy = false;
    snapshot_.next_retry.reset();
    log_->info("stopped");
    outlet_.publish_snapshot();
}

void controller::arm_presence_check() {
    presence_timer_.expires_after(settings_.presence_check);
    presence_timer_.async_wait([self = shared_from_this(), generation = link_.generation()](error_code ec) {
        if (ec || generation != self->link_.generation()) return;
        // A vanished node (unplugged adapter, removed link) is not always seen by a pending read.
        if (!self->link_.still_present())
            return self->disconnect(boost::system::errc::make_error_code(boost::system::errc::no_such_device),
                                    "device node vanished");
        if (self->snapshot_.state == connection_state::connected && !self->report_.is_open())
            self->report_.open();
        self->arm_presence_check();
    });
}

// ---- identification ---------------------------------------------------------------------------

void controller::identify() {
    error_log_.reset();
    poller_.reset();
    // reply: ":A Version: USB-9.52 "
    link_.enqueue_internal(ms2000::version(), "identify", [this](error_code ec, const ms2000::reply& r) {
        if (command_aborted(ec)) return;
        if (identify_failed(ec)) return disconnect(ec, "identify (V)");
        apply_version(snapshot_, r);
    });
    // reply: "STD_XYZ\rMotor Axes: X Y Z\r...\r\n"
    link_.enqueue_internal(ms2000::build_x(), "identify", [this](error_code ec, const ms2000::reply& r) {
        if (command_aborted(ec) || !snapshot_.identity) return;
        if (identify_failed(ec)) return disconnect(ec, "identify (BU X)");
        // Firmware without BU X: the smallest MS-2000, an XY stage.
        if (!apply_build(snapshot_, ec ? nullptr : &r)) log_->warn("no motor axes from BU X, assuming XY");
        const auto axes = snapshot_.motor_axes();

        // reply: ":A X=10000.000000 Y=10000.000000"
        link_.enqueue_internal(ms2000::query("CNTS", axes), "identify",
                               [this](error_code ec, const ms2000::reply& r) {
                                   if (command_aborted(ec)) return;
                                   if (identify_failed(ec)) return disconnect(ec, "identify (CNTS)");
                                   if (!ec) apply_axis_numbers(snapshot_, r, &axis_state::counts_per_mm);
                               });
        link_.enqueue_internal(ms2000::query("SL", axes), "identify",
                               [this](error_code ec, const ms2000::reply& r) {
                                   if (command_aborted(ec)) return;
                                   if (identify_failed(ec)) return disconnect(ec, "identify (SL)");
                                   if (!ec) apply_axis_numbers(snapshot_, r, &axis_state::lower_limit_mm);
                               });
        link_.enqueue_internal(ms2000::query("SU", axes), "identify",
                               [this](error_code ec, const ms2000::reply& r) {
                                   if (command_aborted(ec)) return;
                                   if (identify_failed(ec)) return disconnect(ec, "identify (SU)");
                                   if (!ec) apply_axis_numbers(snapshot_, r, &axis_state::upper_limit_mm);
                               });
        for (const auto verb : motion_setting_verbs)
            read_motion_setting(verb, "identify");
        // reply: ":A X=0 Y=0"
        link_.enqueue_internal(ms2000::query("TTL", "XY"), "identify",
                               [this](error_code ec, const ms2000::reply& r) {
                                   if (command_aborted(ec)) return;
                                   if (identify_failed(ec)) return disconnect(ec, "identify (TTL)");
                                   if (!ec) apply_ttl_modes(snapshot_, r);
                               });
        // What the error log holds is news to this connection (the controller may have been power-
        // cycled): read before the controller counts as connected, so no command waits behind it.
        // A controller that cannot answer it is still connected.
        link_.enqueue_internal(ms2000::read_error_log(), "identify",
                               [this](error_code ec, const ms2000::reply& r) {
                                   if (command_aborted(ec)) return;
                                   error_log_.identification_read(ec, r);
                                   on_identified();
                               });
    });
}

void controller::refresh_ttl_modes() {
    // The modes are read back rather than taken from the command: the controller may clamp or refuse
    // part of it, and whoever restores them later must see what the controller really has.
    link_.enqueue_internal(ms2000::query("TTL", "XY"), "refresh",
                           [this](error_code ec, const ms2000::reply& r) {
                               if (!ec) apply_ttl_modes(snapshot_, r);
                           });
}

void controller::refresh_soft_limits() {
    // Read back, as the TTL modes are: the controller refuses an upper limit below the lower one, and
    // jobs check their targets against these.
    const auto axes = snapshot_.motor_axes();
    link_.enqueue_internal(ms2000::query("SL", axes), "refresh",
                           [this](error_code ec, const ms2000::reply& r) {
                               if (!ec) apply_axis_numbers(snapshot_, r, &axis_state::lower_limit_mm);
                           });
    link_.enqueue_internal(ms2000::query("SU", axes), "refresh",
                           [this](error_code ec, const ms2000::reply& r) {
                               if (!ec) apply_axis_numbers(snapshot_, r, &axis_state::upper_limit_mm);
                           });
}

void controller::read_motion_setting(std::string_view verb, const char* tag) {
    // reply: ":A X=5.745760 Y=5.745760" (S, PC), ":X=20 Y=20 A" (AC, B), ":A X=0 Y=0" (OS)
    link_.enqueue_internal(ms2000::query(verb, snapshot_.motor_axes()), tag,
                           [this, verb](error_code ec, const ms2000::reply& r) {
                               if (!ec) apply_motion_setting(snapshot_, verb, r);
                           });
}

void controller::reidentify(const ms2000::command& cause) {
    if (!link_.is_open() || snapshot_.state != connection_state::connected) return;
    log_->info("\"{}\": {}; identifying the controller again", escape_control(cause.wire),
               ms2000::resets_or_recalibrates(cause));
    poller_.stop();
    snapshot_.state = connection_state::identifying;
    outlet_.publish_snapshot();
    identify();
}

void controller::on_identified() {
    backoff_ = settings_.reconnect_min;
    snapshot_.state = connection_state::connected;
    snapshot_.next_retry.reset();
    const auto& id = *snapshot_.identity;
    log_->info("identified: version {}, build {}, axes {}", id.version, id.build.name, id.build.motor_axes);
    report_.open();
    poller_.start();
    outlet_.publish_snapshot();
}

// ---- what the parts ask ------------------------------------------------------------------------

std::optional<queued_command> controller::next_background_command() {
    // The error log's next step goes ahead of the poll's: both wait behind the clients' commands.
    if (auto job = error_log_.next_command()) return job;
    return poller_.next_command();
}

void controller::client_command_finished(const ms2000::command& cmd, error_code ec,
                                         const ms2000::reply* reply) {
    if (!ec && sets_ttl_mode(cmd)) refresh_ttl_modes();
    if (!ec && sets_soft_limit(cmd)) refresh_soft_limits();
    if (const auto verb = motion_setting_set_by(cmd); !ec && !verb.empty())
        read_motion_setting(verb, "refresh");
    poller_.client_command_finished(cmd, ec, reply);
    // A controller that restarts may answer late or with noise: it may have done it all the same.
    const bool may_have_acted =
        !ec || ec == ms2000::error::timeout || ec == ms2000::error::unrecognized_reply;
    if (may_have_acted && !ms2000::resets_or_recalibrates(cmd).empty()) reidentify(cmd);
    if (!ec) return;
    if (ec == ms2000::error::controller_rejected && reply) {
        note_error(reply->error_code, std::string(ms2000::controller_error_name(reply->error_code)),
                   std::string(ms2000::controller_error_description(reply->error_code)));
    } else {
        note_error(0, ec.message(), "command \"" + escape_control(cmd.wire) + "\" failed");
    }
}

void controller::client_answered(error_code ec) {
    // A command the controller refused may have left a code in its error log (a job step too).
    if (ec == ms2000::error::controller_rejected) error_log_.read_soon();
    poller_.client_answered();
}

void controller::position_report(const ms2000::position_report_line& report) {
    ttl_event event;
    event.controller_id = settings_.id;
    event.sequence = ++ttl_sequence_;
    event.steady_time = steady_clock::now();
    event.system_time = system_clock::now();
    event.controller_ms = report.milliseconds;
    const auto axes = snapshot_.motor_axes();
    for (std::size_t i = 0; i < report.positions.size(); ++i) {
        const char letter = i < axes.size() ? axes[i] : '?';
        event.axes.push_back({letter, report.positions[i] / 10.0});
    }
    outlet_.ttl(event);
}

void controller::contain(const char* where, const std::exception& e) {
    outlet_.contained(where, e);
    disconnect(make_error_code(boost::system::errc::io_error), where);
}

void controller::poll_tick() {
    error_log_.note_occasions();
    link_.pump();
}

void controller::move_ended() {
    // A target beyond a soft limit was clamped and logged (34/35).
    error_log_.read_soon();
}

void controller::report_bytes_arrived(steady_clock::time_point at) {
    error_log_.note_report_bytes(at);
}

void controller::note_error(int code, std::string name, std::string text) {
    snapshot_.last_error =
        controller_error_info{code, std::move(name), std::move(text), {}, system_clock::now()};
}

}  // namespace gw::devices
