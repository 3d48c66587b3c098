// The `ring_buffer` job: a tour of up to the buffer's capacity of positions, run by the controller's
// RING BUFFER module ("firmware": RM X=0, LD per position, RM Y=mask Z=pointer F=mode, then TTL X=1,
// RM or autoplay; doc §3.3) or by the gateway with one MOVE per position ("host").
// Steps are "position k" ("tour t position k" with cycles > 1); each arrival is a step event with
// the slot, the tour and the position (measured when the gateway saw the stage stand there).
//
// Firmware path choices:
//  * Progress comes from the buffer pointer: "RM Z? F?" (pointer = index of the next move; the MSB of
//    F is set while autoplaying) and "/" every 20 ms. The pointer advancing past slot k means the
//    move to k has started; k is reached when the pointer is past k+1, or it is the latest move and
//    the stage stands ("/" N). The position is then read with W; when a poll saw a later move
//    already under way, the planned position is reported with "measured": false.
//  * Autoplay once: RT Z=delay, RM F=2, RM. With cycles > 1 every tour is one-shot autoplay started
//    again by the gateway (RM Z=0, RM) after the delay, so tours are counted exactly and pause takes
//    effect between tours. repeat without cycles (until cancelled) uses repeating autoplay (F=3) and
//    can only be cancelled, not paused.
//  * TTL trigger: TTL X=1 (IN0 mode 1, "move to the next ring-buffer position"), the controller steps
//    on each IN0 edge; IN0 goes back to its previous mode after each tour, which is when a pause takes
//    effect. A tour of one position cannot be followed by the pointer, and on TTL_REPORT_INT builds
//    IN0 only latches reports: both run host-driven.
//  * `next`: TTL X=1, then one "RM" (an IN0 pulse in the current IN0 mode) per `next` call.
//  * After a cancel or a failure the manager sets IN0 back to its previous mode
//    (job_context::restore_if_stopped), so later IN0 edges do not move the stage.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <fmt/format.h>
#include <optional>

#include "devices/ms2000/command.hpp"
#include "gateway/jobs/job_commands.hpp"
#include "gateway/jobs/job_json.hpp"
#include "gateway/jobs/kinds/job_kinds.hpp"
#include "gateway/jobs/kinds/ring_buffer_spec.hpp"

