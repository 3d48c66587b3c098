// asi-gateway: puts MS-2000 stage controllers behind one service.
// Reads a JSON config file (--config) or uses the embedded default (three simulated controllers),
// lets flags override it, sets up logging, and runs the controller registry and the job manager until
// SIGINT/SIGTERM, when it stops the running jobs (HALT, interrupted), HALTs connected controllers
// (shutdown.halt_on_exit) and stops. The REST and WebSocket interfaces (api/) come on top.

#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include <CLI/CLI.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/address.hpp>
#include <boost/asio/signal_set.hpp>
#include <spdlog/spdlog.h>

#include "api/mqtt/mqtt_bridge.hpp"
#include "api/server.hpp"
#include "gateway/config.hpp"
#include "gateway/controller_events_bridge.hpp"
#include "gateway/controller_registry.hpp"
#include "gateway/event_hub.hpp"
#include "gateway/gcode_cli.hpp"
#include "gateway/jobs/job_manager.hpp"
#include "gateway/lease_manager.hpp"
#include "gateway/log_observer.hpp"
#include "gateway/logging.hpp"
#include "gateway/metrics.hpp"
#include "gateway/ports_cli.hpp"
#include "gateway/serial_spec.hpp"
#include "gateway/startup_summary.hpp"
#include "gateway/storage_lock.hpp"
#include "gateway/storage_path.hpp"
#include "gateway/version.hpp"

namespace net = boost::asio;

