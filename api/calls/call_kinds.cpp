#include "api/calls/call_kinds.hpp"

#include <array>

namespace gw::api {

namespace {

constexpr bool recorded = true;  // the audit trail records the call
constexpr bool not_recorded = false;

constexpr std::array<call_descriptor, 12> operations = {{
    {"move", role_need::operator_, lease_rule::controller, recorded},
    // The emergency stop: never refused for a lease (or anything else of the gateway's own).
    {"halt", role_need::halt, lease_rule::none, recorded},
    {"home", role_need::operator_, lease_rule::controller, recorded},
    {"zero", role_need::operator_, lease_rule::controller, recorded},
    {"here", role_need::operator_, lease_rule::controller, recorded},
    {"speed", role_need::operator_, lease_rule::controller, recorded},
    {"ttl", role_need::operator_, lease_rule::controller, recorded},
    {"dac", role_need::operator_, lease_rule::controller, recorded},
    {"led", role_need::operator_, lease_rule::controller, recorded},
    {"crisp", role_need::operator_, lease_rule::controller, recorded},
    {"autofocus", role_need::operator_, lease_rule::controller, recorded},
    // A raw line may do anything the controller can: admin only.
    {"command", role_need::admin, lease_rule::controller, recorded},
}};

}  // namespace

std::span<const call_descriptor> operation_descriptors() {
    return operations;
}

const call_descriptor* operation_descriptor(std::string_view name) {
    for (const auto& d : operations)
        if (d.name == name) return &d;
    return nullptr;
}

namespace call_kinds {
const call_descriptor job_submit{"job.submit", role_need::operator_, lease_rule::controller, recorded};
const call_descriptor job_plan{"job.plan", role_need::operator_, lease_rule::controller, not_recorded};
const call_descriptor job_cancel{"job.cancel", role_need::operator_, lease_rule::job, recorded};
const call_descriptor job_pause{"job.pause", role_need::operator_, lease_rule::job, recorded};
const call_descriptor job_resume{"job.resume", role_need::operator_, lease_rule::job, recorded};
const call_descriptor job_next{"job.next", role_need::operator_, lease_rule::job, recorded};
const call_descriptor job_get{"job.get", role_need::viewer, lease_rule::none, not_recorded};
const call_descriptor lease_get{"lease.get", role_need::viewer, lease_rule::none, not_recorded};
const call_descriptor lease_take{"lease.take", role_need::operator_, lease_rule::own, recorded};
// A renewal only extends what its holder already has.
const call_descriptor lease_renew{"lease.renew", role_need::operator_, lease_rule::own, not_recorded};
const call_descriptor lease_release{"lease.release", role_need::operator_, lease_rule::own, recorded};
const call_descriptor lease_break{"lease.break", role_need::admin, lease_rule::none, recorded};
const call_descriptor gcode_check{"gcode.check", role_need::viewer, lease_rule::none, not_recorded};
const call_descriptor halt_all{"halt_all", role_need::halt, lease_rule::none, recorded};
// A start changes the trigger input's mode: a leased controller is its holder's.
const call_descriptor recording_start{"recording.start", role_need::operator_, lease_rule::controller,
                                      recorded};
// A stop puts the mode back as it was; anyone who may operate may end a recording.
const call_descriptor recording_stop{"recording.stop", role_need::operator_, lease_rule::none, recorded};
const call_descriptor recording_delete{"recording.delete", role_need::operator_, lease_rule::none, recorded};
}  // namespace call_kinds

gw::role role_needed(const call_descriptor& d, gw::role halt_role) {
    switch (d.role) {
        case role_need::viewer:
            return gw::role::viewer;
        case role_need::admin:
            return gw::role::admin;
        case role_need::halt:
            return halt_role;
        case role_need::operator_:
            break;
    }
    return gw::role::operator_;
}

}  // namespace gw::api
