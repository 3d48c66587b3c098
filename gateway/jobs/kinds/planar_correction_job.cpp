// planar_correction: the PLANAR CORRECTION module's three-point tilted focal plane (seed "PLANAR
// CORRECTION", protocol doc §3.7). "CCB Z=1..3" stores the current position as point 1..3, "CCB Z=4"
// computes the plane and enables the correction, 5 disables it, 7 clears points and plane.
//
// "set" first clears (CCB Z=7: the old correction must not bend the moves to the new points), then
// for each point moves there (given X/Y/Z) or waits for a `next` call and reads the position ("current"),
// stores it, and enables when asked. The plane reported is z = a*x + b*y + c in micrometres, from
// the positions measured when the points were stored. Firmware only: there is no host-driven path.

#include <array>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "devices/ms2000/build_info.hpp"
#include "gateway/common/json_value.hpp"
#include "gateway/jobs/job_commands.hpp"
#include "gateway/jobs/kinds/job_kinds.hpp"

namespace gw::jobs {

namespace {

using json = nlohmann::json;
using kind = operation_error_kind;

constexpr std::array<char, 3> xyz{'X', 'Y', 'Z'};
constexpr std::chrono::milliseconds point_move_timeout{120000};

operation_error invalid_field(std::string field, std::string message) {
    return make_error(kind::invalid_value, std::move(message), std::move(field));
}

enum class action { set, enable, disable, clear };

struct point_spec {
    std::optional<position_um> given;  // empty: "current" (captured on `next`)
};

struct planar_spec {
    action what = action::set;
    std::vector<point_spec> points;
    bool enable = true;
};

std::string tenths(double um) {
    return std::to_string(std::llround(um * 10.0));
}

operation_result<planar_spec> parse_spec(const json& spec) {
    if (!spec.is_object()) return invalid_field("spec", "must be an object");
    for (const auto& [key, value] : spec.items())
        if (key != "action" && key != "points" && key != "enable" && key != "mode")
            return invalid_field("spec." + key,
                                 "unknown field (planar_correction takes action, points, enable, mode)");
    if (auto m = spec.find("mode"); m != spec.end()) {
        if (!m->is_string() || (*m != "auto" && *m != "firmware" && *m != "host"))
            return invalid_field("spec.mode", "must be \"auto\", \"firmware\" or \"host\"");
        if (*m == "host")
            return invalid_field("spec.mode",
                                 "planar_correction has no host-driven path: the controller's "
                                 "PLANAR CORRECTION module applies the correction");
    }
    planar_spec out;
    auto a = spec.find("action");
    if (a == spec.end() || !a->is_string())
        return invalid_field("spec.action", "required: \"set\", \"enable\", \"disable\" or \"clear\"");
    const auto name = a->get<std::string>();
    if (name == "set")
        out.what = action::set;
    else if (name == "enable")
        out.what = action::enable;
    else if (name == "disable")
        out.what = action::disable;
    else if (name == "clear")
        out.what = action::clear;
    else
        return invalid_field("spec.action", "must be \"set\", \"enable\", \"disable\" or \"clear\"");

    if (out.what != action::set) {
        if (spec.contains("points")) return invalid_field("spec.points", "only with action \"set\"");
        if (spec.contains("enable")) return invalid_field("spec.enable", "only with action \"set\"");
        return out;
    }
    if (auto e = spec.find("enable"); e != spec.end()) {
        if (!e->is_boolean()) return invalid_field("spec.enable", "must be true or false");
        out.enable = e->get<bool>();
    }
    auto points = spec.find("points");
    if (points == spec.end() || !points->is_array() || points->size() != 3)
        return invalid_field("spec.points",
                             "exactly three points: {\"X\":..,\"Y\":..,\"Z\":..} or \"current\"");
    for (std::size_t i = 0; i < 3; ++i) {
        const auto& p = (*points)[i];
        const std::string field = "spec.points[" + std::to_string(i) + "]";
        if (p.is_string() && p == "current") {
            out.points.push_back({});
            continue;
        }
        if (!p.is_object())
            return invalid_field(field, "must be {\"X\":..,\"Y\":..,\"Z\":..} or \"current\"");
        position_um pos;
        for (const auto& [key, value] : p.items()) {
            const auto key_field = fmt::format("{}.{}", field, key);
            if (key.size() != 1 || (key != "X" && key != "Y" && key != "Z"))
                return invalid_field(key_field, "a point has the axes X, Y and Z (micrometres)");
            constexpr double any = std::numeric_limits<double>::max();  // any finite number
            const auto um = read_number(value, -any, any);
            if (!um) return invalid_field(key_field, "must be a number (micrometres)");
            pos[key[0]] = *um.value;
        }
        for (const char axis : xyz)
            if (!pos.contains(axis))
                return invalid_field(field + "." + std::string(1, axis), "required (micrometres)");
        out.points.push_back({std::move(pos)});
    }
    return out;
}

// z = a*x + b*y + c through three points; empty when they lie on one line in XY.
std::optional<std::array<double, 3>> plane_through(const std::array<position_um, 3>& p) {
    const double ux = p[1].at('X') - p[0].at('X'), uy = p[1].at('Y') - p[0].at('Y'),
                 uz = p[1].at('Z') - p[0].at('Z');
    const double vx = p[2].at('X') - p[0].at('X'), vy = p[2].at('Y') - p[0].at('Y'),
                 vz = p[2].at('Z') - p[0].at('Z');
    const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    const double scale = std::max({std::abs(ux), std::abs(uy), std::abs(vx), std::abs(vy), 1.0});
    if (std::abs(nz) < 1e-9 * scale * scale) return std::nullopt;
    const double a = -nx / nz, b = -ny / nz;
    return std::array<double, 3>{a, b, p[0].at('Z') - a * p[0].at('X') - b * p[0].at('Y')};
}

// "CCB Z=<code>": 1..3 store the current position as a point, 4 enables the correction, 5 disables
// it, 7 clears it.
namespace ccb {
constexpr int enable = 4;
constexpr int disable = 5;
constexpr int clear = 7;
}  // namespace ccb

devices::ms2000::command ccb_command(int code) {
    return typed_command("CCB", {set_arg('Z', code, 0)});
}

devices::ms2000::command command_of(action a) {
    switch (a) {
        case action::enable:
            return ccb_command(ccb::enable);
        case action::disable:
            return ccb_command(ccb::disable);
        case action::clear:
        case action::set:
            break;
    }
    return ccb_command(ccb::clear);
}

const char* name_of(action a) {
    switch (a) {
        case action::enable:
            return "enable";
        case action::disable:
            return "disable";
        case action::clear:
            return "clear";
        case action::set:
            break;
    }
    return "set";
}

json point_json(const position_um& p) {
    json out = json::object();
    for (const auto& [axis, um] : p)
        out[std::string(1, axis)] = std::round(um * 10.0) / 10.0;
    return out;
}

}  // namespace

operation_result<job_plan> plan_planar_correction(const json& spec, const plan_context& ctx) {
    auto parsed = parse_spec(spec);
    if (!parsed) return parsed.error();
    const auto& s = ctx.snapshot;
    if (!s.identity || !s.identity->build.has(devices::ms2000::module::planar_correction)) {
        const auto m = devices::ms2000::module::planar_correction;
        return make_error(
            kind::missing_module,
            fmt::format("planar_correction needs the {} firmware module, which {} (build {}) does not "
                        "have",
                        devices::ms2000::module_line(m), s.id,
                        s.identity ? s.identity->build.name : std::string("unknown")),
            std::string(devices::ms2000::module_id(m)));
    }
    job_plan plan;
    plan.path = "firmware";
    if (parsed->what != action::set) {
        plan.steps.push_back({name_of(parsed->what), std::nullopt, 0, false});
        add_preview_command(plan, text_of(command_of(parsed->what)));
        plan.summary = fmt::format("planar correction: {}", name_of(parsed->what));
        return plan;
    }
    for (const char axis : xyz)
        if (s.axis(axis) == nullptr)
            return invalid_field("spec.points",
                                 fmt::format("{} has no {} axis (a plane needs X, Y and Z)", s.id, axis));

    // Where the stage is (for the first move's estimate); unknown after a "current" point.
    std::optional<position_um> at;
    {
        position_um now;
        for (const char axis : xyz)
            if (const auto* a = s.axis(axis); a && a->position_um) now[axis] = *a->position_um;
        if (now.size() == 3) at = now;
    }
    add_preview_command(plan, text_of(ccb_command(ccb::clear)));
    std::size_t given = 0;
    for (std::size_t i = 0; i < 3; ++i) {
        const auto& p = parsed->points[i];
        plan_step step;
        step.name = "point " + std::to_string(i + 1);
        if (p.given) {
            ++given;
            step.target = *p.given;
            if (at) {
                std::vector<axis_delta_mm> deltas;
                for (const char axis : xyz)
                    deltas.push_back(
                        {axis, (p.given->at(axis) - at->at(axis)) / 1000.0, p.given->at(axis) / 1000.0});
                step.estimated_s = ctx.motion.move_seconds(deltas);
            }
            at = *p.given;
            plan.bounds.include(*p.given);
            add_preview_command(plan, fmt::format("M X={} Y={} Z={}", tenths(p.given->at('X')),
                                                  tenths(p.given->at('Y')), tenths(p.given->at('Z'))));
        } else {
            step.waits_for_trigger = true;
            at.reset();
            add_preview_command(plan, "W X Y Z");
        }
        add_preview_command(plan, text_of(ccb_command(static_cast<int>(i) + 1)));
        plan.estimated_s += step.estimated_s;
        plan.steps.push_back(std::move(step));
    }
    if (given == 3) {
        std::array<position_um, 3> pts{*parsed->points[0].given, *parsed->points[1].given,
                                       *parsed->points[2].given};
        if (!plane_through(pts))
            return invalid_field("spec.points", "the three points lie on one line in XY: no plane");
    }
    // The given points against the travel range and the soft limits here, so that a refusal names the
    // point's field (spec.points[i]) rather than the plan step's.
    for (std::size_t i = 0; i < 3; ++i) {
        if (!plan.steps[i].target) continue;
        job_plan one;
        one.steps.push_back(plan.steps[i]);
        if (auto limits = check_soft_limits(one, s); !limits) {
            auto e = limits.error();
            e.field = "spec.points[" + std::to_string(i) + "]";
            return e;
        }
    }
    if (parsed->enable) {
        plan.steps.push_back({"enable", std::nullopt, 0, false});
        add_preview_command(plan, text_of(ccb_command(ccb::enable)));
    }
    plan.summary = fmt::format("planar correction: 3 points ({} given, {} captured on `next`){}", given,
                               3 - given, parsed->enable ? ", then enable" : "");
    return plan;
}

boost::asio::awaitable<void> run_planar_correction(job_context& ctx) {
    auto parsed = parse_spec(ctx.job().spec);
    if (!parsed) throw job_failure(parsed.error());
    const auto& plan = ctx.plan();
    const std::size_t first = ctx.first_step();

    if (parsed->what != action::set) {
        if (first > 0) co_return;  // done before an interruption
        co_await ctx.checkpoint();
        ctx.step_started(0);
        auto line = command_of(parsed->what);  // named: see below
        co_await ctx.command(std::move(line));
        ctx.step_done(0, {{"action", name_of(parsed->what)}});
        co_return;
    }

    // Points stored by an earlier run (a resume): from the job's history.
    std::array<std::optional<position_um>, 3> measured;
    for (const auto& e : ctx.completed_steps()) {
        const auto index = e.value("index", std::size_t{99});
        if (index >= 3 || !e.contains("position") || !e["position"].is_object()) continue;
        position_um p;
        for (const auto& [axis, um] : e["position"].items())
            if (axis.size() == 1 && um.is_number()) p[axis[0]] = um.get<double>();
        measured[index] = std::move(p);
    }

    // Every argument of a co_await is a named variable: g++ 12 mishandles temporaries across it.
    if (first == 0) {
        auto clear = ccb_command(ccb::clear);  // the old plane must not bend the new points
        co_await ctx.command(std::move(clear));
    }
    for (std::size_t i = first; i < 3; ++i) {
        co_await ctx.checkpoint();
        ctx.step_started(i);
        const auto& p = parsed->points[i];
        position_um at;
        if (p.given) {
            move_request m;
            for (const char axis : xyz)
                m.axes.push_back({axis, p.given->at(axis)});
            m.wait = true;
            m.wait_timeout = point_move_timeout;
            const auto result = co_await ctx.move(std::move(m));
            for (const auto& v : result.positions)
                at[v.axis] = v.micrometres;
        } else {
            co_await ctx.wait_advance(advance_source::next);
            auto where = devices::ms2000::where("XYZ");
            const auto reply = co_await ctx.command(std::move(where));
            for (std::size_t k = 0; k < xyz.size(); ++k) {
                const auto tenths_um = reply.number(k);
                if (!tenths_um)
                    throw job_failure(
                        make_error(kind::controller_error, fmt::format("{}: unexpected WHERE reply "
                                                                       "\"{}\"",
                                                                       ctx.job().controller, reply.raw)));
                at[xyz[k]] = *tenths_um / 10.0;
            }
        }
        auto store = ccb_command(static_cast<int>(i) + 1);
        co_await ctx.command(std::move(store));
        measured[i] = at;
        ctx.step_done(i, {{"point", i + 1}, {"position", point_json(at)}});
    }
    bool enabled = false;
    if (parsed->enable && plan.steps.size() > 3 && first <= 3) {
        co_await ctx.checkpoint();
        ctx.step_started(3);
        auto enable = ccb_command(ccb::enable);
        co_await ctx.command(std::move(enable));
        enabled = true;
        ctx.step_done(3, {{"enabled", true}});
    }

    json points = json::array();
    bool complete = true;
    for (const auto& m : measured) {
        if (m && m->size() == 3)
            points.push_back(point_json(*m));
        else
            complete = false;
    }
    json plane = nullptr;
    if (complete) {
        if (auto abc = plane_through({*measured[0], *measured[1], *measured[2]}))
            plane = {{"a", (*abc)[0]}, {"b", (*abc)[1]}, {"c", (*abc)[2]}};
    }
    ctx.emit("plane", {{"points", std::move(points)}, {"plane", std::move(plane)}, {"enabled", enabled}});
}

}  // namespace gw::jobs
