#pragma once
// Maps one HTTP request to one response: the dashboard's files, then the route table (route_table.hpp)
// of the REST routes (rest_routes.hpp) and the G-code routes (gcode_requests.hpp), with auth, request
// ids and the problem+json errors. Transport-free: http_session reads and writes, the router decides.
//
// The routes, each with its method and the role it needs, are the tables of rest_routes() (rest_routes.cpp)
// and gcode_routes() (gcode_requests.cpp), plus GET /api/v1/openapi.yaml and /openapi.yaml (public);
// GET|HEAD / and /dashboard/<file> serve the dashboard (static_assets.hpp).
// Thread safety: handle() may be called from any session strand; `done` is called exactly once, on
// `session_executor` (immediately, inside handle(), for everything but the controller operations and
// the job submissions and job commands).

#include <functional>
#include <memory>
#include <string>

#include "api/common/api_context.hpp"
#include "api/common/auth.hpp"
#include "api/common/net.hpp"
#include "api/common/problem.hpp"
#include "api/common/problem_response.hpp"
#include "api/common/response_headers.hpp"
#include "api/common/streamed_body.hpp"

namespace gw::api {

class route_table;
// The table of every /api/v1 route: the REST routes, the G-code routes and the OpenAPI document.
const route_table& api_routes();

struct routed_response {
    string_response response;
    std::string route;  // the route template for metrics ("/api/v1/controllers/{id}/move"), or "unmatched"
    // Not null: the body comes from here, chunked (`response` gives the status and headers only).
    std::shared_ptr<streamed_body> stream{};
};

using response_handler = std::function<void(routed_response)>;

// The HTTP response for a route's outcome: problem+json, or JSON with status 200/201 (Location) or 204;
// Idempotency-Replayed: true on a replayed submission.
struct api_outcome;
string_response outcome_response(api_outcome o, unsigned version, bool keep_alive, std::string_view target,
                                 const std::string& request_id);

// Resolves the Authorization header, or fills `error` (401).
std::optional<auth_identity> identify(const api_context& ctx, const http::request_header<>& request,
                                      problem& error);

// What the header of a request with a body decides before the body is read or memory reserved for
// it, so that an unauthenticated client's body costs nothing: the browser rules, an unknown route
// (404, 405), the caller (401, 403), a JSON body's media type (415). Nothing: read the body. G-code
// programs are admitted by their own rules (admit_gcode_program) before this.
std::optional<routed_response> refusal_from_header(const api_context& ctx,
                                                   const http::request<http::empty_body>& header,
                                                   const std::string& request_id,
                                                   const std::string& client_address);

void handle_request(const std::shared_ptr<api_context>& ctx, string_request&& request, std::string request_id,
                    net::any_io_executor session_executor, response_handler done,
                    std::string client_address = {});

}  // namespace gw::api
