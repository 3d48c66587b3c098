// Retiring topics that have ended (a job's topic once the job ended): they leave the hub after their
// grace period, replay buffer and bookkeeping included, so memory does not grow with the number of
// jobs ever run; and a subscriber that could be waiting on one is told ("retired"), never left in
// silence. Memory is measured by the hub's own counters (topics, replay bytes), not by the clock.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gateway/events/event_hub.hpp"
#include "tests/unit/gateway/event_hub_fixture.hpp"

namespace {

using namespace gw::hub_test;

const std::string job = "jobs/j-1";

std::vector<std::shared_ptr<const gw::event>> retired(const recording_sink& s) {
    std::vector<std::shared_ptr<const gw::event>> out;
    for (const auto& e : s.events)
        if (e->kind == event_kind::retired) out.push_back(e);
    return out;
}

class event_hub_retire_test : public event_hub_test {
  protected:
    // Publishes n job events of about 1 kB (a job record is that big).
    void publish_job_events(const std::string& topic, int n) {
        for (int i = 0; i < n; ++i)
            ASSERT_FALSE(hub_->publish(topic, nlohmann::json{{"i", i}, {"job", std::string(1000, 'x')}}));
        run();
    }
    void advance(std::chrono::milliseconds d) {
        clock_->advance(d);
        hub_->tick();
        run();
    }
};

TEST_F(event_hub_retire_test, a_retired_topic_and_its_replay_buffer_leave_the_hub_after_the_grace_period) {
    make_hub();
    publish(reports, 2);
    const auto reports_bytes = hub_->counters().replay_bytes;
    publish_job_events(job, 9);
    EXPECT_EQ(hub_->counters().topics, 2u);
    EXPECT_GT(hub_->counters().replay_bytes, reports_bytes + 9 * 2000);  // payload and message per event

    ASSERT_FALSE(hub_->retire_topic(job, 60s));
    run();
    advance(59s);
    EXPECT_EQ(hub_->counters().topics, 2u) << "still within its grace period";
    advance(2s);
    EXPECT_EQ(hub_->counters().topics, 1u);
    EXPECT_EQ(hub_->counters().replay_bytes, reports_bytes);
    EXPECT_EQ(hub_->counters().retired, 1u);
}

TEST_F(event_hub_retire_test,
       retiring_again_moves_the_time_and_unknown_or_invalid_topics_are_refused_or_ignored) {
    make_hub();
    publish(job, 1);
    ASSERT_FALSE(hub_->retire_topic(job, 10s));
    run();
    advance(8s);
    ASSERT_FALSE(hub_->retire_topic(job, 10s));  // a late event moved it
    run();
    advance(8s);
    EXPECT_EQ(hub_->counters().topics, 1u);
    advance(3s);
    EXPECT_EQ(hub_->counters().topics, 0u);
    EXPECT_EQ(hub_->retire_topic("jobs/+", 0s), gw::topic_error::wildcard_in_name);
    ASSERT_FALSE(hub_->retire_topic("jobs/never-published", 0s));
    run();
    EXPECT_EQ(hub_->counters().retired, 1u);
}

TEST_F(event_hub_retire_test, a_subscriber_gets_a_retired_event_after_the_topics_last_event) {
    make_hub();
    auto sink = add_sink();
    ASSERT_FALSE(hub_->subscribe(sink->id, "jobs/#"));
    run();
    publish(job, 3);
    ASSERT_FALSE(hub_->retire_topic(job, 0s));
    run();
    ASSERT_EQ(sink->events.size(), 4u);
    EXPECT_EQ(sink->seqs(job), range(1, 3));
    const auto& last = *sink->events.back();
    EXPECT_EQ(last.kind, event_kind::retired);
    EXPECT_EQ(last.sequence, 3u);
    auto j = nlohmann::json::parse(*last.message);
    EXPECT_EQ(j["type"], "retired");
    EXPECT_EQ(j["topic"], job);
    EXPECT_EQ(j["last_seq"], 3);
    EXPECT_EQ(j["time"], "2026-11-22T04:45:40.000Z");
    EXPECT_FALSE(j.contains("data"));
    EXPECT_EQ(hub_->counters().topics, 0u);
}

TEST_F(event_hub_retire_test, a_slow_subscriber_gets_its_gap_first_and_the_retired_event_once_there_is_room) {
    make_hub();
    auto sink = add_sink(gw::subscriber_settings{.queue_limit = 2, .max_batch_events = 1});
    sink->auto_ack = false;
    ASSERT_FALSE(hub_->subscribe(sink->id, job));
    run();
    publish(job, 6);  // 1 in flight, 2 and 3 queued, 4..6 overflow into a gap
    ASSERT_FALSE(hub_->retire_topic(job, 0s));
    run();
    for (int i = 0; i < 10 && sink->pending_ack; ++i) {
        sink->ack();
        run();
    }
    ASSERT_GE(sink->events.size(), 5u);
    EXPECT_EQ(sink->seqs(job), range(1, 3));
    const auto& gap = *sink->events[sink->events.size() - 2];
    EXPECT_EQ(gap.kind, event_kind::gap);
    EXPECT_EQ(gap.gap_from, 4u);
    EXPECT_EQ(gap.gap_to, 6u);
    EXPECT_EQ(sink->events.back()->kind, event_kind::retired);
    EXPECT_FALSE(sink->closed);
}

TEST_F(event_hub_retire_test, a_reader_still_in_the_replay_gets_a_gap_for_the_rest_then_retired) {
    make_hub();
    publish(job, 10);
    auto sink = add_sink(gw::subscriber_settings{.queue_limit = 4, .max_batch_events = 2});
    sink->auto_ack = false;
    ASSERT_FALSE(hub_->subscribe(sink->id, job, {.resume = {{job, 0}}}));
    run();  // 1, 2 delivered, 3, 4 queued: 5..10 not read yet
    ASSERT_FALSE(hub_->retire_topic(job, 0s));
    run();
    for (int i = 0; i < 10 && sink->pending_ack; ++i) {
        sink->ack();
        run();
    }
    EXPECT_EQ(sink->seqs(job), range(1, 4));
    ASSERT_EQ(sink->gaps().size(), 1u);
    EXPECT_EQ(sink->gaps()[0]->gap_from, 5u);
    EXPECT_EQ(sink->gaps()[0]->gap_to, 10u);
    ASSERT_EQ(retired(*sink).size(), 1u);
    EXPECT_EQ(sink->events.back()->kind, event_kind::retired);
}

TEST_F(event_hub_retire_test, a_later_subscription_naming_or_resuming_a_retired_topic_is_told_so) {
    make_hub();
    publish(job, 3);
    ASSERT_FALSE(hub_->retire_topic(job, 0s));
    run();
    auto exact = add_sink();
    auto resumed = add_sink();
    auto wildcard = add_sink();
    ASSERT_FALSE(hub_->subscribe(exact->id, job));
    ASSERT_FALSE(hub_->subscribe(resumed->id, "jobs/#", {.resume = {{job, 2}}}));
    ASSERT_FALSE(hub_->subscribe(wildcard->id, "jobs/#"));
    run();
    for (const auto* s : {exact.get(), resumed.get()}) {
        ASSERT_EQ(s->events.size(), 1u);
        EXPECT_EQ(s->events[0]->kind, event_kind::retired);
        EXPECT_EQ(nlohmann::json::parse(*s->events[0]->message)["last_seq"], 3);
    }
    EXPECT_TRUE(wildcard->events.empty()) << "a wildcard alone does not list every retired topic";
}

TEST_F(event_hub_retire_test, a_topic_published_again_after_retiring_starts_at_1_for_every_subscriber) {
    make_hub();
    auto sink = add_sink();
    ASSERT_FALSE(hub_->subscribe(sink->id, "jobs/#"));
    run();
    publish(job, 3);
    ASSERT_FALSE(hub_->retire_topic(job, 0s));
    run();
    publish(job, 2);
    EXPECT_EQ(sink->seqs(job), (std::vector<std::uint64_t>{1, 2, 3, 1, 2}));
    EXPECT_EQ(retired(*sink).size(), 1u);
    // In use again: a new subscription to it hears of no retirement.
    auto later = add_sink();
    ASSERT_FALSE(hub_->subscribe(later->id, job));
    run();
    EXPECT_TRUE(retired(*later).empty());
}

TEST_F(event_hub_retire_test, the_hub_remembers_a_bounded_number_of_retired_topics) {
    make_hub({.max_retired_topics = 2});
    for (const auto* t : {"jobs/1", "jobs/2", "jobs/3"}) {
        publish(t, 1);
        ASSERT_FALSE(hub_->retire_topic(t, 0s));
        run();
    }
    auto sink = add_sink();
    for (const auto* t : {"jobs/1", "jobs/2", "jobs/3"})
        ASSERT_FALSE(hub_->subscribe(sink->id, t));
    run();
    std::vector<std::string> told;
    for (const auto& e : retired(*sink))
        told.push_back(e->topic);
    EXPECT_EQ(told, (std::vector<std::string>{"jobs/2", "jobs/3"})) << "jobs/1 is forgotten";
}

TEST_F(event_hub_retire_test, a_topic_forgotten_beyond_max_topics_is_announced_as_retired) {
    make_hub({.max_topics = 2});
    auto sink = add_sink();
    ASSERT_FALSE(hub_->subscribe(sink->id, "jobs/#"));
    run();
    publish("jobs/1", 2);
    publish("jobs/2", 1);
    publish("jobs/3", 1);  // forgets jobs/1
    ASSERT_EQ(retired(*sink).size(), 1u);
    EXPECT_EQ(retired(*sink)[0]->topic, "jobs/1");
    EXPECT_EQ(retired(*sink)[0]->sequence, 2u);
    EXPECT_EQ(hub_->counters().topics, 2u);
}

TEST_F(event_hub_retire_test, two_thousand_short_job_topics_leave_a_bounded_hub) {
    // Jobs of nine events, one ending every 100 ms, each topic retired 1 s after its end, with two
    // subscribers on jobs/#: at most about eleven topics are ever held, and nothing once they are gone.
    make_hub();
    auto a = add_sink();
    auto b = add_sink();
    ASSERT_FALSE(hub_->subscribe(a->id, "jobs/#"));
    ASSERT_FALSE(hub_->subscribe(b->id, "jobs/#"));
    run();
    std::uint64_t max_topics = 0;
    std::uint64_t max_bytes = 0;
    for (int i = 0; i < 2000; ++i) {
        const auto topic = "jobs/j-" + std::to_string(i);
        publish_job_events(topic, 9);
        ASSERT_FALSE(hub_->retire_topic(topic, 1s));
        advance(100ms);
        max_topics = std::max(max_topics, hub_->counters().topics);
        max_bytes = std::max(max_bytes, hub_->counters().replay_bytes);
    }
    EXPECT_LE(max_topics, 12u);
    EXPECT_LE(max_bytes, 12u * 9 * 2200);
    advance(2s);
    EXPECT_EQ(hub_->counters().topics, 0u);
    EXPECT_EQ(hub_->counters().replay_bytes, 0u);
    EXPECT_EQ(hub_->counters().retired, 2000u);
    EXPECT_EQ(retired(*a).size(), 2000u);
    EXPECT_EQ(a->seqs("jobs/j-1999"), range(1, 9));
    EXPECT_EQ(b->events.size(), 2000u * 10);
}

}  // namespace
