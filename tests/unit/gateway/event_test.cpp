#include "gateway/events/event.hpp"

#include <chrono>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gateway/common/timestamp.hpp"

namespace {

using namespace std::chrono;

system_clock::time_point at_epoch_ms(std::int64_t ms) {
    return system_clock::time_point(milliseconds(ms));
}

TEST(timestamp, iso8601_with_milliseconds) {
    EXPECT_EQ(gw::format_timestamp(at_epoch_ms(0)), "1970-01-01T00:00:00.000Z");
    EXPECT_EQ(gw::format_timestamp(at_epoch_ms(1795322740123)), "2026-11-22T04:45:40.123Z");
    EXPECT_EQ(gw::format_timestamp(at_epoch_ms(951782400999)), "2000-02-29T00:00:00.999Z");
    EXPECT_EQ(gw::format_timestamp(at_epoch_ms(9223372036853)), "2262-04-11T23:47:16.853Z");
    EXPECT_EQ(gw::format_timestamp(at_epoch_ms(-1)), "1969-12-31T23:59:59.999Z");
    // Truncated, not rounded: a time stamp never lies in the future.
    EXPECT_EQ(gw::format_timestamp(at_epoch_ms(951782400999) + microseconds(999)),
              "2000-02-29T00:00:00.999Z");
    EXPECT_EQ(gw::epoch_ms(at_epoch_ms(1795322740123) + microseconds(999)), 1795322740123);
}

TEST(event, data_message_embeds_the_payload_once) {
    auto data = std::make_shared<const std::string>(R"({"x":1.5,"s":"a\"b"})");
    auto e = gw::make_data_event("controllers/stage1/position", 42, at_epoch_ms(1795322740123), data);
    EXPECT_EQ(e->kind, gw::event_kind::data);
    EXPECT_EQ(e->data, data);  // shared, not copied
    EXPECT_EQ(e->missed(), 0u);
    EXPECT_EQ(*e->message,
              R"({"type":"event","topic":"controllers/stage1/position","seq":42,)"
              R"("time":"2026-11-22T04:45:40.123Z","time_ms":1795322740123,"data":{"x":1.5,"s":"a\"b"}})");
    auto j = nlohmann::json::parse(*e->message);
    EXPECT_EQ(j["data"]["s"], "a\"b");
    EXPECT_EQ(e->address.kind, gw::topic_kind::controller_position);
    EXPECT_EQ(e->key(), "stage1");
    auto copy = *e;  // the key is kept as a place in the topic, not a view into this event's string
    EXPECT_EQ(copy.key(), "stage1");
}

TEST(event, gap_message) {
    auto e = gw::make_gap_event("jobs/7", 101, 140, at_epoch_ms(0));
    EXPECT_EQ(e->kind, gw::event_kind::gap);
    EXPECT_EQ(e->missed(), 40u);
    EXPECT_EQ(e->address.kind, gw::topic_kind::job);
    EXPECT_EQ(e->key(), "7");
    EXPECT_EQ(*e->message, R"({"type":"gap","topic":"jobs/7","missed":40,"from":101,"to":140,)"
                           R"("time":"1970-01-01T00:00:00.000Z","time_ms":0})");
}

}  // namespace
