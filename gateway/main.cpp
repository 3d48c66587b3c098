// asi-gateway: puts MS-2000 stage controllers behind one service.
// Today it runs the devices layer: simulated (--simulate N) or real (--serial) controllers, each
// driven by its own controller object, with what they report written to the log. The REST,
// WebSocket and MQTT interfaces come with issues 3 and 6.

#include <csignal>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include <CLI/CLI.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <spdlog/spdlog.h>

#include "devices/serial/controller.hpp"
#include "gateway/log_observer.hpp"
#include "gateway/serial_spec.hpp"
#include "gateway/simulated_fleet.hpp"

namespace net = boost::asio;

int main(int argc, char** argv) {
    CLI::App app{"asi-gateway: ASI MS-2000 stage controllers behind one service"};
    std::size_t simulate = 0;
    double time_scale = 1.0;
    std::string sim_dir = "/tmp/asi-gateway-" + std::to_string(::getpid());
    std::vector<std::string> serial_specs;
    std::string log_level = "info";
    int poll_ms = 100;
    app.add_option("--simulate", simulate,
                   "Start N simulated MS-2000 controllers in-process (builds cycle: full, plain, planar)")
        ->check(CLI::Range(0, 16));
    app.add_option("--time-scale", time_scale, "Speed-up of the simulated controllers (1 = real time)")
        ->check(CLI::Range(0.01, 1000.0));
    app.add_option("--sim-dir", sim_dir, "Directory for the simulated ports' symlinks");
    app.add_option("--serial", serial_specs,
                   "A real controller: ID=PATH[@BAUD][,report=PATH] (repeatable), e.g. "
                   "stage1=/dev/ttyUSB0@115200");
    app.add_option("--poll-ms", poll_ms, "Position/status polling interval in ms (0 = off)")
        ->check(CLI::Range(0, 60000));
    app.add_option("--log-level", log_level, "trace, debug, info, warn, error")
        ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
    CLI11_PARSE(app, argc, argv);

    spdlog::set_level(spdlog::level::from_str(log_level));
    auto log = spdlog::default_logger()->clone("gateway");
    spdlog::register_logger(log);

    std::vector<gw::devices::controller_settings> settings;
    for (const auto& spec : serial_specs) {
        auto parsed = gw::parse_serial_spec(spec);
        if (!parsed) {
            log->error("--serial {}: {}", spec, parsed.error());
            return 2;
        }
        settings.push_back(std::move(*parsed));
    }
    if (simulate == 0 && settings.empty()) {
        log->error("nothing to drive: give --simulate N and/or --serial ID=PATH (see --help)");
        return 2;
    }

    net::io_context ioc;
    gw::simulated_fleet fleet(ioc.get_executor(), simulate, time_scale, sim_dir);
    try {
        fleet.start();
    } catch (const std::exception& e) {
        log->error("cannot start the simulated controllers: {}", e.what());
        return 1;
    }
    for (auto& s : fleet.controller_settings())
        settings.push_back(std::move(s));
    for (const auto& sim : fleet.simulators()) {
        log->info("simulated {} ({}) on {}{}", sim->config().name, sim->config().build_name, sim->port_path(),
                  sim->report_port_path().empty() ? "" : ", reports on " + sim->report_port_path());
    }

    auto observer = std::make_shared<gw::log_observer>();
    std::vector<std::shared_ptr<gw::devices::controller>> controllers;
    for (auto& s : settings) {
        s.poll_interval = std::chrono::milliseconds(poll_ms);
        auto c = std::make_shared<gw::devices::controller>(ioc.get_executor(), s, observer);
        c->start();
        controllers.push_back(std::move(c));
    }

    net::signal_set signals(ioc, SIGINT, SIGTERM);
    signals.async_wait([&](boost::system::error_code ec, int signal) {
        if (ec) return;
        log->info("signal {}: stopping", signal);
        for (auto& c : controllers)
            c->stop();
        fleet.stop();
        // A watchdog, not a timer on ioc: a pending timer would itself keep run() going.
        std::thread([&ioc] {
            std::this_thread::sleep_for(std::chrono::seconds(2));
            ioc.stop();
        }).detach();
    });
    ioc.run();
    log->info("stopped");
    return EXIT_SUCCESS;
}
