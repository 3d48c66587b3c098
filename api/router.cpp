#include "api/router.hpp"

#include <boost/asio/bind_executor.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/logger.h>

#include "api/openapi_document.hpp"
#include "api/operation_requests.hpp"
#include "gateway/controller_registry.hpp"
#include "gateway/event_hub.hpp"
#include "gateway/event_json.hpp"
#include "gateway/metrics.hpp"

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
    return make_response(status, body.dump(), "application/json", req, request_id);
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
}

}  // namespace

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
    res.keep_alive(keep_alive);
    res.body() = p.to_json().dump();
    res.prepare_payload();
    return res;
}

string_response problem_response(problem p, const string_request& req, const std::string& request_id) {
    return problem_response(std::move(p), req.version(), req.keep_alive(), req.target(), request_id);
}

std::optional<auth_identity> identify(const api_context& ctx, const string_request& req, problem& error) {
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
    if (!path.starts_with(prefix) || (path.size() > prefix.size() && path[prefix.size()] != '/'))
        return fail("unmatched", make_problem(http_error::not_found, "no route for " + path));
    auto segments = split_path(std::string_view(path).substr(prefix.size()));

    if (segments.size() == 1 && segments[0] == "health") {
        const std::string route = "/api/v1/health";
        if (!method_ok(route, http::verb::get)) return;
        return reply(route, json_response(http::status::ok, {{"status", "ok"}}, req, request_id));
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
        auto version = req.version();
        auto keep_alive = req.keep_alive();
        std::string target(req.target());
        run_operation(*ctx, segments[1], segments[2], body, request_id, who->role,
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
                          res.body() = o.result.dump();
                          res.prepare_payload();
                          done({std::move(res), route});
                      }));
        return;
    }
    return fail("unmatched", make_problem(http_error::not_found, "no route for " + path));
}

}  // namespace gw::api
