#pragma once
// Points and arc planes. Machine coordinates in millimetres. Each plane is seen in its FANUC axis
// order (first, second, normal), right-handed, so "clockwise" is the same rule in every plane
// (seen from the + end of the normal axis):
//   G17 XY: (X, Y, Z)    G18 ZX: (Z, X, Y)    G19 YZ: (Y, Z, X)
// Computing G18 in (X, Z) order reverses its arcs: the classic bug of several interpreters.

#include <cmath>
#include <cstdint>

namespace gw::gcode {

struct vec3 {
    double x = 0;
    double y = 0;
    double z = 0;

    bool operator==(const vec3&) const = default;
};

enum class arc_plane : std::uint8_t { xy, zx, yz };
enum class arc_direction : std::uint8_t { cw, ccw };

// A point in plane order: a = first axis, b = second axis, n = normal axis.
struct plane_point {
    double a = 0;
    double b = 0;
    double n = 0;
};

inline plane_point to_plane(const vec3& p, arc_plane plane) {
    switch (plane) {
        case arc_plane::zx:
            return {p.z, p.x, p.y};
        case arc_plane::yz:
            return {p.y, p.z, p.x};
        case arc_plane::xy:
            break;
    }
    return {p.x, p.y, p.z};
}

inline vec3 from_plane(const plane_point& q, arc_plane plane) {
    switch (plane) {
        case arc_plane::zx:
            return {q.b, q.n, q.a};
        case arc_plane::yz:
            return {q.n, q.a, q.b};
        case arc_plane::xy:
            break;
    }
    return {q.a, q.b, q.n};
}

inline double distance(const vec3& p, const vec3& q) {
    return std::hypot(p.x - q.x, p.y - q.y, p.z - q.z);
}

}  // namespace gw::gcode
