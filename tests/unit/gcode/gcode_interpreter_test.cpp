// The interpreter through plan_program(): every code and the edge cases of
// ../shared/docs/gcode-semantics.md section 4 (numbered "#n" in the test names and comments).
#include "gateway/gcode/gcode_interpreter.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include <gtest/gtest.h>

#include "tests/unit/gcode/plan_helper.hpp"

namespace gw::gcode {
namespace {

using test::plan;
constexpr double eps = 1e-9;

void expect_point(const vec3& p, double x, double y, double z, double tol = eps) {
    EXPECT_NEAR(p.x, x, tol);
    EXPECT_NEAR(p.y, y, tol);
    EXPECT_NEAR(p.z, z, tol);
}

// ---- errors: line, column and message, no moves -------------------------------------------------

struct error_case {
    std::string name;
    std::string program;
    int line;
    int column;
    std::string message_part;
};

class program_error_test : public ::testing::TestWithParam<error_case> {};

TEST_P(program_error_test, names_the_place_and_moves_nothing) {
    const auto& c = GetParam();
    const auto p = plan(c.program);
    ASSERT_FALSE(p.ok()) << c.program;
    EXPECT_EQ(p.error->line, c.line) << p.error->message;
    EXPECT_EQ(p.error->column, c.column) << p.error->message;
    EXPECT_NE(p.error->message.find(c.message_part), std::string::npos) << p.error->message;
    EXPECT_TRUE(p.moves.empty());
}

INSTANTIATE_TEST_SUITE_P(
    interpreter, program_error_test,
    ::testing::Values(
        // #54 the first error aborts, even after good lines
        error_case{"late_error_no_moves", "G0 X1.\nG1 X2. F60\nG28\n", 3, 1, "unsupported code G28"},
        // #15 unsupported codes and letters
        error_case{"g54", "G54 G0 X1.", 1, 1, "unsupported code G54"},
        error_case{"g94", "G94", 1, 1, "unsupported code G94"},
        error_case{"m06", "M06", 1, 1, "unsupported code M06"},
        error_case{"t_word", "G0 X1. T1", 1, 8, "unsupported word T1"},
        error_case{"s_word", "S1000 M03", 1, 1, "unsupported word S1000"},
        error_case{"e_exponent", "G0 X1e3", 1, 6, "unsupported word E3"},     // #11
        error_case{"g_fraction", "G1.5 X1.", 1, 1, "unsupported code G1.5"},  // #13
        // #14 repeated words
        error_case{"repeat_x", "G0 X1. X2.", 1, 8, "X given twice"},
        error_case{"repeat_f", "G1 X1. F1 F2", 1, 11, "F given twice"},
        // #17 two codes of one group
        error_case{"g0_g1", "G00 G01 X1.", 1, 5, "motion"},
        error_case{"g90_g91", "G90 G91", 1, 5, "distance"}, error_case{"g17_g18", "G17 G18", 1, 5, "plane"},
        error_case{"g20_g21", "G20 G21", 1, 5, "units"}, error_case{"g15_g16", "G15 G16", 1, 5, "polar"},
        error_case{"m3_m5", "M03 M05", 1, 5, "M05 and M03 in one block"},  // #51
        // #19 G04 alone, #28 its P
        error_case{"g4_with_move", "G04 P100 G01 X1.", 1, 10, "G04 must be alone"},
        error_case{"g4_with_m3", "G04 P100 M03", 1, 10, "G04 must be alone"},
        error_case{"g4_x", "G04 X1.", 1, 5, "G04 must be alone"},
        error_case{"g4_no_p", "G04", 1, 1, "G04 needs P"},
        error_case{"g4_decimal", "G04 P1.5", 1, 5, "no decimal point"},
        error_case{"g4_negative", "G04 P-5", 1, 5, "negative dwell"},
        error_case{"g4_too_long", "G04 P100000000", 1, 5, "exceeds 99999999"},
        error_case{"p_without_g4", "G01 X1. F60 P5", 1, 13, "P is only used with G04"},
        // #21 no motion mode yet
        error_case{"no_motion_mode", "X1.", 1, 1, "no motion mode"},
        // #24 feed
        error_case{"g1_no_feed", "G01 X1.", 1, 1, "without a feed"},
        error_case{"g1_zero_feed", "G01 X1. F0", 1, 1, "zero feed"},
        error_case{"g2_no_feed", "G02 X10. I5.", 1, 1, "G02 without a feed"},
        error_case{"negative_feed", "G01 X1. F-5", 1, 9, "negative feed"},
        // #31 out-of-plane centre words
        error_case{"k_in_g17", "G17 G02 X10. I5. K1. F60", 1, 18, "K is not an arc centre word in G17"},
        error_case{"j_in_g18", "G18 G02 X10. J5. F60", 1, 14, "J is not an arc centre word in G18"},
        error_case{"i_in_g19", "G19 G02 Y10. I5. F60", 1, 14, "I is not an arc centre word in G19"},
        // #33 neither R nor I/J/K
        error_case{"no_centre", "G02 X10. Y0 F60", 1, 1, "needs R or the centre words"},
        error_case{"ijk_without_arc", "G01 X1. I5. F60", 1, 9, "I is only used with G02/G03"},
        // #37 R arc with end = start that moves the third axis
        error_case{"r_full_helix", "G02 Z1. R5. F60", 1, 9, "full helix needs I/J/K"},
        // #39 R too small, R0
        error_case{"r_too_small", "G02 X10. Y0 R4.9998 F60", 1, 13, "too small to reach"},
        error_case{"r_zero", "G02 X10. Y0 R0 F60", 1, 13, "radius R is zero"},
        // #41 radius mismatch beyond max(1 um, 1e-4 r): r1 = 5.0009, r2 = 4.9991, 1.8 um apart
        error_case{"mismatch_small_r", "G02 X10. Y0 I5.0009 F60", 1, 13,
                   "differs from the radius to the start"},
        // r ~ 100: allowed 10 um; I100.006 -> r1 100.006, r2 99.994, 12 um apart
        error_case{"mismatch_large_r", "G02 X200. Y0 I100.006 F60", 1, 14, "differs"},
        // #43 zero radius
        error_case{"zero_radius", "G02 X0 Y0 I0 J0 F60", 1, 11, "zero-radius arc"},
        // #8 N must be whole, #9 O alone
        error_case{"n_fraction", "N1.5 G0", 1, 1, "N (block number)"},
        error_case{"o_with_words", "O1 G0 X1.", 1, 1, "O (program number) must be alone"},
        // #55 absurd line length
        error_case{"long_line", "G0 X1." + std::string(5000, ' '), 1, 4097, "longer than 4096"},
        error_case{"nested_comment_line_2", "G0 X1.\n(a (b))", 2, 4, "nested comment"}),
    [](const auto& info) { return info.param.name; });

// ---- lexical and framing ---------------------------------------------------------------------------

TEST(interpreter, percent_framing_1) {
    const auto p = plan("%\nG0 X1.\n%\nG0 X99.\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 1u);
    expect_point(p.moves[0].end, 1, 0, 0);
    EXPECT_EQ(p.moves[0].line, 2);
    EXPECT_TRUE(p.summary.warnings.empty());
}

TEST(interpreter, missing_closing_percent_warns_1) {
    const auto p = plan("% TITLE\nG0 X1.\nG0 X2.\n");
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p.moves.size(), 2u);
    EXPECT_TRUE(p.warned("no closing '%'"));
}

TEST(interpreter, line_ends_lf_crlf_cr_2) {
    const auto p = plan("G0 X1.\rG0 X2.\r\nG0 X3.\nG0 X4.");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 4u);
    for (int i = 0; i < 4; ++i) {
        EXPECT_EQ(p.moves[i].line, i + 1);
        EXPECT_DOUBLE_EQ(p.moves[i].end.x, i + 1.0);
    }
}

TEST(interpreter, semicolon_ends_the_block_and_warns_on_words_3) {
    const auto p = plan("G0 X1. ; G0 X5.\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 1u);
    EXPECT_DOUBLE_EQ(p.moves[0].end.x, 1);
    EXPECT_TRUE(p.warned("text after ';'"));
    EXPECT_TRUE(plan("G0 X1. ; to the start\n").summary.warnings.empty());
}

TEST(interpreter, comments_case_blanks_4_5_6_7) {
    const auto p = plan("(header)\n\n   \ng0 (go) x1. y2.\nG01 F60\nZ- .1\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 2u);
    expect_point(p.moves[0].end, 1, 2, 0);
    EXPECT_EQ(p.moves[1].kind, move_kind::linear);
    expect_point(p.moves[1].end, 1, 2, -0.1);
    EXPECT_EQ(p.moves[1].line, 6);
}

TEST(interpreter, block_numbers_8) {
    const auto p = plan("N10 G0 X1.\nN5 X2.\nN0 X3.\n");  // any order, gaps; N0 warns
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p.moves.size(), 3u);
    EXPECT_TRUE(p.warned("N0"));
}

TEST(interpreter, program_number_line_is_ignored_9) {
    const auto p = plan("%\nO0001 (PART)\nG0 X1.\n%\n");
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p.moves.size(), 1u);
}

TEST(interpreter, block_delete_executes_with_a_warning_10) {
    const auto p = plan("/G0 X5.\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 1u);
    EXPECT_DOUBLE_EQ(p.moves[0].end.x, 5);
    EXPECT_TRUE(p.warned("block delete"));
}

TEST(interpreter, number_forms_11) {
    const auto p = plan("G0 X.5 Y-.5 Z+1.\n");
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[0].end, 0.5, -0.5, 1);
}

// #12 coordinates without a decimal point
TEST(interpreter, no_decimal_point_calculator_default_12) {
    const auto p = plan("G0 X1000 Y0\n");
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[0].end, 1000, 0, 0);
    ASSERT_TRUE(p.warned("X1000 has no decimal point: read as 1000 mm"));
    EXPECT_EQ(p.summary.warnings.size(), 1u);  // Y0 reads the same either way: no warning
}

