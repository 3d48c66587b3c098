#include "api/calls/calls.hpp"

#include <chrono>

#include <boost/asio/append.hpp>
#include <boost/asio/associated_executor.hpp>
#include <boost/asio/bind_executor.hpp>
#include <boost/asio/post.hpp>

#include "api/calls/call_audit.hpp"
#include "api/calls/gcode_check.hpp"
#include "api/calls/halt_requests.hpp"
#include "api/calls/lease_requests.hpp"
#include "api/calls/operation_requests.hpp"
#include "api/calls/recording_requests.hpp"
#include "api/common/auth.hpp"
#include "gateway/audit/audit_log.hpp"
#include "gateway/common/timestamp.hpp"

namespace gw::api {

namespace {

// Delivers an outcome known at once, on `done`'s executor and not inline (the contract above).
void deliver(api_context& ctx, api_handler done, api_outcome out) {
    // post() runs the handler on its associated executor (the transport's), ctx.executor if none.
    boost::asio::post(ctx.executor, boost::asio::append(std::move(done), std::move(out)));
}

// `done`, once the outcome is in the audit trail (recorded before the answer goes out, so that a
// client that reads the trail after its answer finds its call there).
api_handler audited(api_context& ctx, audit::audit_entry entry, api_handler done) {
    auto ex = boost::asio::get_associated_executor(done, ctx.executor);
    return boost::asio::bind_executor(
        ex, [log = ctx.audit, entry = std::move(entry), done = std::move(done)](api_outcome out) mutable {
            complete_audit_entry(entry, out, epoch_ms(std::chrono::system_clock::now()));
            log->record(std::move(entry));
            std::move(done)(std::move(out));
        });
}

}  // namespace

bool is_emergency_stop(const call& c) {
    if (const auto* op = std::get_if<operation_call>(&c)) return op->operation == "halt";
    return std::holds_alternative<halt_all_call>(c);
}

const call_descriptor& descriptor_of(const call& c) {
    // Not a known operation: needs operator, as every operation but halt and command.
    static const call_descriptor unknown_operation{"", role_need::operator_, lease_rule::controller, true};
    if (const auto* op = std::get_if<operation_call>(&c)) {
        const auto* d = operation_descriptor(op->operation);
        return d ? *d : unknown_operation;
    }
    if (const auto* submit = std::get_if<job_submit_call>(&c))
        return submit->dry_run ? call_kinds::job_plan : call_kinds::job_submit;
    if (const auto* action = std::get_if<job_action_call>(&c)) {
        switch (action->command) {
            case job_command::cancel:
                return call_kinds::job_cancel;
            case job_command::pause:
                return call_kinds::job_pause;
            case job_command::resume:
                return call_kinds::job_resume;
            case job_command::next:
                return call_kinds::job_next;
        }
    }
    if (std::holds_alternative<job_get_call>(c)) return call_kinds::job_get;
    if (std::holds_alternative<lease_get_call>(c)) return call_kinds::lease_get;
    if (std::holds_alternative<lease_take_call>(c)) return call_kinds::lease_take;
    if (std::holds_alternative<lease_renew_call>(c)) return call_kinds::lease_renew;
    if (const auto* release = std::get_if<lease_release_call>(&c))
        return release->force ? call_kinds::lease_break : call_kinds::lease_release;
    if (std::holds_alternative<gcode_check_call>(c)) return call_kinds::gcode_check;
    if (std::holds_alternative<recording_start_call>(c)) return call_kinds::recording_start;
    if (std::holds_alternative<recording_stop_call>(c)) return call_kinds::recording_stop;
    if (std::holds_alternative<recording_delete_call>(c)) return call_kinds::recording_delete;
    return call_kinds::halt_all;
}

gw::role role_for(const call& c, gw::role halt_role) {
    return role_needed(descriptor_of(c), halt_role);
}

namespace {

// dispatch_call without the audit trail.
void run_call(api_context& ctx, const caller& who, call c, api_handler done) {
    const auto needed = role_for(c, ctx.auth.halt_role);
    if (!has_role(auth_identity{who.name, who.role}, needed))
        return deliver(ctx, std::move(done),
                       failed(forbidden_problem(auth_identity{who.name, who.role}, needed), who.request_id));

    if (auto* op = std::get_if<operation_call>(&c))
        return run_operation(ctx, who, op->controller, op->operation, op->args, std::move(done));
    if (std::holds_alternative<halt_all_call>(c)) return run_halt_all(ctx, who, std::move(done));
    if (auto* submit = std::get_if<job_submit_call>(&c)) {
        submit_options options;
        options.dry_run = submit->dry_run;
        options.idempotency_key = std::move(submit->idempotency_key);
        options.lease_id = who.lease_id;
        options.principal = who.name;
        options.request_id = who.request_id;
        return submit_job(ctx, submit->request, std::move(options), std::move(done));
    }
    if (auto* action = std::get_if<job_action_call>(&c)) {
        jobs::job_action a;
        a.job_id = action->job_id;
        a.lease_id = who.lease_id;
        a.principal = who.name;
        a.request_id = who.request_id;
        return control_job(ctx, action->command, std::move(a), std::move(done));
    }
    if (const auto* get = std::get_if<job_get_call>(&c))
        return get_job(ctx, get->job_id, who.request_id, std::move(done));
    if (auto* take = std::get_if<lease_take_call>(&c))
        return acquire_lease(ctx, take->controller, take->body, who.name, who.request_id, std::move(done));
    if (const auto* renew = std::get_if<lease_renew_call>(&c))
        return deliver(ctx, std::move(done),
                       renew_lease(ctx, renew->controller, who.lease_id, renew->body, who.request_id));
    if (const auto* check = std::get_if<gcode_check_call>(&c))
        return check_stored_program(ctx, check->file, check->options, who.request_id, std::move(done));
    if (const auto* start = std::get_if<recording_start_call>(&c))
        return start_recording(ctx, who, start->controller, start->body, std::move(done));
    if (const auto* stop = std::get_if<recording_stop_call>(&c))
        return stop_recording(ctx, stop->recording_id, who.request_id, std::move(done));
    if (const auto* remove = std::get_if<recording_delete_call>(&c))
        return delete_recording(ctx, remove->recording_id, who.request_id, std::move(done));
    if (const auto* release = std::get_if<lease_release_call>(&c))
        return deliver(ctx, std::move(done),
                       release_lease(ctx, release->controller, who.lease_id, release->force, who.request_id));
    const auto& get = std::get<lease_get_call>(c);
    deliver(ctx, std::move(done), get_lease(ctx, get.controller, who.request_id));
}

}  // namespace

void dispatch_call(api_context& ctx, const caller& who, call c, api_handler done) {
    // A new handler, not an assignment: Boost 1.81's any_completion_handler move assignment recurses.
    std::optional<audit::audit_entry> entry = ctx.audit ? audit_entry_for(who, c) : std::nullopt;
    if (entry) return run_call(ctx, who, std::move(c), audited(ctx, std::move(*entry), std::move(done)));
    run_call(ctx, who, std::move(c), std::move(done));
}

}  // namespace gw::api
