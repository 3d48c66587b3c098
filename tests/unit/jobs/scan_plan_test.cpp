// The scan planner: the SCAN module's validation (pixels = encoder counts over the line / divide,
// both < 32768, the seed's 45396 counts/mm example), strict spec parsing, path choice, steps,
// estimates, bounds, soft limits and the command preview.
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gateway/jobs/kinds/job_kinds.hpp"
#include "gateway/jobs/kinds/scan_spec.hpp"

namespace gw::jobs {
namespace {

using json = nlohmann::json;
using devices::ms2000::module;

plan_context make_context(bool scan_module, double counts_per_mm = 45396) {
    plan_context ctx;
    auto& s = ctx.snapshot;
    s.id = "sim1";
    s.state = devices::connection_state::connected;
    devices::controller_identity identity;
    identity.build.name = scan_module ? "STD_XYZ_SCAN" : "STD_XYZ";
    identity.build.motor_axes = "XYZ";
    if (scan_module) identity.build.modules.set(static_cast<std::size_t>(module::scan));
    s.identity = identity;
    for (char a : std::string("XYZ")) {
        devices::axis_state st;
        st.axis = a;
        st.position_um = 0;
        st.counts_per_mm = counts_per_mm;
        st.lower_limit_mm = -110;
        st.upper_limit_mm = 110;
        s.axes.push_back(st);
    }
    s.ttl_in0_mode = 0;
    for (char a : std::string("XYZ"))
        ctx.motion.set_axis(a, {5.5, 20, 14});
    return ctx;
}

json seed_spec() {
    return json::parse(R"({"fast": {"start_mm": 0.0, "stop_mm": 1.0, "encoder_divide": 24},
                           "slow": {"start_mm": 0.0, "stop_mm": 1.0, "lines": 1891},
                           "speed_mm_s": 0.528})");
}

TEST(scan_plan, seed_example_gives_1891_pixels_and_lines_on_the_firmware_path) {
    auto plan = plan_job(job_type::scan, seed_spec(), make_context(true));
    ASSERT_TRUE(plan) << plan.error().message;
    EXPECT_EQ(plan->path, "firmware");
    ASSERT_EQ(plan->steps.size(), 1891u);
    EXPECT_EQ(plan->steps.front().name, "line 1");
    EXPECT_EQ(plan->steps.back().name, "line 1891");
    EXPECT_NE(plan->summary.find("1891 lines x 1891 pixels"), std::string::npos) << plan->summary;
    // The approach move runs at the axis's SPEED; the scan speed is set after it.
    const std::vector<std::string> expected{"SCANR X=0 Y=1 Z=24", "SCANV X=0 Y=1 Z=1891", "SCAN Y=0 Z=1 F=0",
                                            "M X=0 Y=0",          "SPEED X=0.528",        "SCAN",
                                            "SPEED X=5.5"};
    EXPECT_EQ(plan->commands, expected);
    EXPECT_EQ(plan->commands_omitted, 0u);
    ASSERT_EQ(plan->warnings.size(), 1u);
    EXPECT_NE(plan->warnings[0].find("pause"), std::string::npos);
    // Line 2 starts one slow step (1 mm / 1890) further, at the fast start (raster).
    ASSERT_TRUE(plan->steps[1].target);
    EXPECT_DOUBLE_EQ(plan->steps[1].target->at('X'), 0);
    EXPECT_NEAR(plan->steps[1].target->at('Y'), 1000.0 / 1890, 1e-9);
    EXPECT_NEAR(plan->steps.back().target->at('Y'), 1000.0, 1e-9);
    EXPECT_EQ(plan->bounds.min.at('X'), 0);
    EXPECT_EQ(plan->bounds.max.at('X'), 1000);
    EXPECT_EQ(plan->bounds.max.at('Y'), 1000);
}

TEST(scan_plan, estimate_is_line_time_plus_retrace_or_step) {
    auto ctx = make_context(true);
    auto plan = plan_job(job_type::scan, seed_spec(), ctx);
    ASSERT_TRUE(plan);
    // The SCAN module retraces (and steps the slow axis) at the screw's top speed, 6.8 mm/s.
    const double line = ctx.motion.axis_move_seconds('X', 1.0, 0.528);
    const double retrace = ctx.motion.axis_move_seconds('X', 1.0, 6.8);
    EXPECT_LT(retrace, ctx.motion.axis_move_seconds('X', 1.0, 5.5));
    EXPECT_NEAR(plan->steps[0].estimated_s, line, 1e-9);  // the stage already is at the start
    EXPECT_NEAR(plan->steps[1].estimated_s, line + retrace, 1e-9);
    double sum = 0;
    for (const auto& s : plan->steps)
        sum += s.estimated_s;
    EXPECT_NEAR(plan->estimated_s, sum, 1e-6);

    auto serpentine = seed_spec();
    serpentine["pattern"] = "serpentine";
    auto splan = plan_job(job_type::scan, serpentine, ctx);
    ASSERT_TRUE(splan);
    const double step = ctx.motion.axis_move_seconds('Y', 1.0 / 1890, 6.8);
    EXPECT_NEAR(splan->steps[1].estimated_s, line + step, 1e-9);
    EXPECT_LT(splan->estimated_s, plan->estimated_s);
    // Serpentine: odd lines (0-based) start at the fast stop.
    EXPECT_DOUBLE_EQ(splan->steps[1].target->at('X'), 1000);
    EXPECT_DOUBLE_EQ(splan->steps[2].target->at('X'), 0);
    EXPECT_EQ(splan->commands[2], "SCAN Y=0 Z=1 F=1");
}

TEST(scan_plan, host_estimate_moves_to_each_line_start_at_speed) {
    auto ctx = make_context(false);
    auto plan = plan_job(job_type::scan, seed_spec(), ctx);
    ASSERT_TRUE(plan) << plan.error().message;
    EXPECT_EQ(plan->path, "host");
    const double line = ctx.motion.axis_move_seconds('X', 1.0, 0.528);
    // One move back to the next line's start, both axes together at their SPEED (5.5 mm/s).
    const double between = ctx.motion.move_seconds({{'X', -1.0}, {'Y', 1.0 / 1890}});
    EXPECT_NEAR(between, ctx.motion.axis_move_seconds('X', 1.0, 5.5), 1e-9);  // the retrace is longer
    EXPECT_NEAR(plan->steps[1].estimated_s, line + between, 1e-9);
}

struct pixel_row {
    const char* name;
    double counts_per_mm;
    json fast;
    int expected_pixels;        // 0: refused
    const char* refused_field;  // when refused
};

const pixel_row pixel_table[] = {
    {"seed_1891", 45396, {{"start_mm", 0.0}, {"stop_mm", 1.0}, {"encoder_divide", 24}}, 1891, ""},
    {"backwards_line", 45396, {{"start_mm", 1.0}, {"stop_mm", 0.0}, {"encoder_divide", 24}}, 1891, ""},
    {"simulator_counts", 45397.6, {{"start_mm", 0.0}, {"stop_mm", 1.0}, {"encoder_divide", 24}}, 1891, ""},
    {"default_divide_24", 45396, {{"start_mm", 0.0}, {"stop_mm", 1.0}}, 1891, ""},
    {"divide_1", 45396, {{"start_mm", 0.0}, {"stop_mm", 0.5}, {"encoder_divide", 1}}, 22698, ""},
    {"just_below_limit", 45396, {{"start_mm", 0.0}, {"stop_mm", 17.32}, {"encoder_divide", 24}}, 32760, ""},
    {"pixels_over_limit",
     45396,
     {{"start_mm", 0.0}, {"stop_mm", 17.33}, {"encoder_divide", 24}},
     0,
     "spec.fast.stop_mm"},
    {"seed_18mm",
     45396,
     {{"start_mm", 0.0}, {"stop_mm", 18.0}, {"encoder_divide", 24}},
     0,
     "spec.fast.stop_mm"},
    {"divide_32767", 45396, {{"start_mm", 0.0}, {"stop_mm", 1.0}, {"encoder_divide", 32767}}, 1, ""},
    {"divide_32768",
     45396,
     {{"start_mm", 0.0}, {"stop_mm", 1.0}, {"encoder_divide", 32768}},
     0,
     "spec.fast.encoder_divide"},
    {"shorter_than_a_pixel",
     45396,
     {{"start_mm", 0.0}, {"stop_mm", 0.0005}, {"encoder_divide", 24}},
     0,
     "spec.fast.stop_mm"},
    {"pixels_given", 45396, {{"start_mm", 0.0}, {"pixels", 1891}, {"encoder_divide", 24}}, 1891, ""},
    {"pixels_32767", 45396, {{"start_mm", 0.0}, {"pixels", 32767}, {"encoder_divide", 24}}, 32767, ""},
    {"pixels_32768",
     45396,
     {{"start_mm", 0.0}, {"pixels", 32768}, {"encoder_divide", 24}},
     0,
     "spec.fast.pixels"},
};

class scan_pixels : public ::testing::TestWithParam<pixel_row> {};

TEST_P(scan_pixels, firmware_validation) {
    const auto& row = GetParam();
    json spec = {{"fast", row.fast}, {"slow", {{"start_mm", 0.0}, {"lines", 1}}}};
    auto parsed = parse_scan_spec(spec);
    ASSERT_TRUE(parsed) << parsed.error().message;
    auto g = scan_firmware_geometry(*parsed, row.counts_per_mm);
    auto plan = plan_job(job_type::scan, spec, make_context(true, row.counts_per_mm));
    if (row.expected_pixels == 0) {
        ASSERT_FALSE(g);
        EXPECT_EQ(g.error().kind, operation_error_kind::invalid_value);
        EXPECT_EQ(g.error().field, row.refused_field) << g.error().message;
        ASSERT_FALSE(plan);
        EXPECT_EQ(plan.error().field, row.refused_field);
        // The host path validates the same way (a spec means the same on every controller).
        auto host = plan_job(job_type::scan, spec, make_context(false, row.counts_per_mm));
        ASSERT_FALSE(host);
        EXPECT_EQ(host.error().field, row.refused_field);
    } else {
        ASSERT_TRUE(g) << g.error().message;
        EXPECT_EQ(g->pixels, row.expected_pixels);
        ASSERT_TRUE(plan) << plan.error().message;
    }
}

INSTANTIATE_TEST_SUITE_P(table, scan_pixels, ::testing::ValuesIn(pixel_table),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(scan_plan, pixels_given_sets_the_stop_like_scanr_f) {
    json spec = {{"fast", {{"start_mm", 0.5}, {"pixels", 1000}, {"encoder_divide", 24}}},
                 {"slow", {{"start_mm", 0.0}, {"lines", 1}}}};
    auto plan = plan_job(job_type::scan, spec, make_context(true));
    ASSERT_TRUE(plan) << plan.error().message;
    EXPECT_EQ(plan->commands[0], "SCANR X=0.5 F=1000 Z=24");
    EXPECT_NEAR(plan->bounds.max.at('X'), 500 + 1000.0 * 24 / 45396 * 1000, 1e-6);
}

struct scan_refusal_row {
    const char* name;
    const char* spec;
    const char* field;
};

const scan_refusal_row scan_refusal_table[] = {
    {"not_an_object", R"([1])", "spec"},
    {"unknown_field", R"({"fast":{"stop_mm":1},"slow":{"lines":1},"speed":1})", "spec.speed"},
    {"unknown_fast_field", R"({"fast":{"stop_mm":1,"end":2},"slow":{"lines":1}})", "spec.fast.end"},
    {"unknown_slow_field", R"({"fast":{"stop_mm":1},"slow":{"lines":1,"step":2}})", "spec.slow.step"},
    {"missing_fast", R"({"slow":{"lines":1}})", "spec.fast"},
    {"missing_slow", R"({"fast":{"stop_mm":1}})", "spec.slow"},
    {"stop_and_pixels", R"({"fast":{"stop_mm":1,"pixels":10},"slow":{"lines":1}})", "spec.fast.pixels"},
    {"neither_stop_nor_pixels", R"({"fast":{"start_mm":1},"slow":{"lines":1}})", "spec.fast.stop_mm"},
    {"stop_equals_start", R"({"fast":{"start_mm":1,"stop_mm":1},"slow":{"lines":1}})", "spec.fast.stop_mm"},
    {"divide_zero", R"({"fast":{"stop_mm":1,"encoder_divide":0},"slow":{"lines":1}})",
     "spec.fast.encoder_divide"},
    {"divide_not_integer", R"({"fast":{"stop_mm":1,"encoder_divide":2.5},"slow":{"lines":1}})",
     "spec.fast.encoder_divide"},
    {"pixels_zero", R"({"fast":{"pixels":0},"slow":{"lines":1}})", "spec.fast.pixels"},
    {"lines_zero", R"({"fast":{"stop_mm":1},"slow":{"lines":0}})", "spec.slow.lines"},
    {"lines_32768", R"({"fast":{"stop_mm":1},"slow":{"lines":32768,"stop_mm":1}})", "spec.slow.lines"},
    {"lines_missing", R"({"fast":{"stop_mm":1},"slow":{"stop_mm":1}})", "spec.slow.lines"},
    {"slow_stop_missing", R"({"fast":{"stop_mm":1},"slow":{"lines":2}})", "spec.slow.stop_mm"},
    {"slow_stop_equals_start", R"({"fast":{"stop_mm":1},"slow":{"lines":2,"stop_mm":0}})",
     "spec.slow.stop_mm"},
    {"start_not_number", R"({"fast":{"start_mm":"0","stop_mm":1},"slow":{"lines":1}})", "spec.fast.start_mm"},
    {"pattern_bad", R"({"fast":{"stop_mm":1},"slow":{"lines":1},"pattern":"zigzag"})", "spec.pattern"},
    {"speed_zero", R"({"fast":{"stop_mm":1},"slow":{"lines":1},"speed_mm_s":0})", "spec.speed_mm_s"},
    {"speed_too_fast", R"({"fast":{"stop_mm":1},"slow":{"lines":1},"speed_mm_s":51})", "spec.speed_mm_s"},
    {"mode_bad", R"({"fast":{"stop_mm":1},"slow":{"lines":1},"mode":"fast"})", "spec.mode"},
    {"fast_axis_two_letters", R"({"fast_axis":"XY","fast":{"stop_mm":1},"slow":{"lines":1}})",
     "spec.fast_axis"},
    {"same_axes", R"({"fast_axis":"Y","fast":{"stop_mm":1},"slow":{"lines":1}})", "spec.slow_axis"},
    {"axis_not_on_controller", R"({"slow_axis":"F","fast":{"stop_mm":1},"slow":{"lines":1}})",
     "spec.slow_axis"},
    // Soft limits (+-110 mm on every axis): the field is the setting whose position is beyond them.
    {"beyond_soft_limit", R"({"fast":{"stop_mm":120,"encoder_divide":1000},"slow":{"lines":1}})",
     "spec.fast.stop_mm"},
    {"fast_start_beyond_soft_limit",
     R"({"fast":{"start_mm":-115,"stop_mm":0,"encoder_divide":1000},"slow":{"lines":1}})",
     "spec.fast.start_mm"},
    {"pixels_end_beyond_soft_limit",  // 1000 pixels of 1000 counts = 22.03 mm from 100 mm
     R"({"fast":{"start_mm":100,"pixels":1000,"encoder_divide":1000},"slow":{"lines":1}})",
     "spec.fast.pixels"},
    {"slow_beyond_soft_limit", R"({"fast":{"stop_mm":1},"slow":{"lines":2,"start_mm":100,"stop_mm":111}})",
     "spec.slow.stop_mm"},
    {"slow_start_beyond_soft_limit",
     R"({"fast":{"stop_mm":1},"slow":{"lines":2,"start_mm":-111,"stop_mm":0}})", "spec.slow.start_mm"},
    {"one_line_beyond_soft_limit", R"({"fast":{"stop_mm":1},"slow":{"lines":1,"start_mm":120}})",
     "spec.slow.start_mm"},
    {"slow_axis_x_beyond_soft_limit",
     R"({"fast_axis":"Y","slow_axis":"X","fast":{"stop_mm":1},"slow":{"lines":3,"start_mm":0,"stop_mm":-112}})",
     "spec.slow.stop_mm"},
    {"fast_axis_z_beyond_soft_limit",
     R"({"fast_axis":"Z","slow_axis":"X","fast":{"start_mm":105,"stop_mm":111,"encoder_divide":100},"slow":{"lines":1}})",
     "spec.fast.stop_mm"},
};

class scan_refusals : public ::testing::TestWithParam<scan_refusal_row> {};

TEST_P(scan_refusals, invalid_value_names_the_field) {
    const auto& row = GetParam();
    auto plan = plan_job(job_type::scan, json::parse(row.spec), make_context(true));
    ASSERT_FALSE(plan) << row.spec;
    EXPECT_EQ(plan.error().kind, operation_error_kind::invalid_value) << plan.error().message;
    EXPECT_EQ(plan.error().field, row.field) << plan.error().message;
}

INSTANTIATE_TEST_SUITE_P(table, scan_refusals, ::testing::ValuesIn(scan_refusal_table),
                         [](const auto& info) { return std::string(info.param.name); });

// Each setting is checked against its own axis's limits: Y (the slow axis) allows only 0..5 mm here,
// X (the fast axis) +-110 mm.
TEST(scan_plan, soft_limits_use_the_axis_of_each_setting) {
    auto ctx = make_context(true);
    ctx.snapshot.axes[1].lower_limit_mm = 0;
    ctx.snapshot.axes[1].upper_limit_mm = 5;
    json fits = {{"fast", {{"start_mm", 0.0}, {"stop_mm", 8.0}, {"encoder_divide", 100}}},
                 {"slow", {{"start_mm", 0.0}, {"stop_mm", 5.0}, {"lines", 2}}}};
    auto plan = plan_job(job_type::scan, fits, ctx);
    EXPECT_TRUE(plan) << plan.error().message;  // fast 8 mm is within X's limits

    json slow_out = fits;
    slow_out["slow"]["stop_mm"] = 6.0;
    plan = plan_job(job_type::scan, slow_out, ctx);
    ASSERT_FALSE(plan);
    EXPECT_EQ(plan.error().kind, operation_error_kind::invalid_value);
    EXPECT_EQ(plan.error().field, "spec.slow.stop_mm") << plan.error().message;
    EXPECT_NE(plan.error().message.find("Y=6000.0 um"), std::string::npos) << plan.error().message;
    EXPECT_NE(plan.error().message.find("upper soft limit 5 mm"), std::string::npos) << plan.error().message;

    json slow_below = fits;
    slow_below["slow"]["start_mm"] = -0.5;
    plan = plan_job(job_type::scan, slow_below, ctx);
    ASSERT_FALSE(plan);
    EXPECT_EQ(plan.error().field, "spec.slow.start_mm") << plan.error().message;
    EXPECT_NE(plan.error().message.find("lower soft limit 0 mm"), std::string::npos) << plan.error().message;
}

TEST(scan_plan, host_path_without_the_module_summarises_the_preview) {
    auto plan = plan_job(job_type::scan, seed_spec(), make_context(false));
    ASSERT_TRUE(plan) << plan.error().message;
    EXPECT_EQ(plan->path, "host");
    EXPECT_EQ(plan->steps.size(), 1891u);
    ASSERT_EQ(plan->commands.size(), max_preview_commands);
    EXPECT_EQ(plan->commands_omitted, 4u * 1891 - max_preview_commands);
    EXPECT_EQ(plan->commands[0], "M X=0 Y=0");
    EXPECT_EQ(plan->commands[1], "SPEED X=0.528");
    EXPECT_EQ(plan->commands[2], "M X=10000");
    EXPECT_EQ(plan->commands[3], "SPEED X=5.5");
    EXPECT_EQ(plan->commands[4], "M X=0 Y=5.291");  // 1000 um / 1890 lines = 0.5291 um
    ASSERT_EQ(plan->warnings.size(), 1u);
    EXPECT_NE(plan->warnings[0].find("no SCAN MODULE"), std::string::npos);
}

TEST(scan_plan, mode_choice) {
    auto spec = seed_spec();
    spec["mode"] = "firmware";
    auto refused = plan_job(job_type::scan, spec, make_context(false));
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, operation_error_kind::missing_module);
    spec["mode"] = "host";
    auto host = plan_job(job_type::scan, spec, make_context(true));
    ASSERT_TRUE(host);
    EXPECT_EQ(host->path, "host");
    EXPECT_TRUE(host->warnings.empty());
}

TEST(scan_plan, other_axes_use_their_hardware_ids) {
    auto spec = seed_spec();
    spec["fast_axis"] = "Y";
    spec["slow_axis"] = "Z";
    spec["slow"]["lines"] = 3;
    auto plan = plan_job(job_type::scan, spec, make_context(true));
    ASSERT_TRUE(plan) << plan.error().message;
    EXPECT_EQ(plan->commands[2], "SCAN Y=1 Z=2 F=0");
    EXPECT_EQ(plan->commands[3], "M Y=0 Z=0");
    EXPECT_EQ(plan->commands[4], "SPEED Y=0.528");
    EXPECT_DOUBLE_EQ(plan->steps[2].target->at('Z'), 1000);
}

TEST(scan_plan, unknown_counts_per_mm_is_not_connected) {
    auto ctx = make_context(true);
    ctx.snapshot.axes[0].counts_per_mm.reset();
    auto plan = plan_job(job_type::scan, seed_spec(), ctx);
    ASSERT_FALSE(plan);
    EXPECT_EQ(plan.error().kind, operation_error_kind::not_connected);
}

}  // namespace
}  // namespace gw::jobs
