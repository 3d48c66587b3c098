#pragma once
// A controller's shared port as the API shows it: in GET /api/v1/controllers(/{id}) ("share", null when
// the controller has none) and in /metrics.

#include <string>

#include <nlohmann/json.hpp>

#include "devices/share/share_status.hpp"

namespace gw::api {

struct api_context;

nlohmann::json share_json(const devices::share::port_status& s);
// The controller's "share" value: its port's status, or null.
nlohmann::json share_json_of(const api_context& ctx, const std::string& controller);
// gw_share_* gauges and counters, per controller: declared once, set before a scrape.
void describe_share_metrics(const api_context& ctx);
void copy_share_counters(const api_context& ctx);

}  // namespace gw::api
