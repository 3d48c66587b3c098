#pragma once
// The event hub test fixture: a hub on a manual clock over an io_context that the test runs by hand,
// and sinks that record what they get. Shared by event_hub_test.cpp and event_hub_retire_test.cpp.

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gateway/events/event_hub.hpp"

namespace gw::hub_test {

using namespace std::chrono_literals;
using gw::event_kind;

// Time the test moves by hand: rate limits and eviction are decided by this clock only.
struct manual_clock {
    std::chrono::steady_clock::time_point steady{std::chrono::hours(1000)};
    std::chrono::system_clock::time_point system{std::chrono::milliseconds(1795322740000)};

    void advance(std::chrono::milliseconds d) {
        steady += d;
        system += d;
    }
};

// Records what it gets; acknowledges batches automatically or when the test says so.
class recording_sink final : public gw::event_sink {
  public:
    void deliver(std::vector<std::shared_ptr<const gw::event>> batch) override {
        ++batches;
        last_batch_size = batch.size();
        for (auto& e : batch)
            events.push_back(std::move(e));
        pending_ack = true;
        if (auto_ack) ack();
    }
    void close(std::string reason) override { closed = std::move(reason); }

    void ack() {
        pending_ack = false;
        hub->request_more(id);
    }

    // Sequence numbers of the data events of one topic, in arrival order.
    std::vector<std::uint64_t> seqs(const std::string& topic) const {
        std::vector<std::uint64_t> out;
        for (const auto& e : events)
            if (e->topic == topic && e->kind == event_kind::data) out.push_back(e->sequence);
        return out;
    }
    std::vector<std::shared_ptr<const gw::event>> gaps() const {
        std::vector<std::shared_ptr<const gw::event>> out;
        for (const auto& e : events)
            if (e->kind == event_kind::gap) out.push_back(e);
        return out;
    }

    std::shared_ptr<gw::event_hub> hub;
    gw::subscriber_id id = 0;
    bool auto_ack = true;
    bool pending_ack = false;
    std::size_t batches = 0;
    std::size_t last_batch_size = 0;
    std::vector<std::shared_ptr<const gw::event>> events;
    std::optional<std::string> closed;
};

inline std::vector<std::uint64_t> range(std::uint64_t from, std::uint64_t to) {
    std::vector<std::uint64_t> out;
    for (auto i = from; i <= to; ++i)
        out.push_back(i);
    return out;
}

class event_hub_test : public ::testing::Test {
  protected:
    void make_hub(gw::event_hub_settings settings = {}) {
        gw::event_clock clock;
        clock.steady = [c = clock_] { return c->steady; };
        clock.system = [c = clock_] { return c->system; };
        hub_ = gw::event_hub::create(ioc_.get_executor(), settings, clock);
    }

    std::shared_ptr<recording_sink> add_sink(std::optional<gw::subscriber_settings> settings = {}) {
        auto sink = std::make_shared<recording_sink>();
        sink->hub = hub_;
        sink->id = settings ? hub_->add_subscriber(sink, *settings) : hub_->add_subscriber(sink);
        return sink;
    }

    // Runs everything that is ready; never waits for timers (the manual clock decides time).
    void run() {
        ioc_.restart();
        ioc_.poll();
    }

    void publish(const std::string& topic, int n = 1) {
        for (int i = 0; i < n; ++i)
            ASSERT_FALSE(hub_->publish(topic, nlohmann::json{{"i", i}}));
        run();
    }

    boost::asio::io_context ioc_;
    std::shared_ptr<manual_clock> clock_ = std::make_shared<manual_clock>();
    std::shared_ptr<gw::event_hub> hub_;
};

const std::string reports = "controllers/stage1/reports";
const std::string ttl = "controllers/stage1/ttl";
const std::string position = "controllers/stage1/position";
const std::string state = "controllers/stage1/state";

}  // namespace gw::hub_test
