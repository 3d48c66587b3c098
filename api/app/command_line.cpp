#include "api/app/command_line.hpp"

#include <chrono>
#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "api/app/gcode_cli.hpp"
#include "api/app/ports_cli.hpp"
#include "api/app/token_cli.hpp"
#include "gateway/config/serial_spec.hpp"
#include "gateway/storage/storage_path.hpp"
#include "gateway/version.hpp"

namespace gw {

namespace {

// The flags as given; an unset optional leaves the config's value.
struct flags {
    std::string config_file;
    std::string check_file;
    std::optional<std::size_t> simulate;
    std::optional<double> time_scale;
    std::optional<std::string> sim_dir;
    std::vector<std::string> serial_specs;
    std::optional<int> poll_ms;
    std::string log_level;
    std::string listen;
    std::optional<std::uint16_t> port;
    std::string storage_dir;
};

void declare(CLI::App& app, flags& f) {
    app.add_option("--config", f.config_file, "JSON config file (without it: four simulated controllers)")
        ->check(CLI::ExistingFile);
    app.add_option("--check-config", f.check_file,
                   "Validate a config file, print \"ok\" or the error, exit 0/2");
    app.add_option(
           "--simulate", f.simulate,
           "Start N simulated MS-2000 controllers in-process (builds cycle: full, plain, planar, crisp)")
        ->check(CLI::Range(std::size_t{0}, max_simulated_controllers));
    app.add_option("--time-scale", f.time_scale, "Speed-up of the simulated controllers (1 = real time)")
        ->check(CLI::Range(0.01, 1000.0));
    app.add_option("--sim-dir", f.sim_dir, "Directory for the simulated ports' symlinks");
    app.add_option("--serial", f.serial_specs,
                   "A real controller: ID=PATH[@BAUD][,report=PATH] (repeatable), e.g. "
                   "stage1=/dev/ttyUSB0@115200");
    app.add_option("--poll-ms", f.poll_ms, "Position/status polling interval in ms (0 = off)")
        ->check(CLI::Range(0, 60000));
    app.add_option("--log-level", f.log_level, "trace, debug, info, warn, error")
        ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
    app.add_option("--listen", f.listen,
                   "Address to serve HTTP on (overrides http.listen_address), e.g. 0.0.0.0");
    app.add_option("--port", f.port, "HTTP port (overrides http.port; 0 = any free port)");
    app.add_option("--storage", f.storage_dir,
                   "Directory of the job store (overrides storage.path; default $STATE_DIRECTORY, "
                   "$XDG_STATE_HOME/asi-gateway or ~/.local/state/asi-gateway)");
    app.set_version_flag("--version", std::string("asi-gateway ") + std::string(version));
}

// The file (or the embedded default), then the flags on top; an error message or the config.
boost::system::result<gateway_config, std::string> resolve_config(const flags& f) {
    gateway_config config = default_config();
    if (!f.config_file.empty()) {
        auto loaded = load_config_file(f.config_file);
        if (!loaded) return loaded.error();
        config = std::move(*loaded);
    } else if (!f.serial_specs.empty() && !f.simulate) {
        config.simulate.count = 0;  // real controllers only
    }
    if (f.simulate) config.simulate.count = *f.simulate;
    if (f.time_scale) config.simulate.time_scale = *f.time_scale;
    if (f.sim_dir) config.simulate.directory = *f.sim_dir;
    for (const auto& spec : f.serial_specs) {
        auto parsed = parse_serial_spec(spec);
        if (!parsed) return "--serial " + spec + ": " + parsed.error();
        config.controllers.push_back(std::move(*parsed));
    }
    if (!f.listen.empty()) config.http.listen_address = f.listen;
    if (f.port) config.http.port = *f.port;
    std::error_code ec;
    auto storage = resolve_storage_path(
        {f.storage_dir, config.storage.path, f.config_file, std::filesystem::current_path(ec).string()},
        process_environment());
    if (!storage) return storage.error().message;
    config.storage.path = *storage;
    for (auto level :
         {log_level::trace, log_level::debug, log_level::info, log_level::warn, log_level::error})
        if (to_string(level) == f.log_level) config.logging.level = level;
    if (auto problem = validate_config(config); !problem.empty()) return problem;
    return config;
}

}  // namespace

std::variant<launch_settings, int> parse_command_line(int argc, const char* const* argv, std::ostream& out,
                                                      std::ostream& err) {
    CLI::App app{"asi-gateway: ASI MS-2000 stage controllers behind one service"};
    flags f;
    declare(app, f);
    gcode_cli gcode(app);  // "asi-gateway gcode plan|preview FILE": no controllers, no store
    ports_cli ports(app);  // "asi-gateway ports": find MS-2000s on the serial ports
    token_cli token(app);  // "asi-gateway token new": a token and its config entry
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help and --version exit 0; every usage error exits 2, as a bad config does.
        return app.exit(e, out, err) == 0 ? 0 : 2;
    }
    if (gcode.selected()) return gcode.run(out, err);
    if (ports.selected()) return ports.run(out, err);
    if (token.selected()) return token.run(out, err);
    if (!f.check_file.empty()) return check_config_file(f.check_file, out, err);

    auto config = resolve_config(f);
    if (!config) {
        err << "asi-gateway: " << config.error() << '\n';
        return 2;
    }
    launch_settings launch{std::move(*config), {}};
    launch.registry = make_registry_options(launch.config);
    if (f.poll_ms) {
        const std::chrono::milliseconds poll(*f.poll_ms);
        for (auto& c : launch.registry.controllers)
            c.poll_interval = poll;
        launch.registry.simulated_poll_interval = poll;
    }
    return launch;
}

}  // namespace gw
