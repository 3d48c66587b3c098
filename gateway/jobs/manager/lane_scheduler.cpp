#include "gateway/jobs/manager/lane_scheduler.hpp"

#include <algorithm>
#include <fmt/format.h>

#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/post.hpp>
#include <spdlog/spdlog.h>

#include "gateway/controllers/controller_registry.hpp"
#include "gateway/jobs/job_plan.hpp"
#include "gateway/jobs/kinds/job_kinds.hpp"
#include "gateway/jobs/manager/job_recovery.hpp"
#include "gateway/jobs/manager/job_states.hpp"
#include "gateway/jobs/manager/run_recording.hpp"
#include "gateway/jobs/manager/submission_planner.hpp"

namespace gw::jobs {

namespace net = boost::asio;
using kind = operation_error_kind;

lane_scheduler::lane_scheduler(net::strand<net::any_io_executor> strand, controller_registry& registry,
                               std::shared_ptr<job_states> states, std::shared_ptr<job_recovery> recovery,
                               std::shared_ptr<submission_planner> planner,
                               std::shared_ptr<recordings::recorder> recorder,
                               std::shared_ptr<spdlog::logger> log)
    : strand_(std::move(strand)),
      registry_(registry),
      states_(std::move(states)),
      recovery_(std::move(recovery)),
      planner_(std::move(planner)),
      recorder_(std::move(recorder)),
      log_(std::move(log)) {}

// ---------------------------------------------------------------------------------------------
// The lanes.

void lane_scheduler::queue(live_job& job, bool first) {
    lanes_.enqueue(job.record.controller, job.record.id, first);
    job.queued_in_lane = true;
}

void lane_scheduler::unqueue(live_job& job) {
    lanes_.remove(job.record.controller, job.record.id);
    job.queued_in_lane = false;
}

void lane_scheduler::requeue_holder(live_job& job) {
    lanes_.release(job.record.controller, job.record.id);
    queue(job, true);
}

bool lane_scheduler::holds_controller(const live_job& job) const {
    return lanes_.holder(job.record.controller) == job.record.id;
}

std::shared_ptr<live_job> lane_scheduler::holder(const std::string& controller) const {
    return states_->find(lanes_.holder(controller));
}

std::optional<job_wait> lane_scheduler::queue_wait(const std::string& controller) const {
    if (!lanes_.busy(controller)) return std::nullopt;
    return job_wait::controller;
}

std::string lane_scheduler::jobs_in_lane(const std::string& controller) const {
    std::vector<std::string> parts;
    // A job that has ended (job_states keeps only the others) may hold the controller a little longer,
    // until its stop has been sent: it moves nothing more.
    if (auto job = holder(controller); job && !is_terminal(job->record.state))
        parts.push_back(fmt::format("{} {}", job->record.id, to_string(job->record.state)));
    for (const auto& id : lanes_.queue(controller))
        if (auto job = states_->find(id); job && job->record.state == job_state::queued)
            parts.push_back(id + " queued");
    std::string out;
    for (const auto& p : parts)
        out += (out.empty() ? "" : ", ") + p;
    return out;
}

std::vector<std::shared_ptr<live_job>> lane_scheduler::holders() const {
    std::vector<std::shared_ptr<live_job>> out;
    for (const auto& controller : lanes_.controllers())
        if (auto job = holder(controller)) out.push_back(std::move(job));
    return out;
}

bool lane_scheduler::halt_latched(const std::string& controller) const {
    auto s = registry_.get(controller);
    return s && s->halted;
}

bool lane_scheduler::controller_connected(const std::string& controller) const {
    auto s = registry_.get(controller);
    return s && s->state == devices::connection_state::connected && s->identity;
}

bool lane_scheduler::stopped() const {
    return closed_ || states_->abandoned();
}

// ---------------------------------------------------------------------------------------------
// Running.

void lane_scheduler::dispatch_all() {
    for (const auto& controller : lanes_.controllers())
        dispatch(controller);
}

void lane_scheduler::dispatch(const std::string& controller) {
    if (stopped()) return;
    show_halt_waits(controller);
    if (halt_latched(controller)) return;
    const auto next = lanes_.take_next(controller, [this](const std::string& id) {
        auto job = states_->find(id);
        if (!job) return false;
        job->queued_in_lane = false;
        return job->record.state == job_state::queued;
    });
    if (!next) return;
    auto job = states_->find(*next);
    if (job->plan) return launch(job);
    // Recovered after a restart: plans are not stored, so it is planned again first, from the
    // controller's build and limits. While the controller is away it waits at the front of its queue
    // (controller_came_up dispatches again).
    if (!controller_connected(controller)) {
        requeue_holder(*job);
        states_->set_held_wait(*job, job_wait::controller);
        return;
    }
    lanes_.set_planning(controller, true);
    plan_again(job, [self = shared_from_this(), job, controller](const operation_result<void>& planned) {
        self->lanes_.set_planning(controller, false);
        if (job->record.state != job_state::queued || self->stopped()) {
            self->release(controller, job->record.id);
            return;
        }
        if (!planned) {
            self->states_->set_state(*job, job_state::failed,
                                     "cannot plan the job again: " + describe(planned.error()));
            self->release(controller, job->record.id);
            return;
        }
        self->launch(job);
    });
}

void lane_scheduler::plan_again(const std::shared_ptr<live_job>& job,
                                std::function<void(operation_result<void>)> done) {
    if (job->plan) return done({});
    // Answered later on the strand, as every plan is.
    net::post(strand_, [self = shared_from_this(), job, done = std::move(done)]() mutable {
        self->planner_->plan(job->record.controller, job->record.type, job->record.spec,
                             [self, job, done = std::move(done)](operation_result<job_plan> plan) {
                                 if (!plan) return done(plan.error());
                                 if (plan->steps.size() != job->record.progress.steps_total)
                                     self->log_->warn("job {}: the plan now has {} steps, it had {}",
                                                      job->record.id, plan->steps.size(),
                                                      job->record.progress.steps_total);
                                 job->record.progress.steps_total = plan->steps.size();
                                 job->plan = std::move(*plan);
                                 done({});
                             });
    });
}

void lane_scheduler::launch(const std::shared_ptr<live_job>& job) {
    const auto& controller = job->record.controller;
    // The HALT count first, then the latch: a HALT latched after this check is counted after this
    // read (the registry sets the latch before the driver counts the HALT), so it guards the run.
    const auto halts_seen = registry_.halts_accepted(controller);
    if (halt_latched(controller)) {
        // Halted while it was being taken (or planned again): it waits at the front of its queue.
        requeue_holder(*job);
        states_->set_held_wait(*job, job_wait::halt);
        return;
    }
    const auto first = std::min(job->record.progress.steps_done, job->plan->steps.size());
    job->ttl_low_on_reconnect = false;  // the run owns the output again
    auto exec = std::make_shared<job_execution>(strand_, registry_, states_, job, first, halts_seen);
    job->exec = exec;
    ttl_listeners_.add(job->record.controller);
    job->record.progress.remaining_s = remaining_from(*job->plan, first);
    ++running_;
    states_->set_state(*job, job_state::running, "");
    net::co_spawn(
        strand_,
        [self = shared_from_this(), job, exec]() -> net::awaitable<void> {
            co_await self->recovery_->put_back_before_run(job);
            // A run that was going when the gateway went down is owed a HALT before anything else; the
            // put-back sent it, or waited for the recovery that did, and it stops nothing of this run.
            // A client's HALT meanwhile latched the controller before it was counted: then the run
            // keeps the count it was launched with, and its first command is refused.
            const auto halts_now = self->registry_.halts_accepted(job->record.controller);
            if (!self->halt_latched(job->record.controller)) exec->rebase_halts(halts_now);
            if (job->plan->record)
                co_await run_recorded(self->recorder_, *exec);
            else
                co_await run_job(*exec);
        },
        [self = shared_from_this(), exec](const std::exception_ptr& e) { self->run_finished(exec, e); });
}

void lane_scheduler::run_finished(const std::shared_ptr<job_execution>& exec, const std::exception_ptr& e) {
    --running_;
    auto job = exec->live();
    ttl_listeners_.remove(job->record.controller);
    if (job->exec == exec) job->exec.reset();
    if (states_->abandoned() || exec->abandoned() || job->stopping) return;  // a cancel finishes it
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
        states_->forget_restore_commands(*job);
        states_->set_state(*job, job_state::succeeded, "");
        release(controller, id);
    } else if (cancelled) {
        states_->set_state(*job, job_state::cancelled, "cancelled");
        release(controller, id);
    } else if (halted_by) {
        // The job keeps the controller and sends nothing more: a resume re-approaches the step it
        // stopped in, as after a disconnect. Its outputs and modules are made safe now.
        states_->set_state(*job, job_state::paused, "halted by " + *halted_by,
                           halt_latched(controller) ? std::optional(job_wait::halt) : std::nullopt);
        net::co_spawn(
            strand_,
            [self = shared_from_this(), job]() -> net::awaitable<void> {
                co_await self->recovery_->secure_after_halt(job);
            },
            net::detached);
    } else if (disconnected) {
        // The job keeps the controller: resume continues from the last completed step, once it is back.
        states_->set_state(
            *job, job_state::paused, "controller disconnected: " + failure,
            controller_connected(controller) ? std::nullopt : std::optional(job_wait::controller));
        const auto& r = job->restore_commands;
        if (std::find(r.begin(), r.end(), "TTL Y=0") != r.end()) {
            job->ttl_low_on_reconnect = true;
            if (controller_connected(controller)) recovery_->ttl_low_after_disconnect(job);  // back already
        }
    } else {
        states_->set_state(*job, job_state::failed, failure);
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

void lane_scheduler::release(const std::string& controller, const std::string& id) {
    lanes_.release(controller, id);
    net::post(strand_, [self = shared_from_this(), controller] { self->dispatch(controller); });
}

void lane_scheduler::show_halt_waits(const std::string& controller) {
    const bool latched = halt_latched(controller);
    for (const auto& id : lanes_.queue(controller)) {
        auto job = states_->find(id);
        if (!job || job->record.state != job_state::queued) continue;
        const auto w = job->record.progress.waiting_for;
        if (latched && w != job_wait::halt) states_->set_held_wait(*job, job_wait::halt);
        if (!latched && w == job_wait::halt) states_->set_held_wait(*job, queue_wait(controller));
    }
    // A job a HALT paused (run_finished) waits for a resume alone once the latch is released.
    if (auto job = holder(controller); job && !latched && job->record.progress.waiting_for == job_wait::halt)
        states_->set_held_wait(*job, std::nullopt);
}

// ---------------------------------------------------------------------------------------------
// Controller events.

void lane_scheduler::controller_came_up(const std::string& controller) {
    net::post(strand_, [self = shared_from_this(), controller] {
        // What a crashed run owes it first (its HALT), then the job that waited for it.
        self->recovery_->controller_came_up(controller);
        self->dispatch(controller);
    });
}

void lane_scheduler::controller_snapshot_changed(const devices::controller_snapshot& s) {
    net::post(strand_, [self = shared_from_this(), id = s.id, state = s.state] {
        auto job = self->holder(id);
        if (!job || !job->exec) return;
        if (job->exec->waiting_paused()) return;  // paused by a client: resume finds out
        job->exec->fail(
            make_error(kind::not_connected, fmt::format("{} is {}", id, devices::to_string(state))));
    });
}

void lane_scheduler::controller_reconnected(const std::string& controller) {
    net::post(strand_, [self = shared_from_this(), controller] {
        auto job = self->holder(controller);
        if (!job) return;
        // Paused by the disconnect: it waits for a client's resume now, which is possible again.
        if (job->record.progress.waiting_for == job_wait::controller)
            self->states_->set_waiting(*job, std::nullopt);
        if (!job->ttl_low_on_reconnect) return;
        self->recovery_->ttl_low_after_disconnect(job);
    });
}

void lane_scheduler::controller_halt_latch_changed(const std::string& controller,
                                                   std::optional<std::string> by) {
    net::post(strand_, [self = shared_from_this(), controller, by = std::move(by)] {
        if (by) {
            auto job = self->holder(controller);
            if (job && job->exec) job->exec->halt(*by);
        }
        self->dispatch(controller);  // shows the waits; starts the next job once released
    });
}

void lane_scheduler::controller_ttl_edge(const std::string& controller) {
    net::post(strand_, [self = shared_from_this(), controller] {
        auto job = self->holder(controller);
        if (job && job->exec) job->exec->ttl_edge();
    });
}

}  // namespace gw::jobs
