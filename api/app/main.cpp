// asi-gateway: puts MS-2000 stage controllers behind one service.
// Reads the command line (a JSON config file or the embedded default of four simulated controllers,
// flags on top), sets up logging, and runs the application until SIGINT/SIGTERM.

#include <cstdlib>
#include <iostream>
#include <variant>

#include <spdlog/spdlog.h>

#include "api/app/application.hpp"
#include "api/app/command_line.hpp"
#include "gateway/config/logging.hpp"

int main(int argc, char** argv) {
    auto parsed = gw::parse_command_line(argc, argv, std::cout, std::cerr);
    if (const auto* exit_code = std::get_if<int>(&parsed)) return *exit_code;
    auto& launch = std::get<gw::launch_settings>(parsed);
    gw::setup_logging(launch.config.logging);
    int exit_code = EXIT_FAILURE;
    {
        gw::application app(std::move(launch));
        exit_code = app.run();
    }
    spdlog::shutdown();
    return exit_code;
}
