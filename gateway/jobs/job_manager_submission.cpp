#include "gateway/jobs/job_manager_core.hpp"

namespace gw::jobs {

namespace {

// The answer to a submission whose Idempotency-Key is already stored: the first job, when this is the
// same submission again (same client, controller, type and spec). A key reused for another request is
// refused rather than answered with a job that is not what was asked for; another client's job is not
// named.
operation_result<submit_result> replay(job_record first, const submit_request& r) {
    if (first.submitted_by != r.principal)
        return make_error(kind::invalid_value,
                          "this Idempotency-Key was used by another client: use a new key for this request",
                          "Idempotency-Key");
    if (first.controller != r.controller || first.type != r.type || first.spec != r.spec)
        return make_error(kind::invalid_value,
                          fmt::format("this Idempotency-Key was used for a different request (job {}): "
                                      "use a new key for a new request",
                                      first.id),
                          "Idempotency-Key");
    submit_result out;
    out.job = std::move(first);
    out.replayed = true;
    return out;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Submission.

void manager_core::submit(submit_request r, job_manager::handler<submit_result> h) {
    net::post(strand_, [self = shared_from_this(), r = std::move(r), h = std::move(h)]() mutable {
        if (self->shutting_down_ || self->abandoned_)
            return self->deliver<submit_result>(
                std::move(h), make_error(kind::not_connected, "the gateway is shutting down"));
        auto snapshot = self->registry_.get(r.controller);
        if (!snapshot)
            return self->deliver<submit_result>(
                std::move(h), make_error(kind::unknown_controller,
                                         "no controller with id \"" + r.controller + "\"", "controller"));
        if (self->leases_) {
            auto lease = self->leases_->check(
                r.controller, r.lease_id ? std::optional<std::string_view>(*r.lease_id) : std::nullopt);
            if (!lease) return self->deliver<submit_result>(std::move(h), lease.error());
        }
        if (r.idempotency_key && !r.dry_run) {
            auto store = self->history_->store().get();
            auto found = store ? store->find_by_idempotency_key(*r.idempotency_key)
                               : operation_result<std::optional<job_record>>(
                                     make_error(kind::storage_unavailable, "the job store is closed"));
            if (!found) return self->deliver<submit_result>(std::move(h), found.error());
            if (*found) return self->deliver<submit_result>(std::move(h), replay(std::move(**found), r));
        }
        // The motion settings come from the snapshot: no serial round trip before the job is stored.
        auto model = self->motion_model_for(*snapshot);
        self->plan_submission(std::move(r), std::move(h), std::move(model));
    });
}

bool manager_core::plan_off_strand(job_type type, json spec, devices::controller_snapshot snapshot,
                                   motion_model model, std::function<void(operation_result<job_plan>)> done) {
    return planner_.post([self = shared_from_this(), type, spec = std::move(spec),
                          snapshot = std::move(snapshot), model = std::move(model),
                          gcode_dir = gcode_files_directory(settings_), hook = settings_.on_plan_started,
                          done = std::move(done)]() mutable {
        const plan_context context{std::move(snapshot), std::move(model), gcode_dir};
        if (hook) hook(context.snapshot.id);
        auto plan = plan_job(type, spec, context);
        // The core's reference moves on with the result: the planner's thread never holds the last one.
        auto& strand = self->strand_;
        net::post(strand, [self = std::move(self), plan = std::move(plan), done = std::move(done)]() mutable {
            done(std::move(plan));
        });
    });
}

void manager_core::plan_submission(submit_request r, job_manager::handler<submit_result> h,
                                   motion_model model) {
    if (shutting_down_ || abandoned_)
        return deliver<submit_result>(std::move(h),
                                      make_error(kind::not_connected, "the gateway is shutting down"));
    auto snapshot = registry_.get(r.controller);
    if (!snapshot || snapshot->state != devices::connection_state::connected || !snapshot->identity)
        return deliver<submit_result>(
            std::move(h), make_error(kind::not_connected, fmt::format("{} is not connected: its build and "
                                                                      "limits are needed to plan the job",
                                                                      r.controller)));
    if (!r.spec.is_object())
        return deliver<submit_result>(std::move(h),
                                      make_error(kind::invalid_value, "spec must be a JSON object", "spec"));
    const auto type = r.type;
    auto spec = r.spec;
    auto shared_h = std::make_shared<job_manager::handler<submit_result>>(std::move(h));
    auto shared_r = std::make_shared<submit_request>(std::move(r));
    const bool queued =
        plan_off_strand(type, std::move(spec), std::move(*snapshot), std::move(model),
                        [self = shared_from_this(), shared_r, shared_h](operation_result<job_plan> plan) {
                            self->submit_planned(std::move(*shared_r), std::move(*shared_h), std::move(plan));
                        });
    if (!queued)
        deliver<submit_result>(
            std::move(*shared_h),
            make_error(kind::queue_full, fmt::format("the job planner has {} plans waiting: "
                                                     "submit again shortly",
                                                     planner_.max_waiting())));
}

void manager_core::submit_planned(submit_request r, job_manager::handler<submit_result> h,
                                  operation_result<job_plan> plan) {
    if (shutting_down_ || abandoned_)
        return deliver<submit_result>(std::move(h),
                                      make_error(kind::not_connected, "the gateway is shutting down"));
    if (!plan) return deliver<submit_result>(std::move(h), plan.error());

    const auto now = job_clock::now();
    submit_result out;
    auto& rec = out.job;
    rec.controller = r.controller;
    rec.type = r.type;
    rec.spec = r.spec;
    rec.state = job_state::queued;
    rec.progress.steps_total = plan->steps.size();
    rec.progress.remaining_s = remaining_from(*plan, 0);
    rec.estimated_s = plan->estimated_s;
    rec.plan_path = plan->path;
    rec.idempotency_key = r.idempotency_key;
    rec.submitted_by = r.principal;
    rec.request_id = r.request_id;
    rec.created = now;
    rec.updated = now;
    if (r.dry_run) {
        out.plan = std::move(*plan);
        return deliver<submit_result>(std::move(h), std::move(out));
    }

    // Again, on the strand where leases are granted: one may have been taken while the job planned.
    if (leases_) {
        auto lease = leases_->check(r.controller,
                                    r.lease_id ? std::optional<std::string_view>(*r.lease_id) : std::nullopt);
        if (!lease) return deliver<submit_result>(std::move(h), lease.error());
    }
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
        // Idempotency again: another submission with the key may have been stored while this one planned.
        if (store && r.idempotency_key) {
            auto found = store->find_by_idempotency_key(*r.idempotency_key);
            if (found && *found) return deliver<submit_result>(std::move(h), replay(std::move(**found), r));
        }
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
        auto snapshot = self->registry_.get(job->record.controller);
        if (!snapshot || snapshot->state != devices::connection_state::connected || !snapshot->identity)
            return done(make_error(kind::not_connected, job->record.controller + " is not connected"));
        auto model = self->motion_model_for(*snapshot);
        auto shared_done = std::make_shared<std::function<void(operation_result<void>)>>(std::move(done));
        const bool queued = self->plan_off_strand(
            job->record.type, job->record.spec, std::move(*snapshot), std::move(model),
            [self, job, shared_done](operation_result<job_plan> plan) {
                if (!plan) return (*shared_done)(plan.error());
                if (plan->steps.size() != job->record.progress.steps_total)
                    self->log_->warn("job {}: the plan now has {} steps, it had {}", job->record.id,
                                     plan->steps.size(), job->record.progress.steps_total);
                job->record.progress.steps_total = plan->steps.size();
                job->plan = std::move(*plan);
                (*shared_done)({});
            });
        if (!queued)
            (*shared_done)(make_error(kind::queue_full, "the job planner has too many plans waiting"));
    });
}

motion_model manager_core::motion_model_for(const devices::controller_snapshot& snapshot) const {
    std::optional<unsigned> baud;
    if (const auto c = registry_.controller(snapshot.id)) baud = c->settings().baud;
    return motion_model_of(snapshot, baud);
}

}  // namespace gw::jobs
