#pragma once
// Probes a list of candidate ports for MS-2000 controllers, all at once (one thread per port, at most
// `max_parallel`), so the whole scan takes about as long as the slowest port (every rate without an
// answer: about 1.5 s with the default probe_settings). Blocking: run it on a worker thread. Ports
// this gateway's controllers use are reported in_use and not opened; ports another process holds
// (port_lock.hpp) are reported busy.

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "devices/serial/port_candidates.hpp"
#include "devices/serial/port_probe.hpp"

namespace gw::devices {

struct scan_request {
    std::vector<port_candidate> ports;
    // Resolved node (or the configured path, if it does not resolve) -> controller id.
    std::map<std::string, std::string> in_use;
    probe_settings settings;
    std::size_t max_parallel = 32;
};

// One report per candidate, in the candidates' order.
std::vector<port_report> scan_ports(const scan_request& request);

// The key scan_request::in_use expects for a configured port path.
std::string port_key(const std::string& path);

}  // namespace gw::devices
