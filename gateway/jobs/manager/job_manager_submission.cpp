#include "gateway/jobs/manager/job_manager_core.hpp"

namespace gw::jobs {

// ---------------------------------------------------------------------------------------------
// Submission: admitted and planned by the submission planner, then queued and stored here.

void manager_core::submit(submit_request r, job_manager::handler<submit_result> h) {
    net::post(strand_, [self = shared_from_this(), r = std::move(r), h = std::move(h)]() mutable {
        if (self->shutting_down_ || self->abandoned_)
            return self->deliver<submit_result>(
                std::move(h), make_error(kind::not_connected, "the gateway is shutting down"));
        if (auto answer = self->planner_->admit(r))
            return self->deliver<submit_result>(std::move(h), *answer);
        const auto controller = r.controller;
        const auto type = r.type;
        auto spec = r.spec;
        auto shared_h = std::make_shared<job_manager::handler<submit_result>>(std::move(h));
        auto shared_r = std::make_shared<submit_request>(std::move(r));
        self->planner_->plan(
            controller, type, std::move(spec), [self, shared_r, shared_h](operation_result<job_plan> plan) {
                self->submit_planned(std::move(*shared_r), std::move(*shared_h), std::move(plan));
            });
    });
}

void manager_core::submit_planned(submit_request r, job_manager::handler<submit_result> h,
                                  operation_result<job_plan> plan) {
    if (shutting_down_ || abandoned_)
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
    if (const auto queued = lanes_.queued(r.controller); queued >= settings_.max_queued_per_controller)
        return deliver<submit_result>(
            std::move(h),
            make_error(kind::queue_full, fmt::format("{} already has {} queued jobs", r.controller, queued)));
    rec.id = make_job_id();
    rec.progress.waiting_for = queue_wait(r.controller);
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
    job->queued_in_lane = true;
    job->lease_id = r.lease_id;
    jobs_[rec.id] = job;
    history_->remember(rec);
    history_->publish(rec, queued_event);  // stored by insert()
    log_->info("job {} ({} on {}) queued: {} steps, {:.1f} s estimated", rec.id, to_string(rec.type),
               rec.controller, rec.progress.steps_total, rec.estimated_s);
    lanes_.enqueue(r.controller, rec.id);
    out.plan = std::move(*plan);
    // A submission is someone's decision to move the stage again: it releases a HALT latch there,
    // before the answer goes out (a client that reads the controller after its 201 sees it released).
    registry_.release_halt_latch(r.controller);
    deliver<submit_result>(std::move(h), std::move(out));
    dispatch(r.controller);
}

void manager_core::plan_again(const std::shared_ptr<live_job>& job,
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

}  // namespace gw::jobs
