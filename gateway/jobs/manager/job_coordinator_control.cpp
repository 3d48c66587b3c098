#include <fmt/format.h>

#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>

#include "gateway/controllers/controller_registry.hpp"
#include "gateway/jobs/manager/job_coordinator.hpp"
#include "gateway/jobs/manager/job_history.hpp"
#include "gateway/jobs/manager/job_recovery.hpp"
#include "gateway/jobs/manager/job_states.hpp"
#include "gateway/jobs/manager/lane_scheduler.hpp"
#include "gateway/jobs/store/job_store.hpp"

namespace gw::jobs {

namespace net = boost::asio;
using kind = operation_error_kind;

// ---------------------------------------------------------------------------------------------
// Leases.

void job_coordinator::acquire_lease(std::string controller, std::string holder, std::chrono::seconds ttl,
                                    job_handler<lease> h) {
    net::post(strand_, [self = shared_from_this(), controller = std::move(controller),
                        holder = std::move(holder), ttl, h = std::move(h)]() mutable {
        if (!self->leases_)
            return self->deliver<lease>(std::move(h),
                                        make_error(kind::invalid_state, "leases are not enabled"));
        // Jobs submitted before the lease were not submitted under it: they must not move the stage
        // while it is exclusive, so the lease waits for them (submissions are checked on this strand).
        if (auto busy = self->scheduler_->jobs_in_lane(controller); !busy.empty())
            return self->deliver<lease>(
                std::move(h),
                make_error(kind::busy, fmt::format("{} has jobs that were submitted without this lease ({}): "
                                                   "wait for them to end or cancel them, then take the lease",
                                                   controller, busy)));
        self->deliver<lease>(std::move(h), self->leases_->acquire(controller, std::move(holder), ttl));
    });
}

// ---------------------------------------------------------------------------------------------
// Control actions.

operation_result<std::shared_ptr<live_job>> job_coordinator::find_live(const std::string& id) {
    if (auto job = states_->find(id)) return job;
    {
        // Ended, but the store does not have its end yet (it refused it): the record in memory counts.
        if (auto r = history_->remembered(id); r && is_terminal(r->state))
            return make_error(kind::invalid_state,
                              fmt::format("job {} has ended ({})", id, to_string(r->state)), "state");
    }
    std::optional<job_record> found;
    {
        auto store = history_->store().get();
        if (!store) return make_error(kind::storage_unavailable, "the job store is closed");
        auto r = store->find(id);
        if (!r) return r.error();
        found = std::move(*r);
    }
    if (!found) return make_error(kind::unknown_job, "no job with id \"" + id + "\"", "id");
    if (is_terminal(found->state))
        return make_error(kind::invalid_state,
                          fmt::format("job {} has ended ({})", id, to_string(found->state)), "state");
    // Not terminal but unknown here: an interrupted job from an earlier run of the gateway.
    auto job = std::make_shared<live_job>();
    job->record = std::move(*found);
    states_->add(job);
    return job;
}

operation_result<void> job_coordinator::check_lease(const std::string& controller,
                                                    const job_action& a) const {
    if (!leases_) return {};
    return leases_->check(controller,
                          a.lease_id ? std::optional<std::string_view>(*a.lease_id) : std::nullopt);
}

operation_result<std::shared_ptr<live_job>> job_coordinator::find_for_action(const job_action& a) {
    auto found = find_live(a.job_id);
    if (!found) return found;
    if (auto lease = check_lease((*found)->record.controller, a); !lease) return lease.error();
    return found;
}

void job_coordinator::cancel(job_action a, job_handler<job_record> h) {
    net::co_spawn(
        strand_,
        [self = shared_from_this(), a = std::move(a), h = std::move(h)]() mutable -> net::awaitable<void> {
            auto found = self->find_for_action(a);
            if (!found) co_return self->deliver<job_record>(std::move(h), found.error());
            auto job = *found;
            const auto controller = job->record.controller;
            const auto st = job->record.state;
            if (is_terminal(st))
                co_return self->deliver<job_record>(
                    std::move(h),
                    make_error(kind::invalid_state,
                               fmt::format("job {} has ended ({})", a.job_id, to_string(st)), "state"));
            if (st == job_state::queued || st == job_state::interrupted) {
                self->scheduler_->unqueue(*job);
                self->states_->set_state(*job, job_state::cancelled, "cancelled");
                co_return self->deliver<job_record>(std::move(h), job->record);
            }
            // Running or paused: stop the motion first, then the job. The controller stays the job's
            // until both the HALT/TTL and its run() are over, so the next job starts after them.
            job->stopping = true;
            if (job->exec) job->exec->cancel();
            co_await self->recovery_->safe_stop(job);
            job->stopping = false;
            if (!is_terminal(job->record.state) && job->record.state != job_state::interrupted)
                self->states_->set_state(*job, job_state::cancelled, "cancelled");
            if (!job->exec) self->scheduler_->release(controller, a.job_id);  // else run_finished releases it
            self->deliver<job_record>(std::move(h), job->record);
        },
        net::detached);
}

void job_coordinator::pause(job_action a, job_handler<job_record> h) {
    net::post(strand_, [self = shared_from_this(), a = std::move(a), h = std::move(h)]() mutable {
        auto found = self->find_for_action(a);
        if (!found) return self->deliver<job_record>(std::move(h), found.error());
        auto job = *found;
        if (job->record.state == job_state::paused)
            return self->deliver<job_record>(std::move(h), job->record);
        if (job->record.state != job_state::running || !job->exec)
            return self->deliver<job_record>(
                std::move(h), make_error(kind::invalid_state,
                                         fmt::format("job {} is {}: only a running job can be paused",
                                                     a.job_id, to_string(job->record.state)),
                                         "state"));
        job->exec->request_pause();  // takes effect at the next checkpoint (after the current step)
        self->deliver<job_record>(std::move(h), job->record);
    });
}

void job_coordinator::resume(job_action a, job_handler<job_record> h) {
    net::post(strand_, [self = shared_from_this(), a = std::move(a), h = std::move(h)]() mutable {
        if (self->stopping())
            return self->deliver<job_record>(std::move(h),
                                             make_error(kind::not_connected, "the gateway is shutting down"));
        auto found = self->find_for_action(a);
        if (!found) return self->deliver<job_record>(std::move(h), found.error());
        auto job = *found;
        const auto controller = job->record.controller;
        // Its history must be stored up to date before it runs on: its pause, and every step before it.
        if (auto stored = self->history_->write_unstored(a.job_id); !stored)
            return self->deliver<job_record>(
                std::move(h),
                make_error(kind::storage_unavailable,
                           fmt::format("job {} cannot be resumed while the job store refuses its "
                                       "history: {}",
                                       a.job_id, stored.error().message)));
        job->storage_failure.clear();
        const auto st = job->record.state;
        const bool holds_controller = self->scheduler_->holds_controller(*job);
        // A resume that goes ahead is someone's decision to move the stage again: it releases a HALT
        // latch there (a queued job's resume does only that: the queue moves on).
        // The resumer's lease (if any) is the one whose holder may operate the controller from now on.
        auto go_on = [&] {
            self->registry_.release_halt_latch(controller);
            job->lease_id = a.lease_id;
        };
        if (st == job_state::queued && job->queued_in_lane && self->scheduler_->halt_latched(controller)) {
            go_on();
            self->scheduler_->dispatch(controller);
            return self->deliver<job_record>(std::move(h), job->record);
        }
        if (st == job_state::running && job->exec && job->exec->pause_requested()) {
            job->exec->resume();  // asked to pause, not paused yet: carry on
            return self->deliver<job_record>(std::move(h), job->record);
        }
        if (st == job_state::queued && !job->queued_in_lane && !holds_controller) {
            // Kept from before a restart (restart_queued off): queue it now.
            go_on();
            self->scheduler_->queue(*job);
            self->scheduler_->dispatch(controller);
            return self->deliver<job_record>(std::move(h), job->record);
        }
        if (st != job_state::paused && st != job_state::interrupted)
            return self->deliver<job_record>(
                std::move(h),
                make_error(kind::invalid_state,
                           fmt::format("job {} is {}: only a paused or interrupted job can be resumed",
                                       a.job_id, to_string(st)),
                           "state"));
        if (!self->scheduler_->controller_connected(controller))
            return self->deliver<job_record>(
                std::move(h), make_error(kind::not_connected,
                                         fmt::format("{} is not connected; resume once it is", controller)));
        if (st == job_state::paused && job->exec && job->exec->waiting_paused()) {
            // Its run() waits at a checkpoint: it continues where it stopped.
            go_on();
            self->states_->set_state(*job, job_state::queued, "");
            self->states_->set_state(*job, job_state::running, "");
            job->exec->resume();
            return self->deliver<job_record>(std::move(h), job->record);
        }
        // A job that kept the controller while paused (a disconnect, a HALT) goes first.
        go_on();
        self->states_->set_state(*job, job_state::queued, "",
                                 holds_controller ? std::nullopt : self->scheduler_->queue_wait(controller));
        if (holds_controller)
            self->scheduler_->requeue_holder(*job);
        else
            self->scheduler_->queue(*job);
        auto record = job->record;
        self->scheduler_->dispatch(controller);
        self->deliver<job_record>(std::move(h), std::move(record));
    });
}

void job_coordinator::next(job_action a, job_handler<job_record> h) {
    net::post(strand_, [self = shared_from_this(), a = std::move(a), h = std::move(h)]() mutable {
        auto found = self->find_for_action(a);
        if (!found) return self->deliver<job_record>(std::move(h), found.error());
        auto job = *found;
        if (job->record.state != job_state::running || !job->exec)
            return self->deliver<job_record>(
                std::move(h), make_error(kind::invalid_state,
                                         fmt::format("job {} is {}: `next` needs a running job", a.job_id,
                                                     to_string(job->record.state)),
                                         "state"));
        job->exec->next();
        // The answer shows the wait over: the run takes this call as soon as it is back on the strand.
        if (job->record.progress.waiting_for == job_wait::next)
            self->states_->set_waiting(*job, std::nullopt);
        self->deliver<job_record>(std::move(h), job->record);
    });
}

}  // namespace gw::jobs
