#pragma once
// Bearer-token authentication and role checks. Pure.
//
//   Authorization: Bearer <token>   -> the token's name and role (config auth.tokens)
// Without configured tokens every client is "anonymous" with the admin role: the service then only
// listens on loopback (enforced at start-up by validate_config and the listener).
// Roles are ordered viewer < operator < admin; a role includes the ones below it.

#include <optional>
#include <string>
#include <string_view>

#include "api/problem.hpp"
#include "gateway/config.hpp"

namespace gw::api {

struct auth_identity {
    std::string name;  // the token's name, "anonymous" without tokens
    gw::role role = gw::role::viewer;
};

// The identity for an Authorization header value (empty when the header is absent), or a 401
// problem. Token comparison takes the same time whatever the content.
std::optional<auth_identity> authenticate(const auth_config& auth, std::string_view authorization,
                                          problem& error);

bool has_role(const auth_identity& who, gw::role needed);

// 403 naming the needed role.
problem forbidden_problem(const auth_identity& who, gw::role needed);

}  // namespace gw::api
