#include "gateway/gcode/gcode_options.hpp"

#include <charconv>
#include <cmath>
#include <system_error>

namespace gw::gcode {

namespace {

std::optional<double> parse_number(const std::string& text) {
    double v = 0;
    const char* first = text.data();
    const char* last = text.data() + text.size();
    if (first != last && *first == '+') {
        ++first;
        if (first != last && *first == '-') return std::nullopt;  // "+-1": one sign only
    }
    const auto [end, ec] = std::from_chars(first, last, v);
    if (ec != std::errc{} || end != last || first == last || !std::isfinite(v)) return std::nullopt;
    return v;
}

}  // namespace

std::optional<std::string> validate(const gcode_options& o) {
    auto positive = [](double v) { return std::isfinite(v) && v > 0; };
    auto non_negative = [](double v) { return std::isfinite(v) && v >= 0; };
    // Upper (and scale lower) bounds: beyond them a plan is meaningless (a feed of 0 mm/s, a
    // 60-digit duration), and no stage the gateway drives comes near them.
    constexpr double max_scale = 1e6;
    constexpr double max_speed_mm_s = 1000;
    constexpr double max_wait_ms = 60'000;
    if (!positive(o.xyz_scale)) return "xyz_scale must be > 0";
    if (o.xyz_scale < 1 / max_scale || o.xyz_scale > max_scale) return "xyz_scale must be within 1e-6..1e6";
    if (!positive(o.speed_scale)) return "speed_scale must be > 0";
    if (o.speed_scale < 1 / max_scale || o.speed_scale > max_scale)
        return "speed_scale must be within 1e-6..1e6";
    // Below 0.1 nm the segment count of a large arc explodes without any physical meaning.
    if (!std::isfinite(o.arc_tolerance_mm) || o.arc_tolerance_mm < 1e-7)
        return "arc_tolerance_mm must be >= 1e-7";
    if (!positive(o.max_feed_mm_s)) return "max_feed_mm_s must be > 0";
    if (o.max_feed_mm_s > max_speed_mm_s) return "max_feed_mm_s must be <= 1000";
    if (!positive(o.rapid_mm_s)) return "rapid_mm_s must be > 0";
    if (o.rapid_mm_s > max_speed_mm_s) return "rapid_mm_s must be <= 1000";
    if (!non_negative(o.arc_radius_tolerance_mm)) return "arc_radius_tolerance_mm must be >= 0";
    if (!non_negative(o.arc_radius_relative_tolerance)) return "arc_radius_relative_tolerance must be >= 0";
    if (!non_negative(o.arc_r_deficit_tolerance_mm)) return "arc_r_deficit_tolerance_mm must be >= 0";
    if (o.analog_low_um.has_value() != o.analog_high_um.has_value())
        return "analog_low_um and analog_high_um must be given together";
    if (o.analog_low_um) {
        if (!std::isfinite(*o.analog_low_um) || !std::isfinite(*o.analog_high_um) ||
            !(*o.analog_low_um < *o.analog_high_um))
            return "analog_low_um must be below analog_high_um";
    }
    if (!non_negative(o.ramp_ms)) return "ramp_ms must be >= 0";
    if (o.ramp_ms > max_wait_ms) return "ramp_ms must be <= 60000";
    if (!non_negative(o.settle_ms)) return "settle_ms must be >= 0";
    if (o.settle_ms > max_wait_ms) return "settle_ms must be <= 60000";
    if (o.host.baud == 0) return "baud must be > 0";
    if (!non_negative(o.host.arrival_poll_ms)) return "arrival_poll_ms must be >= 0";
    if (o.host.arrival_poll_ms > max_wait_ms) return "arrival_poll_ms must be <= 60000";
    if (o.max_line_chars < 16) return "max_line_chars must be >= 16";
    return std::nullopt;
}

std::optional<std::string> set_option(gcode_options& o, const std::string& name, const std::string& value) {
    if (name == "decimal_point") {
        if (value == "calculator") {
            o.decimal_point = decimal_point_reading::calculator;
        } else if (value == "least_increment") {
            o.decimal_point = decimal_point_reading::least_increment;
        } else {
            return "decimal_point must be calculator or least_increment";
        }
        return std::nullopt;
    }
    if (name == "z_mode") {
        if (value == "axis") {
            o.z = z_mode::axis;
        } else if (value == "analog") {
            o.z = z_mode::analog;
        } else {
            return "z_mode must be axis or analog";
        }
        return std::nullopt;
    }
    if (name == "analog_range") {
        if (value == "clamp") {
            o.analog_range = analog_range_policy::clamp;
        } else if (value == "error") {
            o.analog_range = analog_range_policy::error;
        } else {
            return "analog_range must be clamp or error";
        }
        return std::nullopt;
    }
    if (name == "baud") {
        const auto v = parse_number(value);
        if (!v || !(*v >= 1 && *v <= 10'000'000) || std::floor(*v) != *v)
            return "baud must be a whole number > 0";
        o.host.baud = static_cast<unsigned>(*v);
        return std::nullopt;
    }
    double* target = nullptr;
    std::optional<double>* optional_target = nullptr;
    if (name == "xyz_scale") target = &o.xyz_scale;
    if (name == "speed_scale") target = &o.speed_scale;
    if (name == "arc_tolerance_mm") target = &o.arc_tolerance_mm;
    if (name == "max_feed_mm_s") target = &o.max_feed_mm_s;
    if (name == "rapid_mm_s") target = &o.rapid_mm_s;
    if (name == "arc_radius_tolerance_mm") target = &o.arc_radius_tolerance_mm;
    if (name == "arc_radius_relative_tolerance") target = &o.arc_radius_relative_tolerance;
    if (name == "arc_r_deficit_tolerance_mm") target = &o.arc_r_deficit_tolerance_mm;
    if (name == "ramp_ms") target = &o.ramp_ms;
    if (name == "settle_ms") target = &o.settle_ms;
    if (name == "arrival_poll_ms") target = &o.host.arrival_poll_ms;
    if (name == "analog_low_um") optional_target = &o.analog_low_um;
    if (name == "analog_high_um") optional_target = &o.analog_high_um;
    if (target == nullptr && optional_target == nullptr) return "unknown option " + name;
    const auto v = parse_number(value);
    if (!v) return name + " must be a number";
    if (target != nullptr) {
        *target = *v;
    } else {
        *optional_target = *v;
    }
    return std::nullopt;
}

}  // namespace gw::gcode
