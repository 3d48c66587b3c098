#pragma once
// The one place that sets the headers every HTTP answer of the gateway carries (Server, X-Request-Id,
// Cache-Control, keep-alive), and the plain body response built on it. problem+json and outcome
// responses (router.hpp), static files and G-code answers all start here.

#include <string>
#include <string_view>

#include "api/common/net.hpp"

namespace gw::api {

using string_request = http::request<http::string_body>;
using string_response = http::response<http::string_body>;

// What a response needs from its request once the request itself is gone (a worker thread, a
// completion handler).
struct response_meta {
    unsigned version = 11;
    bool keep_alive = true;
    std::string target;
    std::string request_id;
};

response_meta meta_of(const string_request& request, std::string request_id);

// Server, X-Request-Id, Cache-Control (no-store unless said otherwise) and keep-alive.
void set_common_headers(string_response& res, const std::string& request_id, bool keep_alive,
                        std::string_view cache_control = "no-store");

// `body` with `content_type`, or no body at all for 204.
string_response body_response(http::status status, std::string body, std::string_view content_type,
                              const response_meta& meta);

}  // namespace gw::api
