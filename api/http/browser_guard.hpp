#pragma once
// What a web page of another site may not do to the gateway through a browser (issue 34). Pure.
//
//   - Host: without tokens every caller is admin, which is safe only because the gateway listens on
//     loopback; a page on a DNS-rebinding name reaches it there. So without tokens the Host header
//     must name a loopback address ("localhost", 127.0.0.1, [::1], any port) or a name the config
//     allows (http.allowed_hosts): 421 misdirected-request otherwise.
//   - Origin: a browser says where a request comes from. A request that may change something (any
//     method but GET, HEAD and OPTIONS) or a WebSocket upgrade whose Origin is neither this gateway's
//     own (its host and port are the Host header's) nor in http.allowed_origins is 403
//     cross-origin. No Origin (curl, scripts, other programs) is no browser's: not judged here.
//   - A HALT is judged by neither: stopping a stage is safe whoever asks.
//   - A JSON body must say so (Content-Type: application/json): a page can post a form or text/plain
//     to another site without the browser asking first, but not JSON. 415 otherwise, judged from the
//     header (router's refusal_from_header) and where a body is read (request_context::json_body).

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "api/common/browser_rules.hpp"
#include "api/common/net.hpp"
#include "api/common/problem.hpp"

namespace gw::api {

// The Host header's host, without its port and brackets: "[::1]:8080" -> "::1"; "" when malformed.
std::string host_name_of(std::string_view host_header);
// "localhost", or an IPv4/IPv6 loopback address.
bool is_loopback_host(std::string_view host);

// True for "application/json" with any parameters ("; charset=utf-8"), in any case.
bool is_json_content_type(std::string_view content_type);
problem unsupported_media_type_problem();

// Why the request must be refused (421 or 403), or nothing. `upgrade`: a WebSocket upgrade.
std::optional<problem> browser_refusal(const http::request_header<>& request, const browser_rules& rules,
                                       bool upgrade);

}  // namespace gw::api
