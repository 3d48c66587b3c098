#include "api/router.hpp"

#include <boost/asio/bind_executor.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/logger.h>

#include "api/gcode_requests.hpp"
#include "api/job_requests.hpp"
#include "api/lease_requests.hpp"
#include "api/openapi_document.hpp"
#include "api/operation_requests.hpp"
#include "api/port_requests.hpp"
#include "api/static_assets.hpp"
#include "gateway/controller_registry.hpp"
#include "gateway/event_hub.hpp"
#include "gateway/event_json.hpp"
#include "gateway/json_text.hpp"
#include "gateway/metrics.hpp"
#include "gateway/version.hpp"

namespace gw::api {

using nlohmann::json;

namespace {

constexpr std::string_view prefix = "/api/v1";

string_response make_response(http::status status, std::string body, std::string_view content_type,
                              const string_request& req, const std::string& request_id) {
    string_response res{status, req.version()};
    res.set(http::field::server, "asi-gateway");
    res.set(http::field::content_type, content_type);
    res.set("X-Request-Id", request_id);
    res.set(http::field::cache_control, "no-store");
    res.keep_alive(req.keep_alive());
    res.body() = std::move(body);
    res.prepare_payload();
    return res;
}

string_response json_response(http::status status, const json& body, const string_request& req,
                              const std::string& request_id) {
    return make_response(status, to_json_text(body), "application/json", req, request_id);
}

// "/controllers/sim1/move" -> {"controllers", "sim1", "move"}; empty segments kept (so "//" fails).
std::vector<std::string_view> split_path(std::string_view path) {
    std::vector<std::string_view> out;
    while (!path.empty()) {
        path.remove_prefix(1);  // the '/'
        auto slash = path.find('/');
        out.push_back(path.substr(0, slash));
        if (slash == std::string_view::npos) break;
        path.remove_prefix(slash);
    }
    return out;
}

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

// The value of a header, if the request has it.
std::optional<std::string> header_value(const string_request& req, std::string_view name) {
    auto it = req.find(name);
    if (it == req.end()) return std::nullopt;
    return std::string(it->value());
}

}  // namespace

string_response outcome_response(api_outcome o, unsigned version, bool keep_alive, std::string_view target,
                                 const std::string& request_id) {
    if (o.error) return problem_response(std::move(*o.error), version, keep_alive, target, request_id);
    string_response res{static_cast<http::status>(o.status), version};
    res.set(http::field::server, "asi-gateway");
    res.set("X-Request-Id", request_id);
    res.set(http::field::cache_control, "no-store");
    if (!o.location.empty()) res.set(http::field::location, o.location);
    if (o.replayed) res.set("Idempotency-Replayed", "true");
    res.keep_alive(keep_alive);
    if (o.status != 204) {
        res.set(http::field::content_type, "application/json");
        res.body() = o.body.dump(-1, ' ', false, json::error_handler_t::replace);
    }
    res.prepare_payload();
    return res;
}

std::string_view target_path(std::string_view target) {
    return target.substr(0, target.find('?'));
}

string_response problem_response(problem p, unsigned version, bool keep_alive, std::string_view target,
                                 const std::string& request_id) {
    if (p.instance.empty()) p.instance = std::string(target_path(target));
    p.request_id = request_id;
    string_response res{static_cast<http::status>(p.status), version};
    res.set(http::field::server, "asi-gateway");
    res.set(http::field::content_type, problem_content_type);
    res.set("X-Request-Id", request_id);
    res.set(http::field::cache_control, "no-store");
    if (p.status == 401) res.set(http::field::www_authenticate, "Bearer realm=\"asi-gateway\"");
    if (p.retry_after_s > 0) res.set(http::field::retry_after, std::to_string(p.retry_after_s));
    res.keep_alive(keep_alive);
    res.body() = to_json_text(p.to_json());
    res.prepare_payload();
    return res;
}

string_response problem_response(problem p, const string_request& req, const std::string& request_id) {
    return problem_response(std::move(p), req.version(), req.keep_alive(), req.target(), request_id);
}

std::optional<auth_identity> identify(const api_context& ctx, const http::request_header<>& req,
                                      problem& error) {
    auto it = req.find(http::field::authorization);
    std::string_view header = it == req.end() ? std::string_view{} : std::string_view(it->value());
    return authenticate(ctx.auth, header, error);
}

void handle_request(const std::shared_ptr<api_context>& ctx, string_request&& req, std::string request_id,
                    net::any_io_executor session_executor, response_handler done) {
    const std::string path(target_path(req.target()));
    const auto method = req.method();

    auto reply = [&](std::string route, string_response res) {
        done(routed_response{std::move(res), std::move(route)});
    };
    auto fail = [&](std::string route, problem p) {
        reply(std::move(route), problem_response(std::move(p), req, request_id));
    };
    // Only `allowed` is accepted on this route; GET also answers HEAD-less clients plainly.
    auto method_ok = [&](const std::string& route, http::verb allowed) {
        if (method == allowed) return true;
        auto res =
            problem_response(make_problem(http_error::method_not_allowed,
                                          std::string(req.method_string()) + " is not allowed here; use " +
                                              std::string(http::to_string(allowed))),
                             req, request_id);
        res.set(http::field::allow, http::to_string(allowed));
        reply(route, std::move(res));
        return false;
    };
    auto authorize = [&](const std::string& route, gw::role needed) -> std::optional<auth_identity> {
        problem p;
        auto who = identify(*ctx, req, p);
        if (!who) {
            fail(route, std::move(p));
            return std::nullopt;
        }
        if (!has_role(*who, needed)) {
            fail(route, forbidden_problem(*who, needed));
            return std::nullopt;
        }
        return who;
    };

    if (path == "/openapi.yaml" || path == "/api/v1/openapi.yaml") {
        const std::string route = "/api/v1/openapi.yaml";
        if (!method_ok(route, http::verb::get)) return;
        return reply(route, make_response(http::status::ok, std::string(openapi_document()),
                                          "application/yaml", req, request_id));
    }
    if (is_static_asset_path(path))  // the dashboard, api/static_assets.hpp
        return reply(static_asset_route(path), static_asset_response(req, request_id));
    if (!path.starts_with(prefix) || (path.size() > prefix.size() && path[prefix.size()] != '/'))
        return fail("unmatched", make_problem(http_error::not_found, "no route for " + path));
    auto segments = split_path(std::string_view(path).substr(prefix.size()));
    if (is_gcode_path(path))  // api/gcode_requests.hpp
        return handle_gcode_request(ctx, std::move(req), std::move(request_id), std::move(session_executor),
                                    std::move(done));

    if (segments.size() == 1 && segments[0] == "health") {
        const std::string route = "/api/v1/health";
        if (!method_ok(route, http::verb::get)) return;
        return reply(route, json_response(http::status::ok, {{"status", "ok"}, {"version", gw::version}}, req,
                                          request_id));
    }
    if (segments.size() == 1 && segments[0] == "ready") {
        const std::string route = "/api/v1/ready";
        if (!method_ok(route, http::verb::get)) return;
        json list = json::array();
        for (const auto& s : ctx->registry.list())
            list.push_back({{"id", s.id}, {"state", devices::to_string(s.state)}});
        const bool ready = ctx->registry.ready();
        return reply(route,
                     json_response(ready ? http::status::ok : http::status::service_unavailable,
                                   {{"ready", ready}, {"controllers", std::move(list)}}, req, request_id));
    }
    if (segments.size() == 1 && segments[0] == "metrics") {
        const std::string route = "/api/v1/metrics";
        if (!method_ok(route, http::verb::get) || !authorize(route, gw::role::viewer)) return;
        copy_hub_counters(*ctx);
        return reply(route, make_response(http::status::ok, ctx->metrics->exposition(),
                                          "text/plain; version=0.0.4; charset=utf-8", req, request_id));
    }
    if (segments.size() == 1 && segments[0] == "whoami") {
        const std::string route = "/api/v1/whoami";
        if (!method_ok(route, http::verb::get)) return;
        auto who = authorize(route, gw::role::viewer);
        if (!who) return;
        return reply(route, json_response(http::status::ok, whoami_json(ctx->auth, *who), req, request_id));
    }
    if (segments.size() == 1 && segments[0] == "controllers") {
        const std::string route = "/api/v1/controllers";
        if (!method_ok(route, http::verb::get) || !authorize(route, gw::role::viewer)) return;
        json list = json::array();
        for (const auto& s : ctx->registry.list())
            list.push_back(state_json(s));
        return reply(route,
                     json_response(http::status::ok, {{"controllers", std::move(list)}}, req, request_id));
    }
    if (segments.size() == 2 && segments[0] == "controllers" && !segments[1].empty()) {
        const std::string route = "/api/v1/controllers/{id}";
        if (!method_ok(route, http::verb::get) || !authorize(route, gw::role::viewer)) return;
        auto s = ctx->registry.get(std::string(segments[1]));
        if (!s)
            return fail(route,
                        make_problem(make_error(operation_error_kind::unknown_controller,
                                                "no controller \"" + std::string(segments[1]) + "\"")));
        return reply(route, json_response(http::status::ok, state_json(*s), req, request_id));
    }
    // Several methods on one route: 405 with Allow listing them.
    auto methods_ok = [&](const std::string& route, std::initializer_list<http::verb> allowed) {
        for (auto v : allowed)
            if (method == v) return true;
        std::string list;
        for (auto v : allowed)
            list += (list.empty() ? "" : ", ") + std::string(http::to_string(v));
        auto res = problem_response(
            make_problem(http_error::method_not_allowed,
                         std::string(req.method_string()) + " is not allowed here; use " + list),
            req, request_id);
        res.set(http::field::allow, list);
        reply(route, std::move(res));
        return false;
    };
    auto query = [&](const std::string& route) -> std::optional<query_params> {
        auto q = parse_query(req.target());
        if (!q) {
            fail(route, make_problem(q.error()));
            return std::nullopt;
        }
        return std::move(*q);
    };
    auto known_only = [&](const std::string& route, const query_params& q,
                          std::initializer_list<std::string_view> known) {
        auto ok = check_known_parameters(q, known);
        if (!ok) fail(route, make_problem(ok.error()));
        return static_cast<bool>(ok);
    };
    // The body as JSON (null when empty), or a 400 answered.
    auto json_body = [&](const std::string& route) -> std::optional<json> {
        json body;
        if (!req.body().empty()) {
            body = json::parse(req.body(), nullptr, false);
            if (body.is_discarded()) {
                fail(route, make_problem(http_error::malformed_json, "the request body is not valid JSON"));
                return std::nullopt;
            }
        }
        return body;
    };
    // A Lease-Id / Idempotency-Key header: absent, valid, or a 422 answered (`ok` false).
    auto key_header = [&](const std::string& route, std::string_view name,
                          bool& ok) -> std::optional<std::string> {
        ok = true;
        auto v = header_value(req, name);
        if (v && !is_valid_key(*v)) {
            ok = false;
            fail(route,
                 make_problem(make_error(operation_error_kind::invalid_value,
                                         std::string(name) + " must be 1..128 printable ASCII characters",
                                         std::string(name))));
        }
        return v;
    };
    auto reply_outcome = [&](const std::string& route, api_outcome o) {
        reply(route,
              outcome_response(std::move(o), req.version(), req.keep_alive(), req.target(), request_id));
    };
    // The answer of an asynchronous route, on the session's executor.
    auto async_reply = [&](std::string route) {
        return net::bind_executor(
            session_executor,
            [route = std::move(route), version = req.version(), keep_alive = req.keep_alive(),
             target = std::string(req.target()), request_id, done = std::move(done)](api_outcome o) {
                done({outcome_response(std::move(o), version, keep_alive, target, request_id), route});
            });
    };

    if (segments.size() == 1 && segments[0] == "leases") {
        const std::string route = "/api/v1/leases";
        if (!method_ok(route, http::verb::get) || !authorize(route, gw::role::viewer)) return;
        return reply_outcome(route, list_leases(*ctx, request_id));
    }
    if (segments.size() == 1 && segments[0] == "ports") {
        const std::string route = "/api/v1/ports";
        if (!method_ok(route, http::verb::get) || !authorize(route, gw::role::admin)) return;
        auto q = query(route);
        if (!q) return;
        if (!ctx->port_scans)
            return fail(route,
                        make_problem(http_error::not_implemented, "port scans are not available here"));
        return scan_ports_request(*ctx, *q, request_id, async_reply(route));
    }
    if (!segments.empty() && segments[0] == "jobs") {
        if (segments.size() == 1) {
            const std::string route = "/api/v1/jobs";
            if (!methods_ok(route, {http::verb::get, http::verb::post})) return;
            auto q = query(route);
            if (!q) return;
            if (method == http::verb::get) {
                if (!authorize(route, gw::role::viewer)) return;
                auto filter = parse_job_filter(*q);
                if (!filter) return fail(route, make_problem(filter.error()));
                return reply_outcome(route, list_jobs(*ctx, *filter, request_id));
            }
            auto who = authorize(route, gw::role::operator_);
            if (!who || !known_only(route, *q, {"dry_run"})) return;
            auto dry_run = query_flag(*q, "dry_run", false);
            if (!dry_run) return fail(route, make_problem(dry_run.error()));
            bool ok = true;
            submit_options options;
            options.dry_run = *dry_run;
            options.idempotency_key = key_header(route, "Idempotency-Key", ok);
            if (!ok) return;
            options.lease_id = key_header(route, "Lease-Id", ok);
            if (!ok) return;
            auto body = json_body(route);
            if (!body) return;
            options.principal = who->name;
            options.request_id = request_id;
            return submit_job(*ctx, *body, std::move(options), async_reply(route));
        }
        if (!segments[1].empty() && is_plausible_job_id(segments[1])) {
            const std::string id(segments[1]);
            if (segments.size() == 2) {
                const std::string route = "/api/v1/jobs/{id}";
                if (!method_ok(route, http::verb::get) || !authorize(route, gw::role::viewer)) return;
                auto q = query(route);
                if (!q || !known_only(route, *q, {})) return;
                return reply_outcome(route, get_job(*ctx, id, request_id));
            }
            if (segments.size() == 3 && segments[2] == "events") {
                const std::string route = "/api/v1/jobs/{id}/events";
                if (!method_ok(route, http::verb::get) || !authorize(route, gw::role::viewer)) return;
                auto q = query(route);
                if (!q) return;
                auto limit = parse_event_limit(*q);
                if (!limit) return fail(route, make_problem(limit.error()));
                return reply_outcome(route, job_events(*ctx, id, *limit, request_id));
            }
            if (segments.size() == 3) {
                if (auto command = parse_job_command(segments[2])) {
                    const std::string route = "/api/v1/jobs/{id}/" + std::string(segments[2]);
                    if (!method_ok(route, http::verb::post)) return;
                    auto who = authorize(route, gw::role::operator_);
                    if (!who) return;
                    auto q = query(route);
                    if (!q || !known_only(route, *q, {})) return;
                    auto body = json_body(route);
                    if (!body) return;
                    if (!body->is_null() && !(body->is_object() && body->empty()))
                        return fail(route, make_problem(make_error(operation_error_kind::invalid_value,
                                                                   "this request takes no body (or {})")));
                    bool ok = true;
                    jobs::job_action action;
                    action.job_id = id;
                    action.lease_id = key_header(route, "Lease-Id", ok);
                    if (!ok) return;
                    action.principal = who->name;
                    action.request_id = request_id;
                    return control_job(*ctx, *command, std::move(action), async_reply(route));
                }
            }
        } else if (segments.size() >= 2 && segments.size() <= 3) {
            // Not a job id at all: the job cannot exist.
            const std::string route = segments.size() == 2 ? "/api/v1/jobs/{id}" : "unmatched";
            if (segments.size() == 2)
                return fail(route,
                            make_problem(make_error(operation_error_kind::unknown_job, "no such job")));
        }
        return fail("unmatched", make_problem(http_error::not_found, "no route for " + path));
    }

    if ((segments.size() == 3 || (segments.size() == 4 && segments[3] == "renew")) &&
        segments[0] == "controllers" && !segments[1].empty() && segments[2] == "lease") {
        const std::string controller(segments[1]);
        if (segments.size() == 4) {
            const std::string route = "/api/v1/controllers/{id}/lease/renew";
            if (!method_ok(route, http::verb::post) || !authorize(route, gw::role::operator_)) return;
            auto q = query(route);
            if (!q || !known_only(route, *q, {})) return;
            bool ok = true;
            auto lease_id = key_header(route, "Lease-Id", ok);
            if (!ok) return;
            auto body = json_body(route);
            if (!body) return;
            return reply_outcome(route, renew_lease(*ctx, controller, lease_id, *body, request_id));
        }
        const std::string route = "/api/v1/controllers/{id}/lease";
        if (!methods_ok(route, {http::verb::get, http::verb::post, http::verb::delete_})) return;
        auto q = query(route);
        if (!q) return;
        if (method == http::verb::get) {
            if (!authorize(route, gw::role::viewer) || !known_only(route, *q, {})) return;
            return reply_outcome(route, get_lease(*ctx, controller, request_id));
        }
        if (method == http::verb::post) {
            auto who = authorize(route, gw::role::operator_);
            if (!who || !known_only(route, *q, {})) return;
            auto body = json_body(route);
            if (!body) return;
            return acquire_lease(*ctx, controller, *body, who->name, request_id, async_reply(route));
        }
        auto who = authorize(route, gw::role::operator_);
        if (!who || !known_only(route, *q, {"force"})) return;
        auto force = query_flag(*q, "force", false);
        if (!force) return fail(route, make_problem(force.error()));
        if (*force && !has_role(*who, gw::role::admin))
            return fail(route, forbidden_problem(*who, gw::role::admin));
        bool ok = true;
        auto lease_id = key_header(route, "Lease-Id", ok);
        if (!ok) return;
        return reply_outcome(route, release_lease(*ctx, controller, lease_id, *force, request_id));
    }

    if (segments.size() == 3 && segments[0] == "controllers" && !segments[1].empty() &&
        is_operation(segments[2])) {
        const std::string route = "/api/v1/controllers/{id}/" + std::string(segments[2]);
        if (!method_ok(route, http::verb::post)) return;
        auto who = authorize(route, required_role(segments[2]));
        if (!who) return;
        json body;  // null: an empty body counts as {}
        if (!req.body().empty()) {
            body = json::parse(req.body(), nullptr, false);
            if (body.is_discarded())
                return fail(route,
                            make_problem(http_error::malformed_json, "the request body is not valid JSON"));
        }
        // Known controller? (a clear 404 before any body field is judged)
        if (!ctx->registry.get(std::string(segments[1])))
            return fail(route,
                        make_problem(make_error(operation_error_kind::unknown_controller,
                                                "no controller \"" + std::string(segments[1]) + "\"")));
        bool lease_ok = true;
        auto lease_id = key_header(route, "Lease-Id", lease_ok);
        if (!lease_ok) return;
        auto version = req.version();
        auto keep_alive = req.keep_alive();
        std::string target(req.target());
        run_operation(*ctx, segments[1], segments[2], body, request_id, who->role, std::move(lease_id),
                      net::bind_executor(session_executor, [route, version, keep_alive, target, request_id,
                                                            done = std::move(done)](operation_outcome o) {
                          if (o.error)
                              return done({problem_response(std::move(*o.error), version, keep_alive, target,
                                                            request_id),
                                           route});
                          string_response res{http::status::ok, version};
                          res.set(http::field::server, "asi-gateway");
                          res.set(http::field::content_type, "application/json");
                          res.set("X-Request-Id", request_id);
                          res.set(http::field::cache_control, "no-store");
                          res.keep_alive(keep_alive);
                          res.body() = to_json_text(o.result);
                          res.prepare_payload();
                          done({std::move(res), route});
                      }));
        return;
    }
    return fail("unmatched", make_problem(http_error::not_found, "no route for " + path));
}

}  // namespace gw::api
