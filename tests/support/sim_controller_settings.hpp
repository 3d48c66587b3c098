#pragma once
// The driver settings that reach an in-process simulator (its port and report port links), with the
// short poll, timeout and reconnect times the integration tests use. Header-only.

#include <chrono>
#include <string>

#include "devices/serial/controller_settings.hpp"
#include "devices/sim/simulator.hpp"

namespace gw::test {

inline devices::controller_settings sim_controller_settings(const std::string& id,
                                                            const devices::sim::simulator& s, unsigned baud) {
    using namespace std::chrono_literals;
    devices::controller_settings c;
    c.id = id;
    c.port = s.port_path();
    c.report_port = s.report_port_path();
    c.baud = baud;
    c.poll_interval = 20ms;
    c.command_timeout = 2000ms;
    c.reconnect_min = 50ms;
    c.reconnect_max = 300ms;
    return c;
}

}  // namespace gw::test
