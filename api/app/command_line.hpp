#pragma once
// The command line of asi-gateway: the flags over the config file (or the embedded default), and the
// subcommands that run instead of the service (gcode, ports, --check-config, --help, --version).
//
//   auto parsed = gw::parse_command_line(argc, argv, std::cout, std::cerr);
//   if (auto* code = std::get_if<int>(&parsed)) return *code;  // a subcommand ran, or a usage error
//   auto& launch = std::get<gw::launch_settings>(parsed);

#include <iosfwd>
#include <variant>

#include "gateway/config/config.hpp"
#include "gateway/controllers/controller_registry.hpp"

namespace gw {

// What the service runs with: the resolved config and the registry options made from it.
struct launch_settings {
    gateway_config config;
    registry_options registry;
};

// Either the settings to run the service with, or the exit code of what ran instead: 0 for --help and
// --version, a subcommand's own code (gcode, ports, --check-config), 2 for a usage or config error
// (printed on `err`).
std::variant<launch_settings, int> parse_command_line(int argc, const char* const* argv, std::ostream& out,
                                                      std::ostream& err);

}  // namespace gw
