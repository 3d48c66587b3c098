// MQTT command payloads: the envelope (id, token, reply_to), fields the topic gives, and the reuse of
// the WebSocket parser's checks (operation names, args, lease, job fields).
#include "api/mqtt/mqtt_request.hpp"

#include <string>
#include <variant>
#include <vector>

#include <gtest/gtest.h>

namespace gw::api {
namespace {

using nlohmann::json;

const mqtt_topics topics("asi", "gw");
const mqtt_command_target sim1{mqtt_command_kind::controller, "sim1"};
const mqtt_command_target submit{mqtt_command_kind::job_submit, {}};
const mqtt_command_target cancel{mqtt_command_kind::job_cancel, {}};

auto parse(const mqtt_command_target& target, const std::string& payload) {
    auto envelope = open_mqtt_envelope(payload, 4096);
    EXPECT_TRUE(envelope) << payload;
    return parse_mqtt_request(topics, target, "asi/gw/x", envelope ? std::move(*envelope) : mqtt_envelope{},
                              "mqtt-7");
}

TEST(mqtt_request, what_is_not_even_looked_at_before_the_sender_is_known) {
    const std::string long_token = R"({"operation":"halt","token":")" + std::string(1025, 't') + "\"}";
    for (const std::string& payload : std::vector<std::string>{
             "not json", "[1]", "", "\"halt\"", R"({"operation":"halt","token":5})", long_token})
        EXPECT_FALSE(open_mqtt_envelope(payload, 4096)) << payload;
    const std::string big = R"({"operation":"halt","token":"t","pad":")" + std::string(5000, 'x') + "\"}";
    auto refused = open_mqtt_envelope(big, 4096);
    ASSERT_FALSE(refused);
    EXPECT_NE(refused.error().find("max_payload_bytes"), std::string::npos) << refused.error();
    auto opened = open_mqtt_envelope(big, big.size());
    ASSERT_TRUE(opened);
    EXPECT_EQ(opened->token, "t");
    EXPECT_FALSE(opened->message.contains("token")) << "the token never travels further than the envelope";
}

TEST(mqtt_request, controller_command) {
    auto r =
        parse(sim1, R"({"id":"c1","operation":"move","args":{"axes":{"X":10}},"lease":"l-1","token":"tok",
                            "reply_to":"clients/me"})");
    ASSERT_TRUE(r) << r.error().error.detail;
    EXPECT_EQ(r->token, "tok");
    EXPECT_EQ(r->reply_to, "clients/me");
    EXPECT_EQ(r->id, "c1");
    auto* c = std::get_if<command_message>(&r->message);
    ASSERT_TRUE(c);
    EXPECT_EQ(c->controller, "sim1");
    EXPECT_EQ(c->operation, "move");
    EXPECT_EQ(c->args["axes"]["X"], 10);
    EXPECT_EQ(c->lease, "l-1");
    EXPECT_EQ(mqtt_request_id(r->id), "mqtt.c1");
}

TEST(mqtt_request, id_is_optional_and_generated) {
    auto r = parse(sim1, R"({"operation":"halt"})");
    ASSERT_TRUE(r) << r.error().error.detail;
    EXPECT_EQ(r->id, "mqtt-7");
    EXPECT_FALSE(r->id_given) << "a generated id cannot tell a redelivery";
    EXPECT_EQ(r->token, "");
    EXPECT_FALSE(r->reply_to);
    auto n = parse(sim1, R"({"id":42,"operation":"halt"})");
    ASSERT_TRUE(n);
    EXPECT_EQ(n->id, 42);
    EXPECT_TRUE(n->id_given);
}

TEST(mqtt_request, not_after_is_taken_off_as_unix_milliseconds) {
    auto r =
        parse(sim1, R"({"id":"m","operation":"move","args":{"axes":{"X":1}},"not_after":1796545200123})");
    ASSERT_TRUE(r) << r.error().error.detail;
    EXPECT_EQ(r->not_after_ms, 1796545200123);
    auto none = parse(sim1, R"({"id":"m","operation":"move","args":{"axes":{"X":1}}})");
    ASSERT_TRUE(none);
    EXPECT_FALSE(none->not_after_ms);
    auto job =
        parse(submit, R"({"id":"s","args":{"controller":"sim1","type":"array","spec":{}},"not_after":5})");
    ASSERT_TRUE(job) << job.error().error.detail;
    EXPECT_EQ(job->not_after_ms, 5);
}

