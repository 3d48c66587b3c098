#include "api/ws/websocket_protocol.hpp"

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <gtest/gtest.h>

namespace gw::api {
namespace {

using nlohmann::json;

// ---- refused messages: one row per way a client can get it wrong ----

struct refused_case {
    std::string_view name;
    std::string text;
    unsigned status;
    std::string_view kind;
    std::string_view field;  // the problem's "field"
    json id;                 // echoed id (null when the message had none or an invalid one)
};

class refused : public ::testing::TestWithParam<refused_case> {};

TEST_P(refused, is_answered_with_a_problem) {
    const auto& c = GetParam();
    auto r = parse_client_message(c.text);
    ASSERT_FALSE(r.has_value()) << c.text;
    const auto& e = r.error();
    EXPECT_EQ(e.error.status, c.status) << c.text;
    EXPECT_EQ(e.error.kind, c.kind) << c.text;
    EXPECT_EQ(e.error.field, c.field) << c.text;
    EXPECT_EQ(e.error.instance, "/api/v1/ws");
    EXPECT_FALSE(e.error.detail.empty());
    EXPECT_EQ(e.id, c.id) << c.text;
    // The answer is one valid JSON text frame.
    auto answer = json::parse(call_error_message(e.id, e.error));
    EXPECT_EQ(answer["type"], "error");
    EXPECT_EQ(answer["id"], c.id);
    EXPECT_EQ(answer["problem"]["status"], c.status);
    EXPECT_EQ(answer["problem"]["type"], e.error.type());
}

const refused_case refused_cases[] = {
    {"not_json", "{\"op\":", 400, "malformed_json", "", nullptr},
    {"empty", "", 400, "malformed_json", "", nullptr},
    {"garbage", "\xff\xfe", 400, "malformed_json", "", nullptr},
    {"array", "[1,2]", 400, "malformed_json", "", nullptr},
    {"string", "\"subscribe\"", 400, "malformed_json", "", nullptr},
    {"no_op", "{\"topics\":[\"#\"]}", 422, "invalid_value", "op", nullptr},
    {"op_not_string", "{\"op\":1}", 422, "invalid_value", "op", nullptr},
    {"unknown_op", "{\"op\":\"publish\",\"id\":5}", 422, "invalid_value", "op", 5},
    {"id_bool", "{\"op\":\"ping\",\"id\":true}", 422, "invalid_value", "id", nullptr},
    {"id_float", "{\"op\":\"ping\",\"id\":1.5}", 422, "invalid_value", "id", nullptr},
    {"id_empty", "{\"op\":\"ping\",\"id\":\"\"}", 422, "invalid_value", "id", nullptr},
    {"id_control_char", "{\"op\":\"ping\",\"id\":\"a\\nb\"}", 422, "invalid_value", "id", nullptr},
    {"id_too_long", "{\"op\":\"ping\",\"id\":\"" + std::string(129, 'x') + "\"}", 422, "invalid_value", "id",
     nullptr},
    {"ping_unknown_field", "{\"op\":\"ping\",\"id\":\"p\",\"x\":1}", 422, "invalid_value", "x", "p"},
    {"subscribe_no_topics", "{\"op\":\"subscribe\",\"id\":1}", 422, "invalid_value", "topics", 1},
    {"subscribe_topics_empty", "{\"op\":\"subscribe\",\"topics\":[]}", 422, "invalid_value", "topics",
     nullptr},
    {"subscribe_topics_string", "{\"op\":\"subscribe\",\"topics\":\"#\"}", 422, "invalid_value", "topics",
     nullptr},
    {"subscribe_topic_number", "{\"op\":\"subscribe\",\"topics\":[\"#\",7]}", 422, "invalid_value",
     "topics[1]", nullptr},
    {"subscribe_bad_wildcard", "{\"op\":\"subscribe\",\"topics\":[\"controllers/+x/state\"]}", 422,
     "invalid_value", "topics[0]", nullptr},
    {"subscribe_hash_not_last", "{\"op\":\"subscribe\",\"topics\":[\"#/state\"]}", 422, "invalid_value",
     "topics[0]", nullptr},
    {"subscribe_empty_level", "{\"op\":\"subscribe\",\"topics\":[\"controllers//state\"]}", 422,
     "invalid_value", "topics[0]", nullptr},
    {"subscribe_space", "{\"op\":\"subscribe\",\"topics\":[\"a b\"]}", 422, "invalid_value", "topics[0]",
     nullptr},
    {"subscribe_unknown_field", "{\"op\":\"subscribe\",\"topics\":[\"#\"],\"qos\":1}", 422, "invalid_value",
     "qos", nullptr},
    {"subscribe_rate_string", "{\"op\":\"subscribe\",\"topics\":[\"#\"],\"max_rate_hz\":\"5\"}", 422,
     "invalid_value", "max_rate_hz", nullptr},
    {"subscribe_rate_negative", "{\"op\":\"subscribe\",\"topics\":[\"#\"],\"max_rate_hz\":-1}", 422,
     "invalid_value", "max_rate_hz", nullptr},
    {"subscribe_rate_too_high", "{\"op\":\"subscribe\",\"topics\":[\"#\"],\"max_rate_hz\":1e6}", 422,
     "invalid_value", "max_rate_hz", nullptr},
    {"subscribe_resume_array", "{\"op\":\"subscribe\",\"topics\":[\"#\"],\"resume\":[1]}", 422,
     "invalid_value", "resume", nullptr},
    {"subscribe_resume_wildcard", "{\"op\":\"subscribe\",\"topics\":[\"#\"],\"resume\":{\"a/+\":1}}", 422,
     "invalid_value", "resume.a/+", nullptr},
    {"subscribe_resume_negative", "{\"op\":\"subscribe\",\"topics\":[\"#\"],\"resume\":{\"a/b\":-1}}", 422,
     "invalid_value", "resume.a/b", nullptr},
    {"subscribe_resume_float", "{\"op\":\"subscribe\",\"topics\":[\"#\"],\"resume\":{\"a/b\":1.5}}", 422,
     "invalid_value", "resume.a/b", nullptr},
    {"subscribe_resume_not_covered",
     "{\"op\":\"subscribe\",\"id\":\"s\",\"topics\":[\"controllers/+/ttl\"],"
     "\"resume\":{\"controllers/sim1/reports\":3}}",
     422, "invalid_value", "resume.controllers/sim1/reports", "s"},
    {"unsubscribe_unknown_field", "{\"op\":\"unsubscribe\",\"topics\":[\"#\"],\"resume\":{}}", 422,
     "invalid_value", "resume", nullptr},
    {"unsubscribe_bad_filter", "{\"op\":\"unsubscribe\",\"topics\":[\"a#\"]}", 422, "invalid_value",
     "topics[0]", nullptr},
    {"command_without_id", "{\"op\":\"command\",\"controller\":\"sim1\",\"operation\":\"halt\"}", 422,
     "invalid_value", "id", nullptr},
    {"command_no_controller", "{\"op\":\"command\",\"id\":1,\"operation\":\"halt\"}", 422, "invalid_value",
     "controller", 1},
    {"command_empty_controller", "{\"op\":\"command\",\"id\":1,\"controller\":\"\",\"operation\":\"halt\"}",
     422, "invalid_value", "controller", 1},
    {"command_no_operation", "{\"op\":\"command\",\"id\":1,\"controller\":\"sim1\"}", 422, "invalid_value",
     "operation", 1},
    {"command_unknown_operation",
     "{\"op\":\"command\",\"id\":\"m\",\"controller\":\"sim1\",\"operation\":\"fly\"}", 422, "invalid_value",
     "operation", "m"},
    {"command_args_array",
     "{\"op\":\"command\",\"id\":1,\"controller\":\"sim1\",\"operation\":\"move\",\"args\":[1]}", 422,
     "invalid_value", "args", 1},
    {"command_unknown_field",
     "{\"op\":\"command\",\"id\":1,\"controller\":\"sim1\",\"operation\":\"halt\",\"body\":{}}", 422,
     "invalid_value", "body", 1},
};

INSTANTIATE_TEST_SUITE_P(websocket_protocol, refused, ::testing::ValuesIn(refused_cases),
                         [](const auto& info) { return std::string(info.param.name); });

// ---- accepted messages ----

TEST(websocket_protocol, subscribe_with_wildcards_resume_and_rate) {
    auto r = parse_client_message(
        R"({"op":"subscribe","id":1,"topics":["controllers/+/position","jobs/#"],
            "resume":{"controllers/sim1/position":41,"jobs/7":0},"max_rate_hz":10})");
    ASSERT_TRUE(r.has_value()) << r.error().error.detail;
    const auto* s = std::get_if<ws_subscribe>(&*r);
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->id, 1);
    EXPECT_EQ(s->topics, (std::vector<std::string>{"controllers/+/position", "jobs/#"}));
    EXPECT_EQ(s->resume.at("controllers/sim1/position"), 41u);
    EXPECT_EQ(s->resume.at("jobs/7"), 0u);
    EXPECT_DOUBLE_EQ(s->max_rate_hz, 10);