TEST(interpreter, no_decimal_point_least_increment_12) {
    gcode_options o;
    o.decimal_point = decimal_point_reading::least_increment;
    const auto p = plan("G0 X1000 Y2.5\nG20 G0 X10000\nG16 G0 X1. Y90000\n", o);
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[0].end, 1, 2.5, 0);         // IS-B: 0.001 mm
    expect_point(p.moves[1].end, 25.4, 2.5, 0);      // 0.0001 inch
    expect_point(p.moves[2].end, 0, 25.4, 0, 1e-9);  // angle 0.001 degree: 90 degrees
    EXPECT_TRUE(p.warned("read as 1 mm (decimal_point=least_increment"));
}

TEST(interpreter, leading_zeros_13) {
    const auto p = plan("G021 G001 X1. F060\nM003\nM005\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 3u);
    EXPECT_EQ(p.moves[0].kind, move_kind::linear);
    EXPECT_TRUE(p.moves[1].ttl_on);
    EXPECT_FALSE(p.moves[2].ttl_on);
}

// ---- block semantics -------------------------------------------------------------------------------

TEST(interpreter, groups_in_any_order_16) {
    const auto p = plan("G0 X5. Y5.\nF60 X1. G01 G91 G17\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 2u);
    EXPECT_EQ(p.moves[1].kind, move_kind::linear);
    expect_point(p.moves[1].end, 6, 5, 0);
}

TEST(interpreter, ttl_before_the_motion_of_its_block_18_51) {
    const auto p = plan("G01 X1. F60 M03\nM03\nX2. M05\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 4u);
    EXPECT_EQ(p.moves[0].kind, move_kind::ttl);
    EXPECT_TRUE(p.moves[0].ttl_on);
    expect_point(p.moves[0].end, 0, 0, 0);  // switched at the start of the block
    EXPECT_EQ(p.moves[1].kind, move_kind::linear);
    // the second M03 is idempotent: no move
    EXPECT_EQ(p.moves[2].kind, move_kind::ttl);
    EXPECT_FALSE(p.moves[2].ttl_on);
    expect_point(p.moves[2].end, 1, 0, 0);
    EXPECT_EQ(p.moves[3].kind, move_kind::linear);
    EXPECT_TRUE(p.summary.warnings.empty());
}

TEST(interpreter, ttl_left_on_is_switched_off_at_the_end_51) {
    const auto p = plan("G01 X1. F60\nM03\nX2.\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 4u);
    EXPECT_EQ(p.moves.back().kind, move_kind::ttl);
    EXPECT_FALSE(p.moves.back().ttl_on);
    EXPECT_EQ(p.moves.back().line, 3);
    EXPECT_TRUE(p.warned("TTL still on"));
}

TEST(interpreter, units_apply_before_f_and_the_move_18_23) {
    const auto p = plan("G20 G01 X1. F10\n");
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[0].end, 25.4, 0, 0);
    EXPECT_NEAR(p.moves[0].feed_mm_s, 10 * 25.4 / 60, 1e-12);  // 10 inch/min
}

TEST(interpreter, modal_motion_repeats_20) {
    const auto p = plan("G01 X1. F60\nY2.\nG02 X3. Y2. I1.\nX5. I1.\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 4u);
    EXPECT_EQ(p.moves[1].kind, move_kind::linear);
    expect_point(p.moves[1].end, 1, 2, 0);
    EXPECT_EQ(p.moves[3].kind, move_kind::arc);
    expect_point(p.moves[3].arc.center, 4, 2, 0);
}

TEST(interpreter, units_switched_mid_program_22) {
    const auto p = plan("G21 G0 X1.\nG20\nG0 X1.\nG21 G0 Y1.\n");
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[1].end, 25.4, 0, 0);
    expect_point(p.moves[2].end, 25.4, 1, 0);
    EXPECT_TRUE(p.warned("units switched"));
}

TEST(interpreter, feed_set_in_a_rapid_block_is_kept_23) {
    const auto p = plan("G00 X1. F120\nG01 X2.\n");
    ASSERT_TRUE(p.ok());
    EXPECT_DOUBLE_EQ(p.moves[0].feed_mm_s, 5.5);  // rapid ignores F
    EXPECT_DOUBLE_EQ(p.moves[1].feed_mm_s, 2);
}

TEST(interpreter, speed_scale_multiplies_f_only_26) {
    gcode_options o;
    o.speed_scale = 2;
    const auto p = plan("G01 X1. F60\nG00 X2.\nG04 P100\n", o);
    ASSERT_TRUE(p.ok());
    EXPECT_DOUBLE_EQ(p.moves[0].feed_mm_s, 2);
    EXPECT_DOUBLE_EQ(p.moves[1].feed_mm_s, 5.5);
    EXPECT_DOUBLE_EQ(p.moves[2].dwell_ms, 100);
}

TEST(interpreter, max_feed_clamps_with_a_warning) {
    const auto p = plan("G01 X1. F600\n");  // 10 mm/s > 6.8
    ASSERT_TRUE(p.ok());
    EXPECT_DOUBLE_EQ(p.moves[0].feed_mm_s, 6.8);
    EXPECT_TRUE(p.warned("clamped to max_feed_mm_s"));
}

TEST(interpreter, rapid_is_a_straight_line_at_the_rapid_speed_27) {
    gcode_options o;
    o.rapid_mm_s = 3;
    const auto p = plan("G00 X3. Y4.\n", o);
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p.moves[0].kind, move_kind::rapid);
    EXPECT_EQ(p.moves[0].segments, 1u);
    EXPECT_DOUBLE_EQ(p.moves[0].feed_mm_s, 3);
}

TEST(interpreter, dwell_28) {
    const auto p = plan("G04 P1500\nN2 G04 P0\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 2u);
    EXPECT_EQ(p.moves[0].kind, move_kind::dwell);
    EXPECT_DOUBLE_EQ(p.moves[0].dwell_ms, 1500);
    EXPECT_DOUBLE_EQ(p.moves[1].dwell_ms, 0);  // still a stop point
}

TEST(interpreter, initial_state_g17_g90_g21_29) {
    const auto p = plan("G02 X10. Y0 I5. F60\nG00 X1.\nG00 X1.\n");
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p.moves[0].arc.plane, arc_plane::xy);
    ASSERT_EQ(p.moves.size(), 2u);  // the repeated absolute X1. is a zero-length move: dropped
    expect_point(p.moves[1].end, 1, 0, 0);
}

TEST(interpreter, zero_length_moves_are_dropped) {
    const auto p = plan("G91 G01 X0 F60\nX0.0000001\nG00 Y0\nG01 X1.\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 1u);
    EXPECT_NEAR(p.moves[0].end.x, 1.0000001, 1e-12);
}

TEST(interpreter, incremental_keeps_ijk_start_relative_30) {
    const auto p = plan("G0 X10. Y10.\nG91 G02 X10. Y0 I5. F60\n");
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[1].end, 20, 10, 0);
    expect_point(p.moves[1].arc.center, 15, 10, 0);
}

// ---- arcs ------------------------------------------------------------------------------------------

TEST(interpreter, missing_centre_word_is_zero_31) {
    const auto p = plan("G03 X0 Y10. J5. F60\n");
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[0].arc.center, 0, 5, 0);
    EXPECT_EQ(p.moves[0].arc.direction, arc_direction::ccw);
    EXPECT_NEAR(p.moves[0].arc.sweep, std::numbers::pi, 1e-12);
}

// #32 direction in every plane: the arc passes the point named in the doc (its bounds reach it).
struct direction_case {
    std::string name;
    std::string program;
    arc_plane plane;
    vec3 center;
    vec3 passes;
};

class arc_direction_test : public ::testing::TestWithParam<direction_case> {};

TEST_P(arc_direction_test, passes_the_point_32) {
    const auto& c = GetParam();
    const auto p = plan(c.program);
    ASSERT_TRUE(p.ok()) << p.error->message;
    ASSERT_EQ(p.moves.size(), 1u);
    const auto& m = p.moves[0];
    EXPECT_EQ(m.arc.plane, c.plane);
    expect_point(m.arc.center, c.center.x, c.center.y, c.center.z);
    expect_point(arc_point(m.arc, 0.5), c.passes.x, c.passes.y, c.passes.z, 1e-9);
}

INSTANTIATE_TEST_SUITE_P(
    interpreter, arc_direction_test,
    ::testing::Values(
        direction_case{"g17_g02", "G17 G02 X10. Y0 I5. F60", arc_plane::xy, {5, 0, 0}, {5, 5, 0}},
        direction_case{"g17_g03", "G17 G03 X10. Y0 I5. F60", arc_plane::xy, {5, 0, 0}, {5, -5, 0}},
        direction_case{"g18_g02", "G18 G02 X10. Z0 I5. K0 F60", arc_plane::zx, {5, 0, 0}, {5, 0, -5}},
        direction_case{"g18_g03", "G18 G03 X10. Z0 I5. K0 F60", arc_plane::zx, {5, 0, 0}, {5, 0, 5}},
        direction_case{"g19_g02", "G19 G02 Y10. Z0 J5. F60", arc_plane::yz, {0, 5, 0}, {0, 5, 5}},
        direction_case{"g19_g03", "G19 G03 Y10. Z0 J5. F60", arc_plane::yz, {0, 5, 0}, {0, 5, -5}}),
    [](const auto& info) { return info.param.name; });

TEST(interpreter, r_wins_over_ijk_with_a_warning_34) {
    const auto p = plan("G02 X10. Y0 I5. R-7. F60\n");
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[0].arc.center, 5, std::sqrt(24.0), 0, 1e-12);
    EXPECT_TRUE(p.warned("R is used, I/J/K ignored"));
}

