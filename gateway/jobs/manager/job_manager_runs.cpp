#include "gateway/jobs/manager/job_manager_core.hpp"

namespace gw::jobs {

// ---------------------------------------------------------------------------------------------
// Running.

void manager_core::dispatch(const std::string& controller) {
    if (shutting_down_ || abandoned_) return;
    show_halt_waits(controller);
    if (halt_latched(controller)) return;
    const auto next = lanes_.take_next(controller, [this](const std::string& id) {
        auto it = jobs_.find(id);
        if (it == jobs_.end()) return false;
        it->second->queued_in_lane = false;
        return it->second->record.state == job_state::queued;
    });
    if (!next) return;
    auto job = jobs_.at(*next);
    if (job->plan) return launch(job);
    // Recovered after a restart: plans are not stored, so it is planned again first.
    lanes_.set_planning(controller, true);
    plan_again(job, [self = shared_from_this(), job, controller](const operation_result<void>& planned) {
        self->lanes_.set_planning(controller, false);
        if (job->record.state != job_state::queued || self->shutting_down_ || self->abandoned_) {
            self->release(controller, job->record.id);
            return;
        }
        if (!planned) {
            self->set_state(*job, job_state::failed,
                            "cannot plan the job again: " + describe(planned.error()));
            self->release(controller, job->record.id);
            return;
        }
        self->launch(job);
    });
}

void manager_core::launch(const std::shared_ptr<live_job>& job) {
    const auto& controller = job->record.controller;
    // The HALT count first, then the latch: a HALT latched after this check is counted after this
    // read (the registry sets the latch before the driver counts the HALT), so it guards the run.
    const auto halts_seen = registry_.halts_accepted(controller);
    if (halt_latched(controller)) {
        // Halted while it was being taken (or planned again): it waits at the front of its queue.
        lanes_.release(controller, job->record.id);
        lanes_.enqueue(controller, job->record.id, true);
        job->queued_in_lane = true;
        set_held_wait(*job, job_wait::halt);
        return;
    }
    const auto first = std::min(job->record.progress.steps_done, job->plan->steps.size());
    job->ttl_low_on_reconnect = false;  // the run owns the output again
    auto exec = std::make_shared<job_execution>(strand_, registry_, weak_from_this(), job, first, halts_seen);
    job->exec = exec;
    ttl_listeners_.add(job->record.controller);
    job->record.progress.remaining_s = remaining_from(*job->plan, first);
    ++running_;
    set_state(*job, job_state::running, "");
    net::co_spawn(
        strand_,
        [self = shared_from_this(), job, exec]() -> net::awaitable<void> {
            co_await self->recovery_->put_back_before_run(job);
            co_await run_job(*exec);
        },
        [self = shared_from_this(), exec](const std::exception_ptr& e) { self->run_finished(exec, e); });
}

void manager_core::run_finished(const std::shared_ptr<job_execution>& exec, const std::exception_ptr& e) {
    --running_;
    auto job = exec->live();
    ttl_listeners_.remove(job->record.controller);
    if (job->exec == exec) job->exec.reset();
    if (abandoned_ || exec->abandoned() || job->stopping) return;  // a cancel in progress finishes it
    const auto controller = job->record.controller;
    const auto id = job->record.id;
    const auto st = job->record.state;
    if (st != job_state::running && st != job_state::paused) {
        // Cancelled or interrupted already (the manager set the state before the coroutine ended).
        release(controller, id);
        return;
    }
    std::string failure;
    bool disconnected = false;
    bool cancelled = false;
    std::optional<std::string> halted_by = exec->halted_by();
    try {
        if (e) std::rethrow_exception(e);
    } catch (const job_cancelled&) {
        cancelled = true;
    } catch (const job_halted& h) {
        halted_by = h.by;
    } catch (const job_failure& f) {
        failure = describe(f.error);
        // A command refused after a HALT: the latch (set before the HALT was counted) names who.
        if (f.error.kind == kind::halted && !halted_by) {
            auto s = registry_.get(controller);
            halted_by = s && s->halted ? s->halted->by : std::string("a HALT");
        }
        // The registry's observer may have seen the disconnect first (exec->failure()), or the command
        // failed first and the snapshot says so.
        disconnected = f.error.kind == kind::not_connected || exec->failure().has_value() ||
                       !controller_connected(controller);
    } catch (const std::exception& x) {
        failure = std::string("internal error: ") + x.what();
    }
    if (!e) {
        // The run put its settings back itself. Cleared before the end is announced, so that whoever
        // sees "succeeded" also finds nothing left to restore.
        history_->store_restore_commands(id, {});
        set_state(*job, job_state::succeeded, "");
        release(controller, id);
    } else if (cancelled) {
        set_state(*job, job_state::cancelled, "cancelled");
        release(controller, id);
    } else if (halted_by) {
        // The job keeps the controller and sends nothing more: a resume re-approaches the step it
        // stopped in, as after a disconnect. Its outputs and modules are made safe now.
        set_state(*job, job_state::paused, "halted by " + *halted_by,
                  halt_latched(controller) ? std::optional(job_wait::halt) : std::nullopt);
        net::co_spawn(
            strand_,
            [self = shared_from_this(), job]() -> net::awaitable<void> {
                co_await self->recovery_->secure_after_halt(job);
            },
            net::detached);
    } else if (disconnected) {
        // The job keeps the controller: resume continues from the last completed step, once it is back.
        set_state(*job, job_state::paused, "controller disconnected: " + failure,
                  controller_connected(controller) ? std::nullopt : std::optional(job_wait::controller));
        const auto& r = job->restore_commands;
        if (std::find(r.begin(), r.end(), "TTL Y=0") != r.end()) {
            job->ttl_low_on_reconnect = true;
            if (controller_connected(controller)) recovery_->ttl_low_after_disconnect(job);  // back already
        }
    } else {
        set_state(*job, job_state::failed, failure);
        // Put back what the job changed before the next job gets the controller.
        net::co_spawn(
            strand_,
            [self = shared_from_this(), job]() -> net::awaitable<void> {
                co_await self->recovery_->restore_settings(job);
            },
            [self = shared_from_this(), controller, id](const std::exception_ptr&) {
                self->release(controller, id);
            });
    }
}

void manager_core::release(const std::string& controller, const std::string& id) {
    lanes_.release(controller, id);
    net::post(strand_, [self = shared_from_this(), controller] { self->dispatch(controller); });
}

// ---------------------------------------------------------------------------------------------
// Controller events.

void manager_core::controller_came_up(const std::string& controller) {
    net::post(strand_,
              [self = shared_from_this(), controller] { self->recovery_->controller_came_up(controller); });
}

void manager_core::controller_snapshot_changed(const devices::controller_snapshot& s) {
    net::post(strand_, [self = shared_from_this(), id = s.id, state = s.state] {
        auto job = self->jobs_.find(self->lanes_.holder(id));
        if (job == self->jobs_.end() || !job->second->exec) return;
        if (job->second->exec->waiting_paused()) return;  // paused by a client: resume finds out
        job->second->exec->fail(
            make_error(kind::not_connected, fmt::format("{} is {}", id, devices::to_string(state))));
    });
}

void manager_core::controller_reconnected(const std::string& controller) {
    net::post(strand_, [self = shared_from_this(), controller] {
        auto job = self->jobs_.find(self->lanes_.holder(controller));
        if (job == self->jobs_.end()) return;
        // Paused by the disconnect: it waits for a client's resume now, which is possible again.
        if (job->second->record.progress.waiting_for == job_wait::controller)
            self->set_waiting(*job->second, std::nullopt);
        if (!job->second->ttl_low_on_reconnect) return;
        self->recovery_->ttl_low_after_disconnect(job->second);
    });
}

void manager_core::controller_halt_latch_changed(const std::string& controller,
                                                 std::optional<std::string> by) {
    net::post(strand_, [self = shared_from_this(), controller, by = std::move(by)] {
        if (by) {
            auto job = self->jobs_.find(self->lanes_.holder(controller));
            if (job != self->jobs_.end() && job->second->exec) job->second->exec->halt(*by);
        }
        self->dispatch(controller);  // shows the waits; starts the next job once released
    });
}

void manager_core::show_halt_waits(const std::string& controller) {
    const bool latched = halt_latched(controller);
    for (const auto& id : lanes_.queue(controller)) {
        auto it = jobs_.find(id);
        if (it == jobs_.end() || it->second->record.state != job_state::queued) continue;
        const auto w = it->second->record.progress.waiting_for;
        if (latched && w != job_wait::halt) set_held_wait(*it->second, job_wait::halt);
        if (!latched && w == job_wait::halt) set_held_wait(*it->second, queue_wait(controller));
    }
    // A job a HALT paused (run_finished) waits for a resume alone once the latch is released.
    if (auto it = jobs_.find(lanes_.holder(controller));
        it != jobs_.end() && !latched && it->second->record.progress.waiting_for == job_wait::halt)
        set_held_wait(*it->second, std::nullopt);
}

void manager_core::controller_ttl_edge(const std::string& controller) {
    net::post(strand_, [self = shared_from_this(), controller] {
        auto job = self->jobs_.find(self->lanes_.holder(controller));
        if (job != self->jobs_.end() && job->second->exec) job->second->exec->ttl_edge();
    });
}

}  // namespace gw::jobs
