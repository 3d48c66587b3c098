// The ring_buffer planner: strict spec parsing, capacity, axis mask, path choice (RING BUFFER,
// TTL_REPORT_INT, one-position TTL tours), steps per tour, estimates and the command preview.
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gateway/jobs/kinds/job_kinds.hpp"
#include "gateway/jobs/kinds/ring_buffer_spec.hpp"
#include "tests/support/plan_context_fixture.hpp"

namespace gw::jobs {
namespace {

using json = nlohmann::json;
using devices::ms2000::module;

plan_context make_context(std::vector<module> modules, int ring_size = 50) {
    auto ctx = test_support::connected_context("XYZ");
    auto& build = ctx.snapshot.identity->build;
    for (auto m : modules)
        build.modules.set(static_cast<std::size_t>(m));
    build.ring_buffer_size = ring_size;
    ctx.snapshot.ttl_in0_mode = 0;
    for (char a : std::string("XYZ"))
        ctx.motion.set_axis(a, {5.5, 20, 14});
    return ctx;
}

json two_positions() {
    return json::parse(R"({"positions": [{"X": 0, "Y": 0}, {"X": 1000, "Y": 500}], "delay_ms": 100})");
}

TEST(ring_buffer_plan, autoplay_once_on_the_firmware_path) {
    auto ctx = make_context({module::ring_buffer});
    auto plan = plan_job(job_type::ring_buffer, two_positions(), ctx);
    ASSERT_TRUE(plan) << plan.error().message;
    EXPECT_EQ(plan->path, "firmware");
    const std::vector<std::string> expected{"RM X=0",         "LD X=0 Y=0", "LD X=10000 Y=5000",
                                            "RM Y=3 Z=0 F=2", "RT Z=100",   "RM"};
    EXPECT_EQ(plan->commands, expected);
    ASSERT_EQ(plan->steps.size(), 2u);
    EXPECT_EQ(plan->steps[0].name, "position 1");
    EXPECT_EQ(plan->steps[1].name, "position 2");
    EXPECT_EQ(plan->steps[1].target->at('X'), 1000);
    EXPECT_FALSE(plan->steps[0].waits_for_trigger);
    EXPECT_DOUBLE_EQ(plan->steps[0].estimated_s, 0);  // already there
    EXPECT_NEAR(plan->steps[1].estimated_s, ctx.motion.move_seconds({{'X', 1.0}, {'Y', 0.5}}) + 0.1, 1e-9);
    EXPECT_EQ(plan->bounds.max.at('Y'), 500);
    EXPECT_NE(plan->summary.find("autoplay, once"), std::string::npos) << plan->summary;
}

TEST(ring_buffer_plan, repeating_tours) {
    auto spec = two_positions();
    spec["repeat"] = true;
    spec["cycles"] = 3;
    auto plan = plan_job(job_type::ring_buffer, spec, make_context({module::ring_buffer}));
    ASSERT_TRUE(plan) << plan.error().message;
    ASSERT_EQ(plan->steps.size(), 6u);
    EXPECT_EQ(plan->steps[0].name, "tour 1 position 1");
    EXPECT_EQ(plan->steps[5].name, "tour 3 position 2");
    const std::vector<std::string> expected{
        "RM X=0", "LD X=0 Y=0", "LD X=10000 Y=5000", "RM Y=3 Z=0 F=2", "RT Z=100", "RM", "RM Z=0", "RM",
        "RM Z=0", "RM"};
    EXPECT_EQ(plan->commands, expected);

    spec.erase("cycles");  // repeat alone: until cancelled, repeating autoplay
    auto forever = plan_job(job_type::ring_buffer, spec, make_context({module::ring_buffer}));
    ASSERT_TRUE(forever);
    EXPECT_EQ(forever->steps.size(), 2u);
    EXPECT_EQ(forever->commands[3], "RM Y=3 Z=0 F=3");
    EXPECT_EQ(forever->commands.back(), "RM");
    EXPECT_FALSE(forever->warnings.empty());
}

TEST(ring_buffer_plan, ttl_and_next_triggers) {
    auto spec = json::parse(R"({"positions": [{"X": 0}, {"X": 100}, {"X": 200}], "trigger": "ttl"})");
    auto plan = plan_job(job_type::ring_buffer, spec, make_context({module::ring_buffer}));
    ASSERT_TRUE(plan) << plan.error().message;
    EXPECT_EQ(plan->path, "firmware");
    EXPECT_TRUE(plan->steps[0].waits_for_trigger);
    const std::vector<std::string> expected{"RM X=0",         "LD X=0",  "LD X=1000", "LD X=2000",
                                            "RM Y=1 Z=0 F=1", "TTL X=1", "TTL X=0"};
    EXPECT_EQ(plan->commands, expected);

    spec["trigger"] = "next";
    auto next = plan_job(job_type::ring_buffer, spec, make_context({module::ring_buffer}));
    ASSERT_TRUE(next);
    EXPECT_EQ(std::count(next->commands.begin(), next->commands.end(), "RM"), 3);

    // TTL_REPORT_INT: IN0 only latches reports, so TTL/next tours run host-driven.
    spec["trigger"] = "ttl";
    auto report =
        plan_job(job_type::ring_buffer, spec, make_context({module::ring_buffer, module::ttl_report}));
    ASSERT_TRUE(report);
    EXPECT_EQ(report->path, "host");
    spec["mode"] = "firmware";
    auto refused =
        plan_job(job_type::ring_buffer, spec, make_context({module::ring_buffer, module::ttl_report}));
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().field, "spec.trigger");
}

TEST(ring_buffer_plan, host_fallback_without_the_module) {
    auto plan = plan_job(job_type::ring_buffer, two_positions(), make_context({}));
    ASSERT_TRUE(plan) << plan.error().message;
    EXPECT_EQ(plan->path, "host");
    const std::vector<std::string> expected{"M X=0 Y=0", "M X=10000 Y=5000"};
    EXPECT_EQ(plan->commands, expected);
    auto spec = two_positions();
    spec["mode"] = "firmware";
    auto refused = plan_job(job_type::ring_buffer, spec, make_context({}));
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, operation_error_kind::missing_module);
}

