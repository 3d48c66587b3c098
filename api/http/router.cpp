#include "api/http/router.hpp"

#include <nlohmann/json.hpp>

#include "api/calls/job_requests.hpp"
#include "api/common/response_headers.hpp"
#include "api/http/browser_guard.hpp"
#include "api/http/gcode_requests.hpp"
#include "api/http/recording_routes.hpp"
#include "api/http/request_context.hpp"
#include "api/http/rest_routes.hpp"
#include "api/http/route_table.hpp"
#include "api/static/openapi_document.hpp"
#include "api/static/static_assets.hpp"
#include "gateway/common/json_text.hpp"

namespace gw::api {

using nlohmann::json;

const route_table& api_routes() {
    static const route_table table = [] {
        auto routes = rest_routes();
        for (auto& r : gcode_routes())
            routes.push_back(std::move(r));
        for (auto& r : recording_routes())
            routes.push_back(std::move(r));
        auto openapi = [](request_context& c) {
            c.reply_body(http::status::ok, std::string(openapi_document()), "application/yaml");
        };
        routes.push_back({http::verb::get, "/api/v1/openapi.yaml", std::nullopt, openapi});
        routes.push_back(
            {http::verb::get, "/openapi.yaml", std::nullopt, openapi});  // the conventional place
        return route_table(std::move(routes));
    }();
    return table;
}

string_response outcome_response(api_outcome o, unsigned version, bool keep_alive, std::string_view target,
                                 const std::string& request_id) {
    if (o.error) return problem_response(std::move(*o.error), version, keep_alive, target, request_id);
    string_response res{static_cast<http::status>(o.status), version};
    set_common_headers(res, request_id, keep_alive);
    if (!o.location.empty()) res.set(http::field::location, o.location);
    if (o.replayed) res.set("Idempotency-Replayed", "true");
    if (o.status != 204) {
        res.set(http::field::content_type, "application/json");
        res.body() = to_json_text(o.body);
    }
    res.prepare_payload();
    return res;
}

std::optional<auth_identity> identify(const api_context& ctx, const http::request_header<>& req,
                                      problem& error) {
    auto it = req.find(http::field::authorization);
    std::string_view header = it == req.end() ? std::string_view{} : std::string_view(it->value());
    return authenticate(ctx.auth, header, error);
}

std::optional<routed_response> refusal_from_header(const api_context& ctx,
                                                   const http::request<http::empty_body>& header,
                                                   const std::string& request_id,
                                                   const std::string& client_address) {
    const std::string path(target_path(header.target()));
    auto refused = [&](problem p, std::string route) {
        return routed_response{problem_response(std::move(p), header.version(), header.keep_alive(),
                                                header.target(), request_id),
                               std::move(route)};
    };
    if (auto p = browser_refusal(header, ctx.browser, false)) return refused(std::move(*p), "unmatched");
    if (is_static_asset_path(path)) return std::nullopt;
    auto d = api_routes().decide(ctx, header, header.keep_alive(), request_id);
    if (d.refusal) {
        route_table::audit_refusal(ctx, header, d, request_id, client_address);
        return routed_response{std::move(*d.refusal), std::move(d.label)};
    }
    const bool program = d.chosen->body == route_body::program;  // any text
    if (!program && !is_json_content_type(header[http::field::content_type]))
        return refused(unsupported_media_type_problem(), std::move(d.label));
    return std::nullopt;
}

void handle_request(const std::shared_ptr<api_context>& ctx, string_request&& req, std::string request_id,
                    net::any_io_executor session_executor, response_handler done,
                    std::string client_address) {
    const std::string path(target_path(req.target()));
    request_context c{ctx, std::move(req), std::move(request_id), std::move(session_executor),
                      std::move(done)};
    c.client_address = std::move(client_address);
    if (auto refused = browser_refusal(c.req, ctx->browser, false)) return c.fail(std::move(*refused));
    if (is_static_asset_path(path)) {  // the dashboard, api/static_assets.hpp
        c.route = static_asset_route(path);
        return c.reply(static_asset_response(c.req, c.request_id));
    }
    api_routes().dispatch(c);
}

}  // namespace gw::api