TEST(interpreter, full_circle_from_ijk_without_end_words_35) {
    const auto p = plan("G02 I5. F60\nG03 X0 Y0 J-2.\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 2u);
    EXPECT_DOUBLE_EQ(p.moves[0].arc.sweep, -2 * std::numbers::pi);
    EXPECT_DOUBLE_EQ(p.moves[1].arc.sweep, 2 * std::numbers::pi);
    expect_point(p.moves[0].end, 0, 0, 0);
    // bounds: circles of radius 5 around (5, 0) and of radius 2 around (0, -2)
    expect_point(p.summary.min, -2, -5, 0);
    expect_point(p.summary.max, 10, 5, 0);
}

TEST(interpreter, near_full_circle_rule_36) {
    // End 5e-6 mm below the start on the circle around (5, 0): CCW of the start by 1e-6 rad.
    const auto cw = plan("G02 X0 Y-.000005 I5. F60\n");
    const auto ccw = plan("G03 X0 Y-.000005 I5. F60\n");
    ASSERT_TRUE(cw.ok());
    ASSERT_TRUE(ccw.ok());
    EXPECT_NEAR(cw.moves[0].arc.sweep, -2 * std::numbers::pi + 1e-6, 1e-9);  // almost a full turn
    EXPECT_NEAR(ccw.moves[0].arc.sweep, 1e-6, 1e-9);                         // a sliver
    // Within 1 nm of the start: a full circle in either direction.
    const auto full = plan("G03 X0 Y-.0000005 I5. F60\n");
    ASSERT_TRUE(full.ok());
    EXPECT_DOUBLE_EQ(full.moves[0].arc.sweep, 2 * std::numbers::pi);
}

TEST(interpreter, r_arc_end_equal_start_is_a_zero_degree_arc_37) {
    const auto p = plan("G01 X1. F60\nG02 X1. Y0 R5.\nG01 X2.\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 2u);  // no motion for the 0-degree arc
    EXPECT_EQ(p.moves[1].line, 3);
    EXPECT_TRUE(p.warned("0-degree arc"));
}

TEST(interpreter, r_sign_picks_the_arc_38) {
    const double h = std::sqrt(49.0 - 25.0);  // centre offset from the chord midpoint
    auto p = plan("G02 X10. Y0 R7. F60\n");
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[0].arc.center, 5, -h, 0, 1e-12);
    EXPECT_GT(p.moves[0].arc.sweep, -std::numbers::pi);
    EXPECT_LT(p.moves[0].arc.sweep, 0);
    p = plan("G02 X10. Y0 R-7. F60\n");
    expect_point(p.moves[0].arc.center, 5, h, 0, 1e-12);
    EXPECT_LT(p.moves[0].arc.sweep, -std::numbers::pi);
    p = plan("G03 X10. Y0 R7. F60\n");
    expect_point(p.moves[0].arc.center, 5, h, 0, 1e-12);
    // Exactly 180 degrees works with either sign.
    for (const char* prog : {"G02 X10. Y0 R5. F60\n", "G02 X10. Y0 R-5. F60\n"}) {
        p = plan(prog);
        ASSERT_TRUE(p.ok());
        expect_point(p.moves[0].arc.center, 5, 0, 0, 1e-12);
        EXPECT_NEAR(std::abs(p.moves[0].arc.sweep), std::numbers::pi, 1e-12);
    }
}

TEST(interpreter, r_slightly_short_becomes_a_half_circle_39) {
    const auto p = plan("G02 X10. Y0 R4.99995 F60\n");  // 0.05 um short of half the chord
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[0].arc.center, 5, 0, 0, 1e-12);
}

