// The `gcode` job: a G-code program (gateway/gcode, the Tracer subset) traced by the host as
// coordinated straight segments (gcode_trace.hpp), with dwells and TTL/analog switches exactly
// between the planned segments. Steps are the program lines that move, dwell or switch
// (gcode_spec.hpp); each finished line is a step event with its planned end position.
//
// Choices:
//  * Program coordinates are the controller's own (millimetres; X, Y and, with z_mode axis, Z).
//    An axis the program never moves is never commanded (a 2-D program leaves Z alone).
//  * Every planned position (each move's end and each arc's extremes, which contain its chords) is
//    checked against the soft limits; the first offending line is named. Memory stays bounded: the
//    program is planned as a stream, nothing per segment is kept.
//  * A run starts with "TTL Y=0" (the program's initial state). A feed move, dwell or switch needs
//    the stage where the plan has it: if it is elsewhere (the first move of a run, a resume, after a
//    pause) the stage first moves there at the rapid speed, TTL off. A first rapid move goes from
//    wherever the stage is, as on any CNC.
//  * Pause takes effect between lines; a TTL output that is on is switched off while paused and on
//    again after the stage is back where the next line starts. Resume after the run ended (a
//    disconnect) plans the program again from its start, replays the modal state (TTL, analog
//    output) of the lines already done without moving, and continues with the next line.
//  * Cancel: the manager sends HALT and "TTL Y=0". "TTL Y=0" and the original SPEEDs are also
//    registered with restore_if_stopped (a failure), and the manager sends "TTL Y=0" when a
//    controller that paused a job by disconnecting comes back (job_recovery).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <fstream>
#include <memory>
#include <numbers>
#include <sstream>

#include "gateway/gcode/gcode_planner.hpp"
#include "gateway/jobs/job_commands.hpp"
#include "gateway/jobs/kinds/gcode_spec.hpp"
#include "gateway/jobs/kinds/gcode_trace.hpp"
#include "gateway/jobs/kinds/job_kinds.hpp"
#include "gateway/storage/gcode_files.hpp"

namespace gw::jobs {

namespace {

namespace gc = gcode;
using devices::ms2000::module;
using std::chrono::milliseconds;

constexpr char axis_letters[3] = {'X', 'Y', 'Z'};
// Closer than this to where a line starts, the stage needs no approach move.
constexpr double approach_tolerance_mm = 0.0005;

double coordinate(const gc::vec3& p, int i) {
    return i == 0 ? p.x : i == 1 ? p.y : p.z;
}

struct program_source {
    std::unique_ptr<std::istream> stream;
};

// The inline text, or the uploaded file (gcode_file_store in `files`).
operation_result<program_source> open_program(const gcode_spec& spec, const std::filesystem::path& files) {
    if (spec.program) return program_source{std::make_unique<std::istringstream>(*spec.program)};
    if (files.empty())
        return make_error(operation_error_kind::invalid_value,
                          "this gateway keeps no uploaded programs (no storage path); send the text as "
                          "\"program\"",
                          "spec.file");
    gcode_file_store store(gcode_file_store_settings{files});
    auto path = store.path_of(*spec.file);
    if (!path) return make_error(operation_error_kind::invalid_value, path.error().message, "spec.file");
    auto in = std::make_unique<std::ifstream>(*path, std::ios::binary);
    if (!*in)
        return make_error(operation_error_kind::invalid_value,
                          fmt::format("the uploaded program {} cannot be read", *spec.file), "spec.file");
    return program_source{std::move(in)};
}

operation_error program_error(const gcode_spec& spec, const gc::gcode_error& e) {
    return make_error(
        operation_error_kind::invalid_value,
        e.line > 0 ? fmt::format("line {}, column {}: {}", e.line, e.column, e.message) : e.message,
        gcode_source_field(spec));
}

// The stage axes the program can drive, with their speed limits.
std::map<char, axis_speed_range> speed_ranges(const motion_model& motion, bool z_axis) {
    std::map<char, axis_speed_range> out;
    for (const char a : axis_letters) {
        if (a == 'Z' && !z_axis) continue;
        const double top = motion.axis(a).max_speed_mm_s;
        out[a] = {top * min_speed_fraction, top};
    }
    return out;
}

// Soft limits and travel range per axis, in micrometres.
struct axis_window {
    double lo_um = -max_travel_um;
    double hi_um = max_travel_um;
    bool present = true;
};

// Groups the program lines into at most max_gcode_steps steps as they stream by: when the list is
// full, neighbours are merged pairwise and each step holds twice as many lines from then on.
class step_builder {
  public:
    struct step {
        int first_line = 0;
        int last_line = 0;
        int lines = 0;
        gc::vec3 end;
        double estimated_s = 0;
    };

