#include "gateway/jobs/manager/job_coordinator.hpp"

#include <map>
#include <mutex>

#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/redirect_error.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <spdlog/spdlog.h>

#include "devices/serial/controller_observer.hpp"
#include "gateway/config/logging.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/jobs/kinds/safe_outputs.hpp"
#include "gateway/jobs/manager/job_history.hpp"
#include "gateway/jobs/manager/job_recovery.hpp"
#include "gateway/jobs/manager/job_states.hpp"
#include "gateway/jobs/manager/lane_scheduler.hpp"
#include "gateway/jobs/manager/submission_planner.hpp"
#include "gateway/jobs/store/job_store.hpp"

namespace gw::jobs {

namespace net = boost::asio;

namespace {

// The registry's events, for the lane scheduler (and through it the recovery service); holds it
// weakly. Called on the controllers' strands.
class registry_observer final : public devices::controller_observer {
  public:
    explicit registry_observer(std::weak_ptr<lane_scheduler> scheduler) : scheduler_(std::move(scheduler)) {}
    void on_snapshot(const devices::controller_snapshot& s) override {
        const bool ready = s.state == devices::connection_state::connected && s.identity.has_value();
        bool came_back = false;
        bool came_up = false;  // the first snapshot seen, or came back
        {
            std::lock_guard lock(mutex_);  // controllers call from their own strands
            auto [it, added] = ready_.try_emplace(s.id, ready);
            came_back = ready && !added && !it->second;
            came_up = ready && (added || came_back);
            it->second = ready;
        }
        auto scheduler = scheduler_.lock();
        if (!scheduler) return;
        if (came_up) scheduler->controller_came_up(s.id);
        if (came_back) scheduler->controller_reconnected(s.id);
        bool latch_changed = false;
        {
            std::lock_guard lock(mutex_);
            auto [it, added] = halted_.try_emplace(s.id, false);
            latch_changed = it->second != s.halted.has_value();
            it->second = s.halted.has_value();
        }
        if (latch_changed)
            scheduler->controller_halt_latch_changed(s.id,
                                                     s.halted ? std::optional(s.halted->by) : std::nullopt);
        if (s.state == devices::connection_state::connected) return;  // otherwise only departures matter
        scheduler->controller_snapshot_changed(s);
    }
    void on_report(const devices::report_event& e) override {
        auto scheduler = scheduler_.lock();
        if (scheduler && scheduler->counts_ttl_edges(e.controller_id))
            scheduler->controller_ttl_edge(e.controller_id);
    }

