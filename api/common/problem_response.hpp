#pragma once
// A problem as an HTTP response (problem+json, status, X-Request-Id, Retry-After, WWW-Authenticate):
// what every HTTP part answers a refusal with.

#include <string>
#include <string_view>

#include "api/common/net.hpp"
#include "api/common/problem.hpp"
#include "api/common/response_headers.hpp"

namespace gw::api {

// The path of a target without its query string.
std::string_view target_path(std::string_view target);

// A problem+json response (status, body, X-Request-Id) for `request`.
string_response problem_response(problem p, const string_request& request, const std::string& request_id);
string_response problem_response(problem p, unsigned version, bool keep_alive, std::string_view target,
                                 const std::string& request_id);

}  // namespace gw::api
