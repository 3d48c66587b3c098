// ms2000-sim: simulated ASI MS-2000 controllers on pseudo-terminals, for trying the gateway (and
// third-party clients such as Micro-Manager or pyserial scripts) without hardware.
#include <csignal>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>

#include "devices/ms2000/build_info.hpp"
#include "devices/sim/control_channel.hpp"
#include "devices/sim/simulator.hpp"

namespace sim = gw::devices::sim;
namespace ms2000 = gw::devices::ms2000;

namespace {

std::vector<std::string> split_list(const std::string& text) {
    std::vector<std::string> out;
    std::string item;
    std::istringstream in(text);
    while (std::getline(in, item, ',')) {
        if (!item.empty()) out.push_back(item);
    }
    return out;
}

std::string module_ids() {
    std::string out;
    for (std::size_t i = 0; i < static_cast<std::size_t>(ms2000::module::count_); ++i)
        out += (out.empty() ? "" : ", ") + std::string(ms2000::module_id(static_cast<ms2000::module>(i)));
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{
        "ms2000-sim: simulated ASI MS-2000 stage controllers on pseudo-terminals.\n"
        "Each controller gets a pty with a stable symlink (default /tmp/ms2000-sim/<name>/port)\n"
        "and, with a report port, a second one for TTL_REPORT frames (.../report)."};
    std::string preset_name = "full";
    std::string name;
    std::string link;
    std::string report_link;
    std::string axes;
    std::string modules;
    std::string lead_screw;
    std::string build_name;
    std::string version;
    unsigned baud = 115200;
    double time_scale = 1.0;
    std::string control;
    std::string empty_line = "ignore";
    std::string report_format = "binary";
    bool ack_space = false;
    bool no_value_space = false;
    bool report_port = false;
    bool no_report_port = false;
    int flash_ms = -1;
    int where_decimals = 1;
    int count = 1;

    std::string presets;
    for (const auto p : sim::preset_names())
        presets += (presets.empty() ? "" : ", ") + std::string(p);
    app.add_option("--preset", preset_name, "firmware preset: " + presets)->capture_default_str();
    app.add_option("--name", name, "controller name (default: the preset name); used in default link paths");
    app.add_option("--link", link, "symlink for the main port (default /tmp/ms2000-sim/<name>/port)");
    app.add_option("--report-link", report_link,
                   "symlink for the report port (default /tmp/ms2000-sim/<name>/report)");
    app.add_option("--axes", axes, "motor axes in hardware order, e.g. XYZ or XY (overrides the preset)");
    app.add_option("--modules", modules,
                   "comma-separated firmware modules (overrides the preset): " + module_ids());
    app.add_option("--lead-screw", lead_screw,
                   "lead screw A (1.58 mm), B (6.35 mm), C (12.7 mm) or D (25.4 mm)")
        ->check(CLI::IsMember({"A", "B", "C", "D", "a", "b", "c", "d"}));
    app.add_option("--build-name", build_name, "build name answered by BU / BU X (overrides the preset)");
    app.add_option("--firmware-version", version, "version for V, e.g. 9.50 -> \":A Version: USB-9.50 \"");
    app.add_option("--baud", baud, "baud rate used to pace output (10 bits per byte)")->capture_default_str();
    app.add_option("--time-scale", time_scale, "simulated seconds per real second (10 = ten times faster)")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    app.add_flag("--report-port", report_port, "open a report (SERIAL OUT) port even if the preset has none");
    app.add_flag("--no-report-port", no_report_port, "no report port");
    app.add_option("--report-format", report_format, "report frames: binary or ascii")
        ->check(CLI::IsMember({"binary", "ascii"}))
        ->capture_default_str();
    app.add_option("--empty-line", empty_line, "reply to an empty line: ignore, or error (\":N-1\")")
        ->check(CLI::IsMember({"ignore", "error"}))
        ->capture_default_str();
    app.add_flag("--ack-space", ack_space, "answer \":A \" (with a trailing space) instead of \":A\"");
    app.add_flag("--no-value-space", no_value_space, "no trailing space after values (\":A 1.0 2.0\")");
    app.add_option("--where-decimals", where_decimals, "decimals of WHERE values (\":A 1234.5\")")
        ->capture_default_str()
        ->check(CLI::Range(0, 6));
    app.add_option("--flash-ms", flash_ms, "SS Z flash-write time in ms (default 300)");
    app.add_option("--count", count, "run COUNT controllers: <name>-1 .. <name>-COUNT")
        ->check(CLI::Range(1, 64));
    app.add_option("--control", control, "Unix socket for the control channel (one command per line)");
    app.footer(
        "Control channel (--control PATH), one command per line, one answer line each:\n"
        "  pulse              one TTL edge on IN0 (TTL_REPORT frame on the report port, or the IN0 mode)\n"
        "  pulse N RATE_HZ    N edges at RATE_HZ (simulated time)\n"
        "  unplug             close the pty: the client sees EIO/HUP; the symlink is removed\n"
        "  replug             a new pty; the symlink points to it again\n"
        "  drop-next          the next reply is not sent\n"
        "  corrupt-next       the next reply's first byte is changed\n"
        "  delay-next MS      the next reply leaves MS real milliseconds late\n"
        "  garbage N          N random bytes (never CR or LF) on the main port\n"
        "  refuse-next VERB CODE  the next VERB command (M, CCB, ...) is answered :N<CODE> (-1..-99)\n"
        "  state              the controller state as one JSON line\n"
        "  list               the controller names\n"
        "  help               this list\n"
        "Prefix a command with a controller name to address it when --count > 1 (\"ms2000-2 pulse\").\n"
        "Example: socat - UNIX-CONNECT:/tmp/ms2000-sim/control.sock");
    CLI11_PARSE(app, argc, argv);

    auto base = sim::preset(preset_name);
    if (!base) {
        std::cerr << "ms2000-sim: unknown preset '" << preset_name << "' (" << presets << ")\n";
        return 2;
    }
    sim::sim_config config = *base;
    if (!name.empty()) config.name = name;
    if (!axes.empty()) config.motor_axes = axes;
    if (!modules.empty()) {
        config.modules.clear();
        for (const auto& id : split_list(modules)) {
            const auto m = ms2000::module_from_id(id);
            if (!m) {
                std::cerr << "ms2000-sim: unknown module '" << id << "' (" << module_ids() << ")\n";
                return 2;
            }
            config.modules.push_back(*m);
        }
        config.report_port = sim::has_module(config, ms2000::module::ttl_report);
    }
    if (!lead_screw.empty()) config.lead_screw = lead_screw.front();
    if (!build_name.empty()) config.build_name = build_name;
    if (!version.empty()) config.version = version;
    config.baud = baud;
    config.time_scale = time_scale;
    if (report_port) config.report_port = true;
    if (no_report_port) config.report_port = false;
    config.report_format =
        report_format == "ascii" ? ms2000::report_format::ascii : ms2000::report_format::binary;
    config.empty_line =
        empty_line == "error" ? sim::empty_line_reply::unknown_command : sim::empty_line_reply::ignore;
    config.ack_trailing_space = ack_space;
    config.value_trailing_space = !no_value_space;
    config.where_decimals = where_decimals;
    if (flash_ms >= 0) config.flash_write_time = std::chrono::milliseconds(flash_ms);

    boost::asio::io_context io;
    std::vector<std::shared_ptr<sim::simulator>> sims;
    try {
        for (int i = 1; i <= count; ++i) {
            auto c = config;
            if (count > 1) {
                const auto suffix = "-" + std::to_string(i);
                c.name += suffix;
                if (!link.empty()) c.link_path = link + suffix;
                if (!report_link.empty()) c.report_link_path = report_link + suffix;
            } else {
                c.link_path = link;
                c.report_link_path = report_link;
            }
            auto s = std::make_shared<sim::simulator>(io.get_executor(), c);
            s->start();
            std::cout << c.name << " port " << s->port_path() << " -> " << s->device_path();
            if (!s->report_port_path().empty()) std::cout << " report " << s->report_port_path();
            std::cout << std::endl;
            sims.push_back(std::move(s));
        }
    } catch (const std::exception& e) {
        std::cerr << "ms2000-sim: cannot start: " << e.what() << "\n";
        return 1;
    }
    std::shared_ptr<sim::control_channel> channel;
    if (!control.empty()) {
        try {
            channel = std::make_shared<sim::control_channel>(io.get_executor(), control, sims);
            channel->start();
            std::cout << "control " << control << std::endl;
        } catch (const std::exception& e) {
            std::cerr << "ms2000-sim: cannot open control socket " << control << ": " << e.what() << "\n";
            return 1;
        }
    }
    boost::asio::signal_set signals(io, SIGINT, SIGTERM);
    signals.async_wait([&](boost::system::error_code, int) {
        for (auto& s : sims)
            s->stop();
        if (channel) channel->stop();
        io.stop();
    });
    io.run();
    return 0;
}
