#pragma once
// RFC 9457 problem details: the ONE mapping from an error kind to an HTTP status, a stable type URI
// and a title. Operation errors (gateway/common/operation_error.hpp) and HTTP-level errors both go through
// it. Type URIs are problem_type_base + the kind with dashes ("missing_module" ->
// "https://asi-gateway.dev/problems/missing-module"); openapi/openapi.yaml lists every one.
//
//   {"type":"https://asi-gateway.dev/problems/missing-module","title":"Missing firmware module",
//    "status":409,"detail":"sim2 has no DAC OUT module","instance":"/api/v1/controllers/sim2/dac",
//    "request_id":"4f1c...","field":"volts"}

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "gateway/common/operation_error.hpp"

namespace gw::api {

inline constexpr std::string_view problem_type_base = "https://asi-gateway.dev/problems/";
inline constexpr std::string_view problem_content_type = "application/problem+json";

// Errors the HTTP layer itself detects (no controller involved).
enum class http_error : std::uint8_t {
    malformed_json,          // 400: the body is not JSON, or not a JSON object
    bad_request,             // 400: an unparseable request line/header
    unauthorized,            // 401: no or an unknown bearer token
    forbidden,               // 403: the token's role is too low
    not_found,               // 404: no such route
    method_not_allowed,      // 405: the route exists, the method does not
    payload_too_large,       // 413: body over http.limits.max_body_bytes
    header_too_large,        // 431: headers over http.limits.max_header_bytes
    not_implemented,         // 501
    too_many_connections,    // 503: over http.limits.max_connections (or the per-address share)
    body_budget_exhausted,   // 503: the bodies held in memory would exceed http.limits.max_buffered_body_mb
    cross_origin,            // 403: a browser page of another origin asked to change something
    unsupported_media_type,  // 415: a JSON body without Content-Type: application/json
    misdirected_request,     // 421: without tokens, a Host that is not loopback (DNS rebinding)
};

std::string_view to_string(http_error e);  // "malformed_json"

struct problem {
    unsigned status = 500;
    std::string kind;  // "missing_module": the last segment of `type`, with underscores
    std::string title;
    std::string detail;
    std::string instance;  // the request target
    std::string request_id;
    std::string field;                 // the offending request field, if any
    int controller_code = 0;           // controller_error: ":N-<code>" (signed)
    std::string controller_code_name;  // controller_error: "parameter_out_of_range"
    unsigned retry_after_s = 0;        // > 0: sent as Retry-After (a 503 that passes soon)
    // invalid_gcode: where the program is wrong (1-based line and column; 0 when not tied to a place)
    // and the translator's message, sent as "line", "column" and "message".
    struct program_error {
        int line = 0;
        int column = 0;
        std::string message;
    };
    std::optional<program_error> program;

    std::string type() const;  // problem_type_base + kind with dashes
    nlohmann::json to_json() const;
};

problem make_problem(const operation_error& e);
problem make_problem(http_error e, std::string detail);

}  // namespace gw::api
