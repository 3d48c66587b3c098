#pragma once
// Options of the G-code translator (the Tracer Console's settings plus the decisions of
// gateway/gcode/README.md). Plain values; validate() before use.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "devices/ms2000/host_step_timing.hpp"

namespace gw::gcode {

// How a coordinate written without a decimal point is read ("X1000").
enum class decimal_point_reading : std::uint8_t {
    calculator,       // X1000 = 1000 mm (or inch): LinuxCNC, grbl, CAM software. The default.
    least_increment,  // FANUC standard notation, IS-B: X1000 = 1.000 mm (0.1000 inch)
};

// What the Z word drives.
enum class z_mode : std::uint8_t {
    axis,    // the Z axis moves
    analog,  // Z sets the analog output (WRDAC) through the vendor's voltage mapping; the stage Z stays
};

// Z outside the analog limits.
enum class analog_range_policy : std::uint8_t { clamp, error };

struct gcode_options {
    double xyz_scale = 1.0;           // multiplies X, Y, Z, I, J, K, R and the polar radius
    double speed_scale = 1.0;         // multiplies F (not the rapid speed, not dwell times)
    double arc_tolerance_mm = 0.001;  // maximum chord error of arc segments (sagitta)
    double max_feed_mm_s = 6.8;       // feeds above this are clamped (with a warning)
    double rapid_mm_s = 5.5;          // G00 speed: the stage's default SPEED
    decimal_point_reading decimal_point = decimal_point_reading::calculator;

    // I/J/K arcs: the radius to the end may differ from the radius to the start by
    // max(arc_radius_tolerance_mm, arc_radius_relative_tolerance * radius); beyond: an error.
    double arc_radius_tolerance_mm = 0.001;
    double arc_radius_relative_tolerance = 1e-4;
    // R arcs: |R| may fall short of half the chord by this much (the arc becomes a half circle).
    double arc_r_deficit_tolerance_mm = 0.0001;

    z_mode z = z_mode::axis;
    // Analog Z: custom limits (SETLOW/SETUP, micrometres). Unset: the standard piezo range -50..+50 um
    // with V = 0.1 * Z + 5. Set: V = 10 * (high - Z) / (high - low), the vendor's reversed slope.
    std::optional<double> analog_low_um;
    std::optional<double> analog_high_um;
    analog_range_policy analog_range = analog_range_policy::clamp;

    // The per-move time model (gw::jobs::motion_model defaults): trapezoid with this ramp, then settle.
    double ramp_ms = 20;
    double settle_ms = 14;
    // The host's cost per segment (devices/ms2000/host_step_timing): each straight segment is one MOVE
    // (after a SPEED when the speeds change) and the host polls STATUS until it has ended. Without a
    // controller (`gcode plan`) the defaults: 115200 baud, STATUS every 20 ms.
    devices::ms2000::host_link_timing host;

    std::size_t max_line_chars = 4096;  // longer lines are an error, never truncated
};

// Nullopt when usable; otherwise what is wrong ("xyz_scale must be > 0").
std::optional<std::string> validate(const gcode_options& options);

// Sets one option from text, as a command line or query string gives it:
//   xyz_scale, speed_scale, arc_tolerance_mm, max_feed_mm_s, rapid_mm_s, decimal_point
//   (calculator|least_increment), arc_radius_tolerance_mm, arc_radius_relative_tolerance,
//   arc_r_deficit_tolerance_mm, z_mode (axis|analog), analog_low_um, analog_high_um,
//   analog_range (clamp|error), ramp_ms, settle_ms, baud, arrival_poll_ms.
// Nullopt on success, otherwise the reason. Call validate() after the last one.
std::optional<std::string> set_option(gcode_options& options, const std::string& name,
                                      const std::string& value);

}  // namespace gw::gcode