TEST(interpreter, r_near_180_is_computed_in_double_40) {
    // Half chord 5, R 5.000001: centre sqrt(R^2 - 25) = sqrt(1.000001e-5) below the chord.
    const auto p = plan("G02 X10. Y0 R5.000001 F60\n");
    ASSERT_TRUE(p.ok());
    EXPECT_NEAR(p.moves[0].arc.center.y, -std::sqrt(5.000001 * 5.000001 - 25), 1e-12);
}

TEST(interpreter, radius_mismatch_within_tolerance_41_42) {
    // r1 = 5.0004, r2 = 4.9996: 0.8 um apart, allowed 1 um.
    const auto p = plan("G02 X10. Y0 I5.0004 F60\n");
    ASSERT_TRUE(p.ok());
    const auto& m = p.moves[0];
    EXPECT_EQ(segment_end(m, m.segments), m.end);  // ends exactly at the programmed point
    const vec3 mid = arc_point(m.arc, 0.5);        // the radius varies linearly: (r1 + r2) / 2
    EXPECT_NEAR(std::hypot(mid.x - 5.0004, mid.y), 5.0, 1e-12);
    // r ~ 100 mm: 1e-4 of the radius (10 um) is allowed; I100.004 is 8 um off.
    EXPECT_TRUE(plan("G02 X200. Y0 I100.004 F60\n").ok());
    // Tighter option: the same program fails.
    gcode_options o;
    o.arc_radius_tolerance_mm = 0.0005;
    EXPECT_FALSE(plan("G02 X10. Y0 I5.0004 F60\n", o).ok());
}

