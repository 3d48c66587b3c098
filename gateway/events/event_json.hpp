#pragma once
// The one place where controller values become JSON, for hub events and for the REST API alike.
// Positions and limits in micrometres (rounded to the nanometre), states and error names as stable
// snake_case strings, times as ISO 8601 UTC with milliseconds. Pure.
//
// state (topic controllers/<id>/state, also GET /controllers/{id}):
//   {"id":"stage1","state":"connected","port":"/dev/ttyUSB0","busy":false,
//    "identity":{"version":"9.52","version_raw":":A Version: USB-9.52","build":"STD_XYZ",
//                "motor_axes":"XYZ","modules":["ring_buffer","array"],"module_lines":[...],
//                "ring_buffer_size":50} | null,
//    "axes":[{"axis":"X","position_um":1234.5|null,"busy":false,"counts_per_mm":45396.6|null,
//             "soft_limits_um":{"lower":-110000.0|null,"upper":110000.0|null}}],
//    "ttl":{"in0_mode":1|null,"out0_mode":0|null},
//    "last_error":{"code":-4,"name":"parameter_out_of_range","text":"...","time":"..."} | null,
//    "error_log":{"recent":[{"code":87,"name":"TTL_REPORT_BUFFER_OVERRUN"}],"count":1},
//    "report_port":"none"|"closed"|"open","updated":"2026-11-22T02:45:40.123Z"}
// position (controllers/<id>/position):
//   {"id":"stage1","busy":false,"axes":[{"axis":"X","position_um":1234.5|null,"busy":false}]}
// report (controllers/<id>/reports), one encoder frame:
//   {"id":"stage1","controller_seq":7,"time":"...","bytes_skipped":0,
//    "axes":[{"axis":"X","counts":12345,"position_um":271.9|null}]}
// ttl (controllers/<id>/ttl), one serial position report ("T:   400    0.0    0.1"):
//   {"id":"stage1","controller_seq":3,"time":"...","controller_ms":400.0,
//    "axes":[{"axis":"X","position_um":0.0}]}
// errors (controllers/<id>/errors), new codes of the controller's own error log (DU Y), oldest first:
//   {"id":"stage1","codes":[{"code":35,"name":"LOWER_LIMIT"}],"time":"..."}

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "devices/ms2000/reply.hpp"
#include "devices/serial/controller_events.hpp"
#include "devices/serial/controller_snapshot.hpp"

namespace gw {

nlohmann::json state_json(const devices::controller_snapshot& snapshot);
// The same with the "identity" member given (identity_json of the snapshot's identity, or null):
// the identity changes once per identification, so a caller may keep it instead of rebuilding it.
nlohmann::json state_json(const devices::controller_snapshot& snapshot, nlohmann::json identity);
nlohmann::json identity_json(const devices::controller_identity& identity);
nlohmann::json position_json(const devices::controller_snapshot& snapshot);
// Text, not a DOM: built for every frame of every report stream.
std::string report_json_text(const devices::report_event& event);
nlohmann::json ttl_json(const devices::ttl_event& event);
nlohmann::json error_log_json(const devices::error_log_event& event);
// In the report stream (controllers/<id>/reports), after frames the controller itself could not send
// (error 87 in its log, read once the stream went quiet), so a subscriber tells frames lost in the
// controller from frames the gateway could not deliver (gap events):
//   {"controller_overruns":3,"id":"stage1","time":"..."}
// Its text starts with {"controller_overruns": (keys are sorted), so is_report_overrun needs no parse.
nlohmann::json report_overrun_json(const devices::error_log_event& event, std::uint64_t overruns);
// The count of a report_overrun_json text, or nullopt for a frame.
std::optional<std::uint64_t> report_overruns(std::string_view data_text);
// A parsed controller reply, as the raw command operation returns it: kind, values, axes, lines.
nlohmann::json reply_json(const devices::ms2000::reply& reply);

}  // namespace gw
