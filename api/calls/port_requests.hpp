#pragma once
// GET /api/v1/ports (admin): the scan of `asi-gateway ports` (api/app/ports_cli.hpp), answered as
// its JSON (gateway/controllers/port_report_json.hpp). The ports of this gateway's controllers are reported
// in_use and not opened. Query parameters:
//   path=P[,P...]   also probe these ports (each must be a character device, or not exist: a 400
//                   invalid-value otherwise, so the route never writes into a file)
//   only_paths      probe only those (default false)
// Runs on api_context::port_scans (never on an I/O thread); 503 port-scan-busy while another runs.

#include <string>

#include "api/calls/job_requests.hpp"

namespace gw::api {

// Validates `q` and starts the scan; `done` gets the outcome: at once for a bad query or a busy
// worker, else dispatched to its associated executor (bind it to the session's) when the scan ends.
void scan_ports_request(api_context& ctx, const query_params& q, const std::string& request_id,
                        api_handler done);

}  // namespace gw::api
