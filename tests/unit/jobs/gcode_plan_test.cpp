// The gcode job's pure parts: coordinated per-axis speeds (limits, smallest SPEED, six decimals,
// helical feed), the trace commander (SPEED only when it changes, undriven axes never commanded),
// the strict spec, step names, and the planner's bounded step list for long programs.
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>
#include <variant>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "devices/ms2000/host_step_timing.hpp"
#include "devices/ms2000/motion_profile.hpp"
#include "gateway/gcode/gcode_planner.hpp"
#include "gateway/jobs/job_commands.hpp"
#include "gateway/jobs/kinds/gcode_spec.hpp"
#include "gateway/jobs/kinds/gcode_trace.hpp"
#include "gateway/jobs/kinds/job_kinds.hpp"
#include "tests/support/plan_context_fixture.hpp"

namespace gw::jobs {
namespace {

using json = nlohmann::json;

// A segment's command as the line it sends ("" when there is none).
std::string line_of(const std::optional<devices::ms2000::command>& c) {
    return c ? text_of(*c) : "";
}

const std::map<char, axis_speed_range> screw_b = {
    {'X', {0.00068, 6.8}}, {'Y', {0.00068, 6.8}}, {'Z', {0.00068, 6.8}}};

TEST(gcode_speeds, every_axis_gets_its_share_of_the_feed) {
    struct row {
        std::map<char, double> delta;
        double feed;
        std::map<char, double> expected;
        double slowdown;
    };
    const row rows[] = {
        {{{'X', 3}, {'Y', 4}}, 5, {{'X', 3}, {'Y', 4}}, 1},
        {{{'X', -3}, {'Y', 4}}, 1, {{'X', 0.6}, {'Y', 0.8}}, 1},
        {{{'X', 1}}, 2, {{'X', 2}}, 1},
        // 10 mm/s along X is above the screw's 6.8: the whole segment slows down.
        {{{'X', 1}}, 10, {{'X', 6.8}}, 0.68},
        {{{'X', 3}, {'Y', 4}}, 10, {{'X', 5.1}, {'Y', 6.8}}, 0.85},
        // Six decimals: 1/3 mm/s.
        {{{'X', 1}, {'Y', 1}}, std::sqrt(2.0) / 3, {{'X', 0.333333}, {'Y', 0.333333}}, 1},
    };
    for (const auto& r : rows) {
        double len2 = 0;
        for (const auto& [a, d] : r.delta)
            len2 += d * d;
        const auto s = coordinated_speeds(r.delta, std::sqrt(len2), r.feed, screw_b);
        ASSERT_EQ(s.mm_s.size(), r.expected.size());
        for (const auto& [a, v] : r.expected)
            EXPECT_NEAR(s.mm_s.at(a), v, 1e-9) << a << " at " << r.feed;
        EXPECT_NEAR(s.slowdown, r.slowdown, 1e-9);
        EXPECT_EQ(s.early_mm, 0);
    }
}

TEST(gcode_speeds, a_tiny_component_runs_at_the_smallest_speed_and_the_bend_is_bounded) {
    // Y moves 10 nm while X moves 1 mm at 1 mm/s: Y would need 0.00001 mm/s.
    const auto s = coordinated_speeds({{'X', 1}, {'Y', 1e-5}}, std::hypot(1, 1e-5), 1, screw_b);
    EXPECT_NEAR(s.mm_s.at('X'), 1, 1e-9);
    EXPECT_NEAR(s.mm_s.at('Y'), 0.00068, 1e-12);
    EXPECT_GT(s.early_mm, 0);
    EXPECT_LE(s.early_mm, 1e-5);  // never more than the component itself
    // Rounding to six decimals never goes below the smallest speed (0.0006805 -> 0.000681).
    const auto r = coordinated_speeds({{'X', 1e-6}}, 1, 1, {{'X', {0.0006805, 6.8}}});
    EXPECT_GE(r.mm_s.at('X'), 0.0006805);
}

TEST(gcode_speeds, helical_segments_take_the_feed_in_the_arc_plane) {
    // In-plane 3-4-5 and Z 1: the plane axes get F * share of the in-plane length, Z follows.
    const auto s = coordinated_speeds({{'X', 3}, {'Y', 4}, {'Z', 1}}, 5, 1, screw_b);
    EXPECT_NEAR(s.mm_s.at('X'), 0.6, 1e-9);
    EXPECT_NEAR(s.mm_s.at('Y'), 0.8, 1e-9);
    EXPECT_NEAR(s.mm_s.at('Z'), 0.2, 1e-9);
}

TEST(gcode_commander, sends_speed_only_when_it_changes_and_never_moves_an_undriven_axis) {
    trace_commander c({{'X', {0.00068, 6.8}}, {'Y', {0.00068, 6.8}}, {'Z', {0.00068, 6.8}}},
                      {{'X', 5.5}, {'Y', 5.5}, {'Z', 5.5}});
    c.set_position('X', 0);
    c.set_position('Y', 0);
    c.set_position('Z', 3);  // a focus position the 2-D program must leave alone
    c.drive('X');
    c.drive('Y');
    auto a = c.segment({1, 0, 0}, 2, std::nullopt);
    EXPECT_EQ(line_of(a.speed), "SPEED X=2");
    EXPECT_EQ(line_of(a.move), "M X=10000");  // Y stays at 0: not commanded
    auto b = c.segment({2, 0, 0}, 2, std::nullopt);
    EXPECT_EQ(line_of(b.speed), "");  // X already runs at 2 mm/s
    EXPECT_EQ(line_of(b.move), "M X=20000");
    auto d = c.segment({2, 0.0000005, 0}, 2, std::nullopt);  // 0.5 nm: not a move
    EXPECT_EQ(line_of(d.move), "");
    auto e = c.segment({5, 4, 0}, 5, std::nullopt);
    EXPECT_EQ(line_of(e.speed), "SPEED X=3 Y=4");
    EXPECT_EQ(line_of(e.move), "M X=50000 Y=40000");
    EXPECT_EQ(c.position('Z'), 3);
    // Targets are tracked as commanded: no drift from uncommanded sub-nanometre steps.
    trace_commander f({{'X', {0.00068, 6.8}}}, {});
    f.set_position('X', 0);
    f.drive('X');
    int moves = 0;
    for (int i = 1; i <= 10; ++i)
        if (f.segment({i * 0.0000004, 0, 0}, 1, std::nullopt).move) ++moves;
    // Ten 0.4 nm steps: commanded at 1.2, 2.4 and 3.6 nm (each more than 1 nm past the last target).
    EXPECT_EQ(moves, 3);
    EXPECT_NEAR(*f.position('X'), 3.6e-6, 1e-12);
}

TEST(gcode_spec_parse, is_strict_and_names_the_field) {
    struct row {
        json spec;
        const char* field;  // empty: accepted
    };
    const row rows[] = {
        {{{"program", "G00 X1"}}, ""},
        {{{"file", "g-01JABCDEFGHJKMNPQRSTVWXYZ0"}}, ""},
        {{{"program", "G00 X1"}, {"options", {{"z_mode", "analog"}, {"arc_tolerance_mm", 0.0005}}}}, ""},
        {json::array(), "spec"},
        {json::object(), "spec.program"},
        {{{"program", "G00"}, {"file", "g-1"}}, "spec.file"},
        {{{"program", 3}}, "spec.program"},
        {{{"file", ""}}, "spec.file"},
        {{{"program", "G00"}, {"mode", "host"}}, "spec.mode"},
        {{{"program", "G00"}, {"options", 3}}, "spec.options"},
        {{{"program", "G00"}, {"options", {{"z_mode", "sideways"}}}}, "spec.options.z_mode"},
        {{{"program", "G00"}, {"options", {{"xyz_scale", -1}}}}, "spec.options.xyz_scale"},
        {{{"program", "G00"}, {"options", {{"xyz_scale", true}}}}, "spec.options.xyz_scale"},
        {{{"program", std::string(max_inline_gcode_bytes + 1, ' ')}}, "spec.program"},
    };
    for (const auto& r : rows) {
        auto s = parse_gcode_spec(r.spec);
        if (std::string(r.field).empty()) {
            EXPECT_TRUE(s) << r.spec.dump() << ": " << s.error().message;
        } else {
            ASSERT_FALSE(s) << r.spec.dump().substr(0, 80);
            EXPECT_EQ(s.error().field, r.field) << s.error().message;
        }
    }
    auto s = parse_gcode_spec(
        {{"program", "G00"}, {"options", {{"arc_tolerance_mm", 0.0005}, {"z_mode", "analog"}}}});
    ASSERT_TRUE(s);
    EXPECT_EQ(s->options.arc_tolerance_mm, 0.0005);
    EXPECT_EQ(s->options.z, gcode::z_mode::analog);
}

TEST(gcode_spec_parse, step_names_round_trip) {
    EXPECT_EQ(gcode_step_name(42, 42), "line 42");
    EXPECT_EQ(gcode_step_name(41, 48), "lines 41-48");
    EXPECT_EQ(gcode_step_last_line("line 42"), 42);
    EXPECT_EQ(gcode_step_last_line("lines 41-48"), 48);
    for (const char* bad : {"", "line", "line x", "lines 4", "lines 4-", "C7", "line 0", "line 12a"})
        EXPECT_FALSE(gcode_step_last_line(bad)) << bad;
}

plan_context xy_context() {
    return test_support::connected_context("XY", "STD_XY");
}

TEST(gcode_plan, long_programs_get_a_bounded_list_of_contiguous_line_groups) {
    std::string program;
    for (int i = 1; i <= 12'000; ++i)
        program += "G01 X" + std::to_string((i % 100) * 0.01) + " F600\n";
    auto plan = plan_gcode({{"program", program}}, xy_context());
    ASSERT_TRUE(plan) << plan.error().message;
    ASSERT_LE(plan->steps.size(), max_gcode_steps);
    ASSERT_GE(plan->steps.size(), max_gcode_steps / 2);
    int next_first = 1;
    for (const auto& st : plan->steps) {
        const auto last = gcode_step_last_line(st.name);
        ASSERT_TRUE(last) << st.name;
        const std::string expected_prefix = "lines " + std::to_string(next_first) + "-";
        EXPECT_TRUE(st.name.starts_with(expected_prefix) || st.name == "line " + std::to_string(next_first))
            << st.name << " after line " << next_first - 1;
        next_first = *last + 1;
    }
    EXPECT_EQ(next_first, 12'001);
    EXPECT_EQ(plan->commands.size(), max_preview_commands);
    EXPECT_GT(plan->commands_omitted, 10'000u);
}

TEST(gcode_plan, a_z_move_on_a_stage_without_z_is_refused_naming_the_line) {
    auto plan = plan_gcode({{"program", "G01 X1 F60\nG01 Z0.5\n"}}, xy_context());
    ASSERT_FALSE(plan);
    EXPECT_EQ(plan.error().field, "spec.program");
    EXPECT_NE(plan.error().message.find("line 2"), std::string::npos) << plan.error().message;
    // The lower limit, and a program error further down (it wins: nothing would run anyway).
    auto low = plan_gcode({{"program", "G01 X-120 F60\n"}}, xy_context());
    ASSERT_FALSE(low);
    EXPECT_NE(low.error().message.find("lower soft limit"), std::string::npos) << low.error().message;
    auto both = plan_gcode({{"program", "G01 X-120 F60\nG99\n"}}, xy_context());
    ASSERT_FALSE(both);
    EXPECT_NE(both.error().message.find("line 2, column 1"), std::string::npos) << both.error().message;
}

// The job's estimate: the planner's (motion, settle and the host's SPEED/MOVE/STATUS per segment)
// with the controller's motion parameters and link, the approach from where the stage stands, and the
// run's own commands (SPEED query, TTL Y=0 at the start, SPEED restored). Each part is checked by
// taking it away.
TEST(gcode_plan, the_estimate_has_the_approach_and_the_host_overhead_of_every_segment) {
    namespace ms = devices::ms2000;
    const std::string program = "G01 X1 F60\n";  // a feed move: the stage first goes to (0, 0)
    const auto link = devices::ms2000::host_link_timing{};
    const double bookends = 3 * ms::command_round_trip_s(link, ms::typical_speed_chars);
    const double line = ms::move_time_s(1, 1, 20) + 0.014 + ms::host_move_overhead_s(link, true);

    auto at_origin = plan_gcode({{"program", program}}, xy_context());
    ASSERT_TRUE(at_origin) << at_origin.error().message;
    EXPECT_NEAR(at_origin->estimated_s, line + bookends, 1e-9);

    // The stage 10 mm away in X: a rapid approach at 5.5 mm/s, with its own overhead.
    auto away_ctx = xy_context();
    away_ctx.snapshot.axes[0].position_um = 10'000;
    auto away = plan_gcode({{"program", program}}, away_ctx);
    ASSERT_TRUE(away) << away.error().message;
    const double approach = ms::move_time_s(10, 5.5, 20) + 0.014 + ms::host_move_overhead_s(link, true);
    EXPECT_NEAR(away->estimated_s - at_origin->estimated_s, approach, 1e-9);
    EXPECT_NEAR(away->steps.at(0).estimated_s, line + approach, 1e-9);

    // A first rapid move goes from where the stage is, not from the program's origin.
    auto rapid = plan_gcode({{"program", "G00 X12\n"}}, away_ctx);
    ASSERT_TRUE(rapid) << rapid.error().message;
    EXPECT_NEAR(rapid->estimated_s,
                ms::move_time_s(2, 5.5, 20) + 0.014 + ms::host_move_overhead_s(link, true) + bookends, 1e-9);

    // The controller's parameters, not the planner's defaults: a slower serial line and a longer ramp.
    auto slow_ctx = xy_context();
    auto slow_link = link;
    slow_link.baud = 9600;
    slow_ctx.motion.set_link(slow_link);
    for (const char a : {'X', 'Y'}) {
        auto p = slow_ctx.motion.axis(a);
        p.ramp_ms = 50;
        slow_ctx.motion.set_axis(a, p);
    }
    auto slow = plan_gcode({{"program", program}}, slow_ctx);
    ASSERT_TRUE(slow) << slow.error().message;
    EXPECT_NEAR(slow->estimated_s,
                ms::move_time_s(1, 1, 50) + 0.014 + ms::host_move_overhead_s(slow_link, true) +
                    3 * ms::command_round_trip_s(slow_link, ms::typical_speed_chars),
                1e-9);
}

// An arc-heavy program: a circle of r = 2 mm at 1 um (100 chords) costs 100 host overheads. The
// job's estimate is the planner's own (what `gcode plan` prints for the same parameters) plus the
// run's bookends.
TEST(gcode_plan, a_circle_costs_a_host_overhead_per_chord_and_matches_the_planner) {
    namespace ms = devices::ms2000;
    const std::string program = "G03 X0 Y0 I2 F60\n";
    auto plan = plan_gcode({{"program", program}}, xy_context());
    ASSERT_TRUE(plan) << plan.error().message;
    std::istringstream in(program);
    const auto checked = gcode::check_program(in, gcode::gcode_options{});
    ASSERT_TRUE(std::holds_alternative<gcode::plan_summary>(checked));
    const auto& summary = std::get<gcode::plan_summary>(checked);
    ASSERT_EQ(summary.segments, 100u);
    const auto link = ms::host_link_timing{};
    EXPECT_NEAR(plan->estimated_s,
                summary.estimated_s + 3 * ms::command_round_trip_s(link, ms::typical_speed_chars), 1e-9);
    const double chord = 2 * 2 * std::sin(std::numbers::pi / 100);
    const double motion_only = 100 * (ms::move_time_s(chord, 1, 20) + 0.014);
    EXPECT_NEAR(summary.estimated_s - motion_only, 100 * ms::host_move_overhead_s(link, true), 1e-9);
}

}  // namespace
}  // namespace gw::jobs
