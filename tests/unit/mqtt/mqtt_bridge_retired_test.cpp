// An ended job's topic leaving the event hub reaches the MQTT bridge as a "retired" event: that is not a
// job state (it carries no data: nothing is published for it, nothing breaks). A real hub and a real
// bridge; the broker is a closed loopback port, so what the bridge would publish waits in its job
// queue (gw_mqtt_job_queue), which is measured.
#include <chrono>
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

nlohmann::json job_state(const std::string& state) {
    return {{"type", "state"}, {"state", state}, {"job", {{"id", "j-1"}, {"state", state}}}};
}

class mqtt_bridge_retired : public ::testing::Test {
  protected:
    void SetUp() override {
        hub_ = event_hub::create(io_.get_executor());
        metrics_ = std::make_shared<gw::metrics>();
        ctx_ = std::make_shared<api_context>(
            api_context{io_.get_executor(), registry_, hub_, metrics_, {}, {}, {}, {}, {}, {}, {}});
        mqtt_bridge_settings s;
        s.config.enabled = true;
        s.config.brokers = {test::closed_broker_url()};
        s.config.reconnect_min = std::chrono::seconds(30);
        s.config.reconnect_max = std::chrono::seconds(30);
        s.gateway_id = "gw";
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
    void settle() {
        for (int i = 0; i < 5; ++i) {
            io_.restart();
            io_.run_for(std::chrono::milliseconds(10));
        }
    }
    double queued() const { return metrics_->value("gw_mqtt_job_queue", {}); }

    net::io_context io_;
    controller_registry registry_{io_.get_executor(), registry_options{}};
    std::shared_ptr<event_hub> hub_;
    std::shared_ptr<gw::metrics> metrics_;
    std::shared_ptr<api_context> ctx_;
    std::shared_ptr<mqtt_bridge> bridge_;
};

TEST_F(mqtt_bridge_retired, a_retired_job_topic_is_no_job_state) {
    ASSERT_FALSE(hub_->publish("jobs/j-1", job_state("running")));
    ASSERT_FALSE(hub_->publish("jobs/j-1", job_state("succeeded")));
    settle();
    EXPECT_EQ(queued(), 2);  // both states, for the broker's return
    ASSERT_FALSE(hub_->retire_topic("jobs/j-1", std::chrono::milliseconds(0)));
    settle();
    EXPECT_EQ(hub_->counters().topics, 0u);
    EXPECT_EQ(queued(), 2) << "the retired event is not a job state";
    // Still working: a new job's states arrive.
    ASSERT_FALSE(hub_->publish("jobs/j-2", job_state("queued")));
    settle();
    EXPECT_EQ(queued(), 3);
}

}  // namespace
}  // namespace gw::api
