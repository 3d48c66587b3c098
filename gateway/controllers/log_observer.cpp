#include "gateway/controllers/log_observer.hpp"

#include <string>

#include <spdlog/spdlog.h>

#include "devices/ms2000/build_info.hpp"
#include "gateway/common/timestamp.hpp"
#include "gateway/config/logging.hpp"

namespace gw {

namespace {

std::string describe_modules(const devices::ms2000::build_info& build) {
    std::string out;
    for (std::size_t i = 0; i < static_cast<std::size_t>(devices::ms2000::module::count_); ++i) {
        auto m = static_cast<devices::ms2000::module>(i);
        if (!build.has(m)) continue;
        if (!out.empty()) out += ' ';
        out += devices::ms2000::module_id(m);
    }
    return out.empty() ? "none" : out;
}

std::string describe_positions(const devices::controller_snapshot& s) {
    std::string out;
    for (const auto& a : s.axes) {
        if (!out.empty()) out += ' ';
        out += a.axis;
        out += a.position_um ? fmt::format("={:.2f}um", *a.position_um) : "=?";
        if (a.busy) out += "(busy)";
    }
    return out;
}

}  // namespace

log_observer::log_observer() : log_(get_logger("gateway")) {}

void log_observer::on_snapshot(const devices::controller_snapshot& s) {
    devices::controller_snapshot previous;
    {
        std::lock_guard lock(mutex_);
        auto& slot = last_[s.id];
        previous = slot;
        slot = s;
    }
    if (s.state != previous.state) {
        if (s.state == devices::connection_state::connected && s.identity) {
            log_->info("{}: connected on {}: firmware {} build {} axes {} modules {}", s.id, s.port,
                       s.identity->version, s.identity->build.name, s.identity->build.motor_axes,
                       describe_modules(s.identity->build));
        } else {
            log_->info("{}: {}", s.id, devices::to_string(s.state));
        }
    }
    if (s.state == devices::connection_state::unreachable && s.last_error) {
        if (s.last_error != previous.last_error) log_unreachable(s);
    } else if (s.last_error && s.last_error != previous.last_error) {
        // A controller that keeps failing the same way says so once in a while, not on every poll.
        std::uint64_t suppressed = 0;
        if (limiter_.allow(s.id + "/" + s.last_error->name, suppressed)) {
            if (suppressed > 0)
                log_->warn("{}: {} ({}; {} similar messages suppressed)", s.id, s.last_error->text,
                           s.last_error->name, suppressed);
            else
                log_->warn("{}: {} ({})", s.id, s.last_error->text, s.last_error->name);
        }
    }
    log_->debug("{}: {}{}", s.id, describe_positions(s), s.busy ? " busy" : "");
}

void log_observer::log_unreachable(const devices::controller_snapshot& s) {
    // Every failed attempt changes last_error (its time): a reason that stays the same is repeated
    // once a minute, a new one at once.
    const auto now = std::chrono::steady_clock::now();
    std::uint64_t unlogged = 0;
    {
        std::lock_guard lock(mutex_);
        auto& seen = unreachable_[s.id];
        if (seen.name == s.last_error->name && now - seen.at < std::chrono::minutes(1)) {
            ++seen.unlogged;
            return;
        }
        unlogged = seen.unlogged;
        seen = {s.last_error->name, now, 0};
    }
    std::string retry = s.next_retry ? "; next attempt at " + format_timestamp(*s.next_retry) : std::string();
    std::string since = unlogged > 0
                            ? fmt::format(" ({} more failed attempts since the last message)", unlogged)
                            : std::string();
    std::string hint = s.last_error->hint.empty() ? std::string() : "; hint: " + s.last_error->hint;
    log_->warn("{}: unreachable: {} ({}){}{}{}", s.id, s.last_error->text, s.last_error->name, hint, retry,
               since);
}

void log_observer::on_report(const devices::report_event& e) {
    // Frames come hundreds of times a second per controller: nothing is formatted unless it is logged.
    if (!log_->should_log(spdlog::level::debug)) return;
    std::string axes;
    for (const auto& a : e.axes)
        axes += fmt::format(" {}={}", a.letter, a.counts);
    log_->debug("{}: report #{}{}", e.controller_id, e.sequence, axes);
}

void log_observer::on_ttl(const devices::ttl_event& e) {
    log_->debug("{}: position report #{} at {} ms", e.controller_id, e.sequence, e.controller_ms);
}

void log_observer::on_trace(const devices::command_trace& t) {
    // Commands somebody asked for at debug, with the request id; the driver's own polls at trace.
    const auto level = t.internal ? spdlog::level::trace : spdlog::level::debug;
    const auto log = get_logger("ms2000." + t.controller_id);
    if (!log->should_log(level)) return;
    log->log(level, "[{}] {} -> {} ({} us){}", t.request_id, t.wire, t.raw_reply, t.latency.count(),
             t.error ? " error: " + t.error.message() : "");
}

}  // namespace gw
