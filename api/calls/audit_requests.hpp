#pragma once
// GET /api/v1/audit (admin): the audit trail, newest first.
//   ?controller=sim1&principal=scheduler&since=<ms>&until=<ms>&limit=100&before=<id>
//   -> {"entries":[{"id","time","principal","role","transport","address","action","controller",
//                   "target","request_id","status","outcome","detail"}],"next_before":id|null}
// since/until are milliseconds since the Unix epoch (since inclusive, until exclusive); before pages.

#include "api/calls/job_requests.hpp"
#include "api/common/api_context.hpp"
#include "gateway/audit/audit_entry.hpp"

namespace gw::api {

inline constexpr std::size_t max_audit_limit = 500;

// The filter, or invalid_value naming the parameter (pure).
operation_result<audit::audit_filter> parse_audit_filter(const query_params& q);

// Runs the query on the audit log's thread; `done` gets the page (or 503 without a store).
void query_audit(api_context& ctx, audit::audit_filter filter, api_handler done);

}  // namespace gw::api
