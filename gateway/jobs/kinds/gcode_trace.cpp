#include "gateway/jobs/kinds/gcode_trace.hpp"

#include <algorithm>
#include <cmath>
#include <span>
#include <stdexcept>
#include <vector>

#include "devices/ms2000/command.hpp"
#include "gateway/jobs/job_commands.hpp"

namespace gw::jobs {

namespace {

namespace ms = devices::ms2000;

constexpr int speed_decimals = 6;

double round_speed(double v) {
    return std::round(v * 1e6) / 1e6;
}

double coordinate(const gcode::vec3& p, char axis) {
    switch (axis) {
        case 'X':
            return p.x;
        case 'Y':
            return p.y;
        case 'Z':
            return p.z;
        default:
            return 0;
    }
}

// The axes of the arc's plane.
bool in_plane(char axis, gcode::arc_plane plane) {
    switch (plane) {
        case gcode::arc_plane::xy:
            return axis == 'X' || axis == 'Y';
        case gcode::arc_plane::zx:
            return axis == 'Z' || axis == 'X';
        case gcode::arc_plane::yz:
            return axis == 'Y' || axis == 'Z';
    }
    return true;
}

}  // namespace

segment_speeds coordinated_speeds(const std::map<char, double>& delta_mm, double reference_mm,
                                  double feed_mm_s, const std::map<char, axis_speed_range>& ranges) {
    segment_speeds out;
    if (delta_mm.empty() || reference_mm <= 0 || feed_mm_s <= 0) return out;
    std::map<char, double> ideal;
    for (const auto& [axis, d] : delta_mm)
        ideal[axis] = feed_mm_s * std::abs(d) / reference_mm;
    // An axis above its top speed slows the whole segment down by the same factor.
    for (const auto& [axis, v] : ideal)
        if (auto r = ranges.find(axis); r != ranges.end() && v > r->second.max_mm_s)
            out.slowdown = std::min(out.slowdown, r->second.max_mm_s / v);
    for (const auto& [axis, v0] : ideal) {
        double v = v0 * out.slowdown;
        const auto r = ranges.find(axis);
        const double lo = r != ranges.end() ? r->second.min_mm_s : 1e-6;
        const double hi = r != ranges.end() ? r->second.max_mm_s : v;
        if (v < lo) {
            // Arrives early: at most its whole travel off the line, less the part it covers in time.
            out.early_mm += std::abs(delta_mm.at(axis)) * (1.0 - v / lo);
            v = lo;
        }
        v = round_speed(std::clamp(v, lo, std::max(lo, hi)));
        if (v < lo) v = std::ceil(lo * 1e6) / 1e6;  // rounding must not go below the smallest SPEED
        out.mm_s[axis] = v;
    }
    return out;
}

trace_commander::trace_commander(std::map<char, axis_speed_range> axes, std::map<char, double> speeds_now)
    : axes_(std::move(axes)), speeds_(std::move(speeds_now)) {}

void trace_commander::set_position(char axis, double mm) {
    position_[axis] = mm;
}

std::optional<double> trace_commander::position(char axis) const {
    if (auto it = position_.find(axis); it != position_.end()) return it->second;
    return std::nullopt;
}

segment_commands trace_commander::segment(const gcode::vec3& to, double feed_mm_s,
                                          std::optional<gcode::arc_plane> plane) {
    segment_commands out;
    std::map<char, double> delta;
    double length2 = 0, plane2 = 0;
    for (const auto& [axis, range] : axes_) {
        if (!driven(axis)) continue;
        const double target = coordinate(to, axis);
        const auto at = position(axis);
        if (at && std::abs(target - *at) <= same_target_mm) continue;
        // An axis whose position is unknown (never the case in a run: it reads them first) is taken
        // to start at zero.
        const double d = at ? target - *at : target;
        delta[axis] = d;
        out.target_mm[axis] = target;
        length2 += d * d;
        if (plane && in_plane(axis, *plane)) plane2 += d * d;
    }
    if (out.target_mm.empty()) return out;
    const double reference = plane && plane2 > 0 ? std::sqrt(plane2) : std::sqrt(length2);
    out.speeds = coordinated_speeds(delta, reference, feed_mm_s, axes_);
    std::map<char, double> changed;
    for (const auto& [axis, v] : out.speeds.mm_s)
        if (auto it = speeds_.find(axis); it == speeds_.end() || std::abs(it->second - v) > 5e-7)
            changed[axis] = v;
    if (!changed.empty()) {
        out.speed = speed_command(changed);
        for (const auto& [axis, v] : changed)
            speeds_[axis] = v;
    }
    std::vector<ms::axis_position> targets;
    targets.reserve(out.target_mm.size());
    for (const auto& [axis, mm] : out.target_mm)
        targets.push_back({axis, mm * 1000.0});
    auto move = ms::move(targets);
    if (!move)
        throw std::invalid_argument("cannot build the move of a G-code segment: " + move.error().message());
    out.move = std::move(*move);
    for (const auto& [axis, mm] : out.target_mm)
        position_[axis] = mm;
    return out;
}

ms::command speed_command(const std::map<char, double>& mm_s) {
    std::vector<ms::argument> args;
    args.reserve(mm_s.size());
    for (const auto& [axis, v] : mm_s)
        args.push_back(set_arg(axis, v, speed_decimals));
    return typed_command("SPEED", args);
}

ms::command analog_command(double volts) {
    return typed_command("WRDAC", {set_arg('X', volts, 3)});
}

}  // namespace gw::jobs
