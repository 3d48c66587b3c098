#include "devices/serial/snapshot_update.hpp"

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
