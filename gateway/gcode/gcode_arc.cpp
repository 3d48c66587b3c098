#include "gateway/gcode/gcode_arc.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

namespace gw::gcode {

namespace {

constexpr double two_pi = 2 * std::numbers::pi;

std::string mm(double v) {
    char buf[48];
    std::snprintf(buf, sizeof buf, "%.6f mm", v);
    return buf;
}

// The sweep from the start angle to the end angle in `direction`; `full` forces a whole turn.
double sweep_between(double start_angle, double end_angle, arc_direction direction, bool full) {
    if (full) return direction == arc_direction::cw ? -two_pi : two_pi;
    double s = end_angle - start_angle;
    if (direction == arc_direction::cw) {
        while (s >= 0)
            s -= two_pi;
        while (s < -two_pi)
            s += two_pi;
    } else {
        while (s <= 0)
            s += two_pi;
        while (s > two_pi)
            s -= two_pi;
    }
    return s;
}

arc_geometry make(const vec3& start, const vec3& end, double ca, double cb, arc_plane plane,
                  arc_direction direction, bool full) {
    const plane_point s = to_plane(start, plane);
    const plane_point e = to_plane(end, plane);
    arc_geometry g;
    g.start = start;
    g.end = end;
    g.center = from_plane({ca, cb, s.n}, plane);
    g.plane = plane;
    g.direction = direction;
    g.start_radius = std::hypot(s.a - ca, s.b - cb);
    g.end_radius = std::hypot(e.a - ca, e.b - cb);
    g.start_angle = std::atan2(s.b - cb, s.a - ca);
    const double end_angle = std::atan2(e.b - cb, e.a - ca);
    g.sweep = sweep_between(g.start_angle, end_angle, direction, full);
    return g;
}

}  // namespace

std::variant<arc_geometry, std::string> arc_from_center(const vec3& start, const vec3& end, double offset_a,
                                                        double offset_b, arc_plane plane,
                                                        arc_direction direction, const arc_tolerances& tol) {
    const plane_point s = to_plane(start, plane);
    const plane_point e = to_plane(end, plane);
    const double ca = s.a + offset_a;
    const double cb = s.b + offset_b;
    const double r1 = std::hypot(s.a - ca, s.b - cb);
    const double r2 = std::hypot(e.a - ca, e.b - cb);
    if (!std::isfinite(r1) || !std::isfinite(r2)) return std::string("arc coordinates out of range");
    if (r1 < min_arc_radius_mm)
        return "zero-radius arc: the centre is the start point (radius " + mm(r1) + ")";
    if (r2 < min_arc_radius_mm) return "zero-radius arc: the centre is the end point (radius " + mm(r2) + ")";
    const double diff = std::abs(r1 - r2);
    const double allowed = std::max(tol.radius_mm, tol.radius_relative * std::max(r1, r2));
    if (diff > allowed) {
        return "radius to the end differs from the radius to the start by " + mm(diff) + " (allowed " +
               mm(allowed) + "): start radius " + mm(r1) + ", end radius " + mm(r2);
    }
    const bool full = std::hypot(e.a - s.a, e.b - s.b) <= same_point_mm;
    return make(start, end, ca, cb, plane, direction, full);
}

std::variant<arc_geometry, std::string> arc_from_radius(const vec3& start, const vec3& end, double r,
                                                        arc_plane plane, arc_direction direction,
                                                        const arc_tolerances& tol) {
    const plane_point s = to_plane(start, plane);
    const plane_point e = to_plane(end, plane);
    const double da = e.a - s.a;
    const double db = e.b - s.b;
    const double chord = std::hypot(da, db);
    if (!std::isfinite(chord) || !std::isfinite(r)) return std::string("arc coordinates out of range");
    if (chord <= same_point_mm) return std::string("R arc with the end point equal to the start point");
    const double radius = std::abs(r);
    if (radius < min_arc_radius_mm) return "arc radius R is zero (" + mm(radius) + ")";
    const double half = chord / 2;
    if (radius < half - tol.r_deficit_mm) {
        return "arc radius R " + mm(radius) + " is too small to reach the end point (half the chord is " +
               mm(half) + ")";
    }
    const double q = radius > half ? std::sqrt((radius - half) * (radius + half)) : 0.0;
    // Left of the chord (seen from + normal) is (-db, da) / chord. G02 with R > 0 (the short arc,
    // clockwise) has its centre on the right; G03 on the left; a negative R picks the other side.
    double side = direction == arc_direction::cw ? -1.0 : 1.0;
    if (r < 0) side = -side;
    const double ca = s.a + da / 2 + side * q * (-db / chord);
    const double cb = s.b + db / 2 + side * q * (da / chord);
    return make(start, end, ca, cb, plane, direction, false);
}

std::uint64_t arc_segment_count(const arc_geometry& arc, double chord_tolerance_mm) {
    const double r = std::max(arc.start_radius, arc.end_radius);
    double step = std::numbers::pi / 2;
    if (r > 0 && chord_tolerance_mm < 2 * r) {
        // sagitta = r (1 - cos(step / 2)) = 2 r sin^2(step / 4) = tolerance
        step = std::min(step, 4 * std::asin(std::sqrt(chord_tolerance_mm / (2 * r))));
    }
    if (!(step > 0)) return 0;
    const double count = std::ceil(std::abs(arc.sweep) / step * (1 - 1e-12));
    if (!std::isfinite(count) || count > static_cast<double>(max_arc_segments)) return 0;
    return std::max<std::uint64_t>(1, static_cast<std::uint64_t>(count));
}

vec3 arc_point(const arc_geometry& arc, double fraction) {
    if (fraction >= 1) return arc.end;
    if (fraction <= 0) return arc.start;
    const plane_point s = to_plane(arc.start, arc.plane);
    const plane_point e = to_plane(arc.end, arc.plane);
    const plane_point c = to_plane(arc.center, arc.plane);
    const double angle = arc.start_angle + arc.sweep * fraction;
    const double radius = arc.start_radius + (arc.end_radius - arc.start_radius) * fraction;
    return from_plane(
        {c.a + radius * std::cos(angle), c.b + radius * std::sin(angle), s.n + (e.n - s.n) * fraction},
        arc.plane);
}

double arc_plane_length(const arc_geometry& arc) {
    return std::abs(arc.sweep) * (arc.start_radius + arc.end_radius) / 2;
}

}  // namespace gw::gcode
