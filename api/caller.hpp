#pragma once
// Who makes a call, on any transport: the token's name and role, the request id its serial commands
// carry, and the lease it holds on the controller, if any (api/calls.hpp dispatches calls for it).

#include <optional>
#include <string>

#include "gateway/config/config.hpp"

namespace gw::api {

struct caller {
    std::string name = "anonymous";  // the token's name
    gw::role role = gw::role::viewer;
    std::string request_id;
    std::optional<std::string> lease_id;  // the lease the caller holds on the controller, if any
};

}  // namespace gw::api
