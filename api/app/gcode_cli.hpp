#pragma once
// The "gcode" subcommands of asi-gateway: planning without any controller, job store or serial port.
//
//   asi-gateway gcode plan FILE [--set NAME=VALUE ...] [--summary]   the plan JSON on stdout
//   asi-gateway gcode preview FILE [--set NAME=VALUE ...]            the preview SVG on stdout
//
// FILE "-" reads stdin (spooled to a temporary file: the program is read twice, so an erroneous one
// prints only its error). --set takes the option names of gateway/gcode/gcode_options.hpp (set_option)
// and, for preview, view / width_px / max_points. Exit status: 0 done; 2 a program error (the error
// JSON {"error":{"line":N,"column":C,"message":...}} on stdout, or for preview on stderr), a bad
// option or an unreadable file (a message on stderr); 1 stdout could not be written.
//
//   gw::gcode_cli gcode(app);          // before CLI11_PARSE
//   CLI11_PARSE(app, argc, argv);
//   if (gcode.selected()) return gcode.run(std::cout, std::cerr);

#include <ostream>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace gw {

class gcode_cli {
  public:
    explicit gcode_cli(CLI::App& app);

    bool selected() const;
    int run(std::ostream& out, std::ostream& err) const;

  private:
    int run_plan(std::ostream& out, std::ostream& err) const;
    int run_preview(std::ostream& out, std::ostream& err) const;

    CLI::App* gcode_ = nullptr;
    CLI::App* plan_ = nullptr;
    CLI::App* preview_ = nullptr;
    std::string file_;
    std::vector<std::string> settings_;
    bool summary_ = false;
};

}  // namespace gw
