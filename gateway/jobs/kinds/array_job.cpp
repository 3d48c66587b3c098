// The `array` job: a plate or grid of wells visited one by one, either by the controller's ARRAY
// module ("firmware": ARRAY/AHOME, TTL X=7, RM X=0 then RM per well) or by the gateway with one MOVE
// per well ("host"). Each arrival is reported with the well name and the measured position.
//
// Firmware path choices (the seed's ARRAY MODULE section):
//  * The ARRAY module visits wells serpentine only and knows no rotation or subsets; such plans run
//    host-driven (auto) or are refused (mode firmware).
//  * Timer advance is host-timed: the gateway sends RM after each dwell instead of starting the
//    controller's self-scan (ARRAY + RT Z=dwell). A self-scan cannot be held after the current well,
//    and pause must stop there; RM stepping also lets every arrival be confirmed before the next.
//  * `next` advance: one RM per `next` call. TTL advance: on builds with TTL_REPORT_INT, IN0 edges
//    only latch encoder reports (every other IN0 function is off), so the gateway sees each edge
//    through the report port and forwards it as RM; on other builds the controller steps itself on
//    IN0 edges (TTL X=7) and the gateway polls the position until the stage reaches the next well.
//  * A fresh run starts with "RM X=0" (move to (1,1), stop gracefully after the last well; it also
//    clears the ring buffer); a resumed run goes to its first well with "AIJ X=<col> Y=<row>", and RM
//    continues from there.
//  * The TTL OUT0 pulse on arrival is "TTL Y=1" then "TTL Y=0", sent by the gateway after it has
//    confirmed the arrival (OUT0 mode 2, "pulse after a move", is only [I] in the protocol doc).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>

#include "devices/ms2000/command.hpp"
#include "gateway/jobs/job_commands.hpp"
#include "gateway/jobs/kinds/array_spec.hpp"
#include "gateway/jobs/kinds/job_kinds.hpp"
#include "gateway/jobs/kinds/plate.hpp"

