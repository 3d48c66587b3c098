#include "api/app/ports_cli.hpp"

#include <chrono>
#include <iomanip>

#include <CLI/CLI.hpp>

#include "devices/serial/port_candidates.hpp"
#include "devices/serial/port_scan.hpp"
#include "gateway/common/json_text.hpp"
#include "gateway/controllers/port_report_json.hpp"

namespace gw {

namespace {

using status = devices::port_report::status;

std::string summary(const devices::port_report& r) {
    switch (r.what) {
        case status::ms2000: {
            std::string s = "MS-2000 at " + std::to_string(r.baud) + " baud, version " + r.version;
            if (r.build) {
                s += ", build " + r.build->name + ", axes " + r.build->motor_axes;
                std::string modules;
                for (const auto& line : r.build->module_lines)
                    modules += (modules.empty() ? "" : ", ") + line;
                if (!modules.empty()) s += ", modules: " + modules;
            } else {
                s += " (no BU X answer: build unknown)";
            }
            return s;
        }
        case status::in_use:
            return "in use by this gateway (controller " + r.controller + ")";
        case status::busy:
            return "busy: " + r.text;
        case status::permission_denied:
            return "permission denied: " + r.text;
        case status::not_found:
            return "not found: " + r.text;
        case status::no_answer:
            return "no answer: " + r.text;
        case status::not_ms2000:
            return "not an MS-2000: " + r.text;
        case status::not_a_tty:
            return "not a serial port: " + r.text;
        case status::error:
            return "error: " + r.text;
    }
    return r.text;
}

}  // namespace

ports_cli::ports_cli(CLI::App& app) {
    ports_ =
        app.add_subcommand("ports", "Find serial ports with an MS-2000 behind them (probes with V and BU X)");
    ports_->add_option("--path", paths_, "Also probe this port (repeatable), e.g. a simulator's pty link");
    ports_->add_flag("--only-paths", only_paths_,
                     "Probe only the --path ports, not /dev/serial/by-id and /dev/tty*");
    ports_
        ->add_option("--baud", bauds_,
                     "Try only this baud rate (repeatable; default: 115200, 9600, 19200, "
                     "28800, 38400, 57600 in that order)")
        ->check(CLI::IsMember({9600u, 19200u, 28800u, 38400u, 57600u, 115200u}));
    ports_->add_option("--timeout-ms", timeout_ms_, "How long to wait for V's answer at each rate")
        ->check(CLI::Range(20, 5000));
    ports_->add_flag("--json", json_, "Print the scan as JSON (the body of GET /api/v1/ports)");
}

bool ports_cli::selected() const {
    return ports_ && ports_->parsed();
}

int ports_cli::run(std::ostream& out, std::ostream& err) const {
    if (only_paths_ && paths_.empty()) {
        err << "asi-gateway ports: --only-paths needs at least one --path\n";
        return 2;
    }
    devices::scan_request request;
    request.ports = devices::list_candidate_ports(paths_, !only_paths_);
    if (!bauds_.empty()) request.settings.bauds = bauds_;
    request.settings.answer_timeout = std::chrono::milliseconds(timeout_ms_);
    const auto started = std::chrono::steady_clock::now();
    const auto reports = devices::scan_ports(request);
    const auto took =
        std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - started);
    const auto entries = controller_entries(reports);

    if (json_) {
        out << to_json_text(port_scan_json(request.ports, reports, took)) << '\n';
    } else if (reports.empty()) {
        out << "no serial ports found (no /dev/serial/by-id/*, /dev/ttyUSB*, /dev/ttyACM* or /dev/ttyS*)\n";
    } else {
        for (std::size_t i = 0; i < reports.size(); ++i) {
            const auto& c = request.ports[i];
            out << c.path;
            if (!c.device.empty() && c.device != c.path) out << " -> " << c.device;
            out << "\n    " << summary(reports[i]) << '\n';
            if (!reports[i].hint.empty()) out << "    hint: " << reports[i].hint << '\n';
        }
        out << "probed " << reports.size() << " port(s) in " << took.count() << " ms\n";
        if (!entries.empty()) {
            out << "\nPaste into the \"controllers\" list of the config file:\n";
            // Keys in the order of the config's documentation, not nlohmann's sorted order.
            for (std::size_t i = 0; i < entries.size(); ++i)
                out << "  {\"id\": " << to_json_text(entries[i]["id"])
                    << ", \"port\": " << to_json_text(entries[i]["port"])
                    << ", \"baud\": " << entries[i]["baud"].get<unsigned>() << '}'
                    << (i + 1 < entries.size() ? ",\n" : "\n");
            for (std::size_t i = 0; i < reports.size(); ++i)
                if (reports[i].what == status::ms2000 && !request.ports[i].by_id &&
                    request.ports[i].path.starts_with("/dev/tty"))
                    out << "note: " << request.ports[i].path
                        << " has no /dev/serial/by-id link; its name may change after a replug\n";
        }
    }
    return entries.empty() ? 1 : 0;
}

}  // namespace gw
