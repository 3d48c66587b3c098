#include "devices/serial/error_log_reader.hpp"

#include <spdlog/spdlog.h>

#include "devices/ms2000/error.hpp"
#include "devices/ms2000/error_log.hpp"

namespace gw::devices {
using boost::system::error_code;
using std::chrono::steady_clock;
using std::chrono::system_clock;

namespace {

// The report stream counts as quiet this long after its last bytes.
constexpr auto report_quiet = std::chrono::milliseconds(250);
// Cleared even while busy from this many codes on: the log must not overflow and drop codes unseen.
constexpr std::size_t clear_anyway_from = 32;
// Reads in a row without a usable answer (a timeout, an answer of another shape) before the log is
// left alone on this connection: the protocol reference does not confirm DU Y's reply format, and
// every such failure costs a resynchronisation of the link.
constexpr std::size_t give_up_after_failures = 3;

}  // namespace

error_log_reader::error_log_reader(const controller_settings& settings, controller_snapshot& snapshot,
                                   event_outlet& outlet, spdlog::logger& log)
    : settings_(settings), snapshot_(snapshot), outlet_(outlet), log_(log) {}

void error_log_reader::reset() {
    seen_.clear();
    failures_ = 0;
    step_ = step::idle;
    read_due_ = clear_due_ = false;
}

void error_log_reader::identification_read(error_code ec, const ms2000::reply& r) {
    read_at_ = steady_clock::now();
    on_read(ec, r);
}

void error_log_reader::note_report_bytes(steady_clock::time_point at) {
    report_activity_ = true;
    last_report_bytes_ = at;
}

void error_log_reader::note_occasions() {
    const auto now = steady_clock::now();
    if (report_activity_ && now - last_report_bytes_ >= report_quiet) {
        report_activity_ = false;
        read_due_ = true;
    }
    if (settings_.error_log_interval.count() > 0 && now - read_at_ >= settings_.error_log_interval)
        read_due_ = true;
}

std::optional<queued_command> error_log_reader::next_command() {
    if (snapshot_.state != connection_state::connected || step_ != step::idle) return std::nullopt;
    queued_command job;
    job.request_id = "error_log";
    job.held_back = [this] { retry_step(); };
    if (clear_due_) {
        clear_due_ = false;
        step_ = step::clearing;
        job.cmd = ms2000::clear_error_log();
        job.internal = [this](error_code ec, const ms2000::reply&) { on_cleared(ec); };
        return job;
    }
    if (!read_due_) return std::nullopt;
    read_due_ = false;
    step_ = step::reading;
    read_at_ = steady_clock::now();
    job.cmd = ms2000::read_error_log();
    job.internal = [this](error_code ec, const ms2000::reply& r) { on_read(ec, r); };
    return job;
}

void error_log_reader::retry_step() {
    if (step_ == step::reading) read_due_ = true;
    if (step_ == step::clearing) clear_due_ = true;
    step_ = step::idle;
}

void error_log_reader::on_read(error_code ec, const ms2000::reply& r) {
    step_ = step::idle;
    if (ec == ms2000::error::controller_rejected) {
        // A firmware without DU Y: not asked again on this connection.
        log_.info("the controller has no error log (DU Y answered {})", r.raw);
        step_ = step::unsupported;
        return;
    }
    const auto codes = ec ? std::nullopt : ms2000::error_log_codes(r);
    if (!codes) {
        if (ec == ms2000::error::disconnected || ec == ms2000::error::cancelled) return;
        if (++failures_ >= give_up_after_failures) {
            log_.warn(
                "the error log (DU Y) got no usable answer {} times in a row ({}); not read again "
                "on this connection",
                failures_, ec ? ec.message() : "a code beyond 9999");
            step_ = step::unsupported;
        }
        return;  // otherwise the next occasion tries again
    }
    failures_ = 0;
    const auto fresh = ms2000::new_error_log_codes(seen_, *codes);
    seen_ = *codes;
    if (!fresh.empty()) {
        auto& recent = snapshot_.error_log_recent;
        recent.insert(recent.end(), fresh.begin(), fresh.end());
        if (recent.size() > controller_snapshot::error_log_recent_limit)
            recent.erase(recent.begin(), recent.end() - static_cast<std::ptrdiff_t>(
                                                            controller_snapshot::error_log_recent_limit));
        snapshot_.error_log_count += fresh.size();
        log_.warn("error log: {} new code(s), the newest {} ({})", fresh.size(), fresh.back(),
                  ms2000::error_log_name(fresh.back()));
        outlet_.error_log(error_log_event{settings_.id, fresh, system_clock::now()});
        outlet_.publish_snapshot();
    }
    if (!codes->empty() && clear_is_safe(codes->size())) clear_due_ = true;
}

void error_log_reader::on_cleared(error_code ec) {
    step_ = step::idle;
    // Cleared: the next read starts afresh. Not cleared: the next read still sees what we saw.
    if (!ec) seen_.clear();
}

bool error_log_reader::clear_is_safe(std::size_t logged) const {
    if (logged >= clear_anyway_from) return true;
    return !snapshot_.busy && !report_activity_ && steady_clock::now() - last_report_bytes_ >= report_quiet;
}

}  // namespace gw::devices
