// The "events" section of the config file (the event hub): how long an ended job's topic stays, and
// that a job's retained MQTT state goes at the same time unless mqtt.jobs.retain_finished_s says otherwise.
#include <string>

#include <gtest/gtest.h>

#include "gateway/config/config.hpp"
#include "gateway/jobs/manager/job_manager.hpp"

namespace gw {
namespace {

using namespace std::chrono_literals;

TEST(events_config, an_ended_jobs_topic_stays_ten_minutes_by_default) {
    auto c = parse_config("{}");
    ASSERT_TRUE(c) << c.error();
    EXPECT_EQ(c->events.ended_job_topic_ttl, 600s);
    EXPECT_EQ(c->mqtt.retain_finished_jobs, 600s);
    EXPECT_EQ(jobs::make_job_manager_settings(*c).ended_job_topic_ttl, 600s);
    EXPECT_EQ(c->events.replay_memory_mb, 16u);
}

TEST(events_config, replay_memory_is_read) {
    auto c = parse_config(R"({"events":{"replay_memory_mb":4}})");
    ASSERT_TRUE(c) << c.error();
    EXPECT_EQ(c->events.replay_memory_mb, 4u);
}

TEST(events_config, the_topic_ttl_is_read_and_the_retained_mqtt_state_follows_it) {
    auto c = parse_config(R"({"events":{"ended_job_topic_ttl_s":30}})");
    ASSERT_TRUE(c) << c.error();
    EXPECT_EQ(c->events.ended_job_topic_ttl, 30s);
    EXPECT_EQ(c->mqtt.retain_finished_jobs, 30s);
    EXPECT_EQ(jobs::make_job_manager_settings(*c).ended_job_topic_ttl, 30s);
    auto zero = parse_config(R"({"events":{"ended_job_topic_ttl_s":0}})");
    ASSERT_TRUE(zero) << zero.error();
    EXPECT_EQ(zero->events.ended_job_topic_ttl, 0s);
}

TEST(events_config, an_explicit_retain_finished_s_keeps_its_own_time) {
    auto c =
        parse_config(R"({"events":{"ended_job_topic_ttl_s":30},"mqtt":{"jobs":{"retain_finished_s":90}}})");
    ASSERT_TRUE(c) << c.error();
    EXPECT_EQ(c->events.ended_job_topic_ttl, 30s);
    EXPECT_EQ(c->mqtt.retain_finished_jobs, 90s);
}

TEST(events_config, errors_name_the_key) {
    const std::pair<std::string, std::string> cases[] = {
        {R"({"events":{"ended_job_topic_ttl_s":-1}})",
         "events.ended_job_topic_ttl_s: must be an integer from 0 to 604800"},
        {R"({"events":{"ended_job_topic_ttl_s":604801}})",
         "events.ended_job_topic_ttl_s: must be an integer from 0 to 604800"},
        {R"({"events":{"ended_job_topic_ttl_s":"10"}})", "events.ended_job_topic_ttl_s: must be an integer"},
        {R"({"events":{"ttl":1}})", "events.ttl: unknown key"},
        {R"({"events":{"replay_memory_mb":0}})",
         "events.replay_memory_mb: must be an integer from 1 to 4096"},
        {R"({"events":{"replay_memory_mb":4097}})",
         "events.replay_memory_mb: must be an integer from 1 to 4096"},
        {R"({"events":[]})", "events: must be an object"},
    };
    for (const auto& [text, expected] : cases) {
        auto c = parse_config(text);
        ASSERT_FALSE(c) << text;
        EXPECT_TRUE(c.error().starts_with(expected)) << text << "\n  got: " << c.error();
    }
}

}  // namespace
}  // namespace gw
