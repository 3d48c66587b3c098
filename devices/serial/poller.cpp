#include "devices/serial/poller.hpp"

#include <spdlog/spdlog.h>

#include "devices/ms2000/crisp.hpp"
#include "devices/ms2000/error.hpp"
#include "devices/serial/snapshot_update.hpp"

namespace gw::devices {
namespace net = boost::asio;
using boost::system::error_code;
using std::chrono::steady_clock;
using std::chrono::system_clock;

poller::poller(const net::strand<net::any_io_executor>& strand, const controller_settings& settings,
               controller_snapshot& snapshot, event_outlet& outlet, spdlog::logger& log, owner& owner)
    : settings_(settings), snapshot_(snapshot), outlet_(outlet), log_(log), owner_(owner), timer_(strand) {}

void poller::reset() {
    crisp_refused_ = false;
    snapshot_.crisp_state.reset();
}

void poller::start() {
    due_ = settings_.poll_interval.count() > 0;
    arm_timer();
}

void poller::stop() {
    ++generation_;
    timer_.cancel();
    step_ = step::idle;
    due_ = false;
}

void poller::arm_timer() {
    if (settings_.poll_interval.count() <= 0) return;
    timer_.expires_after(settings_.poll_interval);
    timer_.async_wait([this, alive = owner_.keep_alive(), generation = generation_](error_code ec) {
        if (ec || generation != generation_) return;
        // At most one poll round: a round still running absorbs this tick.
        if (step_ == step::idle && round_wanted()) due_ = true;
        owner_.poll_tick();
        arm_timer();
    });
}

// A round that watches a move (CRISP trying to lock ends by itself too) or follows a change: it goes at
// the fast pace and never yields to a client.
bool poller::round_watches_change() const {
    return snapshot_.busy || changed_since_round_ || snapshot_.crisp_state == 'K';
}

bool poller::round_wanted() const {
    return round_watches_change() || steady_clock::now() - last_round_ >= settings_.idle_poll_interval;
}

bool poller::idle_round_yields() const {
    if (round_watches_change()) return false;
    const auto now = steady_clock::now();
    return now - last_client_answer_ < settings_.client_pause &&
           now - last_round_ < 2 * settings_.idle_poll_interval;
}

std::optional<queued_command> poller::next_command() {
    if (snapshot_.state != connection_state::connected) return std::nullopt;
    if (step_ == step::idle) {
        // A yielding round stays due: the next tick, or the next answer, looks again.
        if (!due_ || idle_round_yields()) return std::nullopt;
        due_ = false;
        step_ = step::status;
        last_round_ = steady_clock::now();
        changed_since_round_ = false;
    }
    const auto axes = snapshot_.motor_axes();
    queued_command job;
    job.request_id = "poll";
    job.internal = [this, asked = step_, index = axis_](error_code ec, const ms2000::reply& r) {
        on_reply(asked, index, ec, r);
    };
    // Held back while the link gets back in step: the next tick starts a new round.
    job.held_back = [this] { step_ = step::idle; };
    switch (step_) {
        case step::where:
            job.cmd = ms2000::where(axes);
            return job;
        case step::status:
            job.cmd = ms2000::status();
            return job;
        case step::axis_status:
            job.cmd = ms2000::query("RS", axes.substr(axis_, 1));
            return job;
        case step::crisp:
            job.cmd = ms2000::crisp_state_query();
            return job;
        case step::idle:
            break;
    }
    return std::nullopt;
}

void poller::client_command_finished(const ms2000::command& cmd, error_code ec, const ms2000::reply* reply) {
    // Whoever asked "/" (a waited move, a job), its answer is the newest word on motion: the snapshot
    // must not go on saying "moving" after a move's waiter was told it stopped.
    if (!ec && reply && reply->what == ms2000::reply::kind::status) {
        if (snapshot_.busy && !reply->busy) {
            changed_since_round_ = true;
            due_ = settings_.poll_interval.count() > 0;  // read where it stopped now, not next tick
        }
        apply_busy(snapshot_, reply->busy);
    }
    // It may have started a move or changed a setting: the next tick starts a round.
    if (!ms2000::only_reads(cmd)) changed_since_round_ = true;
}

void poller::on_reply(step answered, std::size_t axis_index, error_code ec, const ms2000::reply& r) {
    if (answered == step::crisp && ec == ms2000::error::controller_rejected) {
        // A build that names CRISP but refuses LK X?: the round ends without it from now on.
        log_.warn("LK X? refused: the CRISP state is not polled on this connection");
        crisp_refused_ = true;
        snapshot_.crisp_state.reset();
        step_ = step::idle;
        return;
    }
    if (ec) {
        // Give up this round; the next tick starts a new one (at once: nothing fresh was read).
        step_ = step::idle;
        changed_since_round_ = true;
        if (!command_aborted(ec)) outlet_.log_error("poll", ec);
        return;
    }
    switch (answered) {
        case step::status:
            polled_busy_ = r.busy;  // reply: "B" or "N"
            step_ = step::where;
            return;
        case step::where:
            apply_where(snapshot_, r);
            snapshot_.positions_read = system_clock::now();
            if (snapshot_.busy && !polled_busy_) owner_.move_ended();
            apply_busy(snapshot_, polled_busy_);
            if (polled_busy_ && !snapshot_.axes.empty()) {
                step_ = step::axis_status;
                axis_ = 0;
                return;
            }
            break;
        case step::axis_status:
            apply_axis_busy(snapshot_, axis_index, r);
            axis_ = axis_index + 1;
            if (axis_ < snapshot_.axes.size()) return;
            break;
        case step::crisp:
            snapshot_.crisp_state = ms2000::crisp_state_of(r);
            step_ = step::idle;
            snapshot_.updated = system_clock::now();
            return;
        case step::idle:
            break;
    }
    // A controller with CRISP: its lock state ends the round.
    if (!crisp_refused_ && snapshot_.identity && snapshot_.identity->build.has(ms2000::module::crisp)) {
        step_ = step::crisp;
        return;
    }
    step_ = step::idle;
    snapshot_.updated = system_clock::now();
}

}  // namespace gw::devices