TEST(ring_buffer_plan, capacity_comes_from_the_build) {
    json spec = {{"positions", json::array()}};
    for (int i = 0; i < 51; ++i)
        spec["positions"].push_back({{"X", i * 10}});
    auto refused = plan_job(job_type::ring_buffer, spec, make_context({module::ring_buffer}));
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().field, "spec.positions");
    auto bigger = plan_job(job_type::ring_buffer, spec, make_context({module::ring_buffer}, 250));
    ASSERT_TRUE(bigger) << bigger.error().message;
    spec["positions"].erase(50);
    EXPECT_TRUE(plan_job(job_type::ring_buffer, spec, make_context({module::ring_buffer})));
}

struct refusal_row {
    const char* name;
    const char* spec;
    const char* field;
};

const refusal_row refusal_table[] = {
    {"unknown_field", R"({"positions":[{"X":0}],"dwell_ms":1})", "spec.dwell_ms"},
    {"no_positions", R"({"trigger":"ttl"})", "spec.positions"},
    {"empty_positions", R"({"positions":[]})", "spec.positions"},
    {"position_not_object", R"({"positions":[{"X":0},5]})", "spec.positions[1]"},
    {"position_bad_axis", R"({"positions":[{"x":0}]})", "spec.positions[0].x"},
    {"position_not_number", R"({"positions":[{"X":"0"}]})", "spec.positions[0].X"},
    {"position_beyond_travel", R"({"positions":[{"X":2e6}]})", "spec.positions[0].X"},
    {"position_missing_axis", R"({"positions":[{"X":0,"Y":0},{"X":1}]})", "spec.positions[1].Y"},
    {"position_outside_mask", R"({"positions":[{"X":0,"Y":0}],"axes":"X"})", "spec.positions[0].Y"},
    {"axes_twice", R"({"positions":[{"X":0}],"axes":"XX"})", "spec.axes"},
    {"axes_not_motor", R"({"positions":[{"F":0}]})", "spec.axes"},
    {"trigger_bad", R"({"positions":[{"X":0}],"trigger":"timer"})", "spec.trigger"},
    {"delay_negative", R"({"positions":[{"X":0}],"delay_ms":-1})", "spec.delay_ms"},
    {"delay_with_ttl", R"({"positions":[{"X":0},{"X":1}],"trigger":"ttl","delay_ms":5})", "spec.delay_ms"},
    {"repeat_not_bool", R"({"positions":[{"X":0}],"repeat":1})", "spec.repeat"},
    {"cycles_without_repeat", R"({"positions":[{"X":0}],"cycles":3})", "spec.cycles"},
    {"cycles_negative", R"({"positions":[{"X":0}],"repeat":true,"cycles":-1})", "spec.cycles"},
    {"mode_bad", R"({"positions":[{"X":0}],"mode":"both"})", "spec.mode"},
    {"ttl_one_position_firmware", R"({"positions":[{"X":0}],"trigger":"ttl","mode":"firmware"})",
     "spec.trigger"},
    {"beyond_soft_limit", R"({"positions":[{"X":0},{"X":111000}]})", "spec.steps[1]"},
};

class ring_buffer_refusals : public ::testing::TestWithParam<refusal_row> {};

TEST_P(ring_buffer_refusals, invalid_value_names_the_field) {
    const auto& row = GetParam();
    auto plan = plan_job(job_type::ring_buffer, json::parse(row.spec), make_context({module::ring_buffer}));
    ASSERT_FALSE(plan) << row.spec;
    EXPECT_EQ(plan.error().kind, operation_error_kind::invalid_value) << plan.error().message;
    EXPECT_EQ(plan.error().field, row.field) << plan.error().message;
}

INSTANTIATE_TEST_SUITE_P(table, ring_buffer_refusals, ::testing::ValuesIn(refusal_table),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace gw::jobs