TEST(interpreter, micrometre_arcs_are_fine_43) {
    // r = 20 nm (LinuxCNC rejects anything under 1.27 um in mm mode).
    const auto p = plan("G02 X.00004 Y0 I.00002 F60\n");
    ASSERT_TRUE(p.ok()) << p.error->message;
    expect_point(p.moves[0].arc.center, 0.00002, 0, 0, 1e-15);
}

TEST(interpreter, helix_44) {
    const auto p = plan("G02 Z5. I5. F60\n");  // a full helical turn
    ASSERT_TRUE(p.ok());
    const auto& m = p.moves[0];
    EXPECT_EQ(m.kind, move_kind::arc);
    expect_point(m.end, 0, 0, 5);
    expect_point(arc_point(m.arc, 0.25), 5, 5, 1.25, 1e-12);  // CW from 180 degrees passes 90 degrees
}

TEST(interpreter, arcs_in_inches_46) {
    const auto p = plan("G20 G02 X1. Y0 I.5 F10\n");
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[0].end, 25.4, 0, 0, 1e-12);
    expect_point(p.moves[0].arc.center, 12.7, 0, 0, 1e-12);
}

// ---- polar coordinates -----------------------------------------------------------------------------

TEST(interpreter, polar_mapping_per_plane_47) {
    const double c = 100 * std::cos(std::numbers::pi / 6);
    auto p = plan("G17 G16 G01 X100. Y30. F60\n");
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[0].end, c, 50, 0, 1e-9);
    p = plan("G18 G16 G01 Z100. X30. F60\n");
    expect_point(p.moves[0].end, 50, 0, c, 1e-9);
    p = plan("G19 G16 G01 Y100. Z30. F60\n");
    expect_point(p.moves[0].end, 0, c, 50, 1e-9);
}

