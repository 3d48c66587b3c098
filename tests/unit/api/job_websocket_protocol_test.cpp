// The WebSocket's job messages ({"op":"job"}) and the "lease" field of commands.
#include <string>
#include <string_view>
#include <variant>

#include <gtest/gtest.h>

#include "api/ws/websocket_protocol.hpp"

namespace gw::api {
namespace {

using nlohmann::json;

TEST(job_message, submit_with_every_field) {
    auto r = parse_client_message(
        R"({"op":"job","id":"s1","action":"submit","args":{"controller":"sim1","type":"array","spec":{"plate":"96"}},)"
        R"("lease":"l-0123","idempotency_key":"plate-7","dry_run":true})");
    ASSERT_TRUE(r.has_value()) << r.error().error.detail;
    const auto* j = std::get_if<job_message>(&*r);
    ASSERT_NE(j, nullptr);
    EXPECT_EQ(j->id, "s1");
    EXPECT_EQ(j->action, "submit");
    EXPECT_EQ(j->args["controller"], "sim1");
    EXPECT_EQ(j->args["spec"]["plate"], "96");
    EXPECT_EQ(j->lease, "l-0123");
    EXPECT_EQ(j->idempotency_key, "plate-7");
    EXPECT_TRUE(j->dry_run);
    EXPECT_TRUE(j->job.empty());
}

TEST(job_message, actions_on_a_job) {
    for (std::string_view action : {"get", "cancel", "pause", "resume", "next"}) {
        auto text =
            std::string(R"({"op":"job","id":7,"action":")") + std::string(action) + R"(","job":"j-01ABC"})";
        auto r = parse_client_message(text);
        ASSERT_TRUE(r.has_value()) << text << ": " << r.error().error.detail;
        const auto* j = std::get_if<job_message>(&*r);
        ASSERT_NE(j, nullptr);
        EXPECT_EQ(j->action, action);
        EXPECT_EQ(j->job, "j-01ABC");
        EXPECT_EQ(j->id, 7);
        EXPECT_FALSE(j->lease);
        EXPECT_FALSE(j->dry_run);
    }
}

TEST(command_message, carries_the_lease) {
    auto r = parse_client_message(
        R"({"op":"command","id":"c1","controller":"sim1","operation":"move","args":{"axes":{"X":1}},"lease":"l-9"})");
    ASSERT_TRUE(r.has_value()) << r.error().error.detail;
    const auto* c = std::get_if<command_message>(&*r);
    ASSERT_NE(c, nullptr);
    EXPECT_EQ(c->lease, "l-9");
    auto plain = parse_client_message(R"({"op":"command","id":"c2","controller":"sim1","operation":"halt"})");
    ASSERT_TRUE(plain.has_value());
    EXPECT_FALSE(std::get<command_message>(*plain).lease);
}

struct refused_job_case {
    std::string_view name;
    std::string text;
    std::string_view field;
    json id;
};

class refused_job : public ::testing::TestWithParam<refused_job_case> {};

TEST_P(refused_job, is_422_naming_the_field) {
    const auto& c = GetParam();
    auto r = parse_client_message(c.text);
    ASSERT_FALSE(r.has_value()) << c.text;
    EXPECT_EQ(r.error().error.status, 422u);
    EXPECT_EQ(r.error().error.kind, "invalid_value");
    EXPECT_EQ(r.error().error.field, c.field) << c.text;
    EXPECT_EQ(r.error().id, c.id);
    EXPECT_EQ(r.error().error.instance, "/api/v1/ws");
}

INSTANTIATE_TEST_SUITE_P(
    all, refused_job,
    ::testing::Values(
        refused_job_case{"no_id", R"({"op":"job","action":"get","job":"j-1"})", "id", nullptr},
        refused_job_case{"no_action", R"({"op":"job","id":1,"job":"j-1"})", "action", 1},
        refused_job_case{"unknown_action", R"({"op":"job","id":1,"action":"delete","job":"j-1"})", "action",
                         1},
        refused_job_case{"unknown_field", R"({"op":"job","id":1,"action":"get","job":"j-1","x":1})", "x", 1},
        refused_job_case{"no_job", R"({"op":"job","id":1,"action":"cancel"})", "job", 1},
        refused_job_case{"job_not_id", R"({"op":"job","id":1,"action":"cancel","job":"a/b"})", "job", 1},
        refused_job_case{"job_number", R"({"op":"job","id":1,"action":"cancel","job":5})", "job", 1},
        refused_job_case{"submit_without_args", R"({"op":"job","id":1,"action":"submit"})", "args", 1},
        refused_job_case{"submit_args_array", R"({"op":"job","id":1,"action":"submit","args":[]})", "args",
                         1},
        refused_job_case{"submit_with_job", R"({"op":"job","id":1,"action":"submit","args":{},"job":"j-1"})",
                         "job", 1},
        refused_job_case{"dry_run_string",
                         R"({"op":"job","id":1,"action":"submit","args":{},"dry_run":"yes"})", "dry_run", 1},
        refused_job_case{"args_on_cancel", R"({"op":"job","id":1,"action":"cancel","job":"j-1","args":{}})",
                         "args", 1},
        refused_job_case{"dry_run_on_next",
                         R"({"op":"job","id":1,"action":"next","job":"j-1","dry_run":true})", "dry_run", 1},
        refused_job_case{"lease_empty", R"({"op":"job","id":1,"action":"next","job":"j-1","lease":""})",
                         "lease", 1},
        refused_job_case{"lease_number", R"({"op":"job","id":1,"action":"next","job":"j-1","lease":3})",
                         "lease", 1},
        refused_job_case{"key_space",
                         R"({"op":"job","id":1,"action":"submit","args":{},"idempotency_key":"a b"})",
                         "idempotency_key", 1},
        refused_job_case{"command_lease_space",
                         R"({"op":"command","id":1,"controller":"sim1","operation":"halt","lease":"a b"})",
                         "lease", 1}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(job_message, replayed_result_message) {
    auto plain = json::parse(call_result_message("s1", {{"id", "j-1"}}));
    EXPECT_FALSE(plain.contains("replayed"));
    auto replayed = json::parse(call_result_message("s1", {{"id", "j-1"}}, true));
    EXPECT_EQ(replayed["replayed"], true);
    EXPECT_EQ(replayed["result"]["id"], "j-1");
    EXPECT_EQ(replayed["type"], "result");
}

}  // namespace
}  // namespace gw::api
