#pragma once
// The routes of position recordings (api/calls/recording_requests.hpp): start one on a controller,
// stop, delete, list, read one, and download its rows as CSV or JSON Lines, streamed in chunks.

#include <vector>

#include "api/http/route_table.hpp"

namespace gw::api {

std::vector<route> recording_routes();

}  // namespace gw::api
