#include "gateway/gcode/gcode_move.hpp"

namespace gw::gcode {

const char* to_string(move_kind kind) {
    switch (kind) {
        case move_kind::rapid:
            return "rapid";
        case move_kind::linear:
            return "linear";
        case move_kind::arc:
            return "arc";
        case move_kind::dwell:
            return "dwell";
        case move_kind::ttl:
            return "ttl";
        case move_kind::analog:
            return "analog";
    }
    return "?";
}

const char* to_string(arc_plane plane) {
    switch (plane) {
        case arc_plane::xy:
            return "XY";
        case arc_plane::zx:
            return "ZX";
        case arc_plane::yz:
            return "YZ";
    }
    return "?";
}

const char* to_string(arc_direction direction) {
    return direction == arc_direction::cw ? "cw" : "ccw";
}

vec3 segment_end(const planned_move& move, std::uint64_t i) {
    if (i == 0) return move.start;
    if (i >= move.segments) return move.end;
    if (move.kind != move_kind::arc) return move.end;
    return arc_point(move.arc, static_cast<double>(i) / static_cast<double>(move.segments));
}

}  // namespace gw::gcode
