// The `scan` job: a raster or serpentine area scan, run by the controller's SCAN module
// ("firmware": SCANR/SCANV/SCAN, seed 000 SCAN MODULE) or line by line by the gateway ("host").
// Steps are the lines ("line 1".."line N"); each finished line is a step event.
//
// Firmware path choices:
//  * Before SCAN the gateway moves the stage to the start of the first line itself, so that the
//    slow-axis position it polls always names the current line (the firmware's own approach move
//    could otherwise pass through other lines' positions).
//  * Progress: "SCAN X?" (P = idle) and "W <fast> <slow>" every 25 ms; the slow axis leaving line k
//    means line k is finished (the firmware steps the slow axis only after a line). Lines finished
//    between two polls are reported with their planned end and "measured": false; the last line is
//    reported with the measured position after the scan stopped.
//  * A firmware scan cannot be held mid-scan: pause takes effect when the scan has finished (plan
//    warning). Cancel is the manager's HALT, which stops the scan at once.
//  * A scan already running on the controller (left from before a gateway restart or an unplugged
//    cable) is stopped with "SCAN P" before the job's own scan is set up.
//  * A resumed firmware scan restarts at its first unfinished line (SCANV X= that line's slow
//    position, Z= the remaining lines); a serpentine scan resumes at an even line so that the
//    firmware's first (forward) line has the right direction.
//  * SPEED of the fast axis is set for the scan (after the approach move, which runs at the axis's
//    own SPEED) and restored afterwards; after a cancel or a failure the manager restores it
//    (job_context::restore_if_stopped).
//  * "TTL X=1" (the encoder interrupt, seed) is sent only on builds with ENC_INT, and IN0 is
//    restored to its previous mode afterwards, in the same way.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>

#include "devices/ms2000/command.hpp"
#include "gateway/jobs/job_commands.hpp"
#include "gateway/jobs/job_json.hpp"
#include "gateway/jobs/kinds/job_kinds.hpp"
#include "gateway/jobs/kinds/scan_spec.hpp"

