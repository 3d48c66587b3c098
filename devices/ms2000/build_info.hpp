#pragma once
// Parses the BUILD X reply into a capability set. Pure: no I/O.
//   "STD_XYZ_SEQ\rMotor Axes: X Y Z\rCMDs: XYZFTR\rBootLdr V:1\rHdwr REV.E\rLL COMMANDS\r
//    RING BUFFER\rSEARCH INDEX\rARRAY MODULE\rINO_INT\rDAC OUT\rSEQUENCER\rPLANAR CORRECTION"
// (lines separated by CR; the framer removed the final CR LF). Module lines are recognised by name;
// every line that is not a known key is still kept in module_lines.

#include <bitset>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <boost/system/result.hpp>

namespace gw::devices::ms2000 {

enum class module : std::uint8_t {
    array,              // "ARRAY MODULE"
    ring_buffer,        // "RING BUFFER" (optionally followed by its size)
    scan,               // "SCAN MODULE"
    ttl_report,         // "TTL_REPORT_INT", "TTL REPORT", "TTL_REPORT"
    serial_out,         // "SERIAL OUT" (second port for TTL reports)
    binary_output,      // "BINARY_OUTPUT"
    planar_correction,  // "PLANAR CORRECTION"
    dac_out,            // "DAC OUT", "DAC_OUT"
    led_dimmer,         // "LED DIMMER", "DLED"
    autofocus,          // "AUTOFOCUS", "AFOCUS"
    crisp,              // "CRISP"
    sequencer,          // "SEQUENCER"
    tracer,             // "TRACER" line, or a build name ending in "_TRACER"
    multiaxis_moves,    // "MULTIAXIS MOVES"
    search_index,       // "SEARCH INDEX"
    in0_int,            // "IN0_INT", "INO_INT"
    enc_int,            // "ENC_INT", "ENC_INT_2"
    ll_commands,        // "LL COMMANDS"
    count_
};

// Stable lower-case id used above the devices layer ("ring_buffer").
std::string_view module_id(module m);
// The line the firmware prints for it ("RING BUFFER").
std::string_view module_line(module m);
std::optional<module> module_from_id(std::string_view id);

struct build_info {
    std::string name;                       // "STD_XYZ"
    std::string motor_axes;                 // "XYZ", hardware order (WHERE answers in this order)
    std::string command_axes;               // "XYZFTR"
    std::string bootloader;                 // "1" from "BootLdr V:1"
    std::string hardware_revision;          // "E" from "Hdwr REV.E"
    std::vector<std::string> module_lines;  // every other line, as printed
    std::bitset<static_cast<std::size_t>(module::count_)> modules;
    int ring_buffer_size = 0;  // "RING BUFFER 250" -> 250; plain "RING BUFFER" -> 50; 0 if absent

    bool has(module m) const { return modules.test(static_cast<std::size_t>(m)); }
    bool operator==(const build_info&) const = default;
};

// error::unrecognized_reply when the text has no build name line.
boost::system::result<build_info> parse_build_x(std::string_view text);

// The reverse, used by the simulator so that both sides agree on the layout.
std::string format_build_x(const build_info& info);

}  // namespace gw::devices::ms2000
