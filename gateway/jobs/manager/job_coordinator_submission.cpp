#include <fmt/format.h>

#include <spdlog/spdlog.h>

#include "gateway/common/job_id.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/jobs/job_json.hpp"
#include "gateway/jobs/manager/job_coordinator.hpp"
#include "gateway/jobs/manager/job_history.hpp"
#include "gateway/jobs/manager/job_states.hpp"
#include "gateway/jobs/manager/lane_scheduler.hpp"
#include "gateway/jobs/manager/submission_planner.hpp"
#include "gateway/jobs/store/job_store.hpp"

namespace gw::jobs {

namespace net = boost::asio;
using kind = operation_error_kind;

// ---------------------------------------------------------------------------------------------
// Submission: admitted and planned by the submission planner, then queued and stored here.

void job_coordinator::submit(submit_request r, job_handler<submit_result> h) {
    net::post(strand_, [self = shared_from_this(), r = std::move(r), h = std::move(h)]() mutable {
        if (self->stopping())
            return self->deliver<submit_result>(
                std::move(h), make_error(kind::not_connected, "the gateway is shutting down"));
        if (auto answer = self->planner_->admit(r))
            return self->deliver<submit_result>(std::move(h), *answer);
        const auto controller = r.controller;
        const auto type = r.type;
        auto spec = r.spec;
        auto shared_h = std::make_shared<job_handler<submit_result>>(std::move(h));
        auto shared_r = std::make_shared<submit_request>(std::move(r));
        self->planner_->plan(
            controller, type, std::move(spec), [self, shared_r, shared_h](operation_result<job_plan> plan) {
                self->submit_planned(std::move(*shared_r), std::move(*shared_h), std::move(plan));
            });
    });
}

void job_coordinator::submit_planned(submit_request r, job_handler<submit_result> h,
                                     operation_result<job_plan> plan) {
    if (stopping())
        return deliver<submit_result>(std::move(h),
                                      make_error(kind::not_connected, "the gateway is shutting down"));
    if (!plan) return deliver<submit_result>(std::move(h), plan.error());

    const auto now = job_clock::now();
    submit_result out;
    out.job = submission_planner::record_of(r, *plan, now);
    auto& rec = out.job;
    if (r.dry_run) {
        out.plan = std::move(*plan);
        return deliver<submit_result>(std::move(h), std::move(out));
    }
    if (auto answer = planner_->admit_again(r)) return deliver<submit_result>(std::move(h), *answer);
    if (const auto queued = scheduler_->queued(r.controller); queued >= settings_.max_queued_per_controller)
        return deliver<submit_result>(
            std::move(h),
            make_error(kind::queue_full, fmt::format("{} already has {} queued jobs", r.controller, queued)));
    rec.id = make_job_id();
    rec.progress.waiting_for = scheduler_->queue_wait(r.controller);
    // Stored with the job, in one transaction: a store that cannot take the job's history refuses the
    // job, rather than letting it run unrecorded.
    const auto queued_event = state_event(rec, now);
    {
        auto store = history_->store().get();
        auto inserted =
            store ? store->insert(rec, queued_event)
                  : operation_result<void>(make_error(kind::storage_unavailable, "the job store is closed"));
        history_->note_store_fill();
        if (!inserted) {
            auto e = inserted.error();
            if (e.kind != kind::storage_unavailable) e.kind = kind::storage_unavailable;
            log_->error("job submission for {} not stored: {}", r.controller, e.message);
            return deliver<submit_result>(std::move(h), std::move(e));
        }
    }
    auto job = std::make_shared<live_job>();
    job->record = rec;
    job->plan = *plan;
    job->lease_id = r.lease_id;
    states_->add(job);
    history_->remember(rec);
    history_->publish(rec, queued_event);  // stored by insert()
    log_->info("job {} ({} on {}) queued: {} steps, {:.1f} s estimated", rec.id, to_string(rec.type),
               rec.controller, rec.progress.steps_total, rec.estimated_s);
    scheduler_->queue(*job);
    out.plan = std::move(*plan);
    // A submission is someone's decision to move the stage again: it releases a HALT latch there,
    // before the answer goes out (a client that reads the controller after its 201 sees it released).
    registry_.release_halt_latch(r.controller);
    deliver<submit_result>(std::move(h), std::move(out));
    scheduler_->dispatch(r.controller);
}

}  // namespace gw::jobs
