#include "gateway/gcode/gcode_planner.hpp"

#include <cmath>
#include <numbers>
#include <streambuf>
#include <string>

#include <gtest/gtest.h>

#include "devices/ms2000/host_step_timing.hpp"
#include "devices/ms2000/motion_profile.hpp"
#include "tests/unit/gcode/plan_helper.hpp"

namespace gw::gcode {
namespace {

using test::plan;

// Durations from the trapezoid model by hand: long move t = d/v + ramp, short move 2 sqrt(d/a) with
// a = v / ramp; then the settle time; then the host's cost of the segment (SPEED, MOVE, the STATUS
// poll that notices the stop). Defaults: ramp 20 ms, settle 14 ms, rapid 5.5 mm/s, 115200 baud.
const double host = devices::ms2000::host_move_overhead_s(gcode_options{}.host, true);

TEST(planner, linear_and_rapid_durations) {
    const auto p = plan("G01 X10. F300\nG00 X21.\nG01 X21.01\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 3u);
    EXPECT_NEAR(p.moves[0].estimated_s, 10.0 / 5 + 0.020 + 0.014 + host, 1e-12);
    EXPECT_NEAR(p.moves[1].estimated_s, 11.0 / 5.5 + 0.020 + 0.014 + host, 1e-12);
    const double a = 5 / 0.020;  // 0.01 mm < v * ramp = 0.1 mm: triangle
    EXPECT_NEAR(p.moves[2].estimated_s, 2 * std::sqrt(0.01 / a) + 0.014 + host, 1e-9);
    EXPECT_NEAR(p.summary.estimated_s,
                p.moves[0].estimated_s + p.moves[1].estimated_s + p.moves[2].estimated_s, 1e-12);
}

TEST(planner, dwell_and_switches) {
    const auto p = plan("G04 P1500\nM03\nM05\n");
    ASSERT_TRUE(p.ok());
    EXPECT_DOUBLE_EQ(p.moves[0].estimated_s, 1.5);
    // A switch is one command ("TTL Y=1") and its reply.
    const double ttl = devices::ms2000::command_round_trip_s(gcode_options{}.host, 7);
    EXPECT_DOUBLE_EQ(p.moves[1].estimated_s, ttl);
    EXPECT_DOUBLE_EQ(p.summary.estimated_s, 1.5 + 2 * ttl);
    EXPECT_EQ(p.summary.segments, 0u);
}

TEST(planner, arc_duration_segments_and_helical_feed_25) {
    // r = 10, tolerance 5 mm: 90-degree segments (the cap), 4 chords of 10 sqrt(2) at 5 mm/s.
    gcode_options o;
    o.arc_tolerance_mm = 5;
    const double chord = 10 * std::sqrt(2.0);
    const double each = chord / 5 + 0.020 + 0.014 + host;
    auto p = plan("G02 I10. F300\n", o);
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p.moves[0].segments, 4u);
    EXPECT_EQ(p.summary.segments, 4u);
    EXPECT_NEAR(p.moves[0].estimated_s, 4 * each, 1e-9);
    // Helix rising 4 mm: FANUC feed is along the arc in the plane, so the time does not change.
    p = plan("G02 I10. Z4. F300\n", o);
    ASSERT_TRUE(p.ok());
    EXPECT_NEAR(p.moves[0].estimated_s, 4 * each, 1e-9);
    // Segment ends: the square through (0,0), (10,10), (20,0), (10,-10) clockwise from (0, 0).
    const auto& m = p.moves[0];
    const vec3 s1 = segment_end(m, 1);
    EXPECT_NEAR(s1.x, 10, 1e-9);
    EXPECT_NEAR(s1.y, 10, 1e-9);
    EXPECT_NEAR(s1.z, 1, 1e-9);
    EXPECT_EQ(segment_end(m, 4), m.end);
}

// Every chord of an arc is a MOVE of its own, so the host's cost grows with the segment count: a
// full circle at 1 um tolerance (100 chords of r = 2 mm) pays it 100 times, and a slow serial line
// makes every chord dearer. Without it the estimate ran 13-27 % short of traced arcs.
TEST(planner, every_arc_chord_pays_the_host_overhead) {
    const std::string circle = "G01 X4. F600\nG03 X4. Y0 I-2. F60\n";
    const auto fast = plan(circle);
    ASSERT_TRUE(fast.ok());
    const auto& arc = fast.moves[1];
    ASSERT_EQ(arc.segments, 100u);
    const double chord = 2 * 2 * std::sin(std::numbers::pi / 100);
    const double motion = devices::ms2000::move_time_s(chord, 1, 20) + 0.014;
    EXPECT_NEAR(arc.estimated_s, 100 * (motion + host), 1e-9);
    EXPECT_GT(arc.estimated_s - 100 * motion, 100 * 0.015);  // SPEED + MOVE + a poll: well above 15 ms
    gcode_options slow;
    slow.host.baud = 9600;
    const auto at_9600 = plan(circle, slow);
    ASSERT_TRUE(at_9600.ok());
    EXPECT_NEAR(at_9600.moves[1].estimated_s - arc.estimated_s,
                100 * (devices::ms2000::host_move_overhead_s(slow.host, true) - host), 1e-9);
    EXPECT_GT(at_9600.moves[1].estimated_s, arc.estimated_s + 100 * 0.04);
    // The straight segment helper is the same model.
    EXPECT_NEAR(straight_segment_seconds(chord, 1, gcode_options{}, true), motion + host, 1e-12);
    EXPECT_EQ(straight_segment_seconds(0, 1, gcode_options{}, true), 0);
}

TEST(planner, bounds_include_start_and_arc_extremes) {
    const auto p = plan("G0 X5. Y5. Z-1.\nG03 X5. Y5. I-5. F60\n");  // circle around (0, 5), r = 5
    ASSERT_TRUE(p.ok());
    EXPECT_DOUBLE_EQ(p.summary.min.x, -5);
    EXPECT_DOUBLE_EQ(p.summary.min.y, 0);
    EXPECT_DOUBLE_EQ(p.summary.min.z, -1);
    EXPECT_DOUBLE_EQ(p.summary.max.x, 5);
    EXPECT_DOUBLE_EQ(p.summary.max.y, 10);
    EXPECT_DOUBLE_EQ(p.summary.max.z, 0);  // the start point (0, 0, 0)
}

TEST(planner, counts_lines_moves_and_segments) {
    const auto p = plan("G0 X1.\n(c)\nG1 X2. F60\n\n");
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p.summary.lines, 4);
    EXPECT_EQ(p.summary.moves, 2u);
    EXPECT_EQ(p.summary.segments, 2u);
}

TEST(planner, bad_options_are_an_error_without_a_place) {
    gcode_options o;
    o.xyz_scale = 0;
    const auto p = plan("G0 X1.\n", o);
    ASSERT_FALSE(p.ok());
    EXPECT_EQ(p.error->line, 0);
    EXPECT_NE(p.error->message.find("xyz_scale"), std::string::npos);
}

// A stream that makes its lines on demand and counts what was read: planning a long program keeps
// only the current line, and the planner reads no further than the move it hands out.
class generated_program : public std::streambuf {
  public:
    explicit generated_program(long lines) : lines_(lines) {}
    long lines_read() const { return next_; }

