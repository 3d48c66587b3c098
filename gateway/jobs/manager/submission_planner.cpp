#include "gateway/jobs/manager/submission_planner.hpp"

#include <fmt/format.h>

#include <boost/asio/post.hpp>

#include "gateway/controllers/controller_registry.hpp"
#include "gateway/jobs/kinds/job_kinds.hpp"
#include "gateway/jobs/manager/job_history.hpp"
#include "gateway/jobs/snapshot_motion_model.hpp"
#include "gateway/leases/lease_manager.hpp"
#include "gateway/storage/gcode_files.hpp"

namespace gw::jobs {

namespace net = boost::asio;
using kind = operation_error_kind;

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

submission_planner::submission_planner(net::strand<net::any_io_executor> strand,
                                       controller_registry& registry, std::shared_ptr<lease_manager> leases,
                                       std::shared_ptr<job_history> history,
                                       const job_manager_settings& settings)
    : strand_(std::move(strand)),
      registry_(registry),
      leases_(std::move(leases)),
      history_(std::move(history)),
      gcode_files_(gcode_directory(settings.storage_path)),
      on_plan_started_(settings.on_plan_started) {}

std::optional<operation_result<submit_result>> submission_planner::admit(const submit_request& r) const {
    if (!registry_.get(r.controller))
        return make_error(kind::unknown_controller, "no controller with id \"" + r.controller + "\"",
                          "controller");
    if (leases_) {
        auto lease = leases_->check(r.controller,
                                    r.lease_id ? std::optional<std::string_view>(*r.lease_id) : std::nullopt);
        if (!lease) return lease.error();
    }
    if (r.dry_run) return std::nullopt;
    return stored_with_key(r);
}

std::optional<operation_result<submit_result>> submission_planner::admit_again(
    const submit_request& r) const {
    if (leases_) {
        auto lease = leases_->check(r.controller,
                                    r.lease_id ? std::optional<std::string_view>(*r.lease_id) : std::nullopt);
        if (!lease) return lease.error();
    }
    return stored_with_key(r);
}

std::optional<operation_result<submit_result>> submission_planner::stored_with_key(
    const submit_request& r) const {
    if (!r.idempotency_key) return std::nullopt;
    auto store = history_->store().get();
    if (!store) return make_error(kind::storage_unavailable, "the job store is closed");
    auto found = store->find_by_idempotency_key(*r.idempotency_key);
    if (!found) return found.error();
    if (*found) return replay(std::move(**found), r);
    return std::nullopt;
}

void submission_planner::plan(const std::string& controller, job_type type, nlohmann::json spec,
                              plan_handler done) {
    auto snapshot = registry_.get(controller);
    if (!snapshot || snapshot->state != devices::connection_state::connected || !snapshot->identity)
        return done(make_error(kind::not_connected, fmt::format("{} is not connected: its build and limits "
                                                                "are needed to plan the job",
                                                                controller)));
    if (!spec.is_object()) return done(make_error(kind::invalid_value, "spec must be a JSON object", "spec"));
    // The motion settings come from the snapshot: no serial round trip before the job is stored.
    auto model = motion_model_for(*snapshot);
    auto shared_done = std::make_shared<plan_handler>(std::move(done));
    const bool queued =
        planner_.post([self = shared_from_this(), type, spec = std::move(spec),
                       snapshot = std::move(*snapshot), model = std::move(model), shared_done]() mutable {
            const plan_context context{std::move(snapshot), std::move(model), self->gcode_files_};
            if (self->on_plan_started_) self->on_plan_started_(context.snapshot.id);
            auto plan = plan_job(type, spec, context);
            // The reference moves on with the result: the planner's thread never holds the last one.
            auto& strand = self->strand_;
            net::post(strand, [self = std::move(self), plan = std::move(plan), shared_done]() mutable {
                (*shared_done)(std::move(plan));
            });
        });
    if (!queued)
        (*shared_done)(make_error(kind::queue_full, fmt::format("the job planner has {} plans waiting: "
                                                                "submit again shortly",
                                                                planner_.max_waiting())));
}

job_record submission_planner::record_of(const submit_request& r, const job_plan& plan,
                                         job_clock::time_point now) {
    job_record rec;
    rec.controller = r.controller;
    rec.type = r.type;
    rec.spec = r.spec;
    rec.state = job_state::queued;
    rec.progress.steps_total = plan.steps.size();
    rec.progress.remaining_s = remaining_from(plan, 0);
    rec.estimated_s = plan.estimated_s;
    rec.plan_path = plan.path;
    rec.idempotency_key = r.idempotency_key;
    rec.submitted_by = r.principal;
    rec.request_id = r.request_id;
    rec.created = now;
    rec.updated = now;
    return rec;
}

motion_model submission_planner::motion_model_for(const devices::controller_snapshot& snapshot) const {
    std::optional<unsigned> baud;
    if (const auto c = registry_.controller(snapshot.id)) baud = c->settings().baud;
    return motion_model_of(snapshot, baud);
}

}  // namespace gw::jobs
