#pragma once
// Helpers for driving the pure model in simulated time.

#include <chrono>
#include <string>

#include "devices/sim/ms2000_model.hpp"

namespace gw::devices::sim::test {

using namespace std::chrono_literals;

// Sends one command (CR-terminated) and returns the reply bytes.
inline std::string send(ms2000_model& m, const std::string& line, sim_time now) {
    return m.feed(line + "\r", now);
}

// Runs every scheduled model event (array steps, dwells, scan lines, flash writes) in time order and
// returns when the stage is idle for good: the time the last motion settled.
inline sim_time run_to_completion(ms2000_model& m) {
    for (int guard = 0; guard < 1000000; ++guard) {
        const auto next = m.next_event();
        if (!next) break;
        m.take_output(*next);
    }
    return m.idle_at();
}

inline sim_config config_for(const char* preset_name, char screw = 'B') {
    auto c = preset(preset_name).value();
    c.lead_screw = screw;
    return c;
}

}  // namespace gw::devices::sim::test