TEST(interpreter, polar_pole_48) {
    // G91 with a radius: the pole is the current position; the angle adds to the current position's
    // angle (more cases in gcode_polar_incremental_test.cpp).
    auto p = plan("G91 G16 G01 X20. Y20. F60\nX20. Y20.\n");
    ASSERT_TRUE(p.ok());
    const double a = 20 * std::numbers::pi / 180;
    expect_point(p.moves[0].end, 20 * std::cos(a), 20 * std::sin(a), 0, 1e-9);  // (18.794, 6.840)
    expect_point(p.moves[1].end, 20 * std::cos(a) + 20 * std::cos(2 * a),
                 20 * std::sin(a) + 20 * std::sin(2 * a), 0, 1e-9);
    // G90: radius omitted -> distance of the current position from the work zero; angle omitted ->
    // the current position's angle.
    p = plan("G0 X3. Y4.\nG16 G0 Y90.\n");
    expect_point(p.moves[1].end, 0, 5, 0, 1e-9);
    p = plan("G0 X3. Y4.\nG16 G0 X10.\n");
    expect_point(p.moves[1].end, 6, 8, 0, 1e-9);
}

TEST(interpreter, polar_arc_end_with_cartesian_centre_49) {
    const auto p = plan("G91 G16 G02 X20. Y20. I9.397 J3.42 F60\n");
    ASSERT_TRUE(p.ok()) << p.error->message;
    const double a = 20 * std::numbers::pi / 180;
    expect_point(p.moves[0].end, 20 * std::cos(a), 20 * std::sin(a), 0, 1e-9);
    expect_point(p.moves[0].arc.center, 9.397, 3.42, 0, 1e-12);
}

