#include "gateway/events/event_hub.hpp"

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/unit/gateway/event_hub_fixture.hpp"

namespace {

using namespace gw::hub_test;

TEST_F(event_hub_test, numbers_events_per_topic_and_stamps_them) {
    make_hub();
    auto sink = add_sink();
    ASSERT_FALSE(hub_->subscribe(sink->id, "#"));
    run();
    ASSERT_FALSE(hub_->publish(reports, nlohmann::json{{"n", 1}}));
    ASSERT_FALSE(hub_->publish("jobs/7", nlohmann::json{{"n", 2}}));
    ASSERT_FALSE(hub_->publish(reports, nlohmann::json{{"n", 3}}));
    clock_->advance(5ms);
    ASSERT_FALSE(hub_->publish("jobs/7", nlohmann::json{{"n", 4}}));
    ASSERT_FALSE(hub_->publish(reports, nlohmann::json{{"n", 5}},
                               std::chrono::system_clock::time_point(std::chrono::milliseconds(1000))));
    run();
    EXPECT_EQ(sink->seqs(reports), range(1, 3));
    EXPECT_EQ(sink->seqs("jobs/7"), range(1, 2));
    ASSERT_EQ(sink->events.size(), 5u);

    auto j = nlohmann::json::parse(*sink->events[3]->message);
    EXPECT_EQ(j["type"], "event");
    EXPECT_EQ(j["topic"], "jobs/7");
    EXPECT_EQ(j["seq"], 2);
    EXPECT_EQ(j["time"], "2026-11-22T04:45:40.005Z");
    EXPECT_EQ(j["time_ms"], 1795322740005);
    EXPECT_EQ(j["data"]["n"], 4);
    EXPECT_EQ(nlohmann::json::parse(*sink->events[4]->message)["time"], "1970-01-01T00:00:01.000Z");
    EXPECT_EQ(hub_->counters().published, 5u);
    EXPECT_EQ(hub_->counters().delivered, 5u);

    // Every event says what its topic is about; a job's carries its data as a value too, a report's not.
    EXPECT_EQ(sink->events[3]->address.kind, gw::topic_kind::job);
    EXPECT_EQ(sink->events[3]->key(), "7");
    ASSERT_TRUE(sink->events[3]->document);
    EXPECT_EQ((*sink->events[3]->document)["n"], 4);
    EXPECT_EQ(sink->events[4]->address.kind, gw::topic_kind::controller_reports);
    EXPECT_FALSE(sink->events[4]->document);
}

TEST_F(event_hub_test, refuses_bad_topics_and_filters) {
    make_hub();
    auto sink = add_sink();
    EXPECT_EQ(hub_->publish("controllers/+/reports", nlohmann::json{}), gw::topic_error::wildcard_in_name);
    EXPECT_EQ(hub_->publish("", nlohmann::json{}), gw::topic_error::empty);
    EXPECT_EQ(hub_->subscribe(sink->id, "controllers/#/reports"), gw::topic_error::hash_not_last);
    EXPECT_EQ(hub_->subscribe(sink->id, "a//b"), gw::topic_error::empty_level);
    run();
    EXPECT_EQ(hub_->counters().published, 0u);
}

TEST_F(event_hub_test, delivers_only_matching_topics) {
    make_hub();
    auto sink = add_sink();
    ASSERT_FALSE(hub_->subscribe(sink->id, "controllers/+/reports"));
    run();
    publish(reports, 2);
    publish(ttl, 2);
    publish("controllers/stage2/reports", 1);
    publish("jobs/1", 1);
    EXPECT_EQ(sink->seqs(reports), range(1, 2));
    EXPECT_EQ(sink->seqs("controllers/stage2/reports"), range(1, 1));
    EXPECT_EQ(sink->events.size(), 3u);
}

TEST_F(event_hub_test, overlapping_filters_never_duplicate) {
    make_hub();
    auto sink = add_sink();
    ASSERT_FALSE(hub_->subscribe(sink->id, "controllers/+/reports"));
    ASSERT_FALSE(hub_->subscribe(sink->id, "#"));
    ASSERT_FALSE(hub_->subscribe(sink->id, reports, {.resume = {{reports, 0}}}));
    run();
    publish(reports, 3);
    EXPECT_EQ(sink->seqs(reports), range(1, 3));
    // Resuming from before what it already has gives nothing twice.
    ASSERT_FALSE(hub_->subscribe(sink->id, "controllers/#", {.resume = {{reports, 1}}}));
    run();
    publish(reports, 1);
    EXPECT_EQ(sink->seqs(reports), range(1, 4));
}

TEST_F(event_hub_test, resume_replays_what_is_buffered_then_goes_live) {
    make_hub();
    publish(reports, 5);
    publish(ttl, 3);
    auto sink = add_sink();
    ASSERT_FALSE(hub_->subscribe(sink->id, "controllers/stage1/#", {.resume = {{reports, 2}, {ttl, 3}}}));
    run();
    EXPECT_EQ(sink->seqs(reports), range(3, 5));
    EXPECT_TRUE(sink->seqs(ttl).empty());  // it had everything
    publish(reports, 2);
    publish(ttl, 1);
    EXPECT_EQ(sink->seqs(reports), range(3, 7));
    EXPECT_EQ(sink->seqs(ttl), range(4, 4));
    EXPECT_TRUE(sink->gaps().empty());
    EXPECT_EQ(hub_->counters().replayed, 3u);
}

TEST_F(event_hub_test, resume_reports_a_gap_for_events_no_longer_buffered) {
    make_hub({.stream_replay = 5});
    publish(reports, 10);  // 6..10 still buffered
    auto sink = add_sink();
    ASSERT_FALSE(hub_->subscribe(sink->id, reports, {.resume = {{reports, 2}}}));
    run();
    publish(reports, 1);
    ASSERT_EQ(sink->events.size(), 7u);
    const auto& gap = *sink->events[0];
    EXPECT_EQ(gap.kind, event_kind::gap);
    EXPECT_EQ(gap.gap_from, 3u);
    EXPECT_EQ(gap.gap_to, 5u);
    auto j = nlohmann::json::parse(*gap.message);
    EXPECT_EQ(j["type"], "gap");
    EXPECT_EQ(j["topic"], reports);
    EXPECT_EQ(j["missed"], 3);
    EXPECT_EQ(j["from"], 3);
    EXPECT_EQ(j["to"], 5);
    EXPECT_EQ(sink->seqs(reports), range(6, 11));
    EXPECT_EQ(hub_->counters().gapped, 3u);
    EXPECT_EQ(hub_->counters().gap_events, 1u);
}

TEST_F(event_hub_test, resume_from_a_number_of_an_earlier_hub_replays_from_the_start) {
    make_hub();
    publish(reports, 3);
    auto sink = add_sink();
    ASSERT_FALSE(hub_->subscribe(sink->id, reports, {.resume = {{reports, 500}}}));
    run();
    EXPECT_EQ(sink->seqs(reports), range(1, 3));
}

TEST_F(event_hub_test, resume_numbers_of_another_epoch_count_as_zero) {
    make_hub();
    EXPECT_EQ(hub_->epoch(), 1795322740000u);  // creation time on the hub's clock
    publish(reports, 4);
    auto same = add_sink();
    auto other = add_sink();
    ASSERT_FALSE(
        hub_->subscribe(same->id, reports, {.resume = {{reports, 2}}, .resume_epoch = hub_->epoch()}));
    ASSERT_FALSE(hub_->subscribe(other->id, reports, {.resume = {{reports, 2}}, .resume_epoch = 12345}));
    run();
    EXPECT_EQ(same->seqs(reports), range(3, 4));
    EXPECT_EQ(other->seqs(reports), range(1, 4));
}

TEST_F(event_hub_test, long_replay_goes_through_a_small_queue_interleaved_with_live_events) {
    make_hub();
    publish(reports, 50);
    auto sink = add_sink(gw::subscriber_settings{.queue_limit = 4, .max_batch_events = 2});
    sink->auto_ack = false;
    ASSERT_FALSE(hub_->subscribe(sink->id, "controllers/stage1/#", {.resume = {{reports, 0}}}));
    run();
    // Live events of both topics arrive while it catches up, one acknowledged batch at a time.
    std::uint64_t live_reports = 0;
    std::uint64_t live_ttl = 0;
    for (int round = 0; round < 100; ++round) {
        if (round % 3 == 0) {
            publish(reports, 1);
            ++live_reports;
        }
        if (round % 5 == 0) {
            publish(ttl, 1);
            ++live_ttl;
        }
        if (sink->pending_ack) sink->ack();
        run();
        EXPECT_LE(sink->last_batch_size, 2u);
    }
    for (int i = 0; i < 100 && sink->pending_ack; ++i) {
        sink->ack();
        run();
    }
    EXPECT_EQ(sink->seqs(reports), range(1, 50 + live_reports));
    EXPECT_EQ(sink->seqs(ttl), range(1, live_ttl));
    EXPECT_TRUE(sink->gaps().empty());
    EXPECT_FALSE(sink->closed);
}

TEST_F(event_hub_test, falling_behind_the_replay_buffer_while_resuming_counts_as_overflow) {
    make_hub({.stream_replay = 6});
    publish(reports, 6);
    auto sink = add_sink(gw::subscriber_settings{.queue_limit = 4, .max_batch_events = 2, .slow_ack = 0ms});
    sink->auto_ack = false;
    ASSERT_FALSE(hub_->subscribe(sink->id, reports, {.resume = {{reports, 0}}}));
    run();                 // 1, 2 delivered; 3, 4 queued
    publish(reports, 10);  // 5..14: the buffer now holds 11..14
    for (int i = 0; i < 10 && sink->pending_ack; ++i) {
        sink->ack();
        run();
    }
    EXPECT_EQ(sink->seqs(reports), (std::vector<std::uint64_t>{1, 2, 3, 4, 11, 12, 13, 14, 15, 16}));
    ASSERT_EQ(sink->gaps().size(), 1u);
    EXPECT_EQ(sink->gaps()[0]->gap_from, 5u);
    EXPECT_EQ(sink->gaps()[0]->gap_to, 10u);
    EXPECT_FALSE(sink->closed);
    // Live now; overflowing within the window of that lapse is the second strike.
    publish(reports, 6);
    ASSERT_TRUE(sink->closed);
    EXPECT_EQ(hub_->counters().evicted, 1u);
}

TEST_F(event_hub_test, a_stalled_subscriber_does_not_hold_up_a_healthy_one) {
    make_hub();
    auto healthy = add_sink();
    auto stalled = add_sink(gw::subscriber_settings{.queue_limit = 16, .max_batch_events = 8});
    stalled->auto_ack = false;  // takes one batch and never asks for more
    ASSERT_FALSE(hub_->subscribe(healthy->id, "controllers/+/reports"));
    ASSERT_FALSE(hub_->subscribe(stalled->id, "controllers/+/reports"));
    run();
    // The healthy one acknowledges as it goes (the io_context runs every few events).
    for (int i = 0; i < 1000; ++i) {
        ASSERT_FALSE(hub_->publish(reports, nlohmann::json{{"i", i}}));
        if (i % 10 == 0) run();
    }
    run();
    EXPECT_EQ(healthy->seqs(reports), range(1, 1000));
    EXPECT_FALSE(healthy->closed);
    EXPECT_EQ(stalled->batches, 1u);
    EXPECT_EQ(stalled->seqs(reports), range(1, 1));
    auto c = hub_->counters();
    EXPECT_EQ(c.published, 1000u);
    EXPECT_EQ(c.delivered, 1001u);
}

TEST_F(event_hub_test, overflow_gap_counts_exactly) {
    make_hub();
    auto sink = add_sink(gw::subscriber_settings{.queue_limit = 4, .max_batch_events = 2});
    sink->auto_ack = false;
    ASSERT_FALSE(hub_->subscribe(sink->id, "controllers/stage1/#"));
    run();
    publish(reports, 1);  // delivered at once: 1
    publish(reports, 4);  // queued: 2..5
    publish(reports, 5);  // 6..10 do not fit
    publish(ttl, 2);      // ttl 1..2 do not fit either
    EXPECT_EQ(sink->seqs(reports), range(1, 1));
    sink->ack();
    run();  // 2, 3
    sink->ack();
    run();  // 4, 5
    sink->ack();
    run();  // the two gap events
    publish(reports, 1);
    sink->ack();
    run();
    publish(ttl, 1);
    sink->ack();
    run();
    EXPECT_EQ(sink->seqs(reports), (std::vector<std::uint64_t>{1, 2, 3, 4, 5, 11}));
    EXPECT_EQ(sink->seqs(ttl), range(3, 3));
    auto gaps = sink->gaps();
    ASSERT_EQ(gaps.size(), 2u);
    for (const auto& g : gaps) {
        if (g->topic == reports) {
            EXPECT_EQ(g->gap_from, 6u);
            EXPECT_EQ(g->gap_to, 10u);
            EXPECT_EQ(nlohmann::json::parse(*g->message)["missed"], 5);
        } else {
            EXPECT_EQ(g->topic, ttl);
            EXPECT_EQ(g->gap_from, 1u);
            EXPECT_EQ(g->gap_to, 2u);
        }
    }
    // Each gap comes after what was queued before it and before its topic's next event.
    auto index_of = [&](const std::shared_ptr<const gw::event>& e) {
        return std::find(sink->events.begin(), sink->events.end(), e) - sink->events.begin();
    };
    EXPECT_GT(index_of(gaps[0]), 4);
    EXPECT_EQ(hub_->counters().gapped, 7u);
    EXPECT_EQ(hub_->counters().gap_events, 2u);
    EXPECT_FALSE(sink->closed);
}

TEST_F(event_hub_test, a_second_overflow_within_the_window_evicts) {
    make_hub();
    // Every overflow while a batch is unacknowledged counts (see the next test for slow_ack).
    gw::subscriber_settings settings{
        .queue_limit = 2, .max_batch_events = 2, .overflow_window = 10s, .slow_ack = 0ms};
    auto sink = add_sink(settings);
    sink->auto_ack = false;
    ASSERT_FALSE(hub_->subscribe(sink->id, reports));
    run();
    publish(reports, 4);  // 1 delivered, 2..3 queued, 4 overflows
    sink->ack();
    run();
    sink->ack();
    run();  // the gap
    ASSERT_EQ(sink->gaps().size(), 1u);
    EXPECT_FALSE(sink->closed);

    clock_->advance(11s);  // outside the window: a new overflow is forgiven once
    publish(reports, 4);   // 5 delivered, 6..7 queued, 8 overflows
    EXPECT_FALSE(sink->closed);
    sink->ack();
    run();
    sink->ack();
    run();
    EXPECT_EQ(sink->gaps().size(), 2u);

    clock_->advance(1s);  // inside the window
    publish(reports, 4);
    ASSERT_TRUE(sink->closed);
    EXPECT_NE(sink->closed->find("too slow"), std::string::npos) << *sink->closed;
    EXPECT_EQ(hub_->counters().evicted, 1u);
    EXPECT_EQ(hub_->counters().subscribers, 0u);
    auto delivered = sink->events.size();
    sink->ack();
    publish(reports, 3);
    EXPECT_EQ(sink->events.size(), delivered);
}

TEST_F(event_hub_test, overflows_of_a_subscriber_that_keeps_acknowledging_give_gaps_not_a_close) {
    // The gateway is behind (bursts bigger than the queue), the subscriber is not: every batch is
    // acknowledged within slow_ack. It is told exactly what it missed, burst after burst, and stays.
    make_hub();
    gw::subscriber_settings settings{
        .queue_limit = 4, .max_batch_events = 4, .overflow_window = 10s, .slow_ack = 1s};
    auto sink = add_sink(settings);
    sink->auto_ack = false;
    ASSERT_FALSE(hub_->subscribe(sink->id, reports));
    run();
    std::uint64_t published = 0;
    for (int burst = 0; burst < 5; ++burst) {
        publish(reports, 10);  // 1 delivered, 4 queued, 5 overflow
        published += 10;
        clock_->advance(900ms);  // acknowledged late, but within slow_ack
        for (int i = 0; i < 10 && sink->pending_ack; ++i) {
            sink->ack();
            run();
        }
    }
    EXPECT_FALSE(sink->closed);
    EXPECT_EQ(hub_->counters().evicted, 0u);
    std::uint64_t missed = 0;
    for (const auto& g : sink->gaps())
        missed += g->missed();
    EXPECT_EQ(sink->gaps().size(), 5u);
    EXPECT_EQ(missed, 25u);
    EXPECT_EQ(sink->seqs(reports).size() + missed, published);

    // The same burst, and then no acknowledgement: a subscriber that stopped reading is closed.
    publish(reports, 10);
    clock_->advance(6s);
    hub_->tick();
    run();
    ASSERT_TRUE(sink->closed);
    EXPECT_NE(sink->closed->find("too slow"), std::string::npos) << *sink->closed;
}

TEST_F(event_hub_test, a_subscriber_full_for_too_long_is_evicted) {
    make_hub();
    gw::subscriber_settings settings{.queue_limit = 4, .max_batch_events = 2, .max_stall = 5s};
    auto stalled = add_sink(settings);
    stalled->auto_ack = false;
    auto healthy = add_sink();
    ASSERT_FALSE(hub_->subscribe(stalled->id, "#"));
    ASSERT_FALSE(hub_->subscribe(healthy->id, "#"));
    run();
    publish(reports, 10);
    clock_->advance(4s);
    hub_->tick();
    run();
    EXPECT_FALSE(stalled->closed);
    clock_->advance(1001ms);
    hub_->tick();
    run();
    ASSERT_TRUE(stalled->closed);
    EXPECT_EQ(*stalled->closed, "too slow: send queue full for more than 5000 ms");
    EXPECT_FALSE(healthy->closed);
    EXPECT_EQ(healthy->seqs(reports), range(1, 10));
    EXPECT_EQ(hub_->counters().evicted, 1u);
}

TEST_F(event_hub_test, latest_value_topics_coalesce_to_the_newest) {
    make_hub();
    auto sink = add_sink();
    sink->auto_ack = false;
    ASSERT_FALSE(hub_->subscribe(sink->id, "controllers/+/position"));
    ASSERT_FALSE(hub_->subscribe(sink->id, "controllers/+/state"));
    run();
    publish(position, 1);  // delivered at once
    publish(position, 3);  // 2, 3, 4 while busy
    publish(state, 2);
    EXPECT_EQ(sink->seqs(position), range(1, 1));
    sink->ack();
    run();
    EXPECT_EQ(sink->seqs(position), (std::vector<std::uint64_t>{1, 4}));
    EXPECT_EQ(sink->seqs(state), range(2, 2));
    EXPECT_EQ(hub_->counters().coalesced, 3u);
    EXPECT_TRUE(sink->gaps().empty());  // coalescing is the policy here, not a loss
    // Never evicted for being slow on latest-value topics, however much it misses.
    publish(position, 5000);
    clock_->advance(60s);
    hub_->tick();
    run();
    EXPECT_FALSE(sink->closed);
    sink->ack();
    run();
    EXPECT_EQ(sink->seqs(position), (std::vector<std::uint64_t>{1, 4, 5004}));
}

TEST_F(event_hub_test, latest_value_rate_limit_per_subscription) {
    make_hub();
    auto limited = add_sink();
    auto unlimited = add_sink();
    ASSERT_FALSE(hub_->subscribe(limited->id, "controllers/+/position", {.max_rate_hz = 10}));  // 100 ms
    ASSERT_FALSE(hub_->subscribe(unlimited->id, "controllers/+/position"));
    run();
    publish(position, 1);
    EXPECT_EQ(limited->seqs(position), range(1, 1));
    clock_->advance(50ms);
    publish(position, 1);
    clock_->advance(40ms);
    publish(position, 1);
    hub_->tick();
    run();
    EXPECT_EQ(limited->seqs(position), range(1, 1));
    clock_->advance(10ms);  // 100 ms after the first
    hub_->tick();
    run();
    EXPECT_EQ(limited->seqs(position), (std::vector<std::uint64_t>{1, 3}));
    EXPECT_EQ(unlimited->seqs(position), range(1, 3));
    // 40 events in 2 s at 20 Hz: at most one per 100 ms, the newest each time.
    for (int i = 0; i < 40; ++i) {
        clock_->advance(50ms);
        publish(position, 1);
        hub_->tick();
        run();
    }
    EXPECT_EQ(limited->seqs(position).size(), 2u + 20u);
    EXPECT_EQ(limited->seqs(position).back(), 43u);
    EXPECT_EQ(unlimited->seqs(position).size(), 43u);
}

TEST_F(event_hub_test, rate_limited_value_arrives_by_the_hubs_own_timer) {
    // Real clocks here: only that the held-back value arrives, never how fast.
    hub_ = gw::event_hub::create(ioc_.get_executor());
    auto sink = std::make_shared<recording_sink>();
    sink->hub = hub_;
    sink->id = hub_->add_subscriber(sink);
    ASSERT_FALSE(hub_->subscribe(sink->id, position, {.max_rate_hz = 50}));
    ASSERT_FALSE(hub_->publish(position, nlohmann::json{{"i", 1}}));
    ASSERT_FALSE(hub_->publish(position, nlohmann::json{{"i", 2}}));
    ioc_.restart();
    auto deadline = std::chrono::steady_clock::now() + 30s;
    while (sink->seqs(position).size() < 2 && std::chrono::steady_clock::now() < deadline)
        ioc_.run_one_for(100ms);
    EXPECT_EQ(sink->seqs(position), range(1, 2));
}

TEST_F(event_hub_test, a_new_subscriber_gets_the_current_value_of_latest_topics) {
    make_hub();
    publish(state, 3);
    publish(position, 2);
    publish(reports, 2);
    auto sink = add_sink();
    ASSERT_FALSE(hub_->subscribe(sink->id, "controllers/stage1/#"));
    run();
    EXPECT_EQ(sink->seqs(state), range(3, 3));
    EXPECT_EQ(sink->seqs(position), range(2, 2));
    EXPECT_TRUE(sink->seqs(reports).empty());  // streams: live only unless resumed
}

TEST_F(event_hub_test, resume_on_a_latest_value_topic_replays_its_small_buffer_in_order) {
    make_hub({.latest_replay = 4});
    publish(position, 6);  // 3..6 buffered
    auto sink = add_sink(gw::subscriber_settings{.queue_limit = 2, .max_batch_events = 1});
    ASSERT_FALSE(hub_->subscribe(sink->id, position, {.resume = {{position, 1}}}));
    run();
    publish(position, 1);
    ASSERT_EQ(sink->gaps().size(), 1u);
    EXPECT_EQ(sink->gaps()[0]->gap_from, 2u);
    EXPECT_EQ(sink->gaps()[0]->gap_to, 2u);
    EXPECT_EQ(sink->seqs(position), range(3, 7));
}

TEST_F(event_hub_test, unsubscribe_stops_delivery_of_that_filter_only) {
    make_hub();
    auto sink = add_sink();
    ASSERT_FALSE(hub_->subscribe(sink->id, "controllers/+/reports"));
    ASSERT_FALSE(hub_->subscribe(sink->id, "controllers/+/ttl"));
    run();
    publish(reports, 1);
    publish(ttl, 1);
    hub_->unsubscribe(sink->id, "controllers/+/reports");
    run();
    publish(reports, 1);
    publish(ttl, 1);
    EXPECT_EQ(sink->seqs(reports), range(1, 1));
    EXPECT_EQ(sink->seqs(ttl), range(1, 2));
}

TEST_F(event_hub_test, forgets_destroyed_sinks_and_removed_subscribers) {
    make_hub();
    auto a = add_sink();
    auto b = add_sink();
    ASSERT_FALSE(hub_->subscribe(a->id, "#"));
    ASSERT_FALSE(hub_->subscribe(b->id, "#"));
    run();
    EXPECT_EQ(hub_->counters().subscribers, 2u);
    a.reset();
    publish(reports, 1);
    EXPECT_EQ(hub_->counters().subscribers, 1u);
    hub_->remove_subscriber(b->id);
    run();
    EXPECT_EQ(hub_->counters().subscribers, 0u);
    publish(reports, 1);
    EXPECT_EQ(b->seqs(reports), range(1, 1));
    EXPECT_EQ(hub_->counters().evicted, 0u);
}

TEST_F(event_hub_test, forgets_the_least_recently_published_topic_beyond_the_limit) {
    make_hub({.max_topics = 2});
    auto sink = add_sink();
    ASSERT_FALSE(hub_->subscribe(sink->id, "jobs/#"));
    run();
    publish("jobs/1", 2);
    publish("jobs/2", 1);
    publish("jobs/1", 1);
    publish("jobs/3", 1);  // forgets jobs/2
    publish("jobs/2", 1);  // starts again at 1; forgets jobs/1
    publish("jobs/3", 1);
    EXPECT_EQ(sink->seqs("jobs/1"), range(1, 3));
    EXPECT_EQ(sink->seqs("jobs/2"), (std::vector<std::uint64_t>{1, 1}));
    EXPECT_EQ(sink->seqs("jobs/3"), range(1, 2));
}

TEST(event_hub, publishers_on_many_threads_keep_every_topic_in_order) {
    // Real threads on both sides: four publishers, the io_context on two threads.
    boost::asio::io_context ioc;
    auto work = boost::asio::make_work_guard(ioc);
    auto hub = gw::event_hub::create(ioc.get_executor());
    auto sink = std::make_shared<recording_sink>();  // touched on the hub's strand only, read after join
    sink->hub = hub;
    sink->id = hub->add_subscriber(sink, gw::subscriber_settings{.queue_limit = 100'000});
    ASSERT_FALSE(hub->subscribe(sink->id, "jobs/#"));
    std::vector<std::thread> runners;
    for (int i = 0; i < 2; ++i)
        runners.emplace_back([&] { ioc.run(); });
    constexpr int per_thread = 500;
    std::vector<std::thread> publishers;
    for (int t = 0; t < 4; ++t) {
        publishers.emplace_back([&, t] {
            for (int i = 0; i < per_thread; ++i)
                EXPECT_FALSE(
                    hub->publish("jobs/" + std::to_string(t % 2), nlohmann::json{{"t", t}, {"i", i}}));
        });
    }
    for (auto& p : publishers)
        p.join();
    auto deadline = std::chrono::steady_clock::now() + 60s;
    while (hub->counters().delivered < 4 * per_thread && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(5ms);
    hub->stop();
    work.reset();
    for (auto& r : runners)
        r.join();
    EXPECT_EQ(sink->seqs("jobs/0"), range(1, 2 * per_thread));
    EXPECT_EQ(sink->seqs("jobs/1"), range(1, 2 * per_thread));
    // Each publisher's own events keep their order within the topic.
    for (int t = 0; t < 4; ++t) {
        int expected = 0;
        for (const auto& e : sink->events) {
            auto j = nlohmann::json::parse(*e->data);
            if (j["t"] == t) {
                EXPECT_EQ(j["i"], expected);
                ++expected;
            }
        }
        EXPECT_EQ(expected, per_thread);
    }
    EXPECT_EQ(*sink->closed, "event hub stopped");
}

TEST_F(event_hub_test, stop_closes_every_subscriber) {
    make_hub();
    auto a = add_sink();
    ASSERT_FALSE(hub_->subscribe(a->id, "#"));
    run();
    hub_->stop();
    run();
    ASSERT_TRUE(a->closed);
    EXPECT_EQ(*a->closed, "event hub stopped");
    publish(reports, 1);
    EXPECT_TRUE(a->events.empty());
    auto late = add_sink();
    run();
    EXPECT_TRUE(late->closed);
    EXPECT_EQ(hub_->counters().evicted, 0u);
}

}  // namespace

namespace {

// What a new subscriber resuming `topic` from 0 gets: the replayed sequence numbers and the gap.
struct resumed {
    std::vector<std::uint64_t> seqs;
    std::uint64_t missed = 0;
};

}  // namespace

TEST_F(event_hub_test, replay_buffers_share_a_byte_bound) {
    constexpr std::size_t bound = 64 * 1024;
    make_hub({.max_replay_bytes = bound});
    auto resume = [&](const std::string& topic) {
        auto sink = add_sink(gw::subscriber_settings{.queue_limit = 4096, .max_batch_events = 4096});
        EXPECT_FALSE(hub_->subscribe(sink->id, topic, {.resume = {{topic, 0}}}));
        run();
        resumed r{sink->seqs(topic), 0};
        for (const auto& g : sink->gaps())
            r.missed += g->missed();
        hub_->remove_subscriber(sink->id);
        run();
        return r;
    };

    publish(reports, 2000);  // more than the bound holds, fewer than stream_replay (1000) would
    EXPECT_LE(hub_->counters().replay_bytes, bound);
    EXPECT_GT(hub_->counters().replay_bytes, bound / 2);
    auto alone = resume(reports);
    ASSERT_FALSE(alone.seqs.empty());
    EXPECT_LT(alone.seqs.size(), 1000u) << "the byte bound, not the event count, limits the buffer";
    EXPECT_EQ(alone.seqs.back(), 2000u);
    EXPECT_EQ(alone.missed + alone.seqs.size(), 2000u) << "the rest is an exact gap";

    // A second busy stream: the first gives up room down to about half (each keeps a fair share).
    publish(ttl, 2000);
    EXPECT_LE(hub_->counters().replay_bytes, bound);
    auto first = resume(reports);
    auto second = resume(ttl);
    EXPECT_EQ(first.seqs.back(), 2000u);
    EXPECT_EQ(second.seqs.back(), 2000u);
    EXPECT_LT(first.seqs.size(), alone.seqs.size());
    EXPECT_GE(first.seqs.size(), alone.seqs.size() / 2 - 2);
    EXPECT_GE(second.seqs.size(), alone.seqs.size() / 2 - 2);
    EXPECT_EQ(second.missed + second.seqs.size(), 2000u);

    // Latest-value topics keep at least their newest event, whatever the bound.
    ASSERT_FALSE(hub_->publish(state, nlohmann::json{{"s", std::string(bound, 'x')}}));
    run();
    auto s = add_sink();
    ASSERT_FALSE(hub_->subscribe(s->id, state));
    run();
    EXPECT_EQ(s->seqs(state), range(1, 1));
}
