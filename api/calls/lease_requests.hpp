#pragma once
// The lease routes without the transport (gateway/leases/lease_manager.hpp holds the leases):
//
//   POST   /api/v1/controllers/{id}/lease         operator  {"ttl_s":60,"holder":"notebook-3"} (both
//          optional) -> 201 {"lease_id","controller","holder","acquired","expires"}; 409 leased;
//          409 busy while jobs submitted without the lease run, are paused or wait on the controller
//   POST   /api/v1/controllers/{id}/lease/renew   operator  Lease-Id header, {"ttl_s":60} -> 200 lease
//   DELETE /api/v1/controllers/{id}/lease         operator  Lease-Id header -> 204;
//          ?force=true (admin) ends whoever's lease
//   GET    /api/v1/controllers/{id}/lease         viewer    200 the lease without its id; 404 when free
//   GET    /api/v1/leases                         viewer    200 {"leases":[...]} every lease without its id
// The holder is the caller's principal, plus "/<holder label>" when the body names one
// ("operator1/notebook-3"). Unknown controller: 404 before anything else.

#include <chrono>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "api/calls/job_requests.hpp"
#include "gateway/leases/lease_manager.hpp"

namespace gw::api {

struct lease_body {
    std::chrono::seconds ttl = default_lease_ttl;
    std::optional<std::string> label;  // "holder"
};

// Acquire ({"ttl_s","holder"}) or renew ({"ttl_s"}; `allow_holder` false). null counts as {}.
// ttl_s: an integer within [min_lease_ttl, max_lease_ttl]; holder: 1..64 printable characters.
operation_result<lease_body> parse_lease_body(const nlohmann::json& body, bool allow_holder);

// {"lease_id"(when with_id),"controller","holder","acquired","expires","expires_in_s"}.
nlohmann::json lease_json(const lease& l, bool with_id, std::chrono::system_clock::time_point now);

// Completes on ctx.executor. 409 busy while jobs submitted without the lease hold or wait for the
// controller (job_manager::async_acquire_lease).
void acquire_lease(api_context& ctx, const std::string& controller, const nlohmann::json& body,
                   const std::string& principal, const std::string& request_id, api_handler handler);
api_outcome renew_lease(api_context& ctx, const std::string& controller,
                        const std::optional<std::string>& lease_id, const nlohmann::json& body,
                        const std::string& request_id);
// `force` requires the admin role (checked by the caller).
api_outcome release_lease(api_context& ctx, const std::string& controller,
                          const std::optional<std::string>& lease_id, bool force,
                          const std::string& request_id);
api_outcome get_lease(api_context& ctx, const std::string& controller, const std::string& request_id);

// Every current lease (without ids), by controller: what a dashboard shows without asking per controller.
api_outcome list_leases(api_context& ctx, const std::string& request_id);

}  // namespace gw::api
