// The MQTT topic tree: builders, the hub-topic mapping, command topic parsing and reply topics.
#include "api/mqtt/mqtt_topics.hpp"

#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gw::api {
namespace {

TEST(mqtt_topics, builders) {
    const mqtt_topics t("lab/asi", "pc-3");
    EXPECT_EQ(t.base(), "lab/asi/pc-3");
    EXPECT_EQ(t.status(), "lab/asi/pc-3/status");
    EXPECT_EQ(t.controller("sim1", "state"), "lab/asi/pc-3/controllers/sim1/state");
    EXPECT_EQ(t.controller("sim1", "cmd"), "lab/asi/pc-3/controllers/sim1/cmd");
    EXPECT_EQ(t.job_state("j-01ABC"), "lab/asi/pc-3/jobs/j-01ABC/state");
    EXPECT_EQ(t.job_command(mqtt_command_kind::job_submit), "lab/asi/pc-3/jobs/submit");
    EXPECT_EQ(t.command_filters(),
              (std::vector<std::string>{"lab/asi/pc-3/controllers/+/cmd", "lab/asi/pc-3/jobs/submit",
                                        "lab/asi/pc-3/jobs/cancel", "lab/asi/pc-3/jobs/pause",
                                        "lab/asi/pc-3/jobs/resume", "lab/asi/pc-3/jobs/next",
                                        "lab/asi/pc-3/gcode/check", "lab/asi/pc-3/halt"}));
    EXPECT_EQ(t.command({mqtt_command_kind::gcode_check, {}}), "lab/asi/pc-3/gcode/check");
    EXPECT_EQ(t.command({mqtt_command_kind::halt_all, {}}), "lab/asi/pc-3/halt");
    EXPECT_EQ(t.parse_command_topic("lab/asi/pc-3/halt")->kind, mqtt_command_kind::halt_all);
    EXPECT_FALSE(t.parse_command_topic("lab/asi/pc-3/halt/now"));
    EXPECT_EQ(t.command({mqtt_command_kind::job_pause, {}}), "lab/asi/pc-3/jobs/pause");
    EXPECT_EQ(t.command({mqtt_command_kind::controller, "sim2"}), "lab/asi/pc-3/controllers/sim2/cmd");
}

TEST(mqtt_topics, hub_topics_map_to_the_tree) {
    const mqtt_topics t("asi", "gw");
    const std::vector<std::pair<std::string, std::optional<std::string>>> cases = {
        {"controllers/sim1/state", "asi/gw/controllers/sim1/state"},
        {"controllers/sim1/position", "asi/gw/controllers/sim1/position"},
        {"controllers/sim1/reports", "asi/gw/controllers/sim1/reports"},
        {"controllers/s-2/ttl", "asi/gw/controllers/s-2/ttl"},
        {"controllers/s-2/errors", "asi/gw/controllers/s-2/errors"},
        {"jobs/j-1", "asi/gw/jobs/j-1/state"},
        {"recordings/r-1", "asi/gw/recordings/r-1"},
        {"controllers/sim1/cmd", std::nullopt},
        {"controllers/sim1", std::nullopt},
        {"controllers/sim1/state/x", std::nullopt},
        {"jobs", std::nullopt},
        {"jobs/j-1/x", std::nullopt},
        {"other/sim1/state", std::nullopt},
    };
    for (const auto& [hub, expected] : cases) {
        const auto a = gw::address_of(hub);
        EXPECT_EQ(t.for_hub_topic(a.kind, std::string_view(hub).substr(a.key_at, a.key_size)), expected)
            << hub;
    }
}

TEST(mqtt_topics, command_topics_parse) {
    const mqtt_topics t("asi", "gw");
    auto c = t.parse_command_topic("asi/gw/controllers/sim2/cmd");
    ASSERT_TRUE(c);
    EXPECT_EQ(c->kind, mqtt_command_kind::controller);
    EXPECT_EQ(c->controller, "sim2");
    const std::vector<std::pair<std::string, mqtt_command_kind>> jobs = {
        {"asi/gw/jobs/submit", mqtt_command_kind::job_submit},
        {"asi/gw/jobs/cancel", mqtt_command_kind::job_cancel},
        {"asi/gw/jobs/pause", mqtt_command_kind::job_pause},
        {"asi/gw/jobs/resume", mqtt_command_kind::job_resume},
        {"asi/gw/jobs/next", mqtt_command_kind::job_next},
        {"asi/gw/gcode/check", mqtt_command_kind::gcode_check},
    };
    for (const auto& [topic, kind] : jobs) {
        auto j = t.parse_command_topic(topic);
        ASSERT_TRUE(j) << topic;
        EXPECT_EQ(j->kind, kind) << topic;
    }
    for (const char* not_ours :
         {"asi/gw2/controllers/sim2/cmd", "asi/g/controllers/sim2/cmd", "asi/gw/controllers/sim2/state",
          "asi/gw/controllers//cmd", "asi/gw/controllers/+/cmd", "asi/gw/jobs/get", "asi/gw/jobs/j-1/state",
          "asi/gw", "asi/gwx/jobs/submit", "other/gw/jobs/submit", "asi/gw/gcode/plan", "asi/gw/gcode", ""})
        EXPECT_FALSE(t.parse_command_topic(not_ours)) << not_ours;
}

TEST(mqtt_topics, reply_topics_stay_outside_the_fleet_tree) {
    const mqtt_topics t("lab/asi", "gw");
    EXPECT_TRUE(t.is_allowed_reply_topic("clients/me/replies"));
    EXPECT_TRUE(t.is_allowed_reply_topic("lab/other"));
    EXPECT_TRUE(t.is_allowed_reply_topic("lab/asi2/x"));
    EXPECT_FALSE(t.is_allowed_reply_topic("lab/asi"));
    EXPECT_FALSE(t.is_allowed_reply_topic("lab/asi/gw/status"));
    EXPECT_FALSE(t.is_allowed_reply_topic("lab/asi/other-gw/controllers/sim1/state"));
    EXPECT_FALSE(t.is_allowed_reply_topic("$SYS/x"));
    EXPECT_FALSE(t.is_allowed_reply_topic("clients/+/replies"));
    EXPECT_FALSE(t.is_allowed_reply_topic("clients/#"));
    EXPECT_FALSE(t.is_allowed_reply_topic(""));
    EXPECT_FALSE(t.is_allowed_reply_topic("a//b"));
}

TEST(mqtt_topics, gateway_id_from_the_host_name) {
    EXPECT_EQ(resolve_gateway_id("lab-3", "ignored"), "lab-3");
    EXPECT_EQ(resolve_gateway_id("", "pc3.lab.example"), "pc3.lab.example");
    EXPECT_EQ(resolve_gateway_id("", "my host/#+"), "my-host---");
    EXPECT_EQ(resolve_gateway_id("", ""), "gateway");
    EXPECT_EQ(resolve_gateway_id("", std::string(100, 'a')).size(), 64u);
}

}  // namespace
}  // namespace gw::api