    auto ack = json::parse(ws_subscribed_message(*s));
    EXPECT_EQ(ack, json::parse(R"({"type":"subscribed","id":1,"topics":["controllers/+/position","jobs/#"],
        "resume":{"controllers/sim1/position":41,"jobs/7":0},"max_rate_hz":10.0})"));
}

TEST(websocket_protocol, subscribe_defaults) {
    auto r = parse_client_message(R"({"op":"subscribe","topics":["#"]})");
    ASSERT_TRUE(r.has_value());
    const auto& s = std::get<ws_subscribe>(*r);
    EXPECT_TRUE(s.id.is_null());
    EXPECT_TRUE(s.resume.empty());
    EXPECT_EQ(s.max_rate_hz, 0);
    auto ack = json::parse(ws_subscribed_message(s));
    EXPECT_TRUE(ack["id"].is_null());
    EXPECT_EQ(ack["resume"], json::object());
}

TEST(websocket_protocol, null_id_counts_as_absent) {
    auto r = parse_client_message(R"({"op":"ping","id":null})");
    ASSERT_TRUE(r.has_value());
    EXPECT_TRUE(std::get<ws_ping>(*r).id.is_null());
}

TEST(websocket_protocol, topic_limit_per_message) {
    json msg = {{"op", "subscribe"}, {"topics", json::array()}};
    for (std::size_t i = 0; i < ws_max_topics_per_message; ++i)
        msg["topics"].push_back("jobs/" + std::to_string(i));
    EXPECT_TRUE(parse_client_message(msg.dump()).has_value());
    msg["topics"].push_back("jobs/x");
    auto r = parse_client_message(msg.dump());
    ASSERT_FALSE(r.has_value());
    EXPECT_EQ(r.error().error.field, "topics");
}

TEST(websocket_protocol, unsubscribe) {
    auto r =
        parse_client_message(R"({"op":"unsubscribe","id":"u","topics":["jobs/#","controllers/sim1/ttl"]})");
    ASSERT_TRUE(r.has_value());
    const auto& u = std::get<ws_unsubscribe>(*r);
    EXPECT_EQ(u.topics.size(), 2u);
    EXPECT_EQ(json::parse(ws_unsubscribed_message(u)),
              json::parse(R"({"type":"unsubscribed","id":"u","topics":["jobs/#","controllers/sim1/ttl"]})"));
}

TEST(websocket_protocol, command_keeps_args_for_operation_requests) {
    auto r = parse_client_message(R"({"op":"command","id":"c7","controller":"sim1","operation":"move",
        "args":{"axes":{"X":1000,"Q":1},"mode":"sideways"}})");
    ASSERT_TRUE(r.has_value());
    const auto& c = std::get<command_message>(*r);
    EXPECT_EQ(c.id, "c7");
    EXPECT_EQ(c.controller, "sim1");
    EXPECT_EQ(c.operation, "move");
    // Argument validation is operation_requests' job (same as REST): passed on untouched.
    EXPECT_EQ(c.args, json::parse(R"({"axes":{"X":1000,"Q":1},"mode":"sideways"})"));
}

TEST(websocket_protocol, command_without_args_gets_an_empty_object) {
    for (auto text : {R"({"op":"command","id":3,"controller":"sim2","operation":"halt"})",
                      R"({"op":"command","id":3,"controller":"sim2","operation":"halt","args":null})"}) {
        auto r = parse_client_message(text);
        ASSERT_TRUE(r.has_value()) << text;
        EXPECT_EQ(std::get<command_message>(*r).args, json::object()) << text;
    }
}

TEST(websocket_protocol, every_rest_operation_is_a_command) {
    for (auto name : {"move", "halt", "home", "zero", "here", "speed", "ttl", "dac", "led", "command"}) {
        json msg = {{"op", "command"}, {"id", 1}, {"controller", "sim1"}, {"operation", name}};
        auto r = parse_client_message(msg.dump());
        ASSERT_TRUE(r.has_value()) << name;
        EXPECT_EQ(std::get<command_message>(*r).operation, name);
    }
}

TEST(websocket_protocol, ping_and_pong) {
    auto r = parse_client_message(R"({"op":"ping","id":"p1"})");
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(json::parse(ws_pong_message(std::get<ws_ping>(*r).id)),
              json::parse(R"({"type":"pong","id":"p1"})"));
    auto bare = parse_client_message(R"({"op":"ping"})");
    ASSERT_TRUE(bare.has_value());
    EXPECT_EQ(json::parse(ws_pong_message(std::get<ws_ping>(*bare).id)),
              json::parse(R"({"type":"pong","id":null})"));
}

// ---- server messages ----

TEST(websocket_protocol, request_ids_name_connection_and_client_id) {
    EXPECT_EQ(ws_request_id("ws-5", "c7"), "ws-5.c7");
    EXPECT_EQ(ws_request_id("ws-5", 42), "ws-5.42");
    EXPECT_EQ(ws_request_id("ws-12", -3), "ws-12.-3");
}

TEST(websocket_protocol, hello) {
    const json open = {{"client", nullptr}, {"role", "admin"}, {"auth", "none"}};
    EXPECT_EQ(json::parse(ws_hello_message("ws-1", "anonymous", open, 65536)),
              json::parse(R"({"type":"hello","connection":"ws-1","user":"anonymous","role":"admin",
                              "client":null,"auth":"none","max_message_bytes":65536,
                              "batch_ms":null})"));
    const json token = {{"client", "viewer1"}, {"role", "viewer"}, {"auth", "token"}};
    EXPECT_EQ(json::parse(ws_hello_message("ws-2", "viewer1", token, 65536)),
              json::parse(R"({"type":"hello","connection":"ws-2","user":"viewer1","role":"viewer",
                              "client":"viewer1","auth":"token","max_message_bytes":65536,
                              "batch_ms":null})"));
    EXPECT_EQ(json::parse(ws_hello_message("ws-3", "anonymous", open, 65536, std::chrono::milliseconds(20)))
                  .at("batch_ms"),
              20);
}

TEST(websocket_protocol, batch_window_from_the_upgrade_query) {
    struct row {
        std::string_view target;
        std::optional<long> window_ms;  // nullopt: no batching
        bool valid;
    };
    const row rows[] = {
        {"/api/v1/ws", std::nullopt, true},
        {"/api/v1/ws?access_token=abc", std::nullopt, true},
        {"/api/v1/ws?batch_ms=0", 0, true},
        {"/api/v1/ws?access_token=abc&batch_ms=20", 20, true},
        {"/api/v1/ws?batch_ms=1000", 1000, true},
        {"/api/v1/ws?batch_ms=1001", std::nullopt, false},
        {"/api/v1/ws?batch_ms=", std::nullopt, false},
        {"/api/v1/ws?batch_ms=-5", std::nullopt, false},
        {"/api/v1/ws?batch_ms=5ms", std::nullopt, false},
        {"/api/v1/ws?batch_ms=99999999999999999999999", std::nullopt, false},
        {"/api/v1/ws?batch_ms=1&batch_ms=2", std::nullopt, false},
    };
    for (const auto& r : rows) {
        auto options = parse_websocket_options(r.target);
        ASSERT_EQ(options.has_value(), r.valid) << r.target;
        if (!options) {
            EXPECT_EQ(options.error().kind, gw::operation_error_kind::invalid_value) << r.target;
            EXPECT_EQ(options.error().field, "batch_ms") << r.target;
            continue;
        }
        ASSERT_EQ(options->batch_window.has_value(), r.window_ms.has_value()) << r.target;
        if (r.window_ms) {
            EXPECT_EQ(options->batch_window->count(), *r.window_ms) << r.target;
        }
    }
}

TEST(websocket_protocol, a_batch_joins_the_events_own_messages_in_order) {
    auto t = std::chrono::system_clock::time_point(std::chrono::milliseconds(1'795'322'740'123));
    std::vector<std::shared_ptr<const gw::event>> events{
        gw::make_data_event("controllers/s/reports", 7, t, std::make_shared<const std::string>(R"({"n":1})")),
        gw::make_gap_event("controllers/s/reports", 8, 9, t),
        gw::make_data_event("controllers/s/reports", 10, t, std::make_shared<const std::string>("[1,2]")),
    };
    auto batch = json::parse(ws_batch_message(events));
    ASSERT_EQ(batch.at("type"), "batch");
    ASSERT_EQ(batch.at("events").size(), 3u);
    for (std::size_t i = 0; i < events.size(); ++i)
        EXPECT_EQ(batch["events"][i], json::parse(*events[i]->message)) << i;
    EXPECT_EQ(batch["events"][1]["missed"], 2);
    EXPECT_EQ(json::parse(ws_batch_message({events[0]}))["events"].size(), 1u);
}

TEST(websocket_protocol, result_wraps_the_rest_body) {
    json result = {{"id", "sim1"}, {"operation", "halt"}, {"request_id", "ws-1.9"}, {"latency_us", 812}};
    EXPECT_EQ(json::parse(call_result_message(9, result)),
              (json{{"type", "result"}, {"id", 9}, {"result", result}}));
}

TEST(websocket_protocol, result_text_is_the_documents_text) {
    // Written without a document of the whole message: byte for byte what the document would give.
    const json result = {{"id", "sim1"}, {"reply", {{"raw", ":A 1.5 \u00e9"}}}, {"latency_us", 812}};
    for (const json& id : {json(9), json("s-\u00fc")})
        for (bool replayed : {false, true}) {
            json whole{{"type", "result"}, {"id", id}, {"result", result}};
            if (replayed) whole["replayed"] = true;
            EXPECT_EQ(call_result_message(id, result, replayed),
                      whole.dump(-1, ' ', false, json::error_handler_t::replace))
                << id << " " << replayed;
        }
}

TEST(websocket_protocol, error_carries_the_problem_body) {
    auto p =
        make_problem(make_error(operation_error_kind::missing_module, "sim2 has no DAC OUT module", "volts"));
    p.request_id = "ws-1.d";
    auto msg = json::parse(call_error_message("d", p));
    EXPECT_EQ(msg["type"], "error");
    EXPECT_EQ(msg["id"], "d");
    EXPECT_EQ(msg["problem"], p.to_json());
    EXPECT_EQ(msg["problem"]["status"], 409);
    EXPECT_EQ(msg["problem"]["type"], "https://asi-gateway.dev/problems/missing-module");
}

TEST(websocket_protocol, invalid_utf8_never_throws_when_building_answers) {
    problem p = make_problem(http_error::malformed_json, "bad \xff byte");
    EXPECT_NO_THROW({
        auto text = call_error_message(nullptr, p);
        EXPECT_TRUE(json::accept(text));
    });
}

TEST(websocket_protocol, binary_frames_are_refused) {
    auto e = binary_frame_error();
    EXPECT_EQ(e.error.status, 400u);
    EXPECT_TRUE(e.id.is_null());
}

}  // namespace
}  // namespace gw::api
