// What was taken within a window (api/mqtt/replay_window.hpp): a pair once, the window both ways,
// the bound, and forgetting.
#include "api/mqtt/replay_window.hpp"

#include <gtest/gtest.h>

namespace gw::api {
namespace {

TEST(replay_window, takes_a_pair_once_within_the_window) {
    using v = replay_window::verdict;
    replay_window guard(std::chrono::seconds(30), 3);
    const std::int64_t now = 1'000'000'000;
    EXPECT_EQ(guard.admit("k", "n1", now, now), v::fresh);
    EXPECT_EQ(guard.admit("k", "n1", now, now + 1000), v::replayed);
    EXPECT_EQ(guard.admit("other", "n1", now, now), v::fresh);  // nonces are per key
    EXPECT_EQ(guard.admit("k", "n2", now - 30'001, now), v::stale);
    EXPECT_EQ(guard.admit("k", "n2", now + 30'001, now), v::stale);
    EXPECT_EQ(guard.admit("k", "n3", now + 10'000, now), v::fresh);  // a clock a little ahead
    EXPECT_EQ(guard.admit("k", "n4", now, now), v::full);            // three remembered, none expired
    // Once n1's ts is out of the window, it is forgotten (and could not be fresh again anyway).
    EXPECT_EQ(guard.admit("k", "n4", now + 31'000, now + 31'000), v::fresh);
    EXPECT_EQ(guard.remembered(), 2u);  // n3 (expires at now + 40 s) and n4
    EXPECT_EQ(guard.admit("k", "n1", now, now + 31'000), v::stale);
}

TEST(replay_window, pairs_admitted_at_their_own_time_expire_a_window_later) {
    // The redelivery check's use: ts is the time of delivery.
    using v = replay_window::verdict;
    replay_window ids(std::chrono::seconds(600), 100);
    const std::int64_t t = 2'000'000'000;
    EXPECT_EQ(ids.admit("ada", "id \"c1\"", t, t), v::fresh);
    EXPECT_EQ(ids.admit("ada", "id \"c1\"", t + 599'000, t + 599'000), v::replayed);
    EXPECT_EQ(ids.admit("bob", "id \"c1\"", t + 1, t + 1), v::fresh) << "ids are per sender";
    EXPECT_EQ(ids.admit("ada", "id \"c1\"", t + 600'001, t + 600'001), v::fresh)
        << "forgotten after the window";
}

}  // namespace
}  // namespace gw::api
