#pragma once
// HTTP routes as data: method, path template, the role it needs, handler. The table finds the route
// for a request, answers 404 when no template matches the path and 405 (with Allow) when one matches
// but not with this method, authorises the caller for the route's role (401/403), and only then calls
// the handler with the path parameters and the caller in its request_context.
//
//   route_table table({
//       {http::verb::get, "/api/v1/controllers/{id}", gw::role::viewer, get_controller},
//       {http::verb::get, "/api/v1/health", std::nullopt, health},  // public
//   });
//   table.dispatch(context);  // context.route, params and who filled in
//
// A template is matched segment by segment: "{name}" takes any non-empty segment, anything else must
// be equal. The first template in table order that matches decides.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "api/common/net.hpp"
#include "api/http/request_context.hpp"
#include "gateway/config/config.hpp"

namespace gw::api {

using route_handler = std::function<void(request_context&)>;

// What a route's request body is.
enum class route_body : std::uint8_t {
    json,     // strict JSON (Content-Type application/json), held in memory within the body budget
    program,  // a G-code program (any text), streamed to the G-code store when there is one
};

struct route {
    http::verb method;
    std::string pattern;
    std::optional<gw::role> role;  // nullopt: public (no token needed)
    route_handler handler;
    route_body body = route_body::json;
};

class route_table {
  public:
    explicit route_table(std::vector<route> routes);

    // What the request's header alone decides: its route (404; 405 with Allow) and its caller (401,
    // 403). Without a refusal, `chosen` is the route whose handler may run.
    struct decision {
        const route* chosen = nullptr;
        std::string label = "unmatched";  // the route's template, for metrics
        std::vector<std::string> params;
        std::optional<auth_identity> who;
        std::optional<string_response> refusal;
    };
    decision decide(const api_context& ctx, const http::request_header<>& request, bool keep_alive,
                    const std::string& request_id) const;
    // A request that may change something, refused by `d` because its caller's role is too low for the
    // route (403): recorded in the audit trail like any refused call, its action the route
    // ("POST /api/v1/controllers/{id}/command"). Nothing for any other decision.
    static void audit_refusal(const api_context& ctx, const http::request_header<>& request,
                              const decision& d, const std::string& request_id,
                              const std::string& client_address);

    // True when some template matches the path (whatever the method).
    bool serves(std::string_view path) const;
    // The route of `method` on `path`, without asking who calls; nullptr when there is none.
    const route* route_for(http::verb method, std::string_view path) const;
    // Answers the request: through its route's handler, or with the 404/405/401/403 above.
    void dispatch(request_context& c) const;

  private:
    struct compiled {
        route r;
        std::vector<std::string> segments;
    };
    // The routes of the first template matching `path`, with its parameters.
    std::vector<const compiled*> find(std::string_view path, std::vector<std::string>& params) const;

    std::vector<compiled> routes_;
};

}  // namespace gw::api