TEST(interpreter, polar_radius_scales_angle_does_not_50) {
    gcode_options o;
    o.xyz_scale = 2;
    auto p = plan("G16 G01 X10. Y90. F60\nG15 X1. Y1.\n", o);
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[0].end, 0, 20, 0, 1e-9);
    expect_point(p.moves[1].end, 2, 2, 0, 1e-12);  // G15: Cartesian again
}

// ---- options ---------------------------------------------------------------------------------------

TEST(interpreter, xyz_scale_applies_to_xyz_ijk_r_53) {
    gcode_options o;
    o.xyz_scale = 0.5;
    auto p = plan("G02 X10. Y0 R7. F60\nG02 X10. Y0 Z4. I-2.5\n", o);
    ASSERT_TRUE(p.ok());
    expect_point(p.moves[0].end, 5, 0, 0, 1e-12);
    expect_point(p.moves[0].arc.center, 2.5, -std::sqrt(24.0) / 2, 0, 1e-12);
    expect_point(p.moves[1].arc.center, 3.75, 0, 0, 1e-12);  // from (5, 0): I-2.5 * 0.5
    expect_point(p.moves[1].end, 5, 0, 2, 1e-12);
    EXPECT_DOUBLE_EQ(p.moves[0].feed_mm_s, 1);  // feed not scaled
}

