#pragma once
// The embedded default of asi-gateway (--simulate N): N simulated MS-2000 controllers started
// in-process on pseudo-terminals, with different firmware builds so that every feature can be tried
// without hardware. Controller i uses preset_cycle[i % 4]: "full" (ARRAY, RING BUFFER, SCAN,
// TTL_REPORT with its report port), "plain" (XYZ only), "planar" (PLANAR CORRECTION, DAC OUT, LED),
// "crisp" (CRISP, AUTOFOCUS, LED, RING BUFFER).
// Created and stopped on the main thread; the simulators themselves run on the given executor.

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <boost/asio/any_io_executor.hpp>

#include "devices/serial/controller_settings.hpp"
#include "devices/sim/simulator.hpp"

namespace gw {

class simulated_fleet {
  public:
    // Links are made under `directory` as <id>/port and <id>/report (ids "sim1", "sim2", ...).
    simulated_fleet(const boost::asio::any_io_executor& executor, std::size_t count, double time_scale,
                    std::string directory);

    // Opens every pseudo-terminal. Throws std::system_error when one cannot be opened.
    void start();
    void stop();

    // Driver settings that point at the simulated ports.
    std::vector<devices::controller_settings> controller_settings() const;

    const std::vector<std::shared_ptr<devices::sim::simulator>>& simulators() const { return simulators_; }

  private:
    std::vector<std::string> ids_;
    std::vector<std::shared_ptr<devices::sim::simulator>> simulators_;
};

}  // namespace gw
