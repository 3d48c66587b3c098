#pragma once
// Arc geometry of G02/G03: the centre from I/J/K or from R, the swept angle, the straight segments
// within a chord error, and points along the arc. Pure math, no program state.
//
// Sweep: negative = clockwise (G02), positive = counter-clockwise (G03), |sweep| <= 2 pi. An I/J/K
// arc whose end equals its start in the plane (within same_point_mm) is a full circle. When the end
// radius differs from the start radius (within tolerance) the radius varies linearly with the angle,
// so the path still ends exactly at the programmed end point (a spiral, as LinuxCNC does).

#include <cstdint>
#include <string>
#include <variant>

#include "gateway/gcode/gcode_geometry.hpp"

namespace gw::gcode {

// Two points closer than this (in the plane) are the same point: full circles, zero-length moves.
inline constexpr double same_point_mm = 1e-6;
// Arcs with a smaller radius are an error ("zero-radius arc"): ~ half the encoder step of a stage.
inline constexpr double min_arc_radius_mm = 1e-5;
// More segments than this for one arc is an error (a absurd radius or tolerance).
inline constexpr std::uint64_t max_arc_segments = 10'000'000;

struct arc_geometry {
    vec3 start;
    vec3 end;
    vec3 center;  // the normal-axis coordinate is the start's
    arc_plane plane = arc_plane::xy;
    arc_direction direction = arc_direction::cw;
    double start_angle = 0;  // rad, in the plane's (a, b) frame
    double sweep = 0;        // rad, signed
    double start_radius = 0;
    double end_radius = 0;
};

struct arc_tolerances {
    double radius_mm = 0.001;       // allowed |end radius - start radius| ...
    double radius_relative = 1e-4;  // ... or this fraction of the radius, whichever is larger
    double r_deficit_mm = 0.0001;   // R form: |R| may be this much shorter than half the chord
};

// I/J/K form: `center_offset` = centre - start, in plane order (a, b). An error text on failure.
std::variant<arc_geometry, std::string> arc_from_center(const vec3& start, const vec3& end, double offset_a,
                                                        double offset_b, arc_plane plane,
                                                        arc_direction direction,
                                                        const arc_tolerances& tolerances);

// R form: r > 0 is the arc of at most 180 degrees, r < 0 the one of more than 180 degrees. The
// caller handles end == start (FANUC: a 0-degree arc, no motion); here that is an error.
std::variant<arc_geometry, std::string> arc_from_radius(const vec3& start, const vec3& end, double r,
                                                        arc_plane plane, arc_direction direction,
                                                        const arc_tolerances& tolerances);

// Straight segments so that no chord is farther than `chord_tolerance_mm` from the arc (the sagitta
// at the larger radius), at most 90 degrees each; 0 when more than max_arc_segments would be needed.
std::uint64_t arc_segment_count(const arc_geometry& arc, double chord_tolerance_mm);

// The point at `fraction` of the sweep (0 = start; 1 = exactly the programmed end).
vec3 arc_point(const arc_geometry& arc, double fraction);

// Length of the path in the plane (the arc or spiral; the helical axis excluded).
double arc_plane_length(const arc_geometry& arc);

}  // namespace gw::gcode