    void add(const gc::planned_move& m) {
        if (!steps_.empty() && steps_.back().last_line == m.line) {
            steps_.back().end = m.end;
            steps_.back().estimated_s += m.estimated_s;
            return;
        }
        if (!steps_.empty() && steps_.back().lines < lines_per_step_) {
            auto& s = steps_.back();
            s.last_line = m.line;
            ++s.lines;
            s.end = m.end;
            s.estimated_s += m.estimated_s;
            return;
        }
        if (steps_.size() == max_gcode_steps) halve();
        steps_.push_back({m.line, m.line, 1, m.end, m.estimated_s});
    }
    const std::vector<step>& steps() const { return steps_; }

  private:
    void halve() {
        std::vector<step> merged;
        merged.reserve(steps_.size() / 2 + 1);
        for (std::size_t i = 0; i < steps_.size(); i += 2) {
            step s = steps_[i];
            if (i + 1 < steps_.size()) {
                const auto& t = steps_[i + 1];
                s.last_line = t.last_line;
                s.lines += t.lines;
                s.end = t.end;
                s.estimated_s += t.estimated_s;
            }
            merged.push_back(s);
        }
        steps_ = std::move(merged);
        lines_per_step_ *= 2;
    }

    std::vector<step> steps_;
    int lines_per_step_ = 1;
};

// The moves' arcs reach beyond their end points at multiples of 90 degrees in their plane.
template <typename F>
void for_each_extreme(const gc::planned_move& m, F&& f) {
    f(m.end);
    if (m.kind != gc::move_kind::arc || m.arc.sweep == 0) return;
    const double step = std::numbers::pi / 2;
    const double a0 = m.arc.start_angle;
    const double a1 = a0 + m.arc.sweep;
    for (double k = std::ceil(std::min(a0, a1) / step); k * step <= std::max(a0, a1); k += 1)
        f(gc::arc_point(m.arc, (k * step - a0) / m.arc.sweep));
}

// Marks the axes the move drives: a coordinate other than zero (every axis starts at zero in the
// plan) at its start, end or an arc's extremes.
void mark_driven(const gc::planned_move& m, bool used[3]) {
    const auto mark = [&](const gc::vec3& p) {
        for (int i = 0; i < 3; ++i)
            if (coordinate(p, i) != 0) used[i] = true;
    };
    mark(m.start);
    for_each_extreme(m, mark);
}

position_um to_position(const gc::vec3& p, const bool used[3]) {
    position_um out;
    for (int i = 0; i < 3; ++i)
        if (used[i]) out[axis_letters[i]] = coordinate(p, i) * 1000.0;
    return out;
}

bool is_motion(gc::move_kind k) {
    return k == gc::move_kind::rapid || k == gc::move_kind::linear || k == gc::move_kind::arc;
}

double move_feed(const gc::planned_move& m, const gc::gcode_options& o) {
    return m.kind == gc::move_kind::rapid ? o.rapid_mm_s : m.feed_mm_s;
}

std::optional<gc::arc_plane> move_plane(const gc::planned_move& m) {
    if (m.kind == gc::move_kind::arc) return m.arc.plane;
    return std::nullopt;
}

std::size_t preview_commands_of(const gc::planned_move& m) {
    switch (m.kind) {
        case gc::move_kind::rapid:
        case gc::move_kind::linear:
            return 1 + m.segments;  // a SPEED, then one M per segment
        case gc::move_kind::arc:
            return 2 * m.segments;  // a SPEED and an M per segment (the direction turns)
        case gc::move_kind::ttl:
        case gc::move_kind::analog:
            return 1;
        case gc::move_kind::dwell:
            return 0;
    }
    return 0;
}

// The estimate uses the controller's ramp, settle and serial link (what the planner's defaults stand
// for when there is no controller): the slowest of the axes a program may drive.
void timed_by_controller(gc::gcode_options& o, const motion_model& motion) {
    double ramp = 0, settle = 0;
    for (const char a : axis_letters) {
        if (a == 'Z' && o.z != gc::z_mode::axis) continue;
        ramp = std::max(ramp, motion.axis(a).ramp_ms);
        settle = std::max(settle, motion.axis(a).settle_ms);
    }
    o.ramp_ms = ramp;
    o.settle_ms = settle;
    o.host = motion.link();
}

// Commands of every run besides the program's: the SPEED query, "TTL Y=0" at the start, the SPEED
// restored at the end.
constexpr std::size_t run_bookends = 3;

// The move a run makes before `m` (see the file comment): none, an approach at the rapid speed to
// where `m` starts, or (a first rapid move) from wherever the stage is to its end instead of from the
// program's origin. Returns the seconds to add to `m`'s estimate (negative when the stage is nearer).
double approach_seconds(const gc::planned_move& m, bool ttl_on, const trace_commander& commander,
                        const gc::gcode_options& o) {
    const bool first_rapid = m.kind == gc::move_kind::rapid && !ttl_on;
    const gc::vec3& to = first_rapid ? m.end : m.start;
    double d2 = 0;
    for (int i = 0; i < 3; ++i) {
        const char axis = axis_letters[i];
        if (!commander.driven(axis)) continue;
        const auto at = commander.position(axis);
        if (!at) return 0;  // unknown: the run reads it; nothing to estimate from
        const double d = coordinate(to, i) - *at;
        d2 += d * d;
    }
    const double d = std::sqrt(d2);
    if (first_rapid)
        return gc::straight_segment_seconds(d, std::min(o.rapid_mm_s, o.max_feed_mm_s), o, true) -
               m.estimated_s;
    if (d <= approach_tolerance_mm) return 0;
    return gc::straight_segment_seconds(d, std::min(o.rapid_mm_s, o.max_feed_mm_s), o, true);
}

}  // namespace

operation_result<job_plan> plan_gcode(const nlohmann::json& json, const plan_context& ctx) {
    auto spec = parse_gcode_spec(json);
    if (!spec) return spec.error();
    timed_by_controller(spec->options, ctx.motion);
    const auto& o = spec->options;
    const auto& s = ctx.snapshot;
    const bool z_axis = o.z == gc::z_mode::axis;
    if (!z_axis && !has_module(s, module::dac_out))
        return make_error(operation_error_kind::missing_module,
                          fmt::format("{} has no DAC OUT module: z_mode analog needs WRDAC", s.id),
                          "spec.options.z_mode");
    auto source = open_program(*spec, ctx.gcode_files);
    if (!source) return source.error();

    axis_window window[3];
    for (int i = 0; i < 3; ++i) {
        const auto* a = s.axis(axis_letters[i]);
        window[i].present = s.axes.empty() || a != nullptr;
        if (a && a->lower_limit_mm) window[i].lo_um = std::max(window[i].lo_um, *a->lower_limit_mm * 1000.0);
        if (a && a->upper_limit_mm) window[i].hi_um = std::min(window[i].hi_um, *a->upper_limit_mm * 1000.0);
    }
    const auto ranges = speed_ranges(ctx.motion, z_axis);
    std::map<char, double> speeds_now;
    for (const auto& [axis, range] : ranges)
        speeds_now[axis] = ctx.motion.axis(axis).speed_mm_s;
    trace_commander commander(ranges, speeds_now);
    for (const auto& a : s.axes)
        if (ranges.contains(a.axis) && a.position_um) commander.set_position(a.axis, *a.position_um / 1000.0);

    job_plan plan;
    plan.type = job_type::gcode;
    plan.path = "host";
    add_preview_command(plan, text_of(ttl_output(false)));
    step_builder steps;
    bool used[3] = {false, false, false};
    std::optional<operation_error> refusal;
    std::uint64_t ttl_switches = 0;
    bool positioned = false;  // as in run_gcode: the first move brings the stage to the program
    bool ttl_on = false;
    double approach_s = 0;
    gc::gcode_planner planner(*source->stream, o);
    while (const gc::planned_move* found = planner.next()) {
        if (refusal) continue;  // read on: a program error further down wins (nothing would move)
        gc::planned_move adjusted;
        const gc::planned_move* m = found;
        mark_driven(*m, used);
        for (int i = 0; i < 3; ++i)
            if (used[i]) commander.drive(axis_letters[i]);
        if (!positioned) {
            adjusted = *m;
            approach_s = approach_seconds(*m, ttl_on, commander, o);
            adjusted.estimated_s = std::max(0.0, adjusted.estimated_s + approach_s);
            m = &adjusted;
            positioned = true;
        }
        if (m->kind == gc::move_kind::ttl) ttl_on = m->ttl_on;
        for_each_extreme(*m, [&](const gc::vec3& p) {
            for (int i = 0; i < 3 && !refusal; ++i) {
                const double um = coordinate(p, i) * 1000.0;
                if (!used[i]) continue;  // an axis the program has not moved (yet)
                if (!window[i].present) {
                    refusal = make_error(operation_error_kind::invalid_value,
                                         fmt::format("line {}: the program moves {}, which {} does not have "
                                                     "(axes {})",
                                                     m->line, axis_letters[i], s.id, motor_axes(s)),
                                         gcode_source_field(*spec));
                } else if (!std::isfinite(um) || um < window[i].lo_um || um > window[i].hi_um) {
                    job_plan one;
                    one.steps.push_back(
                        {fmt::format("line {}", m->line), position_um{{axis_letters[i], um}}});
                    auto limits = check_soft_limits(one, s);
                    refusal = limits ? make_error(operation_error_kind::invalid_value,
                                                  fmt::format("line {}: {}={:.1f} um is beyond the travel "
                                                              "range (+-{:.0f} um)",
                                                              m->line, axis_letters[i], um, max_travel_um))
                                     : limits.error();
                    refusal->field = gcode_source_field(*spec);
                }
            }
        });
        steps.add(*m);
        if (m->kind == gc::move_kind::ttl) ++ttl_switches;
        // The preview: the first commands exactly as the run sends them, the rest counted.
        if (plan.commands.size() >= max_preview_commands) {
            plan.commands_omitted += preview_commands_of(*m);
            continue;
        }
        switch (m->kind) {
            case gc::move_kind::rapid:
            case gc::move_kind::linear:
            case gc::move_kind::arc:
                for (std::uint64_t i = 1; i <= m->segments; ++i) {
                    if (plan.commands.size() >= max_preview_commands) {
                        plan.commands_omitted +=
                            (m->kind == gc::move_kind::arc ? 2 : 1) * (m->segments - i + 1);
                        break;
                    }
                    auto c = commander.segment(gc::segment_end(*m, i), move_feed(*m, o), move_plane(*m));
                    if (c.speed) add_preview_command(plan, text_of(*c.speed));
                    if (c.move) add_preview_command(plan, text_of(*c.move));
                }
                break;
            case gc::move_kind::ttl:
                add_preview_command(plan, text_of(ttl_output(m->ttl_on)));
                break;
            case gc::move_kind::analog:
                add_preview_command(plan, text_of(analog_command(m->analog_v)));
                break;
            case gc::move_kind::dwell:
                break;
        }
    }
    if (planner.error()) return program_error(*spec, *planner.error());
    if (refusal) return *refusal;
    const auto summary = planner.summary();

    for (const auto& st : steps.steps()) {
        plan_step step;
        step.name = gcode_step_name(st.first_line, st.last_line);
        step.target = to_position(st.end, used);
        step.estimated_s = st.estimated_s;
        plan.steps.push_back(std::move(step));
    }
    plan.estimated_s = std::max(0.0, summary.estimated_s + approach_s) +
                       static_cast<double>(run_bookends) * devices::ms2000::command_round_trip_s(
                                                               o.host, devices::ms2000::typical_speed_chars);
    plan.bounds.include(to_position(summary.min, used));
    plan.bounds.include(to_position(summary.max, used));
    plan.warnings = summary.warnings;
    {
        // Coordination needs the same ramp on every moving axis.
        std::optional<double> ramp;
        for (int i = 0; i < 3; ++i) {
            if (!used[i]) continue;
            const double r = ctx.motion.axis(axis_letters[i]).ramp_ms;
            if (ramp && std::abs(*ramp - r) > 1e-9)
                plan.warnings.push_back(
                    "the axes have different ACCEL ramps: segments bend slightly while the axes accelerate");
            ramp = r;
        }
    }
    if (steps.steps().size() == max_gcode_steps ||
        (!steps.steps().empty() && steps.steps().front().lines > 1))
        plan.warnings.push_back(
            fmt::format("{} program lines in {} steps: progress is reported per group of lines",
                        summary.lines, steps.steps().size()));
    plan.summary = fmt::format(
        "G-code trace: {} lines, {} moves, {} straight segments, {} TTL switches, "
        "host-driven{}",
        summary.lines, summary.moves, summary.segments, ttl_switches,
        z_axis ? "" : ", Z drives the analog output");
    return plan;
}

namespace {

nlohmann::json step_detail(int line, const gc::vec3& end, bool z_axis) {
    nlohmann::json position = nlohmann::json::object();
    position["X"] = std::round(end.x * 10000.0) / 10.0;
    position["Y"] = std::round(end.y * 10000.0) / 10.0;
    if (z_axis) position["Z"] = std::round(end.z * 10000.0) / 10.0;
    nlohmann::json j = nlohmann::json::object();
    j["line"] = line;
    j["position"] = std::move(position);
    return j;
}

nlohmann::json bend_detail(int line, double early_mm) {
    nlohmann::json j = nlohmann::json::object();
    j["message"] = fmt::format(
        "line {}: an axis ran at its smallest SPEED and arrived early; the path "
        "bends by up to {:.2f} um",
        line, early_mm * 1000.0);
    j["line"] = line;
    return j;
}

milliseconds wait_timeout_for(double estimated_s) {
    const auto ms = static_cast<long long>(estimated_s * 3000.0) + 30'000;
    return std::min(milliseconds(ms), max_wait_timeout);
}

// Sends the commands of one segment and waits until the stage has stopped.
boost::asio::awaitable<void> run_segment(job_context& ctx, segment_commands c, double estimated_s) {
    if (c.speed) co_await ctx.command(std::move(*c.speed));
    if (!c.move) co_return;
    co_await ctx.command(std::move(*c.move));
    co_await ctx.wait_idle(wait_timeout_for(estimated_s));
}

}  // namespace

boost::asio::awaitable<void> run_gcode(job_context& ctx) {
    auto parsed = parse_gcode_spec(ctx.job().spec);
    if (!parsed) throw job_failure(parsed.error());
    const gcode_spec spec = std::move(*parsed);
    const auto& o = spec.options;
    const bool z_axis = o.z == gc::z_mode::axis;
    auto source = open_program(spec, ctx.gcode_files());
    if (!source) throw job_failure(source.error());
    const auto s = ctx.snapshot();

    // The axes this job may command: those of X, Y (and Z) that the controller has, with the limits
    // of the lead screw its encoder resolution names.
    std::map<char, axis_speed_range> ranges;
    std::string axes;
    for (const char axis : axis_letters) {
        const auto* a = s.axis(axis);
        if (!a || (axis == 'Z' && !z_axis)) continue;
        const auto screw = a->counts_per_mm ? lead_screw_for_counts(*a->counts_per_mm) : std::nullopt;
        const double top = screw ? screw->max_speed_mm_s : default_lead_screw().max_speed_mm_s;
        ranges[axis] = {top * min_speed_fraction, top};
        axes += axis;
    }
    const auto original = co_await ctx.settings_before("SPEED", axes);
    ctx.restore_if_stopped(text_of(speed_command(original)));
    ctx.restore_if_stopped(text_of(ttl_output(false)));
    trace_commander commander(ranges, original);
    const auto reposition_from_snapshot = [&] {
        const auto now = ctx.snapshot();
        for (const auto& a : now.axes)
            if (ranges.contains(a.axis) && a.position_um)
                commander.set_position(a.axis, *a.position_um / 1000.0);
    };
    reposition_from_snapshot();

    // Step i covers the program lines up to last_line[i].
    const auto& plan_steps = ctx.plan().steps;
    std::vector<int> last_line;
    last_line.reserve(plan_steps.size());
    for (const auto& st : plan_steps) {
        const auto l = gcode_step_last_line(st.name);
        if (!l)
            throw job_failure(make_error(operation_error_kind::internal,
                                         fmt::format("gcode plan step \"{}\" names no line", st.name)));
        last_line.push_back(*l);
    }
    const std::size_t first = ctx.first_step();
    const int done_through = first > 0 && first <= last_line.size() ? last_line[first - 1] : 0;

    {
        auto low = ttl_output(false);
        co_await ctx.command(std::move(low));
    }
    bool used[3] = {false, false, false};
    bool ttl_on = false;   // the program's TTL state
    bool ttl_out = false;  // what the controller's output is
    std::optional<double> analog_v;
    bool analog_sent = false;
    bool positioned = false;  // the stage is where the plan has it
    std::size_t step = first;
    std::optional<std::size_t> current;
    int current_line = 0;
    gc::vec3 current_end;
    bool bend_reported = false;

    gc::gcode_planner planner(*source->stream, o);
    while (const gc::planned_move* found = planner.next()) {
        const gc::planned_move m = *found;  // a copy: next() reuses its storage
        mark_driven(m, used);
        for (int i = 0; i < 3; ++i)
            if (used[i] && ranges.contains(axis_letters[i])) commander.drive(axis_letters[i]);
        if (m.line <= done_through) {
            // Done before the resume: only the modal state matters.
            if (m.kind == gc::move_kind::ttl) ttl_on = m.ttl_on;
            if (m.kind == gc::move_kind::analog) analog_v = m.analog_v;
            continue;
        }
        while (step < last_line.size() && last_line[step] < m.line)
            ++step;
        if (step >= last_line.size())
            throw job_failure(make_error(operation_error_kind::internal,
                                         fmt::format("line {} is past the plan's last step", m.line)));
        if (!current || *current != step) {
            if (current) ctx.step_done(*current, step_detail(current_line, current_end, z_axis));
            if (ctx.pause_requested()) {
                // Nothing stays lit while the job waits; the stage may also be moved meanwhile.
                if (ttl_out) {
                    auto low = ttl_output(false);
                    co_await ctx.command(std::move(low));
                    ttl_out = false;
                }
                co_await ctx.checkpoint();
                reposition_from_snapshot();
                positioned = false;
            } else {
                co_await ctx.checkpoint();
            }
            ctx.step_started(step);
            current = step;
        }
        current_line = m.line;
        current_end = m.end;

        if (!positioned && (m.kind != gc::move_kind::rapid || ttl_on)) {
            // Only the axes the program drives; the others stay where they are.
            double away_mm = 0;
            for (int i = 0; i < 3; ++i) {
                const char axis = axis_letters[i];
                if (!commander.driven(axis)) continue;
                const auto at = commander.position(axis);
                away_mm =
                    std::max(away_mm, at ? std::abs(*at - coordinate(m.start, i)) : max_travel_um / 1000.0);
            }
            if (ttl_out) {
                auto low = ttl_output(false);
                co_await ctx.command(std::move(low));
                ttl_out = false;
            }
            if (away_mm > approach_tolerance_mm) {
                auto c = commander.segment(m.start, o.rapid_mm_s, std::nullopt);
                co_await run_segment(ctx, std::move(c), 2 * away_mm / o.rapid_mm_s);
            } else {
                for (int i = 0; i < 3; ++i)
                    if (commander.driven(axis_letters[i]))
                        commander.set_position(axis_letters[i], coordinate(m.start, i));
            }
            positioned = true;
        } else if (is_motion(m.kind)) {
            positioned = true;
        }
        if (analog_v && !analog_sent) {
            auto dac = analog_command(*analog_v);
            co_await ctx.command(std::move(dac));
            analog_sent = true;
        }
        if (ttl_on != ttl_out && m.kind != gc::move_kind::ttl) {
            auto ttl = ttl_output(ttl_on);
            co_await ctx.command(std::move(ttl));
            ttl_out = ttl_on;
        }

        switch (m.kind) {
            case gc::move_kind::rapid:
            case gc::move_kind::linear:
            case gc::move_kind::arc: {
                const double per_segment =
                    m.estimated_s / static_cast<double>(std::max<std::uint64_t>(1, m.segments));
                for (std::uint64_t i = 1; i <= m.segments; ++i) {
                    auto c = commander.segment(gc::segment_end(m, i), move_feed(m, o), move_plane(m));
                    if (c.speeds.early_mm > 0.0001 && !bend_reported) {
                        ctx.emit("warning", bend_detail(m.line, c.speeds.early_mm));
                        bend_reported = true;
                    }
                    co_await run_segment(ctx, std::move(c), per_segment);
                }
                break;
            }
            case gc::move_kind::dwell: {
                const milliseconds dwell(std::llround(m.dwell_ms));
                co_await ctx.dwell(dwell);
                break;
            }
            case gc::move_kind::ttl:
                ttl_on = m.ttl_on;
                if (ttl_out != ttl_on) {
                    auto ttl = ttl_output(ttl_on);
                    co_await ctx.command(std::move(ttl));
                    ttl_out = ttl_on;
                }
                break;
            case gc::move_kind::analog: {
                analog_v = m.analog_v;
                auto dac = analog_command(m.analog_v);
                co_await ctx.command(std::move(dac));
                analog_sent = true;
                break;
            }
        }
    }
    if (planner.error()) throw job_failure(program_error(spec, *planner.error()));
    if (current) ctx.step_done(*current, step_detail(current_line, current_end, z_axis));
    if (ttl_out) {
        auto low = ttl_output(false);
        co_await ctx.command(std::move(low));
    }
    auto restore = speed_command(original);
    co_await ctx.command(std::move(restore));
}

}  // namespace gw::jobs