namespace gw::jobs {

namespace {

using devices::ms2000::module;
namespace ms = devices::ms2000;

std::string move_text(double x_um, double y_um) {
    const ms::axis_position to[] = {{'X', x_um}, {'Y', y_um}};
    return jobs::move_text(to);
}

ms::command array_setup(const plate_geometry& g) {
    return typed_command("ARRAY", {set_arg('X', g.columns, 0), set_arg('Y', g.rows, 0),
                                   set_arg('Z', g.column_step_mm), set_arg('F', g.row_step_mm)});
}

ms::command ahome(double x_um, double y_um) {
    return typed_command("AHOME", {set_arg('X', x_um / 1000.0), set_arg('Y', y_um / 1000.0)});
}

ms::command aij(well_index w) {
    return typed_command("AIJ", {set_arg('X', w.column + 1, 0), set_arg('Y', w.row + 1, 0)});
}

// "RM X=0": the ARRAY goes to its first well.
ms::command first_well() {
    return typed_command("RM", {set_arg('X', 0, 0)});
}

std::string_view to_text(advance_source a) {
    switch (a) {
        case advance_source::timer:
            return "timer";
        case advance_source::ttl:
            return "ttl";
        case advance_source::next:
            return "next";
    }
    return "timer";
}

bool has(const devices::controller_snapshot& s, module m) {
    return s.identity && s.identity->build.has(m);
}

// Why the ARRAY module cannot run this spec (empty when it can), and the spec field responsible.
struct misfit {
    std::string field;
    std::string reason;
};

std::optional<misfit> firmware_misfit(const array_spec& spec) {
    if (spec.rotation_deg != 0)
        return misfit{"rotation_deg", "the ARRAY module has no rotation (rotation_deg is not 0)"};
    if (!spec.wells.empty()) return misfit{"wells", "the ARRAY module visits every well (a subset is given)"};
    if (spec.order == well_order::raster)
        return misfit{"order", "the ARRAY module visits wells serpentine only (order raster)"};
    return std::nullopt;
}

struct path_choice {
    bool firmware = false;
    std::vector<std::string> warnings;
};

operation_result<path_choice> choose_path(const array_spec& spec, const devices::controller_snapshot& s) {
    path_choice c;
    const bool module_present = has(s, module::array);
    const auto why_not = firmware_misfit(spec);
    switch (spec.mode) {
        case run_mode::firmware:
            if (!module_present)
                return make_error(
                    operation_error_kind::missing_module,
                    fmt::format("mode firmware needs the ARRAY MODULE, which controller {} lacks", s.id),
                    "spec.mode");
            if (why_not)
                return make_error(operation_error_kind::invalid_value,
                                  fmt::format("mode firmware cannot run this plan: {}; use mode host or auto",
                                              why_not->reason),
                                  "spec." + why_not->field);
            c.firmware = true;
            break;
        case run_mode::host:
            break;
        case run_mode::automatic:
            c.firmware = module_present && !why_not;
            if (module_present && why_not) c.warnings.push_back("host-driven: " + why_not->reason);
            break;
    }
    // The gateway sees IN0 edges only as TTL_REPORT frames; without them only the ARRAY module
    // itself can follow TTL triggers.
    if (!c.firmware && spec.advance == advance_source::ttl && !has(s, module::ttl_report))
        return make_error(operation_error_kind::missing_module,
                          fmt::format("advance ttl on the host path needs the TTL_REPORT module (the gateway "
                                      "sees TTL IN0 edges through its report port); controller {} lacks it",
                                      s.id),
                          "spec.advance");
    return c;
}

std::optional<std::pair<double, double>> current_xy(const devices::controller_snapshot& s) {
    const auto* x = s.axis('X');
    const auto* y = s.axis('Y');
    if (!x || !y || !x->position_um || !y->position_um) return std::nullopt;
    return std::pair{*x->position_um, *y->position_um};
}

std::pair<double, double> target_of(std::pair<double, double> a1, const array_spec& spec, well_index w) {
    const auto [dx, dy] = well_offset_um(spec.geometry, w, spec.rotation_deg);
    return {a1.first + dx, a1.second + dy};
}

std::size_t first_visit(const array_spec& spec, const std::vector<well_index>& visits) {
    if (!spec.resume_from) return 0;
    return static_cast<std::size_t>(std::find(visits.begin(), visits.end(), *spec.resume_from) -
                                    visits.begin());
}

// Whether a firmware TTL run forwards IN0 edges as RM (see the file comment).
bool forwards_ttl_edges(const devices::controller_snapshot& s) {
    return has(s, module::ttl_report);
}

}  // namespace

operation_result<job_plan> plan_array(const nlohmann::json& json_spec, const plan_context& ctx) {
    auto parsed = parse_array_spec(json_spec);
    if (!parsed) return parsed.error();
    const array_spec& spec = *parsed;
    const auto& snap = ctx.snapshot;
    if (!snap.axes.empty() && (!snap.axis('X') || !snap.axis('Y')))
        return make_error(operation_error_kind::invalid_value,
                          fmt::format("an array job moves X and Y; controller {} has no X/Y stage", snap.id),
                          "spec");
    auto path = choose_path(spec, snap);
    if (!path) return path.error();

    const auto here = current_xy(snap);
    std::pair<double, double> a1;
    if (spec.a1_um)
        a1 = *spec.a1_um;
    else if (here)
        a1 = *here;
    else
        return make_error(operation_error_kind::invalid_value,
                          "a1 \"current\": the X/Y position of the controller is not known yet", "spec.a1");

    const auto visits = spec.visits();
    const std::size_t first = first_visit(spec, visits);
    const double dwell_s = spec.dwell_ms / 1000.0;

    job_plan plan;
    plan.type = job_type::array;
    plan.path = path->firmware ? "firmware" : "host";
    plan.warnings = path->warnings;
    const int restore_in0 = snap.ttl_in0_mode.value_or(0);

    // Setup.
    if (path->firmware) {
        add_preview_command(plan, text_of(ttl_in0(7)));
        add_preview_command(plan, text_of(array_setup(spec.geometry)));
        add_preview_command(plan, text_of(ahome(a1.first, a1.second)));
        plan.warnings.push_back("firmware path: RM X=0 also clears the controller's ring buffer");
    } else if (spec.advance == advance_source::ttl) {
        add_preview_command(plan, text_of(ttl_in0(1)));  // any non-zero mode enables the TTL_REPORT interrupt
    }

    std::pair<double, double> from = here.value_or(a1);
    for (std::size_t i = 0; i < visits.size(); ++i) {
        plan_step step;
        step.name = well_name(visits[i]);
        if (i < first) {  // done before resume_from: no target, nothing to check or estimate
            plan.steps.push_back(std::move(step));
            continue;
        }
        const auto t = target_of(a1, spec, visits[i]);
        step.target = position_um{{'X', t.first}, {'Y', t.second}};
        step.estimated_s =
            ctx.motion.move_seconds({{'X', (t.first - from.first) / 1000.0, t.first / 1000.0},
                                     {'Y', (t.second - from.second) / 1000.0, t.second / 1000.0}}) +
            dwell_s;
        step.waits_for_trigger = i > first && spec.advance != advance_source::timer;
        plan.estimated_s += step.estimated_s;
        plan.bounds.include(*step.target);
        from = t;

        if (path->firmware) {
            if (i == first)
                add_preview_command(plan, text_of(first == 0 ? first_well() : aij(visits[i])));
            else if (spec.advance != advance_source::ttl || forwards_ttl_edges(snap))
                add_preview_command(plan, "RM");
        } else {
            add_preview_command(plan, move_text(t.first, t.second));
        }
        if (spec.ttl_pulse) {
            add_preview_command(plan, "TTL Y=1");
            add_preview_command(plan, "TTL Y=0");
        }
        plan.steps.push_back(std::move(step));
    }
    if (path->firmware || spec.advance == advance_source::ttl)
        add_preview_command(plan, text_of(ttl_in0(restore_in0)));

    const std::size_t to_visit = visits.size() - first;
    std::string geometry =
        spec.plate ? fmt::format("plate {} ({}x{})", *spec.plate, spec.geometry.columns, spec.geometry.rows)
                   : fmt::format("grid {}x{}", spec.geometry.columns, spec.geometry.rows);
    plan.summary =
        fmt::format("{} wells of {}, {}, {}, {} advance", to_visit, geometry,
                    spec.order == well_order::raster ? "raster" : "serpentine",
                    path->firmware ? "firmware ARRAY module" : "host-driven", to_text(spec.advance));
    if (spec.dwell_ms > 0) plan.summary += fmt::format(", dwell {} ms", spec.dwell_ms);
    if (spec.rotation_deg != 0) plan.summary += fmt::format(", rotated {} deg", spec.rotation_deg);
    if (spec.ttl_pulse) plan.summary += ", TTL pulse on arrival";
    if (first > 0)
        plan.summary += fmt::format(", resuming at {} ({} wells done)", well_name(visits[first]), first);
    if (spec.advance != advance_source::timer)
        plan.warnings.push_back(
            fmt::format("every well after the first waits for {}: the estimate excludes the waits",
                        spec.advance == advance_source::ttl ? "a TTL IN0 edge" : "a next call"));
    return plan;
}

namespace {

constexpr std::chrono::milliseconds arrival_poll{25};

position_um measured_xy(const ms::reply& r) {
    position_um p;
    const auto x = r.number(0), y = r.number(1);
    if (x) p['X'] = *x / 10.0;
    if (y) p['Y'] = *y / 10.0;
    return p;
}

nlohmann::json to_json(const position_um& p) {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& [axis, um] : p)
        j[std::string(1, axis)] = std::round(um * 10.0) / 10.0;
    return j;
}

// Waits until the stage stopped and reads X/Y.
boost::asio::awaitable<position_um> arrival(job_context& ctx, std::chrono::milliseconds timeout) {
    co_await ctx.wait_idle(timeout);
    const auto r = co_await ctx.command(ms::where("XY"));
    co_return measured_xy(r);
}

// The controller steps on its own (firmware, TTL, no TTL_REPORT): polls until X/Y are within
// `tolerance_um` of the target, then waits for the stage to stop.
boost::asio::awaitable<position_um> controller_arrival(job_context& ctx, std::pair<double, double> target,
                                                       double tolerance_um,
                                                       std::chrono::milliseconds timeout) {
    for (;;) {
        const auto r = co_await ctx.command(ms::where("XY"));
        const auto p = measured_xy(r);
        if (p.contains('X') && p.contains('Y') && std::abs(p.at('X') - target.first) <= tolerance_um &&
            std::abs(p.at('Y') - target.second) <= tolerance_um) {
            auto at = co_await arrival(ctx, timeout);
            co_return at;
        }
        co_await ctx.sleep(arrival_poll);
    }
}

// A1 of an earlier run of this job, from the "target" of one of its step events.
std::optional<std::pair<double, double>> a1_from_history(const std::vector<nlohmann::json>& steps,
                                                         const array_spec& spec) {
    for (auto it = steps.rbegin(); it != steps.rend(); ++it) {
        const auto& e = *it;
        if (!e.is_object() || !e.contains("well") || !e.contains("target") || !e["well"].is_string())
            continue;
        const auto& t = e["target"];
        if (!t.is_object() || !t.contains("X") || !t.contains("Y") || !t["X"].is_number() ||
            !t["Y"].is_number())
            continue;
        const auto well = parse_well(e["well"].get<std::string>(), spec.geometry);
        if (!well) continue;
        const auto [dx, dy] = well_offset_um(spec.geometry, *well, spec.rotation_deg);
        return std::pair{t["X"].get<double>() - dx, t["Y"].get<double>() - dy};
    }
    return std::nullopt;
}

}  // namespace

