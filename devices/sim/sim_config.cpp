#include "devices/sim/sim_config.hpp"

#include <algorithm>
#include <array>
#include <cctype>

#include <boost/system/errc.hpp>

namespace gw::devices::sim {

namespace {

using ms2000::module;

// Calibration (unit test sim_calibration_test.cpp proves it): move time = trapezoid(distance,
// default speed, 20 ms ramp) + settle. A straight-line fit of the table's 9 mm and 0.2 mm times gives
// the effective speed and the fixed overhead; QUDI quotes 5.745920 mm/s as a real default for
// B-type screws, close to the fitted 5.5.
constexpr std::array<lead_screw, 4> table{{
    {'A', 1.58, 1.7, 5.5, 181590.4, 1.361, 68},
    {'B', 6.35, 6.8, 22, 45397.6, 5.5, 14},
    {'C', 12.7, 13.5, 44, 22698.8, 11.41, 12},
    {'D', 25.4, 26, 88, 11349.4, 20.0, 10},
}};

boost::system::error_code invalid() {
    return boost::system::errc::make_error_code(boost::system::errc::invalid_argument);
}

}  // namespace

boost::system::result<lead_screw> lead_screw_for(char id) {
    const char upper = static_cast<char>(std::toupper(static_cast<unsigned char>(id)));
    for (const auto& row : table)
        if (row.id == upper) return row;
    return invalid();
}

boost::system::result<sim_config> preset(std::string_view name) {
    sim_config c;
    c.name = std::string(name);
    if (name == "full") {
        c.build_name = "STD_XYZ_SCAN";
        c.modules = {module::array,       module::ring_buffer,  module::scan,
                     module::ttl_report,  module::serial_out,   module::binary_output,
                     module::ll_commands, module::search_index, module::in0_int};
        c.report_port = true;
        return c;
    }
    if (name == "plain") {
        c.build_name = "STD_XYZ";
        return c;
    }
    if (name == "planar") {
        c.build_name = "STD_XYZ_PC";
        c.modules = {module::planar_correction, module::dac_out, module::led_dimmer, module::ring_buffer,
                     module::array};
        return c;
    }
    if (name == "crisp") {
        c.build_name = "STD_XYZ_CRISP";
        c.modules = {module::crisp, module::autofocus, module::ring_buffer, module::led_dimmer};
        c.version = "9.53";  // reads the signal-to-noise ratio with "EX Y?" (doc §3.12)
        c.focus_plane_um = 150;
        return c;
    }
    if (name == "xy") {
        c.build_name = "STD_XY";
        c.motor_axes = "XY";
        c.modules = {module::ring_buffer, module::array};
        return c;
    }
    return invalid();
}

std::vector<std::string_view> preset_names() {
    return {"full", "plain", "planar", "crisp", "xy"};
}

std::string effective_link_path(const sim_config& config) {
    if (!config.link_path.empty()) return config.link_path;
    return "/tmp/ms2000-sim/" + config.name + "/port";
}

std::string effective_report_link_path(const sim_config& config) {
    if (!config.report_port) return {};
    if (!config.report_link_path.empty()) return config.report_link_path;
    return "/tmp/ms2000-sim/" + config.name + "/report";
}

bool has_module(const sim_config& config, ms2000::module m) {
    return std::find(config.modules.begin(), config.modules.end(), m) != config.modules.end();
}

ms2000::build_info make_build_info(const sim_config& config) {
    ms2000::build_info info;
    info.name = config.build_name;
    info.motor_axes = config.motor_axes;
    info.command_axes = "XYZFTR";
    info.bootloader = "1";
    info.hardware_revision = "E";
    for (const auto m : config.modules) {
        info.modules.set(static_cast<std::size_t>(m));
        info.module_lines.emplace_back(ms2000::module_line(m));
        if (m == module::ring_buffer) info.ring_buffer_size = 50;
    }
    return info;
}

}  // namespace gw::devices::sim