// #52 Z in analog mode
TEST(interpreter, analog_z_standard_mapping_52) {
    gcode_options o;
    o.z = z_mode::analog;
    const auto p = plan("G01 X1. F60 Z-.05\nZ0\nZ.05\nZ.05 X2.\nG91 Z-.01\n", o);
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 6u);
    EXPECT_EQ(p.moves[0].kind, move_kind::analog);  // before the motion of the block
    EXPECT_NEAR(p.moves[0].analog_v, 0, 1e-12);
    EXPECT_EQ(p.moves[1].kind, move_kind::linear);
    expect_point(p.moves[1].end, 1, 0, 0);  // the stage Z does not move
    EXPECT_NEAR(p.moves[2].analog_v, 5, 1e-12);
    EXPECT_NEAR(p.moves[3].analog_v, 10, 1e-12);
    EXPECT_EQ(p.moves[4].kind, move_kind::linear);  // Z.05 again: no new voltage
    EXPECT_NEAR(p.moves[5].analog_v, 9, 1e-12);     // +40 um
}

TEST(interpreter, analog_z_custom_limits_follow_the_falling_rule_52) {
    gcode_options o;
    o.z = z_mode::analog;
    o.analog_low_um = -50;  // equal to the standard range, yet the vendor's SETLOW/SETUP rule applies
    o.analog_high_um = 50;
    auto p = plan("G00 Z-.05\nZ.05\nZ0\n", o);
    ASSERT_TRUE(p.ok());
    EXPECT_NEAR(p.moves[0].analog_v, 10, 1e-12);
    EXPECT_NEAR(p.moves[1].analog_v, 0, 1e-12);
    EXPECT_NEAR(p.moves[2].analog_v, 5, 1e-12);
    o.analog_low_um = 0;
    o.analog_high_um = 100;
    p = plan("G00 Z.025\n", o);
    EXPECT_NEAR(p.moves[0].analog_v, 7.5, 1e-12);
}

TEST(interpreter, analog_z_in_inches_and_unscaled_52) {
    gcode_options o;
    o.z = z_mode::analog;
    o.xyz_scale = 10;
    const auto p = plan("G20 G00 Z.001\n", o);  // 25.4 um -> 0.1 * 25.4 + 5
    ASSERT_TRUE(p.ok());
    EXPECT_NEAR(p.moves[0].analog_v, 7.54, 1e-12);
}

TEST(interpreter, analog_z_out_of_range_52) {
    gcode_options o;
    o.z = z_mode::analog;
    auto p = plan("G00 Z.1\nZ-.1\n", o);  // the vendor sample's lift and plunge in mm: +-100 um
    ASSERT_TRUE(p.ok());
    EXPECT_DOUBLE_EQ(p.moves[0].analog_v, 10);
    EXPECT_DOUBLE_EQ(p.moves[1].analog_v, 0);
    EXPECT_TRUE(p.warned("outside the analog range"));
    o.analog_range = analog_range_policy::error;
    p = plan("G00 X1.\nG00 Z.1\n", o);
    ASSERT_FALSE(p.ok());
    EXPECT_EQ(p.error->line, 2);
    EXPECT_EQ(p.error->column, 5);
}

TEST(interpreter, analog_mode_refuses_arcs_that_need_z) {
    gcode_options o;
    o.z = z_mode::analog;
    EXPECT_FALSE(plan("G18 G02 X10. I5. F60\n", o).ok());
    EXPECT_FALSE(plan("G19 G16 G01 Y1. F60\n", o).ok());
    EXPECT_TRUE(plan("G17 G02 X10. Y0 I5. Z-.01 F60\n", o).ok());
}

TEST(interpreter, program_end_m02_m30) {
    const auto p = plan("G0 X1. M03\nM30\nG0 X99.\n");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p.moves.size(), 3u);  // ttl on, rapid, ttl off at the end
    EXPECT_FALSE(p.moves[2].ttl_on);
    EXPECT_EQ(p.moves[2].line, 2);
    EXPECT_TRUE(p.warned("text after M02/M30"));
    EXPECT_EQ(plan("G0 X1.\nM02\n").moves.size(), 1u);
}

}  // namespace
}  // namespace gw::gcode
