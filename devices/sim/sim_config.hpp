#pragma once
// Configuration of one simulated MS-2000 controller: what its firmware build contains, how its stage
// moves, and how it is exposed (pseudo-terminal links, baud, time scale). Plain values, no I/O.

#include <chrono>
#include <string>
#include <string_view>
#include <vector>

#include <boost/system/result.hpp>

#include "devices/ms2000/build_info.hpp"
#include "devices/ms2000/report_frame.hpp"

namespace gw::devices::sim {

// One row of the "Stage Scanning Speed and Accuracy" table (seed 000), plus the two values we
// calibrated so that move times match the table (see DESIGN note in axis_motion.hpp).
struct lead_screw {
    char id = 'B';                    // 'A'..'D'
    double pitch_mm = 6.35;           // "B - 6.35mm"
    double max_speed_mm_s = 6.8;      // SPEED is clamped to this
    double encoder_nm = 22;           // rotary encoder resolution
    double counts_per_mm = 45397.6;   // CNTS X? (4 TPI rotary: 45396..45398 in the ASI texts)
    double default_speed_mm_s = 5.5;  // calibrated: 9 mm and 0.2 mm move times of the table
    double settle_ms = 14;            // calibrated: time to hunt into the finish error window
};

// 'A'..'D' (case-insensitive); error for anything else.
boost::system::result<lead_screw> lead_screw_for(char id);

// What the controller answers to an empty line (CR alone, e.g. the doubled CR of NAV): doc §1 [U].
enum class empty_line_reply { ignore, unknown_command };

struct sim_config {
    std::string name = "ms2000";          // used for default link paths and in logs
    std::string build_name = "STD_XYZ";   // first line of BU X
    std::string motor_axes = "XYZ";       // hardware order; WHERE answers in this order
    std::vector<ms2000::module> modules;  // firmware modules; commands of absent ones -> ":N-1"
    char lead_screw = 'B';                // 'A'..'D'
    // The stage's physical travel ends in limit switches at +-this, beyond the default soft limits
    // (SU/SL, +-110 mm): any motion stops there, as at a soft limit. Matters when SU/SL are set wider.
    double limit_switch_mm = 125;
    // Where the sample is in focus: the Z position CRISP locks near and AUTOFOCUS finds.
    double focus_plane_um = 0;
    std::string version = "9.50";  // V -> ":A Version: USB-9.50 "
    unsigned baud = 115200;        // output pacing, 10 bits per byte
    double time_scale = 1.0;       // 1 = real time, 10 = ten times faster
    bool report_port = false;      // a second pty for SERIAL OUT (TTL_REPORT frames)
    ms2000::report_format report_format = ms2000::report_format::binary;
    std::string link_path;         // stable symlink to the pty; empty -> /tmp/ms2000-sim/<name>/port
    std::string report_link_path;  // empty -> /tmp/ms2000-sim/<name>/report
    empty_line_reply empty_line = empty_line_reply::ignore;
    bool ack_trailing_space = false;   // ":A \r\n" instead of ":A\r\n" for plain acknowledgements
    bool value_trailing_space = true;  // ":A 1.0 2.0 \r\n" (doc §2.1: safe for every client)
    int where_decimals = 1;            // "W X" -> ":A 1234.5"
    std::chrono::milliseconds flash_write_time{300};  // SS Z: ":" at once, "A\r\n" after this
};

// Presets by name: "full", "plain", "planar", "crisp", "xy". Error for an unknown name.
boost::system::result<sim_config> preset(std::string_view name);
std::vector<std::string_view> preset_names();

// Default link paths when the config leaves them empty.
std::string effective_link_path(const sim_config& config);
std::string effective_report_link_path(const sim_config& config);

// The capability set the simulated firmware reports in BU X.
ms2000::build_info make_build_info(const sim_config& config);

bool has_module(const sim_config& config, ms2000::module m);

}  // namespace gw::devices::sim
