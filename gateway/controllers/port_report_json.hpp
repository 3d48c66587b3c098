#pragma once
// JSON of a port scan (devices/serial/port_scan.hpp), shared by `asi-gateway ports --json` and
// GET /api/v1/ports, and the ready-to-paste "controllers" entries of the MS-2000s it found.
//   {"ports": [{"path", "device", "by_id", "status", "baud", "version", "version_raw", "build",
//               "controller", "text", "hint"}, ...],
//    "controllers": [{"id": "stage1", "port": "/dev/serial/by-id/...", "baud": 115200}],
//    "duration_ms": 1234}
// Every string that holds controller bytes was escaped by the probe (devices/serial/escape.hpp).

#include <chrono>
#include <vector>

#include <nlohmann/json.hpp>

#include "devices/serial/port_candidates.hpp"
#include "devices/serial/port_probe.hpp"

namespace gw {

nlohmann::json port_report_json(const devices::port_candidate& candidate, const devices::port_report& report);

// One entry per MS-2000 found, with the path it was found under (the by-id link when there is one),
// named stage1, stage2, ... in the scan's order.
nlohmann::json controller_entries(const std::vector<devices::port_report>& reports);

nlohmann::json port_scan_json(const std::vector<devices::port_candidate>& candidates,
                              const std::vector<devices::port_report>& reports,
                              std::chrono::milliseconds took);

}  // namespace gw