  protected:
    int_type underflow() override {
        if (next_ >= lines_) return traits_type::eof();
        line_ = next_ % 2 == 0 ? "G01 X" + std::to_string(next_ % 100) + ". Y1. F600\n"
                               : "G02 X" + std::to_string(next_ % 100) + ". Y1. R-50.\n";
        if (next_ == 0) line_ = "G01 X0 Y1. F600\n";
        ++next_;
        setg(line_.data(), line_.data(), line_.data() + line_.size());
        return traits_type::to_int_type(line_[0]);
    }

  private:
    long lines_;
    long next_ = 0;
    std::string line_;
};

TEST(planner, streams_in_bounded_memory) {
    generated_program source(200'000);
    std::istream in(&source);
    gcode_planner planner(in, gcode_options{});
    const planned_move* first = planner.next();
    ASSERT_NE(first, nullptr);
    EXPECT_LE(source.lines_read(), 3);  // pulled, not read ahead
    std::uint64_t moves = 1;
    while (planner.next() != nullptr)
        ++moves;
    ASSERT_FALSE(planner.error()) << planner.error()->message;
    EXPECT_EQ(source.lines_read(), 200'000);
    const auto s = planner.summary();
    EXPECT_EQ(s.moves, moves);
    EXPECT_EQ(s.lines, 200'000);
    EXPECT_GT(s.segments, moves);  // arcs are segmented
}

TEST(planner, check_program_matches_plan_program) {
    const std::string prog = "G0 X1.\nG02 X3. Y0 I1. F60\nG04 P10\n";
    std::istringstream a(prog);
    const auto checked = check_program(a, gcode_options{});
    const auto planned = plan(prog);
    ASSERT_TRUE(std::holds_alternative<plan_summary>(checked));
    EXPECT_EQ(std::get<plan_summary>(checked).segments, planned.summary.segments);
    EXPECT_DOUBLE_EQ(std::get<plan_summary>(checked).estimated_s, planned.summary.estimated_s);
}

}  // namespace
}  // namespace gw::gcode
