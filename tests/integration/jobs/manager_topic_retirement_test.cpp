// Ended jobs leave nothing behind in the event hub: their jobs/<id> topics (and replay buffers) are
// retired ended_job_topic_ttl after the end, so over thousands of jobs the hub's topics and replay
// bytes stay bounded, while each job's history stays in the store. Memory is counted by the hub
// (topics, replay bytes), not by the clock.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/integration/jobs/manager_fixture.hpp"

namespace gw::jobs::test {
namespace {

class manager_topic_retirement : public manager_fixture {
  protected:
    // A job of two wells; it waits for `next` after the first when `hold` (the others queue behind it).
    nlohmann::json short_job(bool hold) const {
        nlohmann::json spec{{"plate", "6"}, {"a1", "current"}, {"wells", {"A1", "A2"}}, {"mode", "host"}};
        if (hold) spec["advance"] = "next";
        return spec;
    }
};

TEST_F(manager_topic_retirement, over_two_thousand_short_jobs_the_hub_holds_a_bounded_number_of_topics) {
    ended_job_topic_ttl_ = std::chrono::milliseconds(0);
    add_sim("sim2", "plain", 50);
    start();
    auto holder = submit("sim2", job_type::array, short_job(true));
    ASSERT_TRUE(holder) << holder.error().message;
    ASSERT_TRUE(wait_state(holder->job.id, job_state::running));
    ASSERT_TRUE(wait_until([&] { return hub_->counters().topics > 0; }));
    const auto before = hub_->counters();  // the controller's topics and the holder's

    // Each job is queued behind the holder and cancelled: it ends at once, with its events published.
    constexpr int jobs = 2000;
    std::uint64_t max_topics = 0;
    std::uint64_t max_bytes = 0;
    std::string last;
    for (int i = 0; i < jobs; ++i) {
        auto j = submit("sim2", job_type::array, short_job(false));
        ASSERT_TRUE(j) << "job " << i << ": " << j.error().message;
        ASSERT_TRUE(cancel(j->job.id)) << "job " << i;
        last = j->job.id;
        const auto c = hub_->counters();
        max_topics = std::max(max_topics, c.topics);
        max_bytes = std::max(max_bytes, c.replay_bytes);
    }
    // A few jobs may be on their way through the hub's strand at any moment; never thousands.
    EXPECT_LE(max_topics, before.topics + 20) << "the hub kept ended jobs' topics";
    EXPECT_LE(max_bytes, before.replay_bytes + 20u * 8 * 1024);
    ASSERT_TRUE(wait_until([&] { return hub_->counters().retired >= before.retired + jobs; }, 10s))
        << "retired " << hub_->counters().retired - before.retired << " of " << jobs << " topics";
    EXPECT_EQ(hub_->counters().topics, before.topics);
    // The history is in the store, and a subscriber of jobs/# was told that each topic went.
    auto events = manager_->events(last, 100);
    ASSERT_TRUE(events);
    ASSERT_FALSE(events->empty());
    EXPECT_EQ(events->back().value("state", ""), "cancelled");
    // The notices reach the subscriber after the hub counted the retirements.
    auto told = [&] {
        const auto all = sink_->all();
        return std::count_if(all.begin(), all.end(),
                             [](const auto& m) { return m.value("type", "") == "retired"; });
    };
    EXPECT_TRUE(wait_until([&] { return told() >= jobs; }, 10s));
    EXPECT_EQ(told(), jobs);
    ASSERT_TRUE(cancel(holder->job.id));
}

TEST_F(manager_topic_retirement, an_ended_jobs_topic_stays_for_its_grace_period) {
    ended_job_topic_ttl_ = std::chrono::milliseconds(3000);
    add_sim("sim2", "plain", 50);
    start();
    auto j = submit("sim2", job_type::array, short_job(false));
    ASSERT_TRUE(j);
    ASSERT_TRUE(wait_state(j->job.id, job_state::succeeded));
    const auto topic = "jobs/" + j->job.id;
    auto retired_count = [&] { return hub_->counters().retired; };
    EXPECT_EQ(retired_count(), 0u) << "retired within its grace period";
    EXPECT_TRUE(wait_until([&] { return retired_count() == 1; }, std::chrono::seconds(15)));
    // The counter moves on the hub's strand; the notice reaches the subscriber after it.
    auto told_retired = [&] {
        const auto msgs = sink_->of(j->job.id);
        return !msgs.empty() && msgs.back().value("type", "") == "retired";
    };
    ASSERT_TRUE(wait_until(told_retired, std::chrono::seconds(5))) << "the subscriber was not told";
    EXPECT_EQ(sink_->of(j->job.id).back().value("topic", ""), topic);
}

}  // namespace
}  // namespace gw::jobs::test
