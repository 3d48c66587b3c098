#pragma once
// One planned move of a G-code program, in machine millimetres after unit conversion and scaling.
// Arcs are kept whole (centre, plane, direction); segment_end() gives the straight segments they are
// executed as, computed on demand so that no move ever holds a list of points.

#include <cstdint>

#include "gateway/gcode/gcode_arc.hpp"
#include "gateway/gcode/gcode_geometry.hpp"

namespace gw::gcode {

enum class move_kind : std::uint8_t {
    rapid,   // G00: straight line at the rapid speed
    linear,  // G01: straight line at the feed
    arc,     // G02/G03, helical included
    dwell,   // G04 P (ms)
    ttl,     // M03 (on) / M05 (off): the TTL output, before the motion of the same block
    analog,  // z_mode analog: Z sets the analog output (WRDAC), before the motion of the same block
};

const char* to_string(move_kind kind);
const char* to_string(arc_plane plane);          // "XY", "ZX", "YZ"
const char* to_string(arc_direction direction);  // "cw", "ccw"

struct planned_move {
    int line = 0;  // 1-based line of the program file
    move_kind kind = move_kind::linear;
    vec3 start;  // where the stage is before the move (== end for dwell, ttl, analog)
    vec3 end;
    double feed_mm_s = 0;        // rapid, linear: vector speed; arc: tangential speed in the arc's plane
    arc_geometry arc;            // kind == arc
    std::uint64_t segments = 0;  // straight segments: 1 (rapid, linear), n (arc), 0 (others)
    double dwell_ms = 0;         // kind == dwell
    bool ttl_on = false;         // kind == ttl
    double analog_v = 0;         // kind == analog: volts for WRDAC
    double estimated_s = 0;      // filled in by the planner
};

// The end of straight segment `i` (1..segments) of a rapid, linear or arc move; segment i runs from
// segment_end(i - 1) (segment_end(0) == start) to segment_end(i); segment_end(segments) == end.
vec3 segment_end(const planned_move& move, std::uint64_t i);

}  // namespace gw::gcode
