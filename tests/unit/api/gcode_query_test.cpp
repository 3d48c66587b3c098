// parse_gcode_query: the query string of /api/v1/gcode/plan and /preview.svg, read the way the route
// reads it (parse_query first: percent escapes, repeated names), every option and the exact error.
#include <functional>
#include <string>
#include <string_view>

#include <gtest/gtest.h>

#include "api/calls/gcode_check.hpp"

namespace gw::api {
namespace {

operation_result<gcode_query> parse(std::string_view target, gcode_output output = gcode_output::plan) {
    auto q = parse_query(target);
    if (!q) return q.error();
    return parse_gcode_query(*q, output);
}

// ---- accepted ----------------------------------------------------------------------------------------

struct good_case {
    std::string name;
    std::string query;
    gcode_output output;
    std::function<bool(const gcode_query&)> holds;
};

class gcode_query_good : public ::testing::TestWithParam<good_case> {};

TEST_P(gcode_query_good, sets_the_option) {
    const auto& c = GetParam();
    auto r = parse("/api/v1/gcode/plan?" + c.query, c.output);
    ASSERT_TRUE(r.has_value()) << c.query << ": " << r.error().message;
    EXPECT_TRUE(c.holds(*r)) << c.query;
}

using gcode::analog_range_policy;
using gcode::decimal_point_reading;
using gcode::z_mode;
constexpr auto plan = gcode_output::plan;
constexpr auto preview = gcode_output::preview;

INSTANTIATE_TEST_SUITE_P(
    all, gcode_query_good,
    ::testing::Values(
        good_case{"xyz_scale", "xyz_scale=2.5", plan, [](auto& r) { return r.options.xyz_scale == 2.5; }},
        good_case{"speed_scale", "speed_scale=0.5", plan,
                  [](auto& r) { return r.options.speed_scale == 0.5; }},
        good_case{"arc_tolerance", "arc_tolerance_mm=0.0005", plan,
                  [](auto& r) { return r.options.arc_tolerance_mm == 0.0005; }},
        good_case{"arc_tolerance_smallest", "arc_tolerance_mm=1e-7", plan,
                  [](auto& r) { return r.options.arc_tolerance_mm == 1e-7; }},
        good_case{"max_feed", "max_feed_mm_s=3", plan, [](auto& r) { return r.options.max_feed_mm_s == 3; }},
        good_case{"rapid", "rapid_mm_s=2", plan, [](auto& r) { return r.options.rapid_mm_s == 2; }},
        good_case{"least_increment", "decimal_point=least_increment", plan,
                  [](auto& r) { return r.options.decimal_point == decimal_point_reading::least_increment; }},
        good_case{"calculator", "decimal_point=calculator", plan,
                  [](auto& r) { return r.options.decimal_point == decimal_point_reading::calculator; }},
        good_case{"z_analog", "z_mode=analog", plan, [](auto& r) { return r.options.z == z_mode::analog; }},
        good_case{"z_axis", "z_mode=axis", plan, [](auto& r) { return r.options.z == z_mode::axis; }},
        good_case{"analog_range_error", "analog_range=error", plan,
                  [](auto& r) { return r.options.analog_range == analog_range_policy::error; }},
        good_case{"analog_limits", "analog_low_um=-20&analog_high_um=30", plan,
                  [](auto& r) { return r.options.analog_low_um == -20 && r.options.analog_high_um == 30; }},
        good_case{"radius_tolerance_zero", "arc_radius_tolerance_mm=0", plan,
                  [](auto& r) { return r.options.arc_radius_tolerance_mm == 0; }},
        good_case{"relative_tolerance", "arc_radius_relative_tolerance=0.001", plan,
                  [](auto& r) { return r.options.arc_radius_relative_tolerance == 0.001; }},
        good_case{"r_deficit", "arc_r_deficit_tolerance_mm=0", plan,
                  [](auto& r) { return r.options.arc_r_deficit_tolerance_mm == 0; }},
        good_case{"ramp_settle", "ramp_ms=0&settle_ms=5", plan,
                  [](auto& r) { return r.options.ramp_ms == 0 && r.options.settle_ms == 5; }},
        good_case{"moves_false", "moves=false", plan, [](auto& r) { return !r.moves; }},
        good_case{"moves_zero", "moves=0", plan, [](auto& r) { return !r.moves; }},
        good_case{"moves_true", "moves=true", plan, [](auto& r) { return r.moves; }},
        good_case{"moves_bare", "moves", plan, [](auto& r) { return r.moves; }},
        good_case{"escaped_value", "xyz_scale=%32", plan, [](auto& r) { return r.options.xyz_scale == 2; }},
        good_case{"escaped_name", "xyz%5Fscale=3", plan, [](auto& r) { return r.options.xyz_scale == 3; }},
        good_case{"plus_sign", "xyz_scale=+2", plan, [](auto& r) { return r.options.xyz_scale == 2; }},
        good_case{"escaped_plus", "xyz_scale=%2B4", plan, [](auto& r) { return r.options.xyz_scale == 4; }},
        good_case{"exponent", "max_feed_mm_s=1e0", plan,
                  [](auto& r) { return r.options.max_feed_mm_s == 1; }},
        good_case{"empty_pairs_skipped", "&&xyz_scale=2&", plan,
                  [](auto& r) { return r.options.xyz_scale == 2; }},
        good_case{"preview_options", "view=ZX&width_px=1200&max_points=500&xyz_scale=2", preview,
                  [](auto& r) {
                      return r.preview.view == gcode::arc_plane::zx && r.preview.width_px == 1200 &&
                             r.preview.max_points == 500 && r.options.xyz_scale == 2;
                  }},
        good_case{"preview_view_lower_case", "view=yz", preview,
                  [](auto& r) { return r.preview.view == gcode::arc_plane::yz; }}),
    [](const auto& info) { return info.param.name; });

TEST(gcode_query, no_parameters_are_the_defaults) {
    auto r = parse("/api/v1/gcode/plan");
    ASSERT_TRUE(r.has_value());
    const gcode::gcode_options defaults;
    EXPECT_TRUE(r->moves);
    EXPECT_EQ(r->options.xyz_scale, defaults.xyz_scale);
    EXPECT_EQ(r->options.arc_tolerance_mm, defaults.arc_tolerance_mm);
    EXPECT_EQ(r->options.max_feed_mm_s, defaults.max_feed_mm_s);
    EXPECT_EQ(r->options.decimal_point, defaults.decimal_point);
    EXPECT_EQ(r->options.z, defaults.z);
    EXPECT_FALSE(r->options.analog_low_um);
}

// ---- refused: invalid_value, the field and the whole message ----------------------------------------

struct bad_case {
    std::string name;
    std::string query;
    gcode_output output;
    std::string field;
    std::string message;
};

class gcode_query_bad : public ::testing::TestWithParam<bad_case> {};

TEST_P(gcode_query_bad, names_the_field_and_says_why) {
    const auto& c = GetParam();
    auto r = parse("/api/v1/gcode/plan?" + c.query, c.output);
    ASSERT_FALSE(r.has_value()) << c.query;
    EXPECT_EQ(r.error().kind, operation_error_kind::invalid_value);
    EXPECT_EQ(r.error().field, c.field);
    EXPECT_EQ(r.error().message, c.message);
}

const std::string plan_unknown_tail = "\" (known: moves and the G-code options of gateway/gcode/README.md)";
const std::string preview_unknown_tail =
    "\" (known: view, width_px, max_points and the G-code options of gateway/gcode/README.md)";

INSTANTIATE_TEST_SUITE_P(
    numbers, gcode_query_bad,
    ::testing::Values(
        bad_case{"not_numeric", "xyz_scale=abc", plan, "xyz_scale",
                 "xyz_scale must be a number, not \"abc\""},
        bad_case{"empty", "xyz_scale=", plan, "xyz_scale", "xyz_scale must be a number, not \"\""},
        bad_case{"bare", "speed_scale", plan, "speed_scale", "speed_scale must be a number, not \"\""},
        bad_case{"nan", "xyz_scale=nan", plan, "xyz_scale", "xyz_scale must be a number, not \"nan\""},
        bad_case{"NaN", "max_feed_mm_s=NaN", plan, "max_feed_mm_s",
                 "max_feed_mm_s must be a number, not \"NaN\""},
        bad_case{"inf", "rapid_mm_s=inf", plan, "rapid_mm_s", "rapid_mm_s must be a number, not \"inf\""},
        bad_case{"minus_infinity", "ramp_ms=-infinity", plan, "ramp_ms",
                 "ramp_ms must be a number, not \"-infinity\""},
        bad_case{"overflow", "xyz_scale=1e400", plan, "xyz_scale",
                 "xyz_scale must be a number, not \"1e400\""},
        bad_case{"hex", "xyz_scale=0x10", plan, "xyz_scale", "xyz_scale must be a number, not \"0x10\""},
        bad_case{"comma", "xyz_scale=1,5", plan, "xyz_scale", "xyz_scale must be a number, not \"1,5\""},
        bad_case{"trailing_unit", "arc_tolerance_mm=1um", plan, "arc_tolerance_mm",
                 "arc_tolerance_mm must be a number, not \"1um\""},
        // A decoded blank or control character is not echoed.
        bad_case{"escaped_blank", "xyz_scale=%201", plan, "xyz_scale",
                 "xyz_scale must be a number, not \"...\""},
        bad_case{"double_sign", "xyz_scale=+-1", plan, "xyz_scale",
                 "xyz_scale must be a number, not \"+-1\""},
        bad_case{"zero_scale", "xyz_scale=0", plan, "xyz_scale", "xyz_scale must be > 0"},
        bad_case{"negative_scale", "xyz_scale=-1", plan, "xyz_scale", "xyz_scale must be > 0"},
        bad_case{"minus_zero", "xyz_scale=-0", plan, "xyz_scale", "xyz_scale must be > 0"},
        bad_case{"zero_speed_scale", "speed_scale=0", plan, "speed_scale", "speed_scale must be > 0"},
        bad_case{"tolerance_too_small", "arc_tolerance_mm=1e-8", plan, "arc_tolerance_mm",
                 "arc_tolerance_mm must be >= 1e-7"},
        bad_case{"tolerance_zero", "arc_tolerance_mm=0", plan, "arc_tolerance_mm",
                 "arc_tolerance_mm must be >= 1e-7"},
        bad_case{"zero_max_feed", "max_feed_mm_s=0", plan, "max_feed_mm_s", "max_feed_mm_s must be > 0"},
        bad_case{"negative_max_feed", "max_feed_mm_s=-5", plan, "max_feed_mm_s", "max_feed_mm_s must be > 0"},
        bad_case{"zero_rapid", "rapid_mm_s=0", plan, "rapid_mm_s", "rapid_mm_s must be > 0"},
        bad_case{"negative_radius_tolerance", "arc_radius_tolerance_mm=-1", plan, "arc_radius_tolerance_mm",
                 "arc_radius_tolerance_mm must be >= 0"},
        bad_case{"negative_relative_tolerance", "arc_radius_relative_tolerance=-0.1", plan,
                 "arc_radius_relative_tolerance", "arc_radius_relative_tolerance must be >= 0"},
        bad_case{"negative_r_deficit", "arc_r_deficit_tolerance_mm=-1e-3", plan, "arc_r_deficit_tolerance_mm",
                 "arc_r_deficit_tolerance_mm must be >= 0"},
        bad_case{"negative_ramp", "ramp_ms=-1", plan, "ramp_ms", "ramp_ms must be >= 0"},
        bad_case{"negative_settle", "settle_ms=-0.5", plan, "settle_ms", "settle_ms must be >= 0"},
        // Upper bounds: past them a plan means nothing (a 0 mm/s feed, a 60-digit duration).
        bad_case{"tiny_speed_scale", "speed_scale=1e-300", plan, "speed_scale",
                 "speed_scale must be within 1e-6..1e6"},
        bad_case{"huge_scale", "xyz_scale=1e7", plan, "xyz_scale", "xyz_scale must be within 1e-6..1e6"},
        bad_case{"huge_max_feed", "max_feed_mm_s=1001", plan, "max_feed_mm_s",
                 "max_feed_mm_s must be <= 1000"},
        bad_case{"huge_rapid", "rapid_mm_s=1e4", plan, "rapid_mm_s", "rapid_mm_s must be <= 1000"},
        bad_case{"huge_ramp", "ramp_ms=1e300", plan, "ramp_ms", "ramp_ms must be <= 60000"},
        bad_case{"huge_settle", "settle_ms=60001", plan, "settle_ms", "settle_ms must be <= 60000"},
        bad_case{"huge_poll", "arrival_poll_ms=1e5", plan, "arrival_poll_ms",
                 "arrival_poll_ms must be <= 60000"},
        // The first bad parameter is named, in query order.
        bad_case{"first_of_two", "speed_scale=x&xyz_scale=y", plan, "speed_scale",
                 "speed_scale must be a number, not \"x\""}),
    [](const auto& info) { return info.param.name; });

INSTANTIATE_TEST_SUITE_P(
    words, gcode_query_bad,
    ::testing::Values(
        bad_case{"decimal_point_case", "decimal_point=Calculator", plan, "decimal_point",
                 "decimal_point must be calculator or least_increment, not \"Calculator\""},
        bad_case{"decimal_point_short", "decimal_point=least", plan, "decimal_point",
                 "decimal_point must be calculator or least_increment, not \"least\""},
        bad_case{"z_mode", "z_mode=sideways", plan, "z_mode",
                 "z_mode must be axis or analog, not \"sideways\""},
        bad_case{"z_mode_empty", "z_mode=", plan, "z_mode", "z_mode must be axis or analog, not \"\""},
        bad_case{"analog_range", "analog_range=wrap", plan, "analog_range",
                 "analog_range must be clamp or error, not \"wrap\""},
        bad_case{"analog_low_alone", "analog_low_um=10", plan, "analog_high_um",
                 "analog_low_um and analog_high_um must be given together"},
        bad_case{"analog_high_alone", "analog_high_um=10", plan, "analog_low_um",
                 "analog_low_um and analog_high_um must be given together"},
        bad_case{"analog_reversed", "analog_low_um=10&analog_high_um=5", plan, "analog_low_um",
                 "analog_low_um must be below analog_high_um"},
        bad_case{"analog_equal", "analog_low_um=5&analog_high_um=5", plan, "analog_low_um",
                 "analog_low_um must be below analog_high_um"},
        bad_case{"analog_not_numeric", "analog_low_um=low&analog_high_um=5", plan, "analog_low_um",
                 "analog_low_um must be a number, not \"low\""},
        bad_case{"moves_word", "moves=maybe", plan, "moves", "moves must be true or false, not \"maybe\""},
        bad_case{"moves_capital", "moves=False", plan, "moves", "moves must be true or false, not \"False\""},
        bad_case{"view", "view=XZ", preview, "view", "view must be XY, ZX or YZ, not \"XZ\""},
        bad_case{"width_small", "width_px=49", preview, "width_px",
                 "width_px must be a number from 50 to 10000, not \"49\""},
        bad_case{"width_large", "width_px=10001", preview, "width_px",
                 "width_px must be a number from 50 to 10000, not \"10001\""},
        bad_case{"width_nan", "width_px=nan", preview, "width_px",
                 "width_px must be a number from 50 to 10000, not \"nan\""},
        bad_case{"max_points_fraction", "max_points=100.5", preview, "max_points",
                 "max_points must be a whole number from 100 to 1000000, not \"100.5\""},
        bad_case{"max_points_small", "max_points=99", preview, "max_points",
                 "max_points must be a whole number from 100 to 1000000, not \"99\""}),
    [](const auto& info) { return info.param.name; });

INSTANTIATE_TEST_SUITE_P(
    names, gcode_query_bad,
    ::testing::Values(
        bad_case{"unknown", "bogus=1", plan, "bogus", "unknown parameter \"bogus" + plan_unknown_tail},
        bad_case{"unknown_preview", "bogus=1", preview, "bogus",
                 "unknown parameter \"bogus" + preview_unknown_tail},
        // The preview's options are not the plan's, and moves is not the preview's.
        bad_case{"view_on_plan", "view=XY", plan, "view", "unknown parameter \"view" + plan_unknown_tail},
        bad_case{"moves_on_preview", "moves=false", preview, "moves",
                 "unknown parameter \"moves" + preview_unknown_tail},
        bad_case{"option_case", "XYZ_SCALE=2", plan, "XYZ_SCALE",
                 "unknown parameter \"XYZ_SCALE" + plan_unknown_tail},
        bad_case{"not_settable", "max_line_chars=100", plan, "max_line_chars",
                 "unknown parameter \"max_line_chars" + plan_unknown_tail},
        // A name with a control character or of absurd length is not echoed, not even as the field.
        bad_case{"control_name", "x%01=1", plan, "...", "unknown parameter \"..." + plan_unknown_tail},
        bad_case{"long_name", std::string(100, 'a') + "=1", plan, "...",
                 "unknown parameter \"..." + plan_unknown_tail},
        // parse_query's refusals, as the route sees them.
        bad_case{"repeated", "xyz_scale=1&xyz_scale=2", plan, "xyz_scale",
                 "parameter xyz_scale is given twice"},
        bad_case{"repeated_through_escape", "xyz_scale=1&xyz%5Fscale=2", plan, "xyz_scale",
                 "parameter xyz_scale is given twice"},
        bad_case{"bad_escape_value", "xyz_scale=%G1", plan, "xyz_scale",
                 "malformed percent escape in the value of xyz_scale"},
        bad_case{"truncated_escape", "xyz_scale=1%2", plan, "xyz_scale",
                 "malformed percent escape in the value of xyz_scale"}),
    [](const auto& info) { return info.param.name; });

}  // namespace
}  // namespace gw::api
