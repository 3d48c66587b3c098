#include "gateway/controllers/operations.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fmt/format.h>
#include <set>

#include "devices/ms2000/crisp.hpp"

namespace gw {

namespace ms2000 = devices::ms2000;
using devices::controller_snapshot;
using kind = operation_error_kind;

namespace {

char upper(char c) {
    return static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
}

std::string motor_axes(const controller_snapshot& s) {
    return s.identity ? s.identity->build.motor_axes : "";
}

std::string spaced(std::string_view letters) {
    std::string out;
    for (const char c : letters) {
        if (!out.empty()) out += ' ';
        out += c;
    }
    return out;
}

// Connected and identified: everything else needs the build.
std::optional<operation_error> check_connected(const controller_snapshot& s) {
    if (s.state == devices::connection_state::connected && s.identity) return std::nullopt;
    return make_error(kind::not_connected,
                      fmt::format("{} is not connected ({})", s.id, devices::to_string(s.state)));
}

std::optional<operation_error> check_module(const controller_snapshot& s, ms2000::module m,
                                            std::string_view what) {
    if (s.identity->build.has(m)) return std::nullopt;
    return make_error(kind::missing_module,
                      fmt::format("{} needs the {} firmware module, which {} (build {}) does not have", what,
                                  ms2000::module_line(m), s.id, s.identity->build.name),
                      std::string(ms2000::module_id(m)));
}

// Every axis letter is a motor axis of the controller, at most once, and the list is not empty.
std::optional<operation_error> check_axis(const controller_snapshot& s, char axis, std::set<char>& seen,
                                          const std::string& field) {
    const auto axes = motor_axes(s);
    const char a = upper(axis);
    if (axes.find(a) == std::string::npos || !std::isalpha(static_cast<unsigned char>(a)))
        return invalid_field(field, fmt::format("{} is not a motor axis of {} ({})", std::string(1, axis),
                                                s.id, spaced(axes)));
    if (!seen.insert(a).second) return invalid_field(field, fmt::format("axis {} is given twice", a));
    return std::nullopt;
}

std::string axis_field(char axis) {
    return std::string("axes.") + upper(axis);
}

operation_result<ms2000::command> built(boost::system::result<ms2000::command> c, std::string_view field) {
    if (!c)
        return invalid_field(std::string(field), "refused by the command builder: " + c.error().message());
    return std::move(*c);
}

std::optional<operation_error> check_position_list(const std::vector<axis_value_um>& axes,
                                                   const controller_snapshot& s) {
    if (axes.empty()) return invalid_field("axes", "at least one axis is needed");
    std::set<char> seen;
    for (const auto& a : axes) {
        if (auto e = check_axis(s, a.axis, seen, axis_field(a.axis))) return e;
        if (!std::isfinite(a.micrometres) || std::fabs(a.micrometres) > max_travel_um)
            return invalid_field(axis_field(a.axis),
                                 fmt::format("{} must be a number from {} to {} um", upper(a.axis),
                                             -max_travel_um, max_travel_um));
    }
    return std::nullopt;
}

std::vector<ms2000::axis_position> to_positions(const std::vector<axis_value_um>& axes) {
    std::vector<ms2000::axis_position> out;
    out.reserve(axes.size());
    for (const auto& a : axes)
        out.push_back({upper(a.axis), a.micrometres});
    return out;
}

}  // namespace

bool is_documented_in0_mode(int mode) {
    return (mode >= 0 && mode <= 12) || mode == 30;
}
bool is_documented_out0_mode(int mode) {
    return mode == 0 || mode == 1 || mode == 2 || mode == 9;
}

std::string hardware_order(const std::vector<axis_value_um>& axes, const controller_snapshot& s) {
    std::string out;
    for (const char m : motor_axes(s)) {
        if (std::any_of(axes.begin(), axes.end(), [m](const axis_value_um& a) { return upper(a.axis) == m; }))
            out += m;
    }
    return out;
}

operation_result<ms2000::command> plan(const move_request& r, const controller_snapshot& s) {
    if (auto e = check_connected(s)) return *e;
    if (auto e = check_position_list(r.axes, s)) return *e;
    if (r.wait && (r.wait_timeout <= std::chrono::milliseconds::zero() || r.wait_timeout > max_wait_timeout))
        return invalid_field("wait_timeout",
                             fmt::format("must be from 1 to {} ms", max_wait_timeout.count()));
    // Soft limits (SL/SU, mm) where the snapshot knows them; a relative move needs the position too.
    for (const auto& a : r.axes) {
        const auto* state = s.axis(upper(a.axis));
        if (!state) continue;
        double target = a.micrometres;
        if (r.kind == move_request::mode::relative) {
            if (!state->position_um) continue;
            target += *state->position_um;
        }
        const double lower = state->lower_limit_mm ? *state->lower_limit_mm * 1000 : -max_travel_um;
        const double upper_um = state->upper_limit_mm ? *state->upper_limit_mm * 1000 : max_travel_um;
        if (target < lower || target > upper_um)
            return invalid_field(axis_field(a.axis),
                                 fmt::format("{} target {} um is outside the soft limits {} .. {} um",
                                             upper(a.axis), target, lower, upper_um));
    }
    const auto positions = to_positions(r.axes);
    return built(
        r.kind == move_request::mode::absolute ? ms2000::move(positions) : ms2000::move_relative(positions),
        "axes");
}

operation_result<ms2000::command> plan(const halt_request&, const controller_snapshot&) {
    // Not even a connection is checked here: the stage must stop whenever the port is open, also
    // before the controller is identified; the driver answers not_connected when it is closed.
    return ms2000::halt();
}

operation_result<ms2000::command> plan(const home_request& r, const controller_snapshot& s) {
    if (auto e = check_connected(s)) return *e;
    std::string axes;
    if (r.axes.empty()) {
        axes = motor_axes(s);
    } else {
        std::set<char> seen;
        for (const char c : r.axes) {
            if (auto e = check_axis(s, c, seen, axis_field(c))) return *e;
            axes += upper(c);
        }
    }
    if (s.busy) return make_error(kind::busy, s.id + " is moving; halt it before homing");
    return ms2000::home(axes);
}

operation_result<ms2000::command> plan(const zero_request&, const controller_snapshot& s) {
    if (auto e = check_connected(s)) return *e;
    if (s.busy) return make_error(kind::busy, s.id + " is moving; zero it when it has stopped");
    return ms2000::zero();
}

operation_result<ms2000::command> plan(const here_request& r, const controller_snapshot& s) {
    if (auto e = check_connected(s)) return *e;
    if (auto e = check_position_list(r.axes, s)) return *e;
    if (s.busy) return make_error(kind::busy, s.id + " is moving; set positions when it has stopped");
    return built(ms2000::here(to_positions(r.axes)), "axes");
}

operation_result<ms2000::command> plan(const speed_request& r, const controller_snapshot& s) {
    if (auto e = check_connected(s)) return *e;
    if (r.axes.empty()) return invalid_field("axes", "at least one axis is needed");
    std::set<char> seen;
    std::vector<ms2000::argument> args;
    for (const auto& a : r.axes) {
        if (auto e = check_axis(s, a.axis, seen, axis_field(a.axis))) return *e;
        if (!std::isfinite(a.mm_per_s) || a.mm_per_s <= 0 || a.mm_per_s > max_speed_mm_s)
            return invalid_field(
                axis_field(a.axis),
                fmt::format("{} speed must be above 0 and at most {} mm/s", upper(a.axis), max_speed_mm_s));
        args.push_back({upper(a.axis), ms2000::argument::op::set, a.mm_per_s, 6});
    }
    return built(ms2000::make_command("S", args), "axes");
}

operation_result<ms2000::command> plan(const ttl_request& r, const controller_snapshot& s) {
    if (auto e = check_connected(s)) return *e;
    if (!r.in0_mode && !r.out0_mode && !r.output_high)
        return invalid_field("", "give at least one of in0_mode, out0_mode, output");
    if (r.out0_mode && r.output_high)
        return invalid_field("output", "output sets OUT0 mode 0 or 1 itself; do not give out0_mode with it");
    std::vector<ms2000::argument> args;
    if (r.in0_mode) {
        const int mode = *r.in0_mode;
        if (!is_documented_in0_mode(mode)) return invalid_field("in0_mode", "must be one of 0..12, 30");
        // With TTL_REPORT_INT every non-zero mode only enables the encoder latch (doc §5.3).
        const auto& build = s.identity->build;
        if (!build.has(ms2000::module::ttl_report)) {
            std::optional<ms2000::module> needed;
            if (mode == 1 || mode == 12) needed = ms2000::module::ring_buffer;
            if (mode == 3) needed = ms2000::module::autofocus;
            if (mode == 6) needed = ms2000::module::scan;
            if (mode == 7) needed = ms2000::module::array;
            if (needed) {
                if (auto e = check_module(s, *needed, fmt::format("TTL IN0 mode {}", mode))) return *e;
            }
        }
        args.push_back({'X', ms2000::argument::op::set, static_cast<double>(mode), 0});
    }
    if (r.out0_mode) {
        if (!is_documented_out0_mode(*r.out0_mode))
            return invalid_field("out0_mode", "must be one of 0, 1, 2, 9");
        args.push_back({'Y', ms2000::argument::op::set, static_cast<double>(*r.out0_mode), 0});
    }
    if (r.output_high) args.push_back({'Y', ms2000::argument::op::set, *r.output_high ? 1.0 : 0.0, 0});
    return built(ms2000::make_command("TTL", args), "");
}

operation_result<ms2000::command> plan(const dac_request& r, const controller_snapshot& s) {
    if (auto e = check_connected(s)) return *e;
    if (auto e = check_module(s, ms2000::module::dac_out, "WRDAC")) return *e;
    if (!std::isfinite(r.volts) || r.volts < 0 || r.volts > max_dac_volts)
        return invalid_field("volts", fmt::format("must be from 0 to {} V", max_dac_volts));
    const ms2000::argument arg{'X', ms2000::argument::op::set, r.volts, 3};
    return built(ms2000::make_command("WRDAC", std::span(&arg, 1)), "volts");
}

operation_result<ms2000::command> plan(const led_request& r, const controller_snapshot& s) {
    if (auto e = check_connected(s)) return *e;
    if (auto e = check_module(s, ms2000::module::led_dimmer, "LED")) return *e;
    const char channel = upper(r.channel);
    if (std::string_view("XYZF").find(channel) == std::string_view::npos)
        return invalid_field("channel", "must be one of X, Y, Z, F");
    if (!std::isfinite(r.percent) || r.percent < 0 || r.percent > max_led_percent)
        return invalid_field("percent", fmt::format("must be from 0 to {}", max_led_percent));
    const ms2000::argument arg{channel, ms2000::argument::op::set, std::round(r.percent), 0};
    return built(ms2000::make_command("LED", std::span(&arg, 1)), "percent");
}

operation_result<crisp_plan> plan(const crisp_request& r, const controller_snapshot& s) {
    if (auto e = check_connected(s)) return *e;
    if (auto e = check_module(s, ms2000::module::crisp, "CRISP")) return *e;
    if (r.wait && r.what != crisp_request::action::lock)
        return invalid_field("wait", "wait goes with action \"lock\"");
    if (r.wait_timeout.count() < 1 || r.wait_timeout > max_wait_timeout)
        return invalid_field("timeout_ms", fmt::format("must be 1..{}", max_wait_timeout.count()));
    crisp_plan p;
    if (r.lock_offset) {
        if (!std::isfinite(*r.lock_offset) || std::abs(*r.lock_offset) > ms2000::max_crisp_offset)
            return invalid_field("lock_offset",
                                 fmt::format("must be from -{0} to {0}", ms2000::max_crisp_offset));
        auto c = built(ms2000::crisp_set_offset(*r.lock_offset), "lock_offset");
        if (!c) return c.error();
        p.writes.push_back(std::move(*c));
    }
    switch (r.what) {
        case crisp_request::action::lock:
            p.writes.push_back(ms2000::crisp_lock());
            break;
        case crisp_request::action::unlock:
            p.writes.push_back(ms2000::crisp_unlock());
            break;
        case crisp_request::action::off:
            p.writes.push_back(ms2000::crisp_off());
            break;
        case crisp_request::action::none:
            break;
    }
    if (r.save) p.writes.push_back(ms2000::save_settings());
    p.reads = {ms2000::crisp_state_query(), ms2000::crisp_focus_error_query(), ms2000::crisp_sum_query(),
               ms2000::crisp_offset_query()};
    if (auto snr = ms2000::crisp_snr_query(s.identity->version)) p.reads.push_back(std::move(*snr));
    return p;
}

operation_result<ms2000::command> plan(const autofocus_request& r, const controller_snapshot& s) {
    if (auto e = check_connected(s)) return *e;
    if (auto e = check_module(s, ms2000::module::autofocus, "AUTOFOCUS")) return *e;
    if (motor_axes(s).find('Z') == std::string::npos)
        return invalid_field("", fmt::format("{} has no Z axis to focus with", s.id));
    if (r.wait_timeout.count() < 1 || r.wait_timeout > max_wait_timeout)
        return invalid_field("timeout_ms", fmt::format("must be 1..{}", max_wait_timeout.count()));
    return ms2000::autofocus_start();
}

operation_result<ms2000::command> plan(const command_request& r, const controller_snapshot& s) {
    if (auto e = check_connected(s)) return *e;
    return r.command;
}

operation_result<ms2000::command> plan(const raw_command_request& r, const controller_snapshot& s) {
    if (auto e = check_connected(s)) return *e;
    if (r.command.empty()) return invalid_field("command", "must not be empty");
    auto c = ms2000::raw_command(r.command);
    if (!c && c.error() == ms2000::error::binary_reply)
        return invalid_field("command",
                             "RDSBYTE (RB) answers raw bytes, which a JSON reply cannot carry: "
                             "RDSTAT (\"RS X\") gives the same status byte as a number");
    if (!c)
        return invalid_field("command",
                             fmt::format("must be one line of at most {} printable ASCII characters",
                                         ms2000::max_raw_command_bytes));
    if (const auto why = ms2000::resets_or_recalibrates(*c); !why.empty() && !r.force)
        return invalid_field("force", fmt::format("{}: send \"force\": true to mean it (the controller is "
                                                  "identified again afterwards)",
                                                  why));
    return std::move(*c);
}

}  // namespace gw
