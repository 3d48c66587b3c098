#pragma once
// Who makes a call, on any transport: the token's name and role, the request id its serial commands
// carry, the lease it holds on the controller, if any, and where it comes from (api/calls.hpp
// dispatches calls for it; the audit trail records them).

#include <optional>
#include <string>

#include "gateway/config/config.hpp"

namespace gw::api {

struct caller {
    std::string name = "anonymous";  // the token's name
    gw::role role = gw::role::viewer;
    std::string request_id;
    std::optional<std::string> lease_id;  // the lease the caller holds on the controller, if any
    std::string transport = "rest";       // rest, websocket, mqtt: for the audit trail
    std::string address{};                // the client's address; "" when not known (MQTT)
};

}  // namespace gw::api
