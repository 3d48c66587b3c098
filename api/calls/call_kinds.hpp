#pragma once
// One descriptor per kind of call, in one table (the model: a command table such as Dragonfly's): its
// name, the role it needs, the lease rule it follows, and whether the audit trail records it.
// dispatch_call checks the role from it (role_for), the REST routes and the WebSocket and MQTT codecs
// read the same role, operations check their lease by it, and the audit trail names the call by it.
// Pure.
//
//   const auto* d = operation_descriptor("move");  // {"move", operator, controller lease, audited}
//   if (!d) ...                                     // no such operation: 404

#include <cstdint>
#include <span>
#include <string_view>

#include "api/common/auth.hpp"

namespace gw::api {

enum class role_need : std::uint8_t {
    viewer,
    operator_,
    admin,
    halt,  // auth.halt_role (viewer by default): whoever may stop the stage
};

enum class lease_rule : std::uint8_t {
    none,        // never waits for a lease: reads, HALT, a G-code check, HALT ALL
    controller,  // while the controller is leased, only that lease's holder (operations, a submission)
    job,         // the lease the job runs under (cancel, pause, resume, next)
    own,         // the lease the call names or takes (take, renew, release; a forced release: none)
};

struct call_descriptor {
    std::string_view name;  // the audit trail's action: "move", "job.submit", "lease.break"
    role_need role = role_need::operator_;
    lease_rule lease = lease_rule::none;
    bool audited = true;  // changes something: the audit trail records it (reads and checks do not)
};

// The operations on a controller ("move", "halt", ..., "command"), in the order of the REST paths.
std::span<const call_descriptor> operation_descriptors();
// Null when `name` is no operation.
const call_descriptor* operation_descriptor(std::string_view name);

// The other calls.
namespace call_kinds {
extern const call_descriptor job_submit;
extern const call_descriptor job_plan;  // a dry run: nothing changes
extern const call_descriptor job_cancel;
extern const call_descriptor job_pause;
extern const call_descriptor job_resume;
extern const call_descriptor job_next;
extern const call_descriptor job_get;
extern const call_descriptor lease_get;
extern const call_descriptor lease_take;
extern const call_descriptor lease_renew;
extern const call_descriptor lease_release;
extern const call_descriptor lease_break;  // a forced release, without the lease
extern const call_descriptor gcode_check;
extern const call_descriptor halt_all;
extern const call_descriptor recording_start;
extern const call_descriptor recording_stop;
extern const call_descriptor recording_delete;
}  // namespace call_kinds

// The role a descriptor asks for, `halt_role` standing for role_need::halt.
gw::role role_needed(const call_descriptor& d, gw::role halt_role);

}  // namespace gw::api
