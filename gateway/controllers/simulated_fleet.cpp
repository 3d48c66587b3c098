#include "gateway/controllers/simulated_fleet.hpp"

#include <array>
#include <string_view>

namespace gw {

namespace {
constexpr std::array<std::string_view, 4> preset_cycle{"full", "plain", "planar", "crisp"};
}

simulated_fleet::simulated_fleet(const boost::asio::any_io_executor& executor, std::size_t count,
                                 double time_scale, std::string directory) {
    for (std::size_t i = 0; i < count; ++i) {
        auto config = devices::sim::preset(preset_cycle[i % preset_cycle.size()]).value();
        std::string id = "sim" + std::to_string(i + 1);
        config.name = id;
        config.time_scale = time_scale;
        config.link_path = directory + "/" + id + "/port";
        config.report_link_path = directory + "/" + id + "/report";
        ids_.push_back(id);
        simulators_.push_back(std::make_shared<devices::sim::simulator>(executor, std::move(config)));
    }
}

void simulated_fleet::start() {
    for (auto& sim : simulators_)
        sim->start();
}

void simulated_fleet::stop() {
    for (auto& sim : simulators_)
        sim->stop();
}

std::vector<devices::controller_settings> simulated_fleet::controller_settings() const {
    std::vector<devices::controller_settings> out;
    for (std::size_t i = 0; i < simulators_.size(); ++i) {
        devices::controller_settings s;
        s.id = ids_[i];
        s.port = simulators_[i]->port_path();
        s.baud = simulators_[i]->config().baud;
        s.report_port = simulators_[i]->report_port_path();
        out.push_back(std::move(s));
    }
    return out;
}

}  // namespace gw
