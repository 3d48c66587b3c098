// The "mqtt" section of the config file: defaults, every key, and errors that name the key.
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "gateway/config/config.hpp"

namespace gw {
namespace {

using namespace std::chrono_literals;

TEST(mqtt_config, defaults_are_off_and_safe) {
    auto c = parse_config("{}");
    ASSERT_TRUE(c) << c.error();
    const auto& m = c->mqtt;
    EXPECT_FALSE(m.enabled);
    EXPECT_FALSE(m.commands_enabled);
    EXPECT_EQ(m.brokers, std::vector<std::string>{"mqtt://127.0.0.1:1883"});
    EXPECT_EQ(m.topic_prefix, "asi");
    EXPECT_TRUE(m.gateway_id.empty());
    EXPECT_EQ(m.protocol, mqtt_protocol::v5);
    EXPECT_EQ(m.keepalive, 30s);
    EXPECT_EQ(m.qos.status, 1);
    EXPECT_EQ(m.qos.telemetry, 0);
    EXPECT_EQ(m.position_max_hz, 10.0);
    EXPECT_EQ(m.reports_batch, 10ms);
    EXPECT_TRUE(m.tcp_nodelay);
    EXPECT_TRUE(m.tls.verify);
    // A broker's return is noticed within reconnect_max however long it was away (issue 12).
    EXPECT_EQ(m.reconnect_min, 500ms);
    EXPECT_EQ(m.reconnect_max, 2000ms);
    // A signed move runs within 10 s of its signing or not at all; ids are remembered for 10 min.
    EXPECT_EQ(m.command_max_age, 10s);
    EXPECT_EQ(m.command_redelivery_window, 600s);
}

TEST(mqtt_config, every_key_is_read) {
    auto c =
        parse_config(R"({"auth":{"tokens":[{"name":"op","token":"Tok-0123456789abcdef","role":"operator"}]},
      "mqtt":{"enabled":true,"brokers":["mqtts://broker.lab:8883","ssl://[::1]:8884","tcp://b2"],
      "client_id":"gw-7","username":"u","password":"p",
      "tls":{"ca_file":"/etc/ca.pem","cert_file":"c.pem","key_file":"k.pem","verify":false},
      "keepalive_s":12,"session_expiry_s":300,"topic_prefix":"lab/asi","gateway_id":"pc-3.lab","protocol":"3.1.1",
      "qos":{"status":2,"state":0,"telemetry":1,"jobs":2,"responses":0},
      "telemetry":{"position_max_hz":2.5,"reports_batch_ms":0},"reconnect":{"min_ms":100,"max_ms":2000},"tcp_nodelay":false,
      "jobs":{"queue_limit":7,"retain_finished_s":0},"commands":{"enabled":true,"max_payload_bytes":2048,
      "signature_window_s":5,"max_age_s":3,"redelivery_window_s":120,"signing_keys":[{"name":"scheduler","role":"operator",
      "key":"a1b2c3d4e5f60718293a4b5c6d7e8f90a1b2c3d4e5f60718293a4b5c6d7e8f91"}]}}})");
    ASSERT_TRUE(c) << c.error();
    const auto& m = c->mqtt;
    EXPECT_TRUE(m.enabled);
    EXPECT_EQ(m.brokers.size(), 3u);
    EXPECT_EQ(m.client_id, "gw-7");
    EXPECT_EQ(m.username, "u");
    EXPECT_EQ(m.password, "p");
    EXPECT_EQ(m.tls.ca_file, "/etc/ca.pem");
    EXPECT_EQ(m.tls.key_file, "k.pem");
    EXPECT_FALSE(m.tls.verify);
    EXPECT_EQ(m.keepalive, 12s);
    EXPECT_EQ(m.topic_prefix, "lab/asi");
    EXPECT_EQ(m.gateway_id, "pc-3.lab");
    EXPECT_EQ(m.protocol, mqtt_protocol::v3_1_1);
    EXPECT_EQ(m.qos.status, 2);
    EXPECT_EQ(m.qos.state, 0);
    EXPECT_EQ(m.qos.telemetry, 1);
    EXPECT_EQ(m.qos.jobs, 2);
    EXPECT_EQ(m.qos.responses, 0);
    EXPECT_EQ(m.position_max_hz, 2.5);
    EXPECT_EQ(m.reports_batch, 0ms);
    EXPECT_FALSE(m.tcp_nodelay);
    EXPECT_EQ(m.reconnect_min, 100ms);
    EXPECT_EQ(m.reconnect_max, 2000ms);
    EXPECT_EQ(m.job_queue_limit, 7u);
    EXPECT_EQ(m.command_max_payload_bytes, 2048u);
    EXPECT_EQ(m.command_max_age, 3s);
    EXPECT_EQ(m.command_redelivery_window, 120s);
    EXPECT_EQ(m.session_expiry, 300s);
    EXPECT_EQ(m.retain_finished_jobs, 0s);
    EXPECT_TRUE(m.commands_enabled);
    EXPECT_EQ(m.command_signature_window, 5s);
    ASSERT_EQ(m.command_signing_keys.size(), 1u);
    EXPECT_EQ(m.command_signing_keys[0].name, "scheduler");
    EXPECT_EQ(m.command_signing_keys[0].role, role::operator_);
    ASSERT_EQ(m.command_signing_keys[0].key.size(), 32u);
    EXPECT_EQ(m.command_signing_keys[0].key[0], 0xa1);
    EXPECT_EQ(m.command_signing_keys[0].key[31], 0x91);
    EXPECT_FALSE(m.accept_bearer_tokens);
}

TEST(mqtt_config, bearer_tokens_in_payloads_only_over_tls) {
    const std::string tokens =
        R"("auth":{"tokens":[{"name":"op","token":"Tok-0123456789abcdef","role":"operator"}]})";
    auto tls = parse_config("{" + tokens + R"(,"mqtt":{"enabled":true,"brokers":["mqtts://b:8883","ssl://c"],
        "commands":{"enabled":true,"accept_bearer_tokens":true}}})");
    ASSERT_TRUE(tls) << tls.error();
    EXPECT_TRUE(tls->mqtt.accept_bearer_tokens);
    auto plain =
        parse_config("{" + tokens + R"(,"mqtt":{"enabled":true,"brokers":["mqtts://b:8883","mqtt://c"],
        "commands":{"enabled":true,"accept_bearer_tokens":true}}})");
    ASSERT_FALSE(plain);
    EXPECT_EQ(plain.error(),
              "mqtt.commands.accept_bearer_tokens: bearer tokens are never taken over a plain connection "
              "(mqtt://c): use mqtts:// brokers, or signed commands (mqtt.commands.signing_keys)");
    // Without tokens there is nothing to accept: commands need signing keys then.
    auto no_tokens = parse_config(R"({"mqtt":{"enabled":true,"brokers":["mqtts://b"],
        "commands":{"enabled":true,"accept_bearer_tokens":true}}})");
    ASSERT_FALSE(no_tokens);
    EXPECT_TRUE(no_tokens.error().starts_with("mqtt.commands.enabled: needs mqtt.commands.signing_keys"));
}

