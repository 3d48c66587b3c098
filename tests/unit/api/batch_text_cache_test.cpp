#include "api/ws/batch_text_cache.hpp"

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "api/ws/websocket_protocol.hpp"

namespace gw::api {
namespace {

std::shared_ptr<const event> report(std::uint64_t seq) {
    return make_data_event(
        "controllers/c1/reports", seq, std::chrono::system_clock::time_point{},
        std::make_shared<const std::string>(R"({"controller_seq":)" + std::to_string(seq) + "}"));
}

TEST(batch_text_cache, the_same_events_share_one_text) {
    batch_text_cache cache;
    const std::vector events{report(1), report(2)};
    const auto first = cache.text(events);
    EXPECT_EQ(*first, ws_batch_message(events));
    // Another session's batch of the same events (its own vector) gets the very same bytes.
    const auto again = cache.text(std::vector{events[0], events[1]});
    EXPECT_EQ(again.get(), first.get());
}

TEST(batch_text_cache, other_events_or_another_order_get_their_own_text) {
    batch_text_cache cache;
    const auto a = report(1), b = report(2), c = report(3);
    const auto ab = cache.text({a, b});
    const auto ba = cache.text({b, a});
    const auto abc = cache.text({a, b, c});
    const auto a_only = cache.text({a});
    EXPECT_NE(ab.get(), ba.get());
    EXPECT_EQ(*ba, ws_batch_message({b, a}));
    EXPECT_EQ(*abc, ws_batch_message({a, b, c}));
    EXPECT_EQ(*a_only, ws_batch_message({a}));
    // Events with equal contents are still other events: only the same ones share a text.
    const auto copy_of_a = report(1);
    const auto copy = cache.text({copy_of_a, b});
    EXPECT_NE(copy.get(), ab.get());
    EXPECT_EQ(*copy, *ab);
}

TEST(batch_text_cache, only_the_most_recent_batches_are_kept) {
    batch_text_cache cache;
    const std::vector first{report(1)};
    const auto kept = cache.text(first);
    for (std::uint64_t seq = 2; seq < 10; ++seq)
        cache.text({report(seq)});
    const auto rebuilt = cache.text(first);
    EXPECT_NE(rebuilt.get(), kept.get());
    EXPECT_EQ(*rebuilt, *kept);
}

}  // namespace
}  // namespace gw::api