TEST(mqtt_request, gcode_check) {
    const mqtt_command_target check{mqtt_command_kind::gcode_check, {}};
    auto r = parse(check, R"({"id":"g","file":"g-01JD0000000000000000000000","options":{"xyz_scale":2}})");
    ASSERT_TRUE(r) << r.error().error.detail;
    auto* g = std::get_if<gcode_message>(&r->message);
    ASSERT_TRUE(g);
    EXPECT_EQ(g->file, "g-01JD0000000000000000000000");
    EXPECT_EQ(g->options["xyz_scale"], 2);
    // The action comes from the topic.
    auto twice = parse(check, R"({"id":"g","action":"check","file":"g-01JD0000000000000000000000"})");
    ASSERT_FALSE(twice);
    EXPECT_EQ(twice.error().error.field, "action");
    auto bad = parse(check, R"({"id":"g","file":"j-01JD0000000000000000000000"})");
    ASSERT_FALSE(bad);
    EXPECT_EQ(bad.error().error.field, "file");
}

TEST(mqtt_request, jobs) {
    auto s = parse(submit,
                   R"({"id":"s","args":{"controller":"sim1","type":"array","spec":{}},"idempotency_key":"k",
                              "dry_run":true,"token":"t"})");
    ASSERT_TRUE(s) << s.error().error.detail;
    auto* j = std::get_if<job_message>(&s->message);
    ASSERT_TRUE(j);
    EXPECT_EQ(j->action, "submit");
    EXPECT_TRUE(j->dry_run);
    EXPECT_EQ(j->idempotency_key, "k");
    auto c = parse(cancel, R"({"job":"j-01ABC","token":"t"})");
    ASSERT_TRUE(c) << c.error().error.detail;
    auto* k = std::get_if<job_message>(&c->message);
    ASSERT_TRUE(k);
    EXPECT_EQ(k->action, "cancel");
    EXPECT_EQ(k->job, "j-01ABC");
}

struct bad_case {
    mqtt_command_target target;
    std::string payload;
    unsigned status;
    std::string field;
    json id;
    bool has_reply_to;
};

TEST(mqtt_request, malformed_payloads_are_refused_with_the_field) {
    const std::vector<bad_case> cases = {
        {sim1, R"({"id":"a","operation":"fly"})", 422, "operation", "a", false},
        {sim1, R"({"id":"a","operation":"move","args":[1]})", 422, "args", "a", false},
        {sim1, R"({"id":"a","operation":"move","colour":1,"reply_to":"me/r"})", 422, "colour", "a", true},
        {sim1, R"({"id":"a","operation":"halt","controller":"sim2"})", 422, "controller", "a", false},
        {sim1, R"({"id":"a","operation":"halt","op":"command"})", 422, "op", "a", false},
        {sim1, R"({"id":{"x":1},"operation":"halt"})", 422, "id", json(), false},
        {sim1, R"({"id":"a","operation":"halt","reply_to":"asi/gw/status"})", 422, "reply_to", "a", false},
        {sim1, R"({"id":"a","operation":"halt","reply_to":"x/#"})", 422, "reply_to", "a", false},
        {sim1, R"({"id":"a","operation":"halt","lease":""})", 422, "lease", "a", false},
        {submit, R"({"id":"a","action":"submit","args":{}})", 422, "action", "a", false},
        {submit, R"({"id":"a"})", 422, "args", "a", false},
        {submit, R"({"id":"a","args":{},"dry_run":"yes"})", 422, "dry_run", "a", false},
        {cancel, R"({"id":"a","job":"bad id!"})", 422, "job", "a", false},
        {cancel, R"({"id":"a","job":"j-1","args":{}})", 422, "args", "a", false},
        {sim1, R"({"id":"a","operation":"halt","not_after":"2026-12-06T10:00:00Z"})", 422, "not_after", "a",
         false},
        {sim1, R"({"id":"a","operation":"halt","not_after":1.5e12})", 422, "not_after", "a", false},
        {sim1, R"({"id":"a","operation":"halt","not_after":-1,"reply_to":"me/r"})", 422, "not_after", "a",
         true},
    };
    for (const auto& c : cases) {
        auto r = parse(c.target, c.payload);
        ASSERT_FALSE(r) << c.payload;
        EXPECT_EQ(r.error().error.status, c.status) << c.payload;
        EXPECT_EQ(r.error().error.field, c.field) << c.payload;
        EXPECT_EQ(r.error().id, c.id) << c.payload;
        EXPECT_EQ(r.error().reply_to.has_value(), c.has_reply_to) << c.payload;
        EXPECT_EQ(r.error().error.instance, "asi/gw/x") << c.payload;
    }
}

}  // namespace
}  // namespace gw::api
