// The controller's internal error log (DU Y), read in the gaps between user commands.
//
// When: as the last step of identification (controller.cpp), when the report stream goes quiet after
// frames (the controller logs error 87 for each frame it could not send), when the poll sees a move
// end (a clamped target logs 34/35), after a user command the controller refused, and every
// error_log_interval. Clearing (DU X) is how the next read tells new codes from old ones, but a code
// logged between the read and the clear would be lost: so the log is cleared only while the stage is
// idle and the report stream quiet, or when it is filling up (the firmware keeps a bounded log).
// Meanwhile each read publishes what follows the codes already seen.
#include <algorithm>

#include <spdlog/spdlog.h>

#include "devices/ms2000/error.hpp"
#include "devices/ms2000/error_log.hpp"
#include "devices/serial/controller.hpp"

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

void controller::note_error_log_occasions() {
    const auto now = steady_clock::now();
    if (report_activity_ && now - last_report_bytes_ >= report_quiet) {
        report_activity_ = false;
        error_log_due_ = true;
    }
    if (settings_.error_log_interval.count() > 0 && now - error_log_read_at_ >= settings_.error_log_interval)
        error_log_due_ = true;
}

std::optional<controller::pending> controller::next_error_log_command() {
    if (snapshot_.state != connection_state::connected || error_log_step_ != error_log_step::idle)
        return std::nullopt;
    auto self = shared_from_this();
    pending job;
    job.request_id = "error_log";
    // Held back while the link gets back in step: due again, after the clients' commands.
    job.held_back = [this] { retry_error_log_step(); };
    if (error_log_clear_due_) {
        error_log_clear_due_ = false;
        error_log_step_ = error_log_step::clearing;
        job.cmd = ms2000::clear_error_log();
        job.internal = [this, self](error_code ec, const auto& r) { on_error_log_cleared(ec, r); };
        return job;
    }
    if (!error_log_due_) return std::nullopt;
    error_log_due_ = false;
    error_log_step_ = error_log_step::reading;
    error_log_read_at_ = steady_clock::now();
    job.cmd = ms2000::read_error_log();
    job.internal = [this, self](error_code ec, const auto& r) { on_error_log_read(ec, r); };
    return job;
}

void controller::retry_error_log_step() {
    if (error_log_step_ == error_log_step::reading) error_log_due_ = true;
    if (error_log_step_ == error_log_step::clearing) error_log_clear_due_ = true;
    error_log_step_ = error_log_step::idle;
}

void controller::on_error_log_read(error_code ec, const ms2000::reply& r) {
    error_log_step_ = error_log_step::idle;
    if (ec == ms2000::error::controller_rejected) {
        // A firmware without DU Y: not asked again on this connection.
        log_->info("the controller has no error log (DU Y answered {})", r.raw);
        error_log_step_ = error_log_step::unsupported;
        return;
    }
    const auto codes = ec ? std::nullopt : ms2000::error_log_codes(r);
    if (!codes) {
        if (ec == ms2000::error::disconnected || ec == ms2000::error::cancelled) return;
        if (++error_log_failures_ >= give_up_after_failures) {
            log_->warn(
                "the error log (DU Y) got no usable answer {} times in a row ({}); not read again "
                "on this connection",
                error_log_failures_, ec ? ec.message() : "a code beyond 9999");
            error_log_step_ = error_log_step::unsupported;
        }
        return;  // otherwise the next occasion tries again
    }
    error_log_failures_ = 0;
    const auto fresh = ms2000::new_error_log_codes(error_log_seen_, *codes);
    error_log_seen_ = *codes;
    if (!fresh.empty()) {
        auto& recent = snapshot_.error_log_recent;
        recent.insert(recent.end(), fresh.begin(), fresh.end());
        if (recent.size() > controller_snapshot::error_log_recent_limit)
            recent.erase(recent.begin(), recent.end() - static_cast<std::ptrdiff_t>(
                                                            controller_snapshot::error_log_recent_limit));
        snapshot_.error_log_count += fresh.size();
        log_->warn("error log: {} new code(s), the newest {} ({})", fresh.size(), fresh.back(),
                   ms2000::error_log_name(fresh.back()));
        outlet_.error_log(error_log_event{settings_.id, fresh, system_clock::now()});
        outlet_.publish_snapshot();
    }
    if (!codes->empty() && error_log_clear_is_safe(codes->size())) error_log_clear_due_ = true;
}

void controller::on_error_log_cleared(error_code ec, const ms2000::reply&) {
    error_log_step_ = error_log_step::idle;
    // Cleared: the next read starts afresh. Not cleared: the next read still sees what we saw.
    if (!ec) error_log_seen_.clear();
}

bool controller::error_log_clear_is_safe(std::size_t logged) const {
    if (logged >= clear_anyway_from) return true;
    return !snapshot_.busy && !report_activity_ && steady_clock::now() - last_report_bytes_ >= report_quiet;
}

}  // namespace gw::devices
