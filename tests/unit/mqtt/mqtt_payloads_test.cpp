// Payload builders: birth, offline, report batches with gap counts, job state tracking.
#include "api/mqtt/mqtt_payloads.hpp"

#include <chrono>
#include <memory>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gateway/events/event_json.hpp"

namespace gw::api {
namespace {

using nlohmann::json;

// One day and 123 ms after the epoch.
const auto t0 = std::chrono::system_clock::time_point(std::chrono::milliseconds(86'400'123));

std::shared_ptr<const event> report(std::uint64_t seq, int counts) {
    auto data = std::make_shared<const std::string>(
        json{{"id", "sim1"}, {"controller_seq", seq}, {"counts", counts}}.dump());
    return make_data_event("controllers/sim1/reports", seq, t0, data);
}

TEST(mqtt_payloads, birth_lists_controllers_and_capabilities) {
    mqtt_birth b;
    b.gateway = "gw";
    b.version = "0.1.0";
    b.protocol = "5";
    b.prefix = "asi";
    b.commands = true;
    b.controllers.push_back(birth_controller(json::parse(
        R"({"id":"sim1","state":"connected","identity":{"build":"STD_XYZ","modules":["array"]},"axes":[]})")));
    b.controllers.push_back(
        birth_controller(json::parse(R"({"id":"sim2","state":"connecting","identity":null})")));
    b.time = t0;
    const auto j = json::parse(birth_payload(b));
    EXPECT_EQ(j["state"], "online");
    EXPECT_EQ(j["gateway"], "gw");
    EXPECT_EQ(j["version"], "0.1.0");
    EXPECT_EQ(j["protocol"], "5");
    EXPECT_EQ(j["capabilities"], json({"state", "position", "reports", "ttl", "jobs", "commands"}));
    EXPECT_EQ(j["controllers"][0],
              json::parse(R"({"id":"sim1","state":"connected","build":"STD_XYZ","modules":["array"]})"));
    EXPECT_EQ(j["controllers"][1],
              json::parse(R"({"id":"sim2","state":"connecting","build":null,"modules":[]})"));
    EXPECT_EQ(j["time"], "1970-01-02T00:00:00.123Z");
    EXPECT_TRUE(j["url"].is_null()) << "no http.public_url: null, not a guess from the listen address";
    b.commands = false;
    b.url = "https://lab3.example:8443/";
    const auto k = json::parse(birth_payload(b));
    EXPECT_EQ(k["capabilities"].size(), 5u);
    EXPECT_EQ(k["url"], "https://lab3.example:8443/");
}

TEST(mqtt_payloads, offline_with_and_without_time) {
    auto will = json::parse(offline_payload("gw", "connection lost", std::nullopt));
    EXPECT_EQ(will,
              json::parse(R"({"state":"offline","gateway":"gw","reason":"connection lost","time":null})"));
    auto bye = json::parse(offline_payload("gw", "shutdown", t0));
    EXPECT_EQ(bye["reason"], "shutdown");
    EXPECT_EQ(bye["time"], "1970-01-02T00:00:00.123Z");
}

TEST(mqtt_payloads, report_batch_counts_gaps_and_empties) {
    mqtt_report_batch b;
    EXPECT_TRUE(b.empty());
    b.add(*report(5, 100));
    b.add(*make_gap_event("controllers/sim1/reports", 6, 9, t0));
    b.add(*report(10, 110));
    b.add_missed(2);
    EXPECT_EQ(b.frames(), 2u);
    EXPECT_EQ(b.missed(), 6u);
    const auto j = json::parse(b.take_payload("sim1", t0));
    EXPECT_EQ(j["type"], "reports");
    EXPECT_EQ(j["controller"], "sim1");
    EXPECT_EQ(j["from"], 5);
    EXPECT_EQ(j["to"], 10);
    EXPECT_EQ(j["missed"], 6);
    ASSERT_EQ(j["frames"].size(), 2u);
    EXPECT_EQ(j["frames"][1]["counts"], 110);
    EXPECT_TRUE(b.empty());
    // Only a loss to report: an empty batch that still says how much is missing.
    b.add_missed(3);
    const auto k = json::parse(b.take_payload("sim1", t0));
    EXPECT_EQ(k["frames"], json::array());
    EXPECT_TRUE(k["from"].is_null());
    EXPECT_EQ(k["missed"], 3);
    EXPECT_EQ(k["controller_overruns"], 0);
}

TEST(mqtt_payloads, report_batch_tells_frames_lost_in_the_controller_from_those_lost_here) {
    mqtt_report_batch b;
    b.add(*report(5, 100));
    // The report stream's notice of frames the controller could not send (its error 87).
    devices::error_log_event log{"sim1", {87, 87, 87}, t0};
    const auto notice = std::make_shared<const std::string>(report_overrun_json(log, 3).dump());
    b.add(*make_data_event("controllers/sim1/reports", 6, t0, notice));
    b.add(*make_gap_event("controllers/sim1/reports", 7, 8, t0));
    EXPECT_EQ(b.frames(), 1u);
    const auto j = json::parse(b.take_payload("sim1", t0));
    EXPECT_EQ(j["frames"].size(), 1u);
    EXPECT_EQ(j["to"], 5);
    EXPECT_EQ(j["missed"], 2);
    EXPECT_EQ(j["controller_overruns"], 3);
    EXPECT_TRUE(b.empty());
    // Overruns alone still make a batch: the stream went quiet before they were read.
    b.add(*make_data_event("controllers/sim1/reports", 9, t0, notice));
    EXPECT_FALSE(b.empty());
    EXPECT_EQ(json::parse(b.take_payload("sim1", t0))["controller_overruns"], 3);
}

TEST(mqtt_payloads, job_state_follows_state_and_step_events) {
    mqtt_job_state s;
    EXPECT_FALSE(s.apply(json::parse(R"({"type":"step","name":"well A1","steps_done":1})")));  // no job yet
    EXPECT_FALSE(s.known());
    ASSERT_TRUE(s.apply(json::parse(
        R"({"type":"state","state":"running","reason":"","job":{"id":"j-1","state":"running","progress":{"steps_done":0,"steps_total":4}}})")));
    EXPECT_FALSE(s.terminal());
    ASSERT_TRUE(s.apply(json::parse(
        R"({"type":"step","index":0,"name":"well A1","steps_done":1,"steps_total":4,"percent":25.0,"remaining_s":3.0,"elapsed_s":1.0,"waiting_for":null,"eta":"2026-11-22T05:30:04.000Z","at":"2026-11-22T05:30:01.000Z"})")));
    EXPECT_EQ(s.job()["progress"]["steps_done"], 1);
    EXPECT_EQ(s.job()["progress"]["current_step"], "well A1");
    EXPECT_EQ(s.job()["progress"]["percent"], 25.0);
    EXPECT_EQ(s.job()["progress"]["eta"], "2026-11-22T05:30:04.000Z");
    EXPECT_TRUE(s.job()["progress"]["waiting_for"].is_null());
    EXPECT_FALSE(s.job()["progress"].contains("at")) << "the step's time is not the job's";
    EXPECT_FALSE(s.apply(json::parse(R"({"type":"other"})")));
    EXPECT_FALSE(s.apply(json::parse(R"([1,2])")));
    ASSERT_TRUE(s.apply(
        json::parse(R"({"type":"state","state":"cancelled","job":{"id":"j-1","state":"cancelled"}})")));
    EXPECT_TRUE(s.terminal());
    const auto p = json::parse(s.payload(9, t0));
    EXPECT_EQ(p["type"], "job");
    EXPECT_EQ(p["seq"], 9);
    EXPECT_EQ(p["job"]["state"], "cancelled");
}

}  // namespace
}  // namespace gw::api
