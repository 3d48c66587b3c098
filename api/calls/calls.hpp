#pragma once
// One call model for every transport: a caller (who, with which role, under which request id and
// lease) and a closed set of calls on controllers and jobs. REST, WebSocket and MQTT decode their wire
// format into a call, dispatch_call() authorises it, checks the lease rules, validates and runs it, and
// its one outcome type (api_outcome) goes back to the transport to encode.
//
//   dispatch_call(ctx, caller{"ada", role::operator_, "rid-1", lease_id},
//                 job_action_call{"j-01...", job_command::pause}, std::move(done));

#include <optional>
#include <string>
#include <variant>

#include <nlohmann/json.hpp>

#include "api/calls/call_kinds.hpp"
#include "api/calls/job_requests.hpp"
#include "api/common/api_context.hpp"
#include "api/common/caller.hpp"
#include "gateway/config/config.hpp"

namespace gw::api {

// A named operation on a controller (move, halt, ..., command): args is its JSON object (null: {}).
struct operation_call {
    std::string controller;
    std::string operation;
    nlohmann::json args;
};
// A job submission: `request` is {"controller", "type", "spec"} (validated when dispatched).
struct job_submit_call {
    nlohmann::json request;
    bool dry_run = false;
    std::optional<std::string> idempotency_key;
};
struct job_action_call {
    std::string job_id;
    job_command command = job_command::cancel;
};
struct job_get_call {
    std::string job_id;
};

// Leases on a controller: the caller's lease_id is the lease renewed or released.
struct lease_get_call {
    std::string controller;
};
struct lease_take_call {
    std::string controller;
    nlohmann::json body;  // {"ttl_s", "holder"} (null: {})
};
struct lease_renew_call {
    std::string controller;
    nlohmann::json body;  // {"ttl_s"} (null: {})
};
struct lease_release_call {
    std::string controller;
    bool force = false;  // without the lease id: admin only
};

// A stored G-code program checked and planned without a controller: the plan's summary. `options`: an
// object of G-code option names to values (null: none), as the query of POST
// /api/v1/gcode/files/{id}/plan. Plans with every move, and previews, are documents the size of the
// program: HTTP only (api/README.md).
struct gcode_check_call {
    std::string file;
    nlohmann::json options;
};

// HALT ALL: every controller halted at once (api/halt_requests.hpp).
struct halt_all_call {};

// Position recordings (api/recording_requests.hpp): a start arms the controller's trigger input.
struct recording_start_call {
    std::string controller;
    nlohmann::json body;  // {"name", "arm", "max_frames", "max_s", "metadata"}
};
struct recording_stop_call {
    std::string recording_id;
};
struct recording_delete_call {
    std::string recording_id;
};

using call = std::variant<operation_call, job_submit_call, job_action_call, job_get_call, lease_get_call,
                          lease_take_call, lease_renew_call, lease_release_call, gcode_check_call,
                          halt_all_call, recording_start_call, recording_stop_call, recording_delete_call>;

// The call's descriptor (call_kinds): its name, role, lease rule and audit. An operation that does not
// exist gets one with an empty name, needing operator (run_operation answers 404).
const call_descriptor& descriptor_of(const call& c);

// The role a call needs, from its descriptor: viewer to read a job or a lease and to check a G-code
// program; `halt_role` (auth.halt_role) for a HALT; admin for the "command" operation and a forced lease
// release; operator for everything else.
gw::role role_for(const call& c, gw::role halt_role = gw::role::viewer);

// A HALT of one controller or HALT ALL: never refused for the gateway's own limits.
bool is_emergency_stop(const call& c);

// Runs `c` for `who` and calls `done` once, on its associated executor (default ctx.executor), never
// inline: 403 when the role is not enough, else the outcome of the operation or job call.
void dispatch_call(api_context& ctx, const caller& who, call c, api_handler done);

}  // namespace gw::api
