// spec.record in the planner: a boolean, on a controller with a report port, for every job type but a
// planar correction; the plan says it records and previews the trigger input it sets and puts back.
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gateway/jobs/kinds/job_kinds.hpp"
#include "tests/support/plan_context_fixture.hpp"

namespace gw::jobs {
namespace {

using json = nlohmann::json;

plan_context make_context(devices::report_port_state report, std::optional<int> in0_mode) {
    auto ctx = test_support::connected_context("XY");
    for (char a : std::string("XY"))
        ctx.motion.set_axis(a, {5.5, 20, 14});
    ctx.snapshot.ttl_in0_mode = in0_mode;
    ctx.snapshot.report = report;
    return ctx;
}

json ring_tour(json record) {
    json spec = json::parse(R"({"positions": [{"X": 0, "Y": 0}, {"X": 1000, "Y": 500}], "mode": "host"})");
    spec["record"] = std::move(record);
    return spec;
}

TEST(record_plan, a_recording_run_sets_the_input_first_and_puts_it_back_last) {
    auto ctx = make_context(devices::report_port_state::open, 0);
    auto plan = plan_job(job_type::ring_buffer, ring_tour(true), ctx);
    ASSERT_TRUE(plan) << plan.error().message;
    EXPECT_TRUE(plan->record);
    EXPECT_NE(plan->summary.find("records each trigger's positions"), std::string::npos) << plan->summary;
    ASSERT_GE(plan->commands.size(), 2u);
    EXPECT_EQ(plan->commands.front(), "TTL X=1");
    EXPECT_EQ(plan->commands.back(), "TTL X=0");
}

TEST(record_plan, an_input_on_already_is_left_as_it_is) {
    auto ctx = make_context(devices::report_port_state::open, 2);
    auto with = plan_job(job_type::ring_buffer, ring_tour(true), ctx);
    auto without = plan_job(job_type::ring_buffer, ring_tour(false), ctx);
    ASSERT_TRUE(with && without);
    EXPECT_TRUE(with->record);
    EXPECT_FALSE(without->record);
    EXPECT_EQ(with->commands, without->commands);
}

TEST(record_plan, refusals_name_spec_record) {
    const auto refused = [](job_type type, const json& spec, const plan_context& ctx) {
        auto plan = plan_job(type, spec, ctx);
        EXPECT_FALSE(plan);
        return plan ? std::string() : plan.error().field + ": " + plan.error().message;
    };
    auto ctx = make_context(devices::report_port_state::open, 0);
    EXPECT_EQ(refused(job_type::ring_buffer, ring_tour("yes"), ctx),
              "spec.record: record must be true or false");
    EXPECT_NE(refused(job_type::planar_correction, json{{"record", true}}, ctx).find("spec.record: a planar"),
              std::string::npos);
    auto no_port = make_context(devices::report_port_state::none, 0);
    EXPECT_NE(refused(job_type::ring_buffer, ring_tour(true), no_port).find("sim1 has no report port"),
              std::string::npos);
    // Without a report port a job that does not record plans as before.
    EXPECT_TRUE(plan_job(job_type::ring_buffer, ring_tour(false), no_port));
}

}  // namespace
}  // namespace gw::jobs