boost::asio::awaitable<void> run_array(job_context& ctx) {
    auto parsed = parse_array_spec(ctx.job().spec);
    if (!parsed) throw job_failure(parsed.error());
    const array_spec& spec = *parsed;
    const job_plan& plan = ctx.plan();
    const auto visits = spec.visits();
    if (visits.size() != plan.steps.size())
        throw job_failure(
            make_error(operation_error_kind::internal, "array plan and spec disagree on the wells"));
    const std::size_t first = std::max(ctx.first_step(), first_visit(spec, visits));
    if (first >= visits.size()) co_return;
    const bool firmware = plan.path == "firmware";
    const auto start_snapshot = ctx.snapshot();
    const bool changes_in0 = firmware || spec.advance == advance_source::ttl;

    // A1: given; or "current" = where the stage is when a fresh job starts; a resumed job keeps the
    // A1 its plan was made with (the stage has moved since).
    std::pair<double, double> a1{0, 0};
    if (spec.a1_um) {
        a1 = *spec.a1_um;
    } else if (ctx.first_step() == 0 && !spec.resume_from) {
        const auto r = co_await ctx.command(ms::where("XY"));
        const auto p = measured_xy(r);
        if (!p.contains('X') || !p.contains('Y'))
            throw job_failure(
                make_error(operation_error_kind::controller_error, "W X Y gave no X/Y position"));
        a1 = {p.at('X'), p.at('Y')};
    } else if (auto from_history = a1_from_history(ctx.completed_steps(), spec)) {
        a1 = *from_history;  // the A1 the earlier run measured from (a re-plan may have moved it)
    } else {
        const auto& t = plan.steps[first].target;
        if (!t || !t->contains('X') || !t->contains('Y'))
            throw job_failure(
                make_error(operation_error_kind::internal, "array plan has no target for its first well"));
        const auto [dx, dy] = well_offset_um(spec.geometry, visits[first], spec.rotation_deg);
        a1 = {t->at('X') - dx, t->at('Y') - dy};
    }
    std::vector<std::pair<double, double>> targets;
    job_plan checked;  // the targets as they will be visited, checked against the soft limits again
    for (std::size_t i = 0; i < visits.size(); ++i) {
        targets.push_back(target_of(a1, spec, visits[i]));
        plan_step s;
        s.name = well_name(visits[i]);
        if (i >= first) s.target = position_um{{'X', targets.back().first}, {'Y', targets.back().second}};
        checked.steps.push_back(std::move(s));
    }
    if (auto limits = check_soft_limits(checked, start_snapshot); !limits) throw job_failure(limits.error());

    const auto timeout = std::chrono::milliseconds(120000);
    const auto dwell = std::chrono::milliseconds(static_cast<long long>(std::llround(spec.dwell_ms)));
    const bool controller_steps =
        firmware && spec.advance == advance_source::ttl && !forwards_ttl_edges(start_snapshot);
    // Half the smaller pitch: a position this close to a well belongs to it.
    const double tolerance_um = std::max(
        1.0,
        0.5 * 1000.0 * std::min(std::abs(spec.geometry.column_step_mm), std::abs(spec.geometry.row_step_mm)));

    // IN0 goes back to its mode after the run; after a cancel or a failure the manager does it.
    int restore_in0 = 0;
    if (changes_in0) {
        restore_in0 = co_await in0_mode_before(ctx);
        ctx.restore_if_stopped(text_of(ttl_in0(restore_in0)));
    }
    if (firmware) {
        // Named lines, never temporaries in a co_await expression (g++ 12 coroutine temporaries).
        const std::vector<ms::command> setup{ttl_in0(7), array_setup(spec.geometry),
                                             ahome(a1.first, a1.second)};
        for (const auto& c : setup)
            co_await ctx.command(c);
    } else if (spec.advance == advance_source::ttl) {
        auto in0 = ttl_in0(1);
        co_await ctx.command(std::move(in0));
    }

    for (std::size_t i = first; i < visits.size(); ++i) {
        co_await ctx.checkpoint();
        if (i > first && !controller_steps) {
            co_await ctx.wait_advance(spec.advance);  // timer: returns at once (the dwell was the wait)
            co_await ctx.checkpoint();
        }
        ctx.step_started(i);
        position_um measured;
        if (!firmware) {
            move_request m;
            m.axes = {{'X', targets[i].first}, {'Y', targets[i].second}};
            m.wait = true;
            m.wait_timeout = timeout;
            const auto r = co_await ctx.move(std::move(m));
            for (const auto& a : r.positions)
                measured[a.axis] = a.micrometres;
        } else if (i == first) {
            auto start = i == 0 ? first_well() : aij(visits[i]);
            co_await ctx.command(std::move(start));
            measured = co_await arrival(ctx, timeout);
        } else if (controller_steps) {
            // The controller moves on the edge by itself: until the stage arrives, the job waits for it.
            ctx.set_waiting(job_wait::ttl);
            measured = co_await controller_arrival(ctx, targets[i], tolerance_um, timeout);
            ctx.set_waiting(std::nullopt);
        } else {
            co_await ctx.command(typed_command("RM"));
            measured = co_await arrival(ctx, timeout);
        }
        if (spec.ttl_pulse) {
            co_await ctx.command(ttl_output(true));
            co_await ctx.command(ttl_output(false));
        }
        if (dwell.count() > 0) co_await ctx.dwell(dwell);
        ctx.step_done(i,
                      {{"well", well_name(visits[i])},
                       {"position", to_json(measured)},
                       {"target", to_json(position_um{{'X', targets[i].first}, {'Y', targets[i].second}})}});
    }
    if (changes_in0) {
        auto restore = ttl_in0(restore_in0);
        co_await ctx.command(std::move(restore));
    }
}

}  // namespace gw::jobs