int main(int argc, char** argv) {
    CLI::App app{"asi-gateway: ASI MS-2000 stage controllers behind one service"};
    std::string config_file;
    std::string check_file;
    std::size_t simulate = 0;
    double time_scale = 1.0;
    std::string sim_dir;
    std::vector<std::string> serial_specs;
    std::string log_level;
    int poll_ms = 100;
    std::string listen;
    std::uint16_t port = 0;
    std::string storage_dir;
    app.add_option("--config", config_file, "JSON config file (without it: three simulated controllers)")
        ->check(CLI::ExistingFile);
    app.add_option("--check-config", check_file,
                   "Validate a config file, print \"ok\" or the error, exit 0/2");
    auto* simulate_opt =
        app.add_option("--simulate", simulate,
                       "Start N simulated MS-2000 controllers in-process (builds cycle: full, plain, planar)")
            ->check(CLI::Range(std::size_t{0}, gw::max_simulated_controllers));
    auto* time_scale_opt =
        app.add_option("--time-scale", time_scale, "Speed-up of the simulated controllers (1 = real time)")
            ->check(CLI::Range(0.01, 1000.0));
    auto* sim_dir_opt = app.add_option("--sim-dir", sim_dir, "Directory for the simulated ports' symlinks");
    app.add_option("--serial", serial_specs,
                   "A real controller: ID=PATH[@BAUD][,report=PATH] (repeatable), e.g. "
                   "stage1=/dev/ttyUSB0@115200");
    auto* poll_opt = app.add_option("--poll-ms", poll_ms, "Position/status polling interval in ms (0 = off)")
                         ->check(CLI::Range(0, 60000));
    app.add_option("--log-level", log_level, "trace, debug, info, warn, error")
        ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
    app.add_option("--listen", listen,
                   "Address to serve HTTP on (overrides http.listen_address), e.g. 0.0.0.0");
    auto* port_opt = app.add_option("--port", port, "HTTP port (overrides http.port; 0 = any free port)");
    app.add_option("--storage", storage_dir,
                   "Directory of the job store (overrides storage.path; default $STATE_DIRECTORY, "
                   "$XDG_STATE_HOME/asi-gateway or ~/.local/state/asi-gateway)");
    app.set_version_flag("--version", std::string("asi-gateway ") + std::string(gw::version));
    gw::gcode_cli gcode(app);  // "asi-gateway gcode plan|preview FILE": no controllers, no store
    gw::ports_cli ports(app);  // "asi-gateway ports": find MS-2000s on the serial ports
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help and --version exit 0; every usage error exits 2, as a bad config does.
        return app.exit(e) == 0 ? EXIT_SUCCESS : 2;
    }
    if (gcode.selected()) return gcode.run(std::cout, std::cerr);
    if (ports.selected()) return ports.run(std::cout, std::cerr);

    if (!check_file.empty()) return gw::check_config_file(check_file, std::cout, std::cerr);

    // The file (or the embedded default), then the flags on top.
    gw::gateway_config config = gw::default_config();
    if (!config_file.empty()) {
        auto loaded = gw::load_config_file(config_file);
        if (!loaded) {
            std::cerr << "asi-gateway: " << loaded.error() << '\n';
            return 2;
        }
        config = std::move(*loaded);
    } else if (!serial_specs.empty() && simulate_opt->count() == 0) {
        config.simulate.count = 0;  // real controllers only
    }
    if (simulate_opt->count() > 0) config.simulate.count = simulate;
    if (time_scale_opt->count() > 0) config.simulate.time_scale = time_scale;
    if (sim_dir_opt->count() > 0) config.simulate.directory = sim_dir;
    for (const auto& spec : serial_specs) {
        auto parsed = gw::parse_serial_spec(spec);
        if (!parsed) {
            std::cerr << "asi-gateway: --serial " << spec << ": " << parsed.error() << '\n';
            return 2;
        }
        config.controllers.push_back(std::move(*parsed));
    }
    if (!listen.empty()) config.http.listen_address = listen;
    if (port_opt->count() > 0) config.http.port = port;
    {
        std::error_code ec;
        auto resolved = gw::resolve_storage_path(
            {storage_dir, config.storage.path, config_file, std::filesystem::current_path(ec).string()},
            gw::process_environment());
        if (!resolved) {
            std::cerr << "asi-gateway: " << resolved.error().message << '\n';
            return 2;
        }
        config.storage.path = *resolved;
    }
    if (!log_level.empty()) {
        for (auto level : {gw::log_level::trace, gw::log_level::debug, gw::log_level::info,
                           gw::log_level::warn, gw::log_level::error})
            if (gw::to_string(level) == log_level) config.logging.level = level;
    }
    auto options = gw::make_registry_options(config);
    if (poll_opt->count() > 0) {
        for (auto& c : options.controllers)
            c.poll_interval = std::chrono::milliseconds(poll_ms);
        options.simulated_poll_interval = std::chrono::milliseconds(poll_ms);
    }
    if (auto problem = gw::validate_config(config); !problem.empty()) {
        std::cerr << "asi-gateway: " << problem << '\n';
        return 2;
    }

    gw::setup_logging(config.logging);
    auto log = gw::get_logger("gateway");
    if (config.controllers.empty() && config.simulate.count == 0)
        log->warn("no controllers configured: give --simulate N, --serial ID=PATH or a config file");
    if (config.auth.tokens.empty())
        log->info("no auth tokens configured: listening on loopback only ({})", config.http.listen_address);

    // One gateway per storage directory, taken before any serial port is opened.
    auto storage = gw::storage_lock::acquire(config.storage.path);
    if (!storage) {
        log->error("{}", storage.error().message);
        return 1;
    }

    net::io_context ioc;
    gw::controller_registry registry(ioc.get_executor(), std::move(options));
    registry.add_observer(
        std::shared_ptr<gw::devices::controller_observer>(std::make_shared<gw::log_observer>()));
    // The API (observers added before start, so nothing is missed): metrics, the event hub fed by every
    // controller, the HTTP/WebSocket server.
    auto metrics = std::make_shared<gw::metrics>();
    auto hub = gw::event_hub::create(ioc.get_executor());
    registry.add_observer(std::shared_ptr<gw::devices::controller_observer>(
        std::make_shared<gw::controller_events_bridge>(hub)));
    // Jobs: leases and the job manager over the durable store (an unusable storage path is fatal).
    auto leases = std::make_shared<gw::lease_manager>();
    const auto job_settings = gw::jobs::make_job_manager_settings(config);
    auto jobs = gw::jobs::job_manager::create(ioc.get_executor(), registry, hub, leases, job_settings);
    if (!jobs) {
        log->error("cannot open the job store in \"{}\": {}", job_settings.storage_path,
                   jobs.error().message);
        return 1;
    }
    auto job_manager = std::move(*jobs);
    gw::api::server http_server(ioc.get_executor(), config, registry, hub, metrics, job_manager, leases);
    try {
        registry.start();
    } catch (const std::exception& e) {
        log->error("cannot start the simulated controllers: {}", e.what());
        return 1;
    }
    job_manager->start();  // restart recovery: interrupted jobs, queued ones kept

    try {
        http_server.start();
    } catch (const std::exception& e) {
        log->error("{}", e.what());
        registry.stop();
        hub->stop();
        return 1;
    }
    // MQTT (mqtt.enabled): the fleet interface over the same API context as REST and WebSocket.
    std::shared_ptr<gw::api::mqtt_bridge> mqtt;
    if (config.mqtt.enabled) {
        char host[256] = {};
        ::gethostname(host, sizeof host - 1);
        gw::api::mqtt_bridge_settings mqtt_settings;
        mqtt_settings.config = config.mqtt;
        mqtt_settings.gateway_id = gw::api::resolve_gateway_id(config.mqtt.gateway_id, host);
        mqtt_settings.log = gw::get_logger("mqtt");
        mqtt = gw::api::mqtt_bridge::create(http_server.context(), std::move(mqtt_settings));
        try {
            mqtt->start();
        } catch (const std::exception& e) {
            log->error("{}", e.what());
            return 1;
        }
    }

    log->info("asi-gateway {} {}", gw::version,
              gw::startup_summary(http_server.local_endpoint(), config.storage.path, registry.list(),
                                  config.mqtt.enabled ? config.mqtt.brokers : std::vector<std::string>{}));

    // After shutdown, run() ends when the last handler has run; a watchdog (not a timer on ioc, which
    // would itself keep run() going) stops it if something lingers.
    std::mutex mutex;
    std::condition_variable cv;
    bool finished = false;
    std::thread watchdog;
    net::signal_set signals(ioc, SIGINT, SIGTERM);
    signals.async_wait([&](boost::system::error_code ec, int signal) {
        if (ec) return;
        log->info("signal {}: stopping", signal);
        http_server.stop();  // stop accepting, close connections
        // Running jobs: HALT, TTL low, interrupted, store flushed; then the controllers; then the hub
        // (the jobs' last state events still go out).
        job_manager->async_shutdown([&] {
            registry.async_shutdown([&] {
                auto stop_hub = [&] {
                    hub->stop();
                    watchdog = std::thread([&] {
                        std::unique_lock lock(mutex);
                        if (!cv.wait_for(lock, std::chrono::seconds(2), [&] { return finished; })) ioc.stop();
                    });
                };
                // MQTT before the hub: it publishes "offline" itself and disconnects.
                if (mqtt)
                    mqtt->async_stop(stop_hub);
                else
                    stop_hub();
            });
        });
    });
    // One handler that throws must not take every controller, job and client down: log and go on.
    for (;;) {
        try {
            ioc.run();
            break;
        } catch (const std::exception& e) {
            log->critical("unhandled exception in an I/O handler, continuing: {}", e.what());
        }
    }
    {
        std::lock_guard lock(mutex);
        finished = true;
    }
    cv.notify_all();
    if (watchdog.joinable()) watchdog.join();
    log->info("stopped");
    spdlog::shutdown();
    return EXIT_SUCCESS;
}
