#include "api/http/rest_routes.hpp"

#include <string>

#include <nlohmann/json.hpp>

#include "api/calls/audit_requests.hpp"
#include "api/calls/calls.hpp"
#include "api/calls/lease_requests.hpp"
#include "api/calls/operation_requests.hpp"
#include "api/calls/port_requests.hpp"
#include "api/calls/share_json.hpp"
#include "api/common/mqtt_link_state.hpp"
#include "gateway/common/metrics.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/events/controller_state_texts.hpp"
#include "gateway/events/event_hub.hpp"
#include "gateway/events/event_json.hpp"
#include "gateway/jobs/manager/job_manager.hpp"
#include "gateway/version.hpp"

namespace gw::api {

namespace {

using http::verb;
using nlohmann::json;

void copy_hub_counters(const api_context& ctx) {
    if (!ctx.hub) return;
    auto c = ctx.hub->counters();
    auto& m = *ctx.metrics;
    m.set("gw_events_published_total", {}, static_cast<double>(c.published));
    m.set("gw_events_delivered_total", {}, static_cast<double>(c.delivered));
    m.set("gw_events_coalesced_total", {}, static_cast<double>(c.coalesced));
    m.set("gw_events_gap_events_total", {}, static_cast<double>(c.gap_events));
    m.set("gw_events_gapped_total", {}, static_cast<double>(c.gapped));
    m.set("gw_events_evicted_subscribers_total", {}, static_cast<double>(c.evicted));
    m.set("gw_event_subscribers", {}, static_cast<double>(c.subscribers));
    m.set("gw_events_topics", {}, static_cast<double>(c.topics));
    m.set("gw_events_replay_bytes", {}, static_cast<double>(c.replay_bytes));
    m.set("gw_events_retired_topics_total", {}, static_cast<double>(c.retired));
}

problem unknown_controller(const std::string& id) {
    return make_problem(make_error(operation_error_kind::unknown_controller, "no controller \"" + id + "\""));
}

// ---- service ----

void health(request_context& c) {
    json body = {{"status", "ok"}, {"version", gw::version}};
    body["mqtt"] = c.ctx->mqtt_link ? c.ctx->mqtt_link->to_json() : json(nullptr);
    c.reply_json(http::status::ok, body);
}

void ready(request_context& c) {
    json list = json::array();
    for (const auto& s : c.ctx->registry.list())
        list.push_back({{"id", s.id}, {"state", devices::to_string(s.state)}});
    const bool ready = c.ctx->registry.ready();
    c.reply_json(ready ? http::status::ok : http::status::service_unavailable,
                 {{"ready", ready}, {"controllers", std::move(list)}});
}

void metrics(request_context& c) {
    copy_hub_counters(*c.ctx);
    copy_share_counters(*c.ctx);
    if (c.ctx->jobs) {
        if (auto fill = c.ctx->jobs->store_fill_ratio())
            c.ctx->metrics->set("gw_job_store_fill_ratio", {}, *fill);
    }
    c.reply_body(http::status::ok, c.ctx->metrics->exposition(), "text/plain; version=0.0.4; charset=utf-8");
}

void whoami(request_context& c) {
    c.reply_json(http::status::ok, whoami_json(c.ctx->auth, *c.who));
}

// ---- controllers ----

void list_controllers(request_context& c) {
    json list = json::array();
    for (const auto& s : c.ctx->registry.list()) {
        auto state = state_json(s);
        state["share"] = share_json_of(*c.ctx, s.id);
        list.push_back(std::move(state));
    }
    c.reply_json(http::status::ok, {{"controllers", std::move(list)}});
}

void get_controller(request_context& c) {
    // The text the events bridge built with the last snapshot: nothing to build per request.
    // The shared port changes on its own (clients come and go): its status is added to that text.
    if (c.ctx->state_texts)
        if (auto text = c.ctx->state_texts->get(c.params[0]); text && text->ends_with('}')) {
            std::string body(*text, 0, text->size() - 1);
            body += R"(,"share":)" + share_json_of(*c.ctx, c.params[0]).dump() + "}";
            return c.reply_body(http::status::ok, std::move(body), "application/json");
        }
    auto s = c.ctx->registry.get(c.params[0]);
    if (!s) return c.fail(unknown_controller(c.params[0]));
    auto state = state_json(*s);
    state["share"] = share_json_of(*c.ctx, s->id);
    c.reply_json(http::status::ok, state);
}

// POST /controllers/{id}/<operation>: the operation's own name is the last segment of the route.
void operation(request_context& c, const std::string& name) {
    auto body = c.json_body();  // null: an empty body counts as {}
    if (!body) return;
    // Known controller? (a clear 404 before any body field is judged)
    if (!c.ctx->registry.get(c.params[0])) return c.fail(unknown_controller(c.params[0]));
    caller who = c.as_caller();
    if (!c.key_header("Lease-Id", who.lease_id)) return;
    dispatch_call(*c.ctx, who, operation_call{c.params[0], name, std::move(*body)}, c.async_reply());
}

// POST /halt: HALT ALL (api/halt_requests.hpp); a body, if any, is ignored: nothing may stand in
// the way of an emergency stop.
void halt_all(request_context& c) {
    dispatch_call(*c.ctx, c.as_caller(), halt_all_call{}, c.async_reply());
}

// ---- leases ----

void list_all_leases(request_context& c) {
    c.reply_outcome(list_leases(*c.ctx, c.request_id));
}

void get_controller_lease(request_context& c) {
    if (!c.query_with({})) return;
    dispatch_call(*c.ctx, c.as_caller(), lease_get_call{c.params[0]}, c.async_reply());
}

void take_lease(request_context& c) {
    if (!c.query_with({})) return;
    auto body = c.json_body();
    if (!body) return;
    dispatch_call(*c.ctx, c.as_caller(), lease_take_call{c.params[0], std::move(*body)}, c.async_reply());
}

void renew_controller_lease(request_context& c) {
    if (!c.query_with({})) return;
    caller who = c.as_caller();
    if (!c.key_header("Lease-Id", who.lease_id)) return;
    auto body = c.json_body();
    if (!body) return;
    dispatch_call(*c.ctx, who, lease_renew_call{c.params[0], std::move(*body)}, c.async_reply());
}

void release_controller_lease(request_context& c) {
    auto q = c.query_with({"force"});
    if (!q) return;
    auto force = query_flag(*q, "force", false);
    if (!force) return c.fail(force.error());
    caller who = c.as_caller();
    if (!c.key_header("Lease-Id", who.lease_id)) return;
    dispatch_call(*c.ctx, who, lease_release_call{c.params[0], *force}, c.async_reply());
}

// ---- serial ports ----

void scan_ports(request_context& c) {
    auto q = c.query();
    if (!q) return;
    if (!c.ctx->port_scans)
        return c.fail(make_problem(http_error::not_implemented, "port scans are not available here"));
    scan_ports_request(*c.ctx, *q, c.request_id, c.async_reply());
}

// ---- jobs ----

void find_jobs(request_context& c) {
    auto q = c.query();
    if (!q) return;
    auto filter = parse_job_filter(*q);
    if (!filter) return c.fail(filter.error());
    list_jobs(*c.ctx, std::move(*filter), c.request_id, c.async_reply());
}

void submit(request_context& c) {
    auto q = c.query_with({"dry_run"});
    if (!q) return;
    auto dry_run = query_flag(*q, "dry_run", false);
    if (!dry_run) return c.fail(dry_run.error());
    job_submit_call submit{{}, *dry_run, {}};
    caller who = c.as_caller();
    if (!c.key_header("Idempotency-Key", submit.idempotency_key) || !c.key_header("Lease-Id", who.lease_id))
        return;
    auto body = c.json_body();
    if (!body) return;
    submit.request = std::move(*body);
    dispatch_call(*c.ctx, who, std::move(submit), c.async_reply());
}

// A job id that cannot be one (a typo, a path) is not looked up.
bool plausible_job(request_context& c) {
    if (is_plausible_job_id(c.params[0])) return true;
    c.fail(make_problem(make_error(operation_error_kind::unknown_job, "no such job")));
    return false;
}

void get_one_job(request_context& c) {
    if (!plausible_job(c) || !c.query_with({})) return;
    get_job(*c.ctx, c.params[0], c.request_id, c.async_reply());
}

void get_job_events(request_context& c) {
    if (!plausible_job(c)) return;
    auto q = c.query();
    if (!q) return;
    auto limit = parse_event_limit(*q);
    if (!limit) return c.fail(limit.error());
    job_events(*c.ctx, c.params[0], *limit, c.request_id, c.async_reply());
}

// GET /audit (admin): the audit trail (api/audit_requests.hpp).
void audit_trail(request_context& c) {
    auto q = c.query();
    if (!q) return;
    auto filter = parse_audit_filter(*q);
    if (!filter) return c.fail(filter.error());
    query_audit(*c.ctx, std::move(*filter), c.async_reply());
}

void job_command_route(request_context& c, job_command command) {
    if (!plausible_job(c) || !c.query_with({})) return;
    auto body = c.json_body();
    if (!body) return;
    if (!body->is_null() && !(body->is_object() && body->empty()))
        return c.fail(make_error(operation_error_kind::invalid_value, "this request takes no body (or {})"));
    caller who = c.as_caller();
    if (!c.key_header("Lease-Id", who.lease_id)) return;
    dispatch_call(*c.ctx, who, job_action_call{c.params[0], command}, c.async_reply());
}

}  // namespace

// A route that makes a call needs the role the call needs (role_for, the one place that decides it),
// checked from the header before the body is read; dispatch_call checks the call itself again, with
// what only the body or the config tells (a forced release, auth.halt_role).
std::vector<route> rest_routes() {
    const std::string v1 = "/api/v1";
    std::vector<route> routes = {
        {verb::get, v1 + "/health", std::nullopt, health},
        {verb::get, v1 + "/ready", std::nullopt, ready},
        {verb::get, v1 + "/metrics", gw::role::viewer, metrics},
        {verb::get, v1 + "/whoami", gw::role::viewer, whoami},
        {verb::get, v1 + "/audit", gw::role::admin, audit_trail},
        {verb::get, v1 + "/controllers", gw::role::viewer, list_controllers},
        {verb::get, v1 + "/controllers/{id}", gw::role::viewer, get_controller},
        // The route lets every token holder in (role_for without auth.halt_role); dispatch_call checks
        // auth.halt_role.
        {verb::post, v1 + "/halt", role_for(halt_all_call{}), halt_all},
        {verb::get, v1 + "/leases", gw::role::viewer, list_all_leases},
        {verb::get, v1 + "/controllers/{id}/lease", role_for(lease_get_call{}), get_controller_lease},
        {verb::post, v1 + "/controllers/{id}/lease", role_for(lease_take_call{}), take_lease},
        // A forced release needs more (admin): dispatch_call checks the call made of the query.
        {verb::delete_, v1 + "/controllers/{id}/lease", role_for(lease_release_call{}),
         release_controller_lease},
        {verb::post, v1 + "/controllers/{id}/lease/renew", role_for(lease_renew_call{}),
         renew_controller_lease},
        {verb::get, v1 + "/ports", gw::role::admin, scan_ports},
        {verb::get, v1 + "/jobs", gw::role::viewer, find_jobs},
        {verb::post, v1 + "/jobs", role_for(job_submit_call{}), submit},
        {verb::get, v1 + "/jobs/{id}", role_for(job_get_call{}), get_one_job},
        {verb::get, v1 + "/jobs/{id}/events", gw::role::viewer, get_job_events},
    };
    for (auto command : {job_command::cancel, job_command::pause, job_command::resume, job_command::next})
        routes.push_back({verb::post, v1 + "/jobs/{id}/" + std::string(to_string(command)),
                          role_for(job_action_call{{}, command}),
                          [command](request_context& c) { job_command_route(c, command); }});
    for (auto name : operation_names())
        routes.push_back({verb::post, v1 + "/controllers/{id}/" + std::string(name),
                          role_for(operation_call{{}, std::string(name), {}}),
                          [name = std::string(name)](request_context& c) { operation(c, name); }});
    return routes;
}

}  // namespace gw::api