  private:
    std::weak_ptr<lane_scheduler> scheduler_;
    std::mutex mutex_;
    std::map<std::string, bool> ready_;   // controller id -> connected and identified
    std::map<std::string, bool> halted_;  // controller id -> its HALT latch is set
};

}  // namespace

job_coordinator::job_coordinator(net::any_io_executor executor, const net::any_io_executor& work_executor,
                                 controller_registry& registry, std::shared_ptr<event_hub> hub,
                                 std::shared_ptr<lease_manager> leases, job_manager_settings settings,
                                 std::unique_ptr<job_store> store)
    : executor_(std::move(executor)),
      strand_(net::make_strand(work_executor)),
      registry_(registry),
      leases_(std::move(leases)),
      settings_(std::move(settings)),
      log_(get_logger("jobs")),
      history_(std::make_shared<job_history>(strand_, executor_, std::move(hub), settings_, log_,
                                             std::move(store))),
      states_(std::make_shared<job_states>(history_, settings_, log_)),
      recovery_(std::make_shared<job_recovery>(strand_, registry_, history_, log_)),
      planner_(std::make_shared<submission_planner>(strand_, registry_, leases_, history_, settings_)),
      scheduler_(std::make_shared<lane_scheduler>(strand_, registry_, states_, recovery_, planner_,
                                                  settings_.recorder, log_)) {}

job_coordinator::~job_coordinator() = default;

void job_coordinator::attach() {
    history_->set_owner(states_);
    observer_ = std::make_shared<registry_observer>(scheduler_);
    registry_.add_observer(std::weak_ptr<devices::controller_observer>(observer_));
}

const job_holds& job_coordinator::holds() const {
    return states_->holds();
}

bool job_coordinator::stopping() const {
    return scheduler_->closed() || states_->abandoned();
}

// ---------------------------------------------------------------------------------------------
// Start, shutdown, abandon.

void job_coordinator::start() {
    net::post(strand_, [self = shared_from_this()] {
        if (self->started_ || self->states_->abandoned()) return;
        self->started_ = true;
        self->history_->start();
        self->recover_from_store();
        self->scheduler_->dispatch_all();
    });
}

void job_coordinator::recover_from_store() {
    auto store = history_->store().get();
    if (!store) return;
    auto active = store->in_states({job_state::running, job_state::paused});
    auto queued = store->in_states({job_state::queued});
    if (!active) log_->error("restart recovery: cannot read the job store: {}", active.error().message);
    if (!queued) log_->error("restart recovery: cannot read the job store: {}", queued.error().message);
    // Restore commands an earlier run of the gateway could not deliver (a job cancelled, or stopped
    // by a shutdown, while its controller was unplugged): sent once the controller is connected.
    recovery_->recover_undelivered(active ? *active : std::vector<job_record>{});
    // A job that was active when the gateway stopped is not continued by itself: nothing is sent
    // twice to a controller. A client may resume it.
    for (auto& r : active ? *active : std::vector<job_record>{}) {
        auto job = std::make_shared<live_job>();
        job->record = std::move(r);
        states_->add(job);
        states_->set_state(*job, job_state::interrupted, "gateway restarted");
        owed_restore rec;
        rec.job_id = job->record.id;
        // The stage may still be moving: HALT before anything else reaches the controller.
        rec.halt = true;
        // A laser must never stay on: the crashed gateway could not switch the output off.
        rec.ttl_low = may_leave_ttl_output_high(job->record.type, job->record.spec);
        // Nor may the settings the run changed stay changed (an IN0 mode that still steps the stage).
        auto stored = store->restore_commands(job->record.id);
        if (stored)
            rec.restore = std::move(*stored);
        else
            log_->error("restart recovery: job {}: cannot read its restore commands: {}", job->record.id,
                        stored.error().message);
        recovery_->owe(job->record.controller, std::move(rec));
    }
    recovery_->send_owed_to_connected();
    for (auto& r : queued ? *queued : std::vector<job_record>{}) {
        auto job = std::make_shared<live_job>();
        job->record = std::move(r);
        states_->add(job);
        // Queued again, it waits for its controller (the first one starts at once); kept, for a resume.
        if (settings_.restart_queued) job->record.progress.waiting_for = job_wait::controller;
        history_->remember(job->record);
        if (settings_.restart_queued) scheduler_->queue(*job);  // else kept; `resume` queues it again
    }
}

void job_coordinator::shutdown(std::function<void()> done) {
    net::co_spawn(strand_, shutdown_coro(std::move(done)), net::detached);
}

net::awaitable<void> job_coordinator::shutdown_coro(std::function<void()> done) {
    auto self = shared_from_this();
    scheduler_->close();
    history_->begin_shutdown();
    recovery_->begin_shutdown();
    std::vector<std::shared_ptr<live_job>> to_stop;
    for (const auto& job : scheduler_->holders()) {
        const auto st = job->record.state;
        if (st != job_state::running && st != job_state::paused) continue;  // queued ones stay queued
        if (job->exec) {
            job->exec->cancel();
            to_stop.push_back(job);
        }
        states_->set_state(*job, job_state::interrupted, "gateway shutting down");
    }
    for (auto& job : to_stop)
        co_await recovery_->safe_stop(job);
    // The coroutines end at their next await (the HALT ends a move in progress).
    net::steady_timer timer(strand_);
    const auto deadline = std::chrono::steady_clock::now() + shutdown_grace;
    while (scheduler_->running() > 0 && std::chrono::steady_clock::now() < deadline) {
        timer.expires_after(std::chrono::milliseconds(10));
        boost::system::error_code ec;
        co_await timer.async_wait(net::redirect_error(net::use_awaitable, ec));
    }
    if (scheduler_->running() > 0)
        log_->warn("shutdown: {} job(s) did not stop in time", scheduler_->running());
    // A last try for what the store refused (what it still refuses is lost, and said so), then the store
    // is closed.
    history_->stop();
    recovery_->abandon();
    states_->abandon();  // nothing is written or published any more
    for (const auto& [id, job] : states_->all())
        if (job->exec) job->exec->abandon();
    net::post(executor_, std::move(done));
}

void job_coordinator::abandon() {
    states_->abandon();
    history_->abandon();  // like a crash: what was committed stays, nothing more is written
    recovery_->abandon();
    net::post(strand_, [self = shared_from_this()] {
        for (const auto& [id, job] : self->states_->all())
            if (job->exec) job->exec->abandon();
    });
}

}  // namespace gw::jobs
