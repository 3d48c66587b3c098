#pragma once
// How a `gcode` job drives an MS-2000 along a planned path: every straight segment is one "M" move
// whose axes all arrive together, because each axis's SPEED is set in proportion to its share of the
// segment (speed_i = feed * |d_i| / |d|). The controller's trapezoid (devices/ms2000/motion_profile)
// then keeps every axis on the straight line: with equal ACCEL, a long move takes |d_i|/v_i + ramp
// and a short (triangle) move 2 * sqrt(|d_i| * ramp / v_i) on every axis, both the same for all of
// them. Pure: wire text in, wire text out; the job's run() sends it.
//
// Limits (per axis):
//  * above the axis's top speed: the whole segment slows down by the same factor (the path stays
//    straight, the feed is lower: `slowdown` < 1);
//  * below the firmware's smallest SPEED (the simulator's, like the controller's documented clamp:
//    1e-4 of the top speed): the axis is raised to it and arrives early; the path then bends by at
//    most that axis's travel in the segment (`early_mm`, a bound reported to the user). A component
//    within 1 nm of the last commanded target is not commanded at all.
//  * SPEED has six decimals (":A X=5.745920"); speeds are rounded to them.
// A SPEED command is sent only when a moving axis needs a speed other than the one it has.

#include <map>
#include <optional>
#include <string>

#include "devices/ms2000/command.hpp"
#include "gateway/gcode/gcode_geometry.hpp"

namespace gw::jobs {

struct axis_speed_range {
    double min_mm_s = 0.00068;
    double max_mm_s = 6.8;
};

// The firmware's smallest SPEED as a fraction of the axis's top speed.
inline constexpr double min_speed_fraction = 1e-4;
// Components at most this far from the last commanded target are not commanded.
inline constexpr double same_target_mm = 1e-6;

struct segment_speeds {
    std::map<char, double> mm_s;  // the moving axes' speeds (rounded to six decimals)
    double slowdown = 1;          // 1, or the factor the feed was lowered by (an axis at its top speed)
    double early_mm = 0;          // bound of the bend from axes raised to their smallest speed
};

// Per-axis speeds for a segment `delta_mm` (moving axes only) at `feed_mm_s` along a reference length
// `reference_mm` (the 3-D length for straight moves; the in-plane length for a helical arc segment,
// FANUC's helical feed). Axes missing from `ranges` are not limited.
segment_speeds coordinated_speeds(const std::map<char, double>& delta_mm, double reference_mm,
                                  double feed_mm_s, const std::map<char, axis_speed_range>& ranges);

// The commands of one segment.
struct segment_commands {
    // "SPEED X=1.2 Y=0.5", or none when every moving axis already has its speed.
    std::optional<devices::ms2000::command> speed;
    std::optional<devices::ms2000::command> move;  // "M X=10000 Y=5000", or none when nothing moves
    std::map<char, double> target_mm;
    segment_speeds speeds;
};

// Turns a path into commands, remembering the last commanded target and SPEED of each axis. One per
// run of a job; not thread-safe.
class trace_commander {
  public:
    // `axes`: the stage axes the program drives ("XY", or "XYZ" when Z is an axis), with their limits;
    // `speeds_now`: their SPEED as it is now (unknown axes get a SPEED with their first move).
    trace_commander(std::map<char, axis_speed_range> axes, std::map<char, double> speeds_now);

    // Axes are commanded only once the program drives them (a coordinate other than the start's
    // zero): an axis the program leaves alone stays wherever it is.
    void drive(char axis) { driven_[axis] = true; }
    bool driven(char axis) const { return driven_.contains(axis); }
    const std::map<char, axis_speed_range>& axes() const { return axes_; }

    // Where the stage is now (at the start, after an approach move).
    void set_position(char axis, double mm);
    std::optional<double> position(char axis) const;

    // The segment from the last commanded target to `to`, at `feed_mm_s`; `plane` for arc segments.
    segment_commands segment(const gcode::vec3& to, double feed_mm_s, std::optional<gcode::arc_plane> plane);

  private:
    std::map<char, axis_speed_range> axes_;
    std::map<char, double> speeds_;
    std::map<char, double> position_;
    std::map<char, bool> driven_;
};

// "SPEED X=5.5 Y=5.5" for the given speeds; "WRDAC X=2.5" (the TTL output: job_commands' ttl_output).
devices::ms2000::command speed_command(const std::map<char, double>& mm_s);
devices::ms2000::command analog_command(double volts);

}  // namespace gw::jobs
