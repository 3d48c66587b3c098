#include "devices/serial/snapshot_update.hpp"

#include <cmath>
#include <string>
#include <utility>

#include "devices/ms2000/build_info.hpp"

namespace gw::devices {

namespace {

std::optional<double> axis_number(const ms2000::reply& r, char axis) {
    if (const auto* a = r.axis(axis)) return a->number;
    return std::nullopt;
}

}  // namespace

void apply_version(controller_snapshot& s, const ms2000::reply& r) {
    controller_identity identity;
    identity.version_raw = r.raw;
    auto version = ms2000::parse_version(r);
    identity.version = version ? *version : r.raw;
    s.identity = std::move(identity);
}

bool apply_build(controller_snapshot& s, const ms2000::reply* r) {
    if (!s.identity) s.identity.emplace();
    if (r) {
        if (auto build = ms2000::parse_build_x(r->raw)) s.identity->build = std::move(*build);
    }
    auto& build = s.identity->build;
    const bool listed = !build.motor_axes.empty();
    if (!listed) build.motor_axes = "XY";
    s.axes.clear();
    for (const char letter : build.motor_axes) {
        axis_state a;
        a.axis = letter;
        s.axes.push_back(a);
    }
    return listed;
}

void apply_axis_numbers(controller_snapshot& s, const ms2000::reply& r,
                        std::optional<double> axis_state::*field) {
    for (auto& a : s.axes)
        a.*field = axis_number(r, a.axis);
}

void apply_finish_errors(controller_snapshot& s, const ms2000::reply& r) {
    for (auto& a : s.axes) {
        const auto* v = r.axis(a.axis);
        a.finish_error_mm = v ? v->number : std::nullopt;
        a.finish_error_printed_step_mm = 0;
        if (!a.finish_error_mm) continue;
        // Half a unit of the last decimal printed: "0.000005" -> 5e-7 (a finish error that prints as a
        // lead screw's default then counts as that default).
        const auto dot = v->text.find('.');
        std::size_t decimals = 0;
        for (std::size_t i = dot == std::string::npos ? v->text.size() : dot + 1;
             i < v->text.size() && v->text[i] >= '0' && v->text[i] <= '9'; ++i)
            ++decimals;
        a.finish_error_printed_step_mm = 0.5 * std::pow(10.0, -static_cast<double>(decimals));
    }
}

void apply_motion_setting(controller_snapshot& s, std::string_view verb, const ms2000::reply& r) {
    if (verb == "PC") return apply_finish_errors(s, r);
    if (verb == "S") return apply_axis_numbers(s, r, &axis_state::speed_mm_s);
    if (verb == "AC") return apply_axis_numbers(s, r, &axis_state::ramp_ms);
    if (verb == "B") return apply_axis_numbers(s, r, &axis_state::backlash_mm);
    if (verb == "OS") apply_axis_numbers(s, r, &axis_state::overshoot_mm);
}

std::string_view motion_setting_set_by(const ms2000::command& cmd) {
    if (cmd.wire.find('=') == std::string::npos) return {};
    const std::string_view v = cmd.verb;
    if (v == "S" || v == "SPEED") return "S";
    if (v == "AC" || v == "ACCEL") return "AC";
    if (v == "PC" || v == "PCROS") return "PC";
    if (v == "B" || v == "BACKLASH") return "B";
    if (v == "OS" || v == "O" || v == "OVERSHOOT") return "OS";
    return {};
}

void apply_ttl_modes(controller_snapshot& s, const ms2000::reply& r) {
    auto mode = [&](char axis, std::size_t index) -> std::optional<int> {
        auto n = axis_number(r, axis);
        if (!n) n = r.number(index);
        // A mode is a small whole number; anything else is not one (and must not overflow the cast).
        if (!n || *n < 0 || *n > 1000) return std::nullopt;
        return static_cast<int>(*n);
    };
    s.ttl_in0_mode = mode('X', 0);
    s.ttl_out0_mode = mode('Y', 1);
}

void apply_where(controller_snapshot& s, const ms2000::reply& r) {
    // ":A 1234.5 432.1 0" in hardware order, tenths of a micron.
    for (std::size_t i = 0; i < s.axes.size(); ++i) {
        if (auto n = r.number(i)) s.axes[i].position_um = *n / 10.0;
    }
}

void apply_axis_busy(controller_snapshot& s, std::size_t axis_index, const ms2000::reply& r) {
    // ":A B" or ":A N"
    if (axis_index >= s.axes.size()) return;
    auto& a = s.axes[axis_index];
    const auto* v = r.axis(a.axis);
    const std::string& text = v ? v->text : (r.values.empty() ? std::string() : r.values.front());
    a.busy = text == "B";
}

void apply_busy(controller_snapshot& s, bool busy) {
    s.busy = busy;
    if (busy) return;
    for (auto& a : s.axes)
        a.busy = false;
}

}  // namespace gw::devices
