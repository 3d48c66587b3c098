#include "gateway/jobs/manager/job_manager_core.hpp"

namespace gw::jobs {

// ---------------------------------------------------------------------------------------------
// Start, shutdown, abandon.

void manager_core::start() {
    net::post(strand_, [self = shared_from_this()] {
        if (self->started_ || self->abandoned_) return;
        self->started_ = true;
        self->history_->start();
        auto store = self->history_->store().get();
        if (!store) return;
        auto active = store->in_states({job_state::running, job_state::paused});
        auto queued = store->in_states({job_state::queued});
        if (!active)
            self->log_->error("restart recovery: cannot read the job store: {}", active.error().message);
        if (!queued)
            self->log_->error("restart recovery: cannot read the job store: {}", queued.error().message);
        // Restore commands an earlier run of the gateway could not deliver (a job cancelled, or stopped
        // by a shutdown, while its controller was unplugged): sent once the controller is connected.
        self->recovery_->recover_undelivered(active ? *active : std::vector<job_record>{});
        // A job that was active when the gateway stopped is not continued by itself: nothing is sent
        // twice to a controller. A client may resume it.
        for (auto& r : active ? *active : std::vector<job_record>{}) {
            auto job = std::make_shared<live_job>();
            job->record = std::move(r);
            self->jobs_[job->record.id] = job;
            self->set_state(*job, job_state::interrupted, "gateway restarted");
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
                self->log_->error("restart recovery: job {}: cannot read its restore commands: {}",
                                  job->record.id, stored.error().message);
            self->recovery_->owe(job->record.controller, std::move(rec));
        }
        self->recovery_->send_owed_to_connected();
        for (auto& r : queued ? *queued : std::vector<job_record>{}) {
            auto job = std::make_shared<live_job>();
            job->record = std::move(r);
            const auto id = job->record.id;
            const auto controller = job->record.controller;
            self->jobs_[id] = job;
            // Queued again, it waits for its controller (the first one starts at once); kept, for a resume.
            if (self->settings_.restart_queued) job->record.progress.waiting_for = job_wait::controller;
            self->history_->remember(job->record);
            if (!self->settings_.restart_queued) continue;  // kept; `resume` queues it again
            job->queued_in_lane = true;
            self->lanes_.enqueue(controller, id);
        }
        for (const auto& controller : self->lanes_.controllers())
            self->dispatch(controller);
    });
}

void manager_core::shutdown(std::function<void()> done) {
    net::co_spawn(strand_, shutdown_coro(std::move(done)), net::detached);
}

net::awaitable<void> manager_core::shutdown_coro(std::function<void()> done) {
    auto self = shared_from_this();
    shutting_down_ = true;
    history_->begin_shutdown();
    recovery_->begin_shutdown();
    std::vector<std::shared_ptr<live_job>> to_stop;
    for (const auto& controller : lanes_.controllers()) {
        auto it = jobs_.find(lanes_.holder(controller));
        if (it == jobs_.end()) continue;
        auto job = it->second;
        const auto st = job->record.state;
        if (st != job_state::running && st != job_state::paused) continue;  // queued ones stay queued
        if (job->exec) {
            job->exec->cancel();
            to_stop.push_back(job);
        }
        set_state(*job, job_state::interrupted, "gateway shutting down");
    }
    for (auto& job : to_stop)
        co_await recovery_->safe_stop(job);
    // The coroutines end at their next await (the HALT ends a move in progress).
    net::steady_timer timer(strand_);
    const auto deadline = std::chrono::steady_clock::now() + shutdown_grace;
    while (running_ > 0 && std::chrono::steady_clock::now() < deadline) {
        timer.expires_after(std::chrono::milliseconds(10));
        boost::system::error_code ec;
        co_await timer.async_wait(net::redirect_error(net::use_awaitable, ec));
    }
    if (running_ > 0) log_->warn("shutdown: {} job(s) did not stop in time", running_);
    // A last try for what the store refused (what it still refuses is lost, and said so), then the store
    // is closed.
    history_->stop();
    recovery_->abandon();
    abandoned_ = true;  // nothing is written or published any more
    for (auto& [id, job] : jobs_)
        if (job->exec) job->exec->abandon();
    net::post(executor_, std::move(done));
}

void manager_core::abandon() {
    abandoned_ = true;
    history_->abandon();  // like a crash: what was committed stays, nothing more is written
    recovery_->abandon();
    net::post(strand_, [self = shared_from_this()] {
        for (auto& [id, job] : self->jobs_)
            if (job->exec) job->exec->abandon();
    });
}

}  // namespace gw::jobs