namespace gw::jobs {

namespace {

namespace ms = devices::ms2000;
using devices::ms2000::module;
using trigger_kind = ring_buffer_spec::trigger_kind;
using std::chrono::milliseconds;

constexpr milliseconds tour_follow_poll{20};

std::size_t capacity_of(const devices::controller_snapshot& s) {
    if (has_module(s, module::ring_buffer) && s.identity->build.ring_buffer_size > 0)
        return static_cast<std::size_t>(s.identity->build.ring_buffer_size);
    return default_ring_buffer_capacity;
}

struct rb_setup {
    ring_buffer_spec spec;
    bool firmware = false;
    int axis_byte = 0;
    std::string hardware_axes;  // the mask's axes in hardware order (W answers in this order)
};

// Why the firmware cannot run this spec (empty: it can).
std::string firmware_unfit(const ring_buffer_spec& spec, const devices::controller_snapshot& s) {
    if (spec.trigger != trigger_kind::autoplay && has_module(s, module::ttl_report))
        return "on a TTL_REPORT_INT build TTL IN0 only latches encoder reports, so it cannot step the ring "
               "buffer";
    if (spec.trigger == trigger_kind::ttl && spec.positions.size() < 2)
        return "a TTL tour of one position cannot be followed by the buffer pointer";
    return {};
}

operation_result<rb_setup> resolve_ring_buffer(const nlohmann::json& json,
                                               const devices::controller_snapshot& s) {
    auto spec = parse_ring_buffer_spec(json);
    if (!spec) return spec.error();
    rb_setup u{*spec, false, 0, {}};
    for (char a : u.spec.axes) {
        const int index = axis_index(s, a);
        if (index < 0)
            return make_error(operation_error_kind::invalid_value,
                              fmt::format("axis {} is not a motor axis of {} ({})", a, s.id, motor_axes(s)),
                              "spec.axes");
        if (index < 8) u.axis_byte |= 1 << index;
    }
    for (const auto& a : s.axes)
        if (u.spec.axes.find(a.axis) != std::string::npos) u.hardware_axes += a.axis;
    const std::size_t capacity = capacity_of(s);
    if (u.spec.positions.size() > capacity)
        return make_error(operation_error_kind::invalid_value,
                          fmt::format("{} positions: the ring buffer of {} holds {}", u.spec.positions.size(),
                                      s.id, capacity),
                          "spec.positions");
    const bool module_present = has_module(s, module::ring_buffer);
    const auto unfit = firmware_unfit(u.spec, s);
    switch (u.spec.mode) {
        case ring_buffer_spec::path_mode::firmware:
            if (!module_present)
                return make_error(operation_error_kind::missing_module,
                                  fmt::format("{} has no RING BUFFER (mode firmware)", s.id), "spec.mode");
            if (!unfit.empty())
                return make_error(operation_error_kind::invalid_value,
                                  fmt::format("mode firmware: {}", unfit), "spec.trigger");
            u.firmware = true;
            break;
        case ring_buffer_spec::path_mode::automatic:
            u.firmware = module_present && unfit.empty();
            break;
        case ring_buffer_spec::path_mode::host:
            break;
    }
    return u;
}

std::string step_name(const ring_buffer_spec& spec, int tour, std::size_t slot) {
    if (spec.tours() > 1) return fmt::format("tour {} position {}", tour + 1, slot + 1);
    return fmt::format("position {}", slot + 1);
}

ms::command load_command(const rb_setup& u, const position_um& p) {
    std::vector<ms::argument> args;
    for (char a : u.hardware_axes)
        args.push_back(set_arg(a, p.at(a) * 10.0, 1));  // tenths of a micron
    return typed_command("LD", args);
}

std::string move_command(const rb_setup& u, const position_um& p) {
    std::vector<ms::axis_position> to;
    for (char a : u.hardware_axes)
        to.push_back({a, p.at(a)});
    return move_text(to);
}

int firmware_mode(const ring_buffer_spec& spec) {
    if (spec.trigger != trigger_kind::autoplay) return 1;  // TTL-triggered (RM steps like a pulse)
    return spec.forever() && spec.positions.size() >= 2 ? 3 : 2;
}

ms::command rbmode_command(const rb_setup& u, std::size_t pointer) {
    return typed_command("RM", {set_arg('Y', u.axis_byte, 0), set_arg('Z', static_cast<double>(pointer), 0),
                                set_arg('F', firmware_mode(u.spec), 0)});
}

// "RM X=0": the ring buffer emptied.
ms::command clear_buffer() {
    return typed_command("RM", {set_arg('X', 0, 0)});
}

ms::command rt_delay_command(double delay_ms) {
    return typed_command("RT", {set_arg('Z', delay_ms, 0)});
}

ms::command pointer_command(std::size_t pointer) {
    return typed_command("RM", {set_arg('Z', static_cast<double>(pointer), 0)});
}

}  // namespace

operation_result<job_plan> plan_ring_buffer(const nlohmann::json& json, const plan_context& ctx) {
    const auto& s = ctx.snapshot;
    auto setup = resolve_ring_buffer(json, s);
    if (!setup) return setup.error();
    const auto& u = *setup;
    const auto& spec = u.spec;
    const std::size_t n = spec.positions.size();

    job_plan plan;
    plan.type = job_type::ring_buffer;
    plan.path = u.firmware ? "firmware" : "host";
    const bool triggered = spec.trigger != trigger_kind::autoplay;

    position_um from;
    for (const auto& a : s.axes)
        if (a.position_um) from[a.axis] = *a.position_um;
    for (int tour = 0; tour < spec.tours(); ++tour) {
        for (std::size_t k = 0; k < n; ++k) {
            const auto& to = spec.positions[k];
            std::vector<axis_delta_mm> d;
            for (const auto& [axis, um] : to)
                if (auto it = from.find(axis); it != from.end())
                    d.push_back({axis, (um - it->second) / 1000.0, um / 1000.0});
            plan_step step;
            step.name = step_name(spec, tour, k);
            step.target = to;
            step.waits_for_trigger = triggered;
            step.estimated_s = ctx.motion.move_seconds(d) + (tour > 0 || k > 0 ? spec.delay_ms / 1000.0 : 0);
            plan.estimated_s += step.estimated_s;
            plan.steps.push_back(std::move(step));
            for (const auto& [axis, um] : to)
                from[axis] = um;
        }
    }
    for (const auto& p : spec.positions)
        plan.bounds.include(p);

    const char* trigger_text = spec.trigger == trigger_kind::autoplay ? "autoplay"
                               : spec.trigger == trigger_kind::ttl    ? "TTL-triggered"
                                                                      : "`next`-triggered";
    const std::string tours_text = spec.forever()     ? "repeating until cancelled"
                                   : spec.cycles == 1 ? "once"
                                                      : fmt::format("{} tours", spec.cycles);
    if (u.firmware) {
        add_preview_command(plan, "RM X=0");
        for (const auto& p : spec.positions)
            add_preview_command(plan, text_of(load_command(u, p)));
        add_preview_command(plan, text_of(rbmode_command(u, 0)));
        if (spec.trigger == trigger_kind::autoplay) {
            add_preview_command(plan, text_of(rt_delay_command(spec.delay_ms)));
            if (firmware_mode(spec) == 3) {
                add_preview_command(plan, "RM");
            } else {
                for (int tour = 0; tour < spec.tours(); ++tour) {
                    if (tour > 0) add_preview_command(plan, "RM Z=0");
                    add_preview_command(plan, "RM");
                }
            }
        } else {
            for (int tour = 0; tour < spec.tours(); ++tour) {
                add_preview_command(plan, "TTL X=1");
                if (spec.trigger == trigger_kind::next)
                    for (std::size_t k = 0; k < n; ++k)
                        add_preview_command(plan, "RM");
                add_preview_command(plan, ttl_in0_command(s.ttl_in0_mode.value_or(0)));
            }
        }
        if (spec.forever() && firmware_mode(spec) == 3)
            plan.warnings.push_back(
                "repeating autoplay runs until cancelled and cannot be paused; progress "
                "restarts with every tour");
        else if (spec.trigger == trigger_kind::autoplay)
            plan.warnings.push_back(
                "pause takes effect at the end of a tour: the controller plays a tour by itself");
        else if (spec.trigger == trigger_kind::ttl)
            plan.warnings.push_back(
                "pause takes effect at the end of a tour: the controller follows IN0 by itself");
    } else {
        for (int tour = 0; tour < spec.tours(); ++tour)
            for (const auto& p : spec.positions)
                add_preview_command(plan, move_command(u, p));
        if (spec.forever())
            plan.warnings.push_back("repeats until cancelled; progress restarts with every tour");
        if (spec.mode == ring_buffer_spec::path_mode::automatic) {
            if (!has_module(s, module::ring_buffer))
                plan.warnings.push_back(
                    fmt::format("{} has no RING BUFFER: the gateway moves to each position", s.id));
            else if (auto why = firmware_unfit(spec, s); !why.empty())
                plan.warnings.push_back(fmt::format("host-driven: {}", why));
        }
    }
    plan.summary =
        fmt::format("{} positions ({}), {}, {}{}, {}", n, spec.axes, trigger_text, tours_text,
                    spec.trigger == trigger_kind::autoplay ? fmt::format(", {:g} ms delay", spec.delay_ms)
                                                           : std::string(),
                    u.firmware ? "RING BUFFER module" : "host-driven");
    return plan;
}

namespace {

// Built outside the coroutines: g++ 12 miscompiles braced json initialisers with string literals in
// a coroutine body ("array used as initializer").
nlohmann::json arrival_detail(std::size_t slot, int tour, const position_um& p, bool measured) {
    nlohmann::json j = nlohmann::json::object();
    j["slot"] = slot + 1;
    j["tour"] = tour + 1;
    j["position"] = measured_position_json(p);
    j["measured"] = measured;
    return j;
}

boost::asio::awaitable<position_um> where(job_context& ctx, const std::string& axes) {
    auto reply = co_await ctx.command(ms::where(axes));
    position_um out;
    for (std::size_t i = 0; i < axes.size(); ++i) {
        const auto v = reply.number(i);
        if (!v)
            throw job_failure(make_error(operation_error_kind::controller_error,
                                         fmt::format("unexpected WHERE reply \"{}\"", reply.raw)));
        out[axes[i]] = *v / 10.0;
    }
    co_return out;
}

struct buffer_state {
    std::size_t pointer = 0;
    bool autoplaying = false;
};

boost::asio::awaitable<buffer_state> read_buffer(job_context& ctx) {
    auto reply = co_await ctx.command(ms::query("RM", "ZF"));
    const auto* z = reply.axis('Z');
    const auto* f = reply.axis('F');
    if (!z || !z->number || !f || !f->number)
        throw job_failure(make_error(operation_error_kind::controller_error,
                                     fmt::format("unexpected RBMODE reply \"{}\"", reply.raw)));
    co_return buffer_state{static_cast<std::size_t>(std::max(0.0, *z->number)),
                           (static_cast<int>(*f->number) & 0x80) != 0};
}

boost::asio::awaitable<bool> stage_busy(job_context& ctx) {
    auto reply = co_await ctx.command(ms::status());
    co_return reply.what == devices::ms2000::reply::kind::status&& reply.busy;
}

// Follows the controller through the moves of one tour from `first_slot` (count = n - first_slot),
// or forever (repeating autoplay). Reports arrivals as steps (the slot's step in tour `tour`).
struct follow_request {
    int tour = 0;
    std::size_t first_slot = 0;
    bool one_shot = false;  // autoplay F=2: the tour ends when autoplay ends
    bool forever = false;   // autoplay F=3: step indexes restart with every tour
};

boost::asio::awaitable<void> follow(job_context& ctx, const rb_setup& u, follow_request r) {
    const std::size_t n = u.spec.positions.size();
    const std::size_t count = n - r.first_slot;
    std::size_t started = 0;   // moves started since the tour began (from the pointer's advance)
    std::size_t reported = 0;  // arrivals reported
    std::size_t last_pointer = r.first_slot;
    const auto report = [&](std::size_t j, const position_um& p, bool measured) {
        const std::size_t global = r.first_slot + j;
        const std::size_t slot = global % n;
        const int tour = r.tour + static_cast<int>(global / n);
        const std::size_t index =
            r.forever ? slot : static_cast<std::size_t>(r.tour) * n + global;  // plan step
        ctx.step_done(index, arrival_detail(slot, tour, p, measured));
        ctx.step_started(r.forever ? (slot + 1) % n : std::min(index + 1, ctx.plan().steps.size() - 1));
    };
    for (;;) {
        const auto before = co_await read_buffer(ctx);
        started += (before.pointer + n - last_pointer % n) % n;
        last_pointer = before.pointer;
        if (r.one_shot && !before.autoplaying) started = count;  // autoplay ended after the last slot
        if (!r.forever) started = std::min(started, count);
        const bool busy = co_await stage_busy(ctx);
        std::optional<position_um> measured;
        if (!busy && started > reported) {
            auto p = co_await where(ctx, u.hardware_axes);
            const auto after = co_await read_buffer(ctx);
            if (after.pointer == before.pointer && after.autoplaying == before.autoplaying) measured = p;
        }
        // Every started move but the latest has arrived; the latest has when the stage stands.
        const std::size_t arrived = busy ? (started > 0 ? started - 1 : 0) : started;
        for (; reported < arrived; ++reported) {
            const bool latest = reported + 1 == arrived && measured;
            report(reported, latest ? *measured : u.spec.positions[(r.first_slot + reported) % n], latest);
        }
        if (!r.forever && reported >= count) co_return;
        co_await ctx.sleep(tour_follow_poll);
    }
}

boost::asio::awaitable<void> run_firmware(job_context& ctx, const rb_setup& u) {
    const auto& spec = u.spec;
    const std::size_t n = spec.positions.size();
    const std::size_t first = ctx.first_step();
    co_await ctx.command(clear_buffer());
    for (const auto& p : spec.positions)
        co_await ctx.command(load_command(u, p));
    const std::size_t first_tour = spec.forever() ? 0 : first / n;
    const std::size_t first_slot = first % n;
    co_await ctx.command(rbmode_command(u, first_slot));

    if (spec.trigger == trigger_kind::autoplay) {
        co_await ctx.command(rt_delay_command(spec.delay_ms));
        if (firmware_mode(spec) == 3) {
            co_await ctx.checkpoint();
            co_await ctx.command(typed_command("RM"));
            co_await follow(ctx, u, {0, first_slot, false, true});
            co_return;  // not reached: follows until cancelled
        }
        for (auto tour = first_tour;; ++tour) {
            if (!spec.forever() && tour >= static_cast<std::size_t>(spec.tours())) break;
            co_await ctx.checkpoint();
            const std::size_t slot = tour == first_tour ? first_slot : 0;
            if (tour != first_tour) {
                co_await ctx.dwell(milliseconds(static_cast<long long>(spec.delay_ms)));
                co_await ctx.command(pointer_command(0));
            }
            ctx.step_started(spec.forever() ? slot : tour * n + slot);
            co_await ctx.command(typed_command("RM"));
            co_await follow(ctx, u, {spec.forever() ? 0 : static_cast<int>(tour), slot, true, false});
        }
        co_return;
    }

    const int previous_in0 = co_await in0_mode_before(ctx);
    for (auto tour = first_tour;; ++tour) {
        if (!spec.forever() && tour >= static_cast<std::size_t>(spec.tours())) break;
        co_await ctx.checkpoint();
        const std::size_t slot = tour == first_tour ? first_slot : 0;
        const std::size_t base = spec.forever() ? 0 : tour * n;
        if (tour != first_tour) co_await ctx.command(pointer_command(0));
        ctx.restore_if_stopped(ttl_in0_command(previous_in0));
        co_await ctx.command(ttl_in0(1));
        if (spec.trigger == trigger_kind::ttl) {
            ctx.step_started(base + slot);
            // The controller steps on each edge by itself; the run follows it, waiting for the edges.
            ctx.set_waiting(job_wait::ttl);
            co_await follow(ctx, u, {spec.forever() ? 0 : static_cast<int>(tour), slot, false, false});
            ctx.set_waiting(std::nullopt);
        } else {
            for (std::size_t k = slot; k < n; ++k) {
                if (k != slot) co_await ctx.checkpoint();
                ctx.step_started(base + k);
                co_await ctx.wait_advance(advance_source::next);
                co_await ctx.command(typed_command("RM"));
                co_await ctx.wait_idle(milliseconds(60'000));
                auto p = co_await where(ctx, u.hardware_axes);
                ctx.step_done(base + k, arrival_detail(k, static_cast<int>(tour), p, true));
            }
        }
        co_await ctx.command(ttl_in0(previous_in0));
    }
}

boost::asio::awaitable<void> run_ring_buffer_host(job_context& ctx, const rb_setup& u) {
    const auto& spec = u.spec;
    const std::size_t n = spec.positions.size();
    const std::size_t first = ctx.first_step();
    bool moved = false;
    for (std::size_t tour = spec.forever() ? 0 : first / n;; ++tour) {
        if (!spec.forever() && tour >= static_cast<std::size_t>(spec.tours())) break;
        for (std::size_t k = 0; k < n; ++k) {
            const std::size_t index = spec.forever() ? k : tour * n + k;
            if ((spec.forever() ? tour * n + k : index) < first) continue;
            co_await ctx.checkpoint();
            ctx.step_started(index);
            if (spec.trigger == trigger_kind::ttl) co_await ctx.wait_advance(advance_source::ttl);
            if (spec.trigger == trigger_kind::next) co_await ctx.wait_advance(advance_source::next);
            if (spec.trigger == trigger_kind::autoplay && moved)
                co_await ctx.dwell(milliseconds(static_cast<long long>(spec.delay_ms)));
            move_request request;
            request.wait = true;
            for (char a : u.hardware_axes)
                request.axes.push_back({a, spec.positions[k].at(a)});
            auto done = co_await ctx.move(std::move(request));
            moved = true;
            position_um measured;
            for (const auto& p : done.positions)
                if (spec.axes.find(p.axis) != std::string::npos) measured[p.axis] = p.micrometres;
            ctx.step_done(index, arrival_detail(k, static_cast<int>(tour), measured, true));
        }
    }
}

}  // namespace

boost::asio::awaitable<void> run_ring_buffer(job_context& ctx) {
    auto setup = resolve_ring_buffer(ctx.job().spec, ctx.snapshot());
    if (!setup) throw job_failure(setup.error());
    auto u = *setup;
    u.firmware = ctx.plan().path == "firmware";
    if (u.firmware)
        co_await run_firmware(ctx, u);
    else
        co_await run_ring_buffer_host(ctx, u);
}

}  // namespace gw::jobs
