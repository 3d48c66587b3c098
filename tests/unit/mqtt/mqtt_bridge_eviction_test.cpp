// The MQTT bridge evicted by the event hub as too slow: it subscribes again at once and resumes its
// stream topics after the last event it saw, so every event published is accounted for (delivered,
// or counted as dropped/gapped) across the eviction. A real hub and a real bridge; the broker is a
// closed loopback port, so the bridge stays disconnected and counts every TTL event it gets as
// dropped (gw_mqtt_dropped_total{kind="ttl"}), which is what is measured here.
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "api/common/api_context.hpp"
#include "api/mqtt/mqtt_bridge.hpp"
#include "gateway/common/metrics.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/events/event_hub.hpp"
#include "tests/support/closed_broker.hpp"

namespace gw::api {
namespace {

namespace net = boost::asio;

// A loopback port nobody listens on (bound, then closed).
nlohmann::json ttl_data(std::uint64_t n) {
    nlohmann::json j = nlohmann::json::object();
    j["id"] = "sim1";
    j["controller_seq"] = n;
    return j;
}

class mqtt_bridge_eviction : public ::testing::Test {
  protected:
    void SetUp() override {
        event_hub_settings hs;
        hs.stream_replay = 100000;  // everything stays replayable: only the resume decides
        hub_ = event_hub::create(io_.get_executor(), hs);
        metrics_ = std::make_shared<gw::metrics>();
        ctx_ = std::make_shared<api_context>(
            api_context{io_.get_executor(), registry_, hub_, metrics_, {}, {}, {}, {}, {}, {}, {}});
        mqtt_bridge_settings s;
        s.config.enabled = true;
        s.config.brokers = {test::closed_broker_url()};
        s.config.reconnect_min = std::chrono::seconds(30);  // one refused attempt is enough
        s.config.reconnect_max = std::chrono::seconds(30);
        s.gateway_id = "gw";
        // Every overflow counts against it, even while it acknowledges (the hub's default forgives
        // those: they mean the gateway is behind), so that two bursts evict it.
        s.hub_subscriber.slow_ack = std::chrono::milliseconds(0);
        s.hub_subscriber.queue_limit = 4096;  // a burst of 5000 overflows it
        bridge_ = mqtt_bridge::create(ctx_, s);
        bridge_->start();
        settle();
    }
    void TearDown() override {
        bool stopped = false;
        bridge_->async_stop([&] { stopped = true; });
        for (int i = 0; i < 200 && !stopped; ++i)
            settle();
        EXPECT_TRUE(stopped);
        hub_->stop();
        settle();
    }
    // Runs every ready handler (Paho posts from its own threads: give them a moment too).
    void settle() {
        for (int i = 0; i < 5; ++i) {
            io_.restart();
            io_.run_for(std::chrono::milliseconds(10));
        }
    }
    // Publishes n TTL events in one go: all of them reach the hub's strand before the bridge can ask
    // for more, so more than its queue bound (4096 here) overflows it once.
    void burst(std::uint64_t n) {
        for (std::uint64_t i = 0; i < n; ++i)
            ASSERT_FALSE(hub_->publish("controllers/sim1/ttl", ttl_data(++published_)));
    }
    double dropped_ttl() const { return metrics_->value("gw_mqtt_dropped_total", {{"kind", "ttl"}}); }

    net::io_context io_;
    controller_registry registry_{io_.get_executor(), registry_options{}};
    std::shared_ptr<event_hub> hub_;
    std::shared_ptr<gw::metrics> metrics_;
    std::shared_ptr<api_context> ctx_;
    std::shared_ptr<mqtt_bridge> bridge_;
    std::uint64_t published_ = 0;
};

TEST_F(mqtt_bridge_eviction, resubscribes_and_accounts_for_every_event) {
    const auto first = bridge_->hub_subscriber();
    ASSERT_NE(first, 0u);
    burst(10);
    settle();
    EXPECT_EQ(dropped_ttl(), 10);  // disconnected: every event counted

    // Two overflows within the hub's overflow window: evicted as too slow.
    burst(5000);
    settle();
    burst(5000);
    settle();
    for (int i = 0; i < 50 && dropped_ttl() < static_cast<double>(published_); ++i)
        settle();

    const auto c = hub_->counters();
    ASSERT_EQ(c.evicted, 1u) << "the bridge was not evicted: the test does not test anything";
    EXPECT_NE(bridge_->hub_subscriber(), first) << "a new subscription";
    EXPECT_EQ(c.subscribers, 1u);
    EXPECT_EQ(metrics_->value("gw_mqtt_dropped_total", {{"kind", "evicted"}}), 1);
    // Every event: data delivered (then dropped: no broker) or reported in a gap event.
    EXPECT_EQ(dropped_ttl(), static_cast<double>(published_));

    // And it keeps receiving.
    burst(3);
    settle();
    EXPECT_EQ(dropped_ttl(), static_cast<double>(published_));
}

}  // namespace
}  // namespace gw::api
