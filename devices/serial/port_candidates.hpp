#pragma once
// The serial ports worth probing for an MS-2000: every /dev/serial/by-id/* link first (their names
// stay the same across reboots and replugs, so a config should use them), then the /dev/ttyUSB*,
// /dev/ttyACM* and /dev/ttyS* nodes that exist and are not already listed through a by-id link, then
// the `extra` paths asked for (which are listed even when missing, so that the report says so).
// Nodes are sorted naturally (ttyS2 before ttyS10); a ttyS node without a UART (sysfs type 0) is
// left out. Reads the file system only.

#include <string>
#include <vector>

namespace gw::devices {

struct port_candidate {
    std::string path;    // what to open and to put into a config: the by-id link, or the node
    std::string device;  // the node it resolves to; empty when it does not resolve
    bool by_id = false;
};

// `system_ports` false: only the `extra` paths (tests, or a user who knows where to look). `dev_root`
// other than "/dev" (a test's fake tree) skips the sysfs UART check.
std::vector<port_candidate> list_candidate_ports(const std::vector<std::string>& extra,
                                                 bool system_ports = true,
                                                 const std::string& dev_root = "/dev");

}  // namespace gw::devices
