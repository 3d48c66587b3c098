#pragma once
// The REST routes under /api/v1 other than G-code (gcode_requests.hpp): health, readiness, metrics,
// whoami, controllers and their operations, leases, serial ports and jobs, as route_table entries.
// The handlers only translate: the work is in operation_requests, lease_requests, port_requests and
// job_requests.

#include <vector>

#include "api/http/route_table.hpp"

namespace gw::api {

std::vector<route> rest_routes();

}  // namespace gw::api
