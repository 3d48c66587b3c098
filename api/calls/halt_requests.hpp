#pragma once
// HALT ALL: the emergency stop of every controller at once (POST /api/v1/halt, the WebSocket
// {"op":"halt_all"}, the MQTT topic <base>/halt). Each controller is halted as its own HALT would
// (controller_registry::async_emergency_halt: latched as halted by the caller, jobs paused, sent to
// every open port), all at once, and the answer lists each:
//   {"operation":"halt_all","request_id":"...","controllers":[
//      {"id":"sim1","halted":true,"latency_us":812},
//      {"id":"sim2","halted":false,"problem":{...not-connected...}}]}
// A controller that could not be reached does not fail the call: the answer says which.

#include <string_view>

#include "api/calls/call_outcome.hpp"
#include "api/common/api_context.hpp"
#include "api/common/caller.hpp"

namespace gw::api {

// The REST paths of a HALT: /api/v1/halt and /api/v1/controllers/<id>/halt (the HTTP session serves
// them from their header, before any limit on bodies or connections applies).
bool is_halt_target(std::string_view path);

// Calls `handler` once, on its associated executor (default: ctx.executor), never inline, after every
// controller answered (or failed). The role (auth.halt_role) is checked by the caller (dispatch_call).
void run_halt_all(api_context& ctx, const caller& who, api_handler handler);

}  // namespace gw::api