TEST(mqtt_config, errors_name_the_key) {
    const std::vector<std::pair<std::string, std::string>> cases = {
        {R"({"mqtt":{"colour":1}})", "mqtt.colour: unknown key"},
        {R"({"mqtt":{"enabled":"yes"}})", "mqtt.enabled: must be true or false"},
        {R"({"mqtt":{"brokers":[]}})", "mqtt.brokers: must be an array of 1..16 broker URIs"},
        {R"({"mqtt":{"brokers":["http://x"]}})", "mqtt.brokers[0]: must start with"},
        {R"({"mqtt":{"brokers":["mqtt://"]}})", "mqtt.brokers[0]: must be <scheme>://host[:port]"},
        {R"({"mqtt":{"brokers":["mqtt://a:1883","mqtt://b:70000"]}})", "mqtt.brokers[1]: the port"},
        {R"({"mqtt":{"brokers":["mqtt://a:x"]}})", "mqtt.brokers[0]: the port"},
        {R"({"mqtt":{"topic_prefix":"a/+/b"}})", "mqtt.topic_prefix: must be levels"},
        {R"({"mqtt":{"topic_prefix":"/a"}})", "mqtt.topic_prefix: must be levels"},
        {R"({"mqtt":{"topic_prefix":"$SYS"}})", "mqtt.topic_prefix: must be levels"},
        {R"({"mqtt":{"gateway_id":"a/b"}})", "mqtt.gateway_id: must be"},
        {R"({"mqtt":{"gateway_id":"#"}})", "mqtt.gateway_id: must be"},
        {R"({"mqtt":{"protocol":"4"}})", "mqtt.protocol: must be one of 5, 3.1.1"},
        {R"({"mqtt":{"qos":{"state":3}}})", "mqtt.qos.state: must be an integer from 0 to 2"},
        {R"({"mqtt":{"qos":{"will":1}}})", "mqtt.qos.will: unknown key"},
        {R"({"mqtt":{"keepalive_s":1}})", "mqtt.keepalive_s: must be an integer from 5 to 3600"},
        {R"({"mqtt":{"telemetry":{"position_max_hz":-1}}})", "mqtt.telemetry.position_max_hz: must be"},
        {R"({"mqtt":{"telemetry":{"reports_batch_ms":1001}}})",
         "mqtt.telemetry.reports_batch_ms: must be an integer from 0 to 1000"},
        {R"({"mqtt":{"reconnect":{"min_ms":5000,"max_ms":1000}}})",
         "mqtt.reconnect.max_ms: must be at least"},
        {R"({"mqtt":{"jobs":{"queue_limit":0}}})", "mqtt.jobs.queue_limit: must be an integer from 1"},
        {R"({"mqtt":{"tls":{"cert_file":"c.pem"}}})",
         "mqtt.tls.key_file: cert_file and key_file go together"},
        {R"({"mqtt":{"enabled":true,"commands":{"enabled":true}}})",
         "mqtt.commands.enabled: needs mqtt.commands.signing_keys (signed commands), or "
         "accept_bearer_tokens"},
        {R"({"mqtt":{"commands":{"signing_keys":{}}}})", "mqtt.commands.signing_keys: must be an array"},
        {R"({"mqtt":{"commands":{"signing_keys":[{"name":"a"}]}}})",
         "mqtt.commands.signing_keys[0].key: required (openssl rand -hex 32)"},
        {R"({"mqtt":{"commands":{"signing_keys":[{"name":"a","key":"abcdef"}]}}})",
         "mqtt.commands.signing_keys[0].key: must be 64..128 hexadecimal digits"},
        {R"({"mqtt":{"commands":{"signing_keys":[{"name":"a",
           "key":"abababababababababababababababababababababababababababababababab"}]}}})",
         "mqtt.commands.signing_keys[0].key: is too easy to guess"},
        {R"({"mqtt":{"commands":{"signing_keys":[{"name":"a","role":"root",
           "key":"a1b2c3d4e5f60718293a4b5c6d7e8f90a1b2c3d4e5f60718293a4b5c6d7e8f91"}]}}})",
         "mqtt.commands.signing_keys[0].role: must be one of"},
        {R"({"mqtt":{"commands":{"signing_keys":[
           {"name":"a","key":"a1b2c3d4e5f60718293a4b5c6d7e8f90a1b2c3d4e5f60718293a4b5c6d7e8f91"},
           {"name":"a","key":"0f1e2d3c4b5a69788796a5b4c3d2e1f00f1e2d3c4b5a69788796a5b4c3d2e1f2"}]}}})",
         "mqtt.commands.signing_keys[1].name: duplicate name \"a\""},
        {R"({"mqtt":{"commands":{"signature_window_s":0}}})",
         "mqtt.commands.signature_window_s: must be an integer from 1"},
        {R"({"mqtt":{"commands":{"max_age_s":0}}})", "mqtt.commands.max_age_s: must be an integer from 1"},
        {R"({"mqtt":{"commands":{"redelivery_window_s":86401}}})",
         "mqtt.commands.redelivery_window_s: must be an integer from 1"},
        {R"({"mqtt":{"commands":{"max_payload_bytes":100}}})",
         "mqtt.commands.max_payload_bytes: must be an integer from 1024"},
    };
    for (const auto& [text, expected] : cases) {
        auto c = parse_config(text);
        ASSERT_FALSE(c) << text;
        EXPECT_TRUE(c.error().starts_with(expected)) << text << "\n  got: " << c.error();
    }
}

TEST(mqtt_config, commands_without_tokens_are_fine_while_mqtt_is_off) {
    EXPECT_TRUE(parse_config(R"({"mqtt":{"enabled":false,"commands":{"enabled":true}}})"));
}

TEST(mqtt_config, levels_and_prefixes) {
    EXPECT_TRUE(is_valid_mqtt_level("gw-1_a.b"));
    EXPECT_FALSE(is_valid_mqtt_level(""));
    EXPECT_FALSE(is_valid_mqtt_level("a b"));
    EXPECT_FALSE(is_valid_mqtt_level("$SYS"));
    EXPECT_FALSE(is_valid_mqtt_level(std::string(65, 'a')));
    EXPECT_TRUE(is_valid_mqtt_prefix("a/b/c"));
    EXPECT_FALSE(is_valid_mqtt_prefix("a//b"));
    EXPECT_FALSE(is_valid_mqtt_prefix("a/"));
    EXPECT_FALSE(is_valid_mqtt_prefix("a/#"));
}

}  // namespace
}  // namespace gw
