#pragma once
// The "ports" subcommand of asi-gateway: finds serial ports with an MS-2000 behind them.
//
//   asi-gateway ports [--path P ...] [--only-paths] [--baud N ...] [--timeout-ms MS] [--json]
//
// Lists /dev/serial/by-id/*, then ttyUSB*/ttyACM*/ttyS* (devices/serial/port_candidates.hpp) and the
// --path ports, probes them all at once with V and BU X (devices/serial/port_probe.hpp; never a
// motion command, a port another program holds is reported busy and left alone), prints one line
// per port (or the scan's JSON with --json, gateway/controllers/port_report_json.hpp) and a "controllers"
// entry to paste into the config file. Exit status: 0 at least one MS-2000 found, 1 none, 2 a bad option.
//
//   gw::ports_cli ports(app);          // before CLI11_PARSE
//   CLI11_PARSE(app, argc, argv);
//   if (ports.selected()) return ports.run(std::cout, std::cerr);

#include <ostream>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace gw {

class ports_cli {
  public:
    explicit ports_cli(CLI::App& app);

    bool selected() const;
    int run(std::ostream& out, std::ostream& err) const;

  private:
    CLI::App* ports_ = nullptr;
    std::vector<std::string> paths_;
    std::vector<unsigned> bauds_;
    bool only_paths_ = false;
    bool json_ = false;
    int timeout_ms_ = 200;
};

}  // namespace gw
