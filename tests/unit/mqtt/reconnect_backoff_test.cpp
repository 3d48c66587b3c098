// The MQTT reconnect backoff: doubling from min, capped at max, every wait jittered within
// [base / 2, base], back to min after a connect.
#include "api/mqtt/reconnect_backoff.hpp"

#include <chrono>
#include <set>

#include <gtest/gtest.h>

namespace gw::api {
namespace {

using std::chrono::milliseconds;

TEST(reconnect_backoff, doubles_from_min_up_to_max_with_each_wait_in_the_upper_half_of_its_base) {
    reconnect_backoff b(milliseconds(500), milliseconds(2000), 1);
    const milliseconds bases[] = {milliseconds(500), milliseconds(1000), milliseconds(2000),
                                  milliseconds(2000), milliseconds(2000)};
    for (auto base : bases) {
        const auto wait = b.next();
        EXPECT_GE(wait, base / 2);
        EXPECT_LE(wait, base);
    }
}

TEST(reconnect_backoff, never_waits_longer_than_max_however_many_attempts_failed) {
    reconnect_backoff b(milliseconds(500), milliseconds(2000), 7);
    for (int i = 0; i < 10000; ++i)
        ASSERT_LE(b.next(), milliseconds(2000)) << "attempt " << i;
}

TEST(reconnect_backoff, jitter_spreads_the_waits_of_gateways_that_lost_the_broker_together) {
    std::set<milliseconds::rep> waits;
    for (std::uint64_t seed = 1; seed <= 20; ++seed) {
        reconnect_backoff b(milliseconds(500), milliseconds(2000), seed);
        for (int i = 0; i < 5; ++i)
            b.next();
        waits.insert(b.next().count());  // at the cap: somewhere in [1000, 2000]
    }
    EXPECT_GE(waits.size(), 10u) << "20 gateways, but only " << waits.size() << " different waits";
}

TEST(reconnect_backoff, starts_again_from_min_after_a_connect) {
    reconnect_backoff b(milliseconds(100), milliseconds(3000), 3);
    for (int i = 0; i < 8; ++i)
        b.next();
    b.reset();
    EXPECT_LE(b.next(), milliseconds(100));
}

TEST(reconnect_backoff, a_max_below_min_counts_as_min) {
    reconnect_backoff b(milliseconds(800), milliseconds(10), 5);
    for (int i = 0; i < 5; ++i) {
        const auto wait = b.next();
        EXPECT_GE(wait, milliseconds(400));
        EXPECT_LE(wait, milliseconds(800));
    }
}

}  // namespace
}  // namespace gw::api