namespace gw::jobs {

namespace {

namespace ms = devices::ms2000;
using devices::ms2000::module;
using std::chrono::milliseconds;

constexpr milliseconds line_follow_poll{25};

std::string axes_move_text(const std::vector<axis_value_um>& axes) {
    std::vector<ms::axis_position> to;
    for (const auto& a : axes)
        to.push_back({a.axis, a.micrometres});
    return jobs::move_text(to);
}

struct scan_setup {
    scan_spec spec;
    scan_geometry geometry;
    bool firmware = false;
};

operation_result<scan_setup> resolve_scan(const nlohmann::json& json, const devices::controller_snapshot& s) {
    auto spec = parse_scan_spec(json);
    if (!spec) return spec.error();
    for (const auto& [letter, field] :
         {std::pair{spec->fast_axis, "fast_axis"}, std::pair{spec->slow_axis, "slow_axis"}})
        if (!s.axes.empty() && !s.axis(letter))
            return make_error(
                operation_error_kind::invalid_value,
                fmt::format("axis {} is not a motor axis of {} ({})", letter, s.id, motor_axes(s)),
                std::string("spec.") + field);
    const auto* fast = s.axis(spec->fast_axis);
    if (!fast || !fast->counts_per_mm)
        return make_error(operation_error_kind::not_connected,
                          fmt::format("{}: the encoder counts per mm of axis {} are not known yet (CNTS {}?)",
                                      s.id, spec->fast_axis, spec->fast_axis));
    auto geometry = scan_firmware_geometry(*spec, *fast->counts_per_mm);
    if (!geometry) return geometry.error();
    scan_setup setup{*spec, *geometry, false};
    const bool module_present = has_module(s, module::scan);
    switch (spec->mode) {
        case scan_spec::path_mode::firmware:
            if (!module_present)
                return make_error(operation_error_kind::missing_module,
                                  fmt::format("{} has no SCAN MODULE (mode firmware)", s.id), "spec.mode");
            setup.firmware = true;
            break;
        case scan_spec::path_mode::automatic:
            setup.firmware = module_present;
            break;
        case scan_spec::path_mode::host:
            break;
    }
    return setup;
}

position_um line_point(const scan_setup& u, double fast_mm, double slow_mm) {
    return {{u.spec.fast_axis, fast_mm * 1000.0}, {u.spec.slow_axis, slow_mm * 1000.0}};
}

std::vector<axis_value_um> to_axes(const position_um& p) {
    std::vector<axis_value_um> out;
    for (const auto& [axis, um] : p)
        out.push_back({axis, um});
    return out;
}

// The firmware setup commands, starting at line `first` (0 for a fresh scan). The scan speed is not
// among them: it is set after the approach move, which runs at the axis's own SPEED.
std::vector<ms::command> firmware_setup(const scan_setup& u, const devices::controller_snapshot& s,
                                        int first) {
    const auto& g = u.geometry;
    std::vector<ms::command> out;
    if (u.spec.pixels)
        out.push_back(typed_command("SCANR", {set_arg('X', g.fast_start_mm, 6), set_arg('F', g.pixels, 0),
                                              set_arg('Z', u.spec.encoder_divide, 0)}));
    else
        out.push_back(
            typed_command("SCANR", {set_arg('X', g.fast_start_mm, 6), set_arg('Y', g.fast_stop_mm, 6),
                                    set_arg('Z', u.spec.encoder_divide, 0)}));
    out.push_back(typed_command("SCANV", {set_arg('X', g.slow_at(first), 6), set_arg('Y', g.slow_stop_mm, 6),
                                          set_arg('Z', g.lines - first, 0)}));
    out.push_back(typed_command(
        "SCAN", {set_arg('Y', axis_index(s, u.spec.fast_axis), 0),
                 set_arg('Z', axis_index(s, u.spec.slow_axis), 0), set_arg('F', g.serpentine ? 1 : 0, 0)}));
    if (has_module(s, module::enc_int)) out.push_back(ttl_in0(1));
    return out;
}

// "SCAN P": a scan in progress stopped.
ms::command scan_stop() {
    return typed_command("SCAN", {bare_arg('P')});
}

ms::command speed_command(char axis, double mm_s) {
    return typed_command("SPEED", {set_arg(axis, mm_s, 6)});
}

// The fast and slow axes' start and stop positions against the soft limits; the error's field is
// the setting (spec.fast.start_mm, spec.fast.stop_mm or spec.fast.pixels, spec.slow.start_mm,
// spec.slow.stop_mm) whose position is beyond them.
operation_result<void> check_scan_extent(const scan_setup& u, const devices::controller_snapshot& s) {
    const auto& g = u.geometry;
    const char f = u.spec.fast_axis, w = u.spec.slow_axis;
    struct setting {
        const char* field;
        char axis;
        double mm;
    };
    const setting settings[] = {
        {"fast.start_mm", f, g.fast_start_mm},
        {u.spec.pixels ? "fast.pixels" : "fast.stop_mm", f, g.fast_stop_mm},
        {"slow.start_mm", w, g.slow_start_mm},
        {"slow.stop_mm", w, g.slow_stop_mm},
    };
    for (const auto& one : settings) {
        job_plan point;
        point.steps.push_back({fmt::format("scan {} ({} axis)", one.field, one.axis),
                               position_um{{one.axis, one.mm * 1000.0}}, 0, false});
        if (auto limits = check_soft_limits(point, s); !limits) {
            auto e = limits.error();
            e.field = std::string("spec.") + one.field;
            return e;
        }
    }
    return {};
}

}  // namespace

operation_result<job_plan> plan_scan(const nlohmann::json& json, const plan_context& ctx) {
    const auto& s = ctx.snapshot;
    auto setup = resolve_scan(json, s);
    if (!setup) return setup.error();
    const auto& u = *setup;
    const auto& g = u.geometry;
    const char f = u.spec.fast_axis, w = u.spec.slow_axis;
    const auto& fp = ctx.motion.axis(f);
    const auto& sp = ctx.motion.axis(w);
    const double scan_speed = u.spec.speed_mm_s.value_or(fp.speed_mm_s);

    job_plan plan;
    plan.type = job_type::scan;
    plan.path = u.firmware ? "firmware" : "host";

    // Line times: the line at the scan speed, then the move to the next line's start. The SCAN module
    // retraces and steps the slow axis together at the screw's top speed (SCANR R=100); the host path
    // sends one move to the next line's start at SPEED (raster: retrace and step; serpentine: the
    // step only).
    const double line_s = ctx.motion.axis_move_seconds(f, g.line_length_mm(), scan_speed);
    const double retrace_mm = g.serpentine ? 0.0 : -g.line_length_mm();
    const double between_s =
        u.firmware ? std::max(ctx.motion.axis_move_seconds(f, retrace_mm, fp.max_speed_mm_s),
                              ctx.motion.axis_move_seconds(w, g.slow_step_mm(), sp.max_speed_mm_s))
                   : ctx.motion.move_seconds({{f, retrace_mm}, {w, g.slow_step_mm()}});
    // The gateway moves to the first line's start itself, at SPEED, before the scan speed is set.
    double approach_s = 0;
    {
        std::vector<axis_delta_mm> d;
        const auto* fa = s.axis(f);
        const auto* sa = s.axis(w);
        if (fa && fa->position_um)
            d.push_back({f, g.fast_begin(0) - *fa->position_um / 1000.0, g.fast_begin(0)});
        if (sa && sa->position_um) d.push_back({w, g.slow_at(0) - *sa->position_um / 1000.0, g.slow_at(0)});
        approach_s = ctx.motion.move_seconds(d);
    }
    plan.steps.reserve(static_cast<std::size_t>(g.lines));
    for (int i = 0; i < g.lines; ++i) {
        plan_step step;
        step.name = fmt::format("line {}", i + 1);
        step.target = line_point(u, g.fast_begin(i), g.slow_at(i));
        step.estimated_s = line_s + (i == 0 ? approach_s : between_s);
        plan.estimated_s += step.estimated_s;
        plan.steps.push_back(std::move(step));
    }
    for (const double slow : {g.slow_start_mm, g.slow_stop_mm}) {
        plan.bounds.include(line_point(u, g.fast_start_mm, slow));
        plan.bounds.include(line_point(u, g.fast_stop_mm, slow));
    }
    // Every line lies within the four settings' positions (line ends are not step targets): each is
    // checked against its own axis's soft limits, so a refusal names the setting to change.
    if (auto limits = check_scan_extent(u, s); !limits) return limits.error();

    const std::string speed_text = fmt::format("{:g} mm/s", scan_speed);
    if (u.firmware) {
        for (const auto& c : firmware_setup(u, s, 0))
            add_preview_command(plan, text_of(c));
        add_preview_command(plan, axes_move_text(to_axes(line_point(u, g.fast_begin(0), g.slow_at(0)))));
        if (u.spec.speed_mm_s) add_preview_command(plan, command_text("SPEED", {set_arg(f, scan_speed, 6)}));
        add_preview_command(plan, "SCAN");
        if (u.spec.speed_mm_s)
            add_preview_command(plan, command_text("SPEED", {set_arg(f, fp.speed_mm_s, 6)}));
        if (has_module(s, module::enc_int))
            add_preview_command(plan, command_text("TTL", {set_arg('X', s.ttl_in0_mode.value_or(0), 0)}));
        plan.warnings.push_back(
            "pause takes effect only when the firmware scan has finished: the SCAN module cannot hold a scan "
            "mid-way (cancel stops it at once)");
    } else {
        for (int i = 0; i < g.lines; ++i) {
            add_preview_command(plan, axes_move_text(to_axes(line_point(u, g.fast_begin(i), g.slow_at(i)))));
            if (u.spec.speed_mm_s)
                add_preview_command(plan, command_text("SPEED", {set_arg(f, scan_speed, 6)}));
            add_preview_command(plan, axes_move_text({{f, g.fast_end(i) * 1000.0}}));
            if (u.spec.speed_mm_s)
                add_preview_command(plan, command_text("SPEED", {set_arg(f, fp.speed_mm_s, 6)}));
        }
        if (u.firmware == false && has_module(s, module::scan) == false &&
            u.spec.mode == scan_spec::path_mode::automatic)
            plan.warnings.push_back(
                fmt::format("{} has no SCAN MODULE: the gateway drives the scan line by line, "
                            "without the SYNC and pixel-clock outputs",
                            s.id));
    }
    plan.summary =
        fmt::format("{} lines x {} pixels ({} counts/pixel, {:g} counts/mm), {}, {} fast at {}, {}", g.lines,
                    g.pixels, u.spec.encoder_divide, g.counts_per_mm, g.serpentine ? "serpentine" : "raster",
                    f, speed_text, u.firmware ? "SCAN module" : "host-driven");
    return plan;
}

namespace {

// "W <axes>" for two axes; the controller answers in hardware order.
boost::asio::awaitable<position_um> where(job_context& ctx, char a, char b) {
    const auto s = ctx.snapshot();
    std::string order{a, b};
    if (axis_index(s, b) < axis_index(s, a)) std::swap(order[0], order[1]);
    auto reply = co_await ctx.command(ms::where(order));
    position_um out;
    for (std::size_t i = 0; i < order.size(); ++i) {
        const auto v = reply.number(i);
        if (!v)
            throw job_failure(make_error(operation_error_kind::controller_error,
                                         fmt::format("unexpected WHERE reply \"{}\"", reply.raw)));
        out[order[i]] = *v / 10.0;
    }
    co_return out;
}

// Built outside the coroutines: g++ 12 miscompiles braced json initialisers with string literals in
// a coroutine body ("array used as initializer").
nlohmann::json line_detail(int line, const position_um& p, bool measured) {
    nlohmann::json j = nlohmann::json::object();
    j["line"] = line;
    j["position"] = measured_position_json(p);
    j["measured"] = measured;
    return j;
}

nlohmann::json message_detail(std::string message) {
    nlohmann::json j = nlohmann::json::object();
    j["message"] = std::move(message);
    return j;
}

milliseconds wait_timeout_for(double estimated_s) {
    const auto ms = static_cast<long long>(estimated_s * 3000.0) + 30'000;
    return std::min(milliseconds(ms), max_wait_timeout);
}

boost::asio::awaitable<void> run_scan_host(job_context& ctx, const scan_setup& u, double original_speed) {
    const auto& g = u.geometry;
    const char f = u.spec.fast_axis;
    const auto& steps = ctx.plan().steps;
    for (int i = static_cast<int>(ctx.first_step()); i < g.lines; ++i) {
        co_await ctx.checkpoint();
        const auto index = static_cast<std::size_t>(i);
        ctx.step_started(index);
        const double estimated = index < steps.size() ? steps[index].estimated_s : 0;
        move_request to_start{move_request::mode::absolute,
                              to_axes(line_point(u, g.fast_begin(i), g.slow_at(i))), true,
                              wait_timeout_for(estimated)};
        const auto at_start = co_await ctx.move(std::move(to_start));
        if (u.spec.speed_mm_s) {
            auto scan_speed = speed_command(f, *u.spec.speed_mm_s);
            co_await ctx.command(std::move(scan_speed));
        }
        move_request line{
            move_request::mode::absolute, {{f, g.fast_end(i) * 1000.0}}, true, wait_timeout_for(estimated)};
        auto done = co_await ctx.move(std::move(line));
        if (u.spec.speed_mm_s) {
            auto restore = speed_command(f, original_speed);
            co_await ctx.command(std::move(restore));
        }
        // The line moves the fast axis only; the slow axis stands where the line began.
        position_um measured;
        for (const auto& p : at_start.positions)
            if (p.axis == u.spec.slow_axis) measured[p.axis] = p.micrometres;
        for (const auto& p : done.positions)
            if (p.axis == f) measured[p.axis] = p.micrometres;
        ctx.step_done(index, line_detail(i + 1, measured, true));
    }
}

boost::asio::awaitable<void> run_firmware(job_context& ctx, const scan_setup& u) {
    const auto& g = u.geometry;
    const char f = u.spec.fast_axis, w = u.spec.slow_axis;
    const auto s = ctx.snapshot();
    int first = static_cast<int>(std::min<std::size_t>(ctx.first_step(), static_cast<std::size_t>(g.lines)));
    if (first >= g.lines) co_return;
    if (g.serpentine && first % 2 == 1) {
        ctx.emit("warning",
                 message_detail(fmt::format("a serpentine firmware scan restarts at an even line: line {} "
                                            "is scanned again",
                                            first)));
        --first;
    }
    // A scan still running (the firmware finishes a scan by itself when the gateway restarted or the
    // cable was pulled mid-scan) would fight the new one: stop it first.
    {
        auto state = co_await ctx.command(ms::query("SCAN", "X"));
        const auto* x = state.axis('X');
        if (x && x->text == "S") {
            ctx.emit("warning",
                     message_detail(fmt::format("{}: a scan was still running; stopped with SCAN P "
                                                "before this one starts",
                                                s.id)));
            co_await ctx.command(scan_stop());
            co_await ctx.wait_idle(milliseconds(30'000));
        }
    }
    // Named, not a range-for temporary: g++ 12 frees a range-init temporary of a coroutine too early.
    const auto setup_commands = firmware_setup(u, s, first);
    for (const auto& c : setup_commands)
        co_await ctx.command(c);
    const auto& steps = ctx.plan().steps;
    move_request to_start;
    to_start.axes = to_axes(line_point(u, g.fast_begin(first), g.slow_at(first)));
    to_start.wait = true;
    to_start.wait_timeout =
        wait_timeout_for(steps.empty() ? 0 : steps[static_cast<std::size_t>(first)].estimated_s);
    co_await ctx.move(std::move(to_start));
    if (u.spec.speed_mm_s) {
        auto scan_speed = speed_command(f, *u.spec.speed_mm_s);
        co_await ctx.command(std::move(scan_speed));
    }
    ctx.step_started(static_cast<std::size_t>(first));
    co_await ctx.command(typed_command("SCAN"));

    // Follow the scan. `reported` = lines of the whole scan reported done.
    int reported = first;
    const double step = g.slow_step_mm();
    auto last_progress = std::chrono::steady_clock::now();
    double max_line_s = 0;
    for (const auto& st : steps)
        max_line_s = std::max(max_line_s, st.estimated_s);
    const auto stall_limit = wait_timeout_for(max_line_s);
    const auto report_until = [&](int done_lines, const std::optional<position_um>& measured_last) {
        for (; reported < done_lines; ++reported) {
            const bool last = reported + 1 == done_lines && measured_last;
            const auto pos = last ? *measured_last : line_point(u, g.fast_end(reported), g.slow_at(reported));
            ctx.step_done(static_cast<std::size_t>(reported), line_detail(reported + 1, pos, last));
            if (reported + 1 < g.lines) ctx.step_started(static_cast<std::size_t>(reported + 1));
        }
        last_progress = std::chrono::steady_clock::now();
    };
    for (;;) {
        auto state = co_await ctx.command(ms::query("SCAN", "X"));
        const auto* x = state.axis('X');
        const bool running = !(x && x->text == "P");
        auto pos = co_await where(ctx, f, w);
        int line = step != 0 ? static_cast<int>(std::lround((pos[w] / 1000.0 - g.slow_start_mm) / step)) : 0;
        line = std::clamp(line, first, g.lines - 1);
        if (!running) {
            co_await ctx.wait_idle(milliseconds(30'000));
            pos = co_await where(ctx, f, w);
            const double tolerance = std::max(0.005, 0.01 * g.line_length_mm());
            const bool at_end =
                line == g.lines - 1 && std::abs(pos[f] / 1000.0 - g.fast_end(g.lines - 1)) <= tolerance;
            if (!at_end) {
                report_until(line, std::nullopt);
                throw job_failure(make_error(operation_error_kind::controller_error,
                                             fmt::format("{}: the SCAN module stopped during line {} of {} "
                                                         "(SCAN X? = P, {}={:.1f} {}={:.1f} um)",
                                                         s.id, line + 1, g.lines, f, pos[f], w, pos[w])));
            }
            report_until(g.lines, pos);
            co_return;
        }
        if (line > reported) report_until(line, std::nullopt);
        if (std::chrono::steady_clock::now() - last_progress > stall_limit)
            throw job_failure(make_error(operation_error_kind::timeout,
                                         fmt::format("{}: the scan made no progress in {} ms (line {} of {})",
                                                     s.id, stall_limit.count(), reported + 1, g.lines)));
        co_await ctx.sleep(line_follow_poll);
    }
}

}  // namespace

boost::asio::awaitable<void> run_scan(job_context& ctx) {
    const auto s = ctx.snapshot();
    auto setup = resolve_scan(ctx.job().spec, s);
    if (!setup) throw job_failure(setup.error());
    auto u = *setup;
    u.firmware = ctx.plan().path == "firmware";
    const char f = u.spec.fast_axis;
    std::string fast_axis(1, f);
    const auto speeds = co_await ctx.settings_before("SPEED", std::move(fast_axis));
    const double original_speed = speeds.at(f);
    const bool enc_int = u.firmware && has_module(s, module::enc_int);
    int original_in0 = 0;
    if (enc_int) original_in0 = co_await in0_mode_before(ctx);
    // What the job changes; the manager puts it back after a cancel or a failure.
    if (u.spec.speed_mm_s) ctx.restore_if_stopped(text_of(speed_command(f, original_speed)));
    if (enc_int) ctx.restore_if_stopped(ttl_in0_command(original_in0));
    if (u.firmware)
        co_await run_firmware(ctx, u);
    else
        co_await run_scan_host(ctx, u, original_speed);
    if (u.spec.speed_mm_s) {
        auto restore = speed_command(f, original_speed);
        co_await ctx.command(std::move(restore));
    }
    if (enc_int) {
        auto in0 = ttl_in0(original_in0);
        co_await ctx.command(std::move(in0));
    }
}

}  // namespace gw::jobs
