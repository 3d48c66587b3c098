#pragma once
// What a call leaves in the audit trail (gateway/audit): every call that may change something (an
// operation, a job submission that is not a dry run, a job action, a lease taken or released, HALT
// ALL), with who, from where, over which transport, and how it ended, refusals included. Reads and
// checks (a job, a lease, a G-code check) leave nothing. Pure.

#include <optional>

#include "api/calls/calls.hpp"
#include "api/calls/job_requests.hpp"
#include "gateway/audit/audit_entry.hpp"

namespace gw::api {

// The entry for `c` by `who`, its outcome not known yet; nothing for a call that changes nothing.
std::optional<audit::audit_entry> audit_entry_for(const caller& who, const call& c);

// Fills in the outcome (status, "ok" or the problem's kind, the job a submission created) and the time.
void complete_audit_entry(audit::audit_entry& entry, const api_outcome& out, std::int64_t time_ms);

// The entry of a request that is not a call (a G-code upload or delete), ended with HTTP `status`
// ("ok" below 400, else "refused" or "failed"), now.
audit::audit_entry route_audit_entry(const caller& who, std::string action, std::string target,
                                     unsigned status);

}  // namespace gw::api
