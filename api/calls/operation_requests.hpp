#pragma once
// The ONE place where a JSON body for a named operation becomes a gateway request struct, runs
// through the controller registry and becomes a JSON result or a problem. REST
// (POST /api/v1/controllers/{id}/{operation}) and WebSocket ({"op":"command", ...}) both call it.
//
// Bodies (unknown fields -> 422 invalid_value naming the field; wrong types -> 422):
//   move    {"axes":{"X":1000.0,"Y":-5}, "mode":"absolute"|"relative", "wait":false,
//            "timeout_ms":60000}
//   halt    {}                       zero {}
//   home    {"axes":["X","Y"]}       (absent: every motor axis)
//   here    {"axes":{"X":0}}
//   speed   {"axes":{"X":2.5}}       (mm/s)
//   ttl     {"in0_mode":1, "out0_mode":0, "output_high":true}
//   dac     {"volts":2.5}
//   led     {"percent":50, "channel":"X"}
//   crisp   {"action":"lock"|"unlock"|"off", "lock_offset":20, "save":false, "wait":false,
//            "timeout_ms":60000}  (every field optional: {} only reads)
//   autofocus {"timeout_ms":60000}
//   command {"command":"W X Y"}      (admin)
// Results:
//   {"id":"sim1","operation":"halt","request_id":"...","latency_us":812}
//   move:    + "waited":true, "positions":[{"axis":"X","position_um":1000.0}]
//   command: + "command":"W X Y", "raw_reply":":A 0 0", "reply":{"kind":"ack","values":[...],...}
//   crisp:   + "crisp":{"state":"F","name":"locked","focus_error":0,"sum":2400,"lock_offset":0,"snr":20}
//   autofocus: + "z_um":150.0

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/any_completion_handler.hpp>
#include <nlohmann/json.hpp>

#include "api/calls/call_outcome.hpp"
#include "api/common/api_context.hpp"
#include "api/common/caller.hpp"
#include "api/common/problem.hpp"
#include "gateway/config/config.hpp"

namespace gw::api {

// "move", "halt", ..., "command", in the order of the REST paths (call_kinds' operation table).
const std::vector<std::string_view>& operation_names();
bool is_operation(std::string_view name);

// Parses `body` (a JSON object; null counts as {}), checks the lease, runs the operation for `who`
// (whose role dispatch_call checked) and calls `handler` once with the result as the outcome's body,
// on its associated executor (default: ctx.executor), never inline. Leases (ctx.leases): while someone holds
// the controller, every operation but halt needs who.lease_id to be that lease (409 leased otherwise). halt
// is never refused for a lease or the controller's state: it is the emergency stop
// (controller_registry::async_emergency_halt, which latches the controller as halted by who.name).
void run_operation(api_context& ctx, const caller& who, std::string_view controller_id,
                   std::string_view operation, const nlohmann::json& body, api_handler handler);

// 409 job-active unless no job holds the controller, or `lease_id` is the lease the job runs under.
std::optional<problem> job_hold_refusal(api_context& ctx, const std::string& controller,
                                        const std::optional<std::string>& lease_id);

// Whether `operation` is subject to leases (its descriptor's lease rule: every one but halt).
bool needs_lease(std::string_view operation);

}  // namespace gw::api
