#pragma once
// Bearer-token authentication and role checks. Pure.
//
//   Authorization: Bearer <token>   -> the token's name and role (config auth.tokens)
//   GET /api/v1/ws?access_token=<token>   (WebSocket upgrade only: browsers cannot set the header)
// Without configured tokens every client is "anonymous" with the admin role: the service then only
// listens on loopback (enforced at start-up by validate_config and the listener).
// Roles are ordered viewer < operator < admin; a role includes the ones below it.

#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "api/common/problem.hpp"
#include "gateway/config/config.hpp"

namespace gw::api {

// No configured token is longer (asi-gateway token new makes 43 characters).
inline constexpr std::size_t max_token_bytes = 1024;

struct auth_identity {
    std::string name;  // the token's name, "anonymous" without tokens
    gw::role role = gw::role::viewer;
};

// The identity for an Authorization header value (empty when the header is absent), or a 401
// problem. Tokens are compared as SHA-256 hashes (the config keeps no token), in the same time
// whatever the content.
std::optional<auth_identity> authenticate(const auth_config& auth, std::string_view authorization,
                                          problem& error);

// The same for a bare token (the WebSocket upgrade's access_token query parameter). An empty token
// is unknown.
std::optional<auth_identity> authenticate_token(const auth_config& auth, std::string_view token,
                                                problem& error);

// The percent-decoded value of the `access_token` query parameter of a request target ("/p?a=b&c"),
// or nullopt when there is none. '+' stays '+' (RFC 3986: percent-encode the token). A malformed
// escape yields an empty string, which no token matches.
std::optional<std::string> access_token_parameter(std::string_view target);

// `target` with every access_token value replaced by "REDACTED": the form that may be logged.
std::string redact_access_token(std::string_view target);

bool has_role(const auth_identity& who, gw::role needed);

// 403 naming the needed role.
problem forbidden_problem(const auth_identity& who, gw::role needed);

// GET /api/v1/whoami, and the WebSocket hello: what the gateway makes of this client, so a page can
// show or hide what its role allows.
//   {"client":"viewer1","role":"viewer","auth":"token"}   a token of the config
//   {"client":null,"role":"admin","auth":"none"}          no tokens configured: every client is admin
nlohmann::json whoami_json(const auth_config& auth, const auth_identity& who);

}  // namespace gw::api
