#include "gateway/common/job_id.hpp"

#include <algorithm>
#include <chrono>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace gw::jobs {
namespace {

constexpr std::string_view crockford = "0123456789ABCDEFGHJKMNPQRSTVWXYZ";

TEST(job_id, format_is_j_dash_26_crockford_characters) {
    auto id = make_job_id();
    ASSERT_EQ(id.size(), 28u);
    EXPECT_EQ(id.substr(0, 2), "j-");
    for (char c : id.substr(2))
        EXPECT_NE(crockford.find(c), std::string_view::npos) << id;
    EXPECT_TRUE(is_job_id(id));
}

TEST(job_id, known_values) {
    std::array<std::uint8_t, 10> zero{};
    EXPECT_EQ(format_job_id(0, zero), "j-00000000000000000000000000");
    std::array<std::uint8_t, 10> ones;
    ones.fill(0xff);
    EXPECT_EQ(format_job_id((std::uint64_t{1} << 48) - 1, ones), "j-7ZZZZZZZZZZZZZZZZZZZZZZZZZ");
    // 1469918176385 ms is ULID's documented example time "01ARYZ6S41".
    EXPECT_EQ(format_job_id(1469918176385, zero).substr(0, 12), "j-01ARYZ6S41");
    EXPECT_EQ(job_id_time_ms(format_job_id(1469918176385, zero)), 1469918176385u);
}

TEST(job_id, validation) {
    EXPECT_FALSE(is_job_id(""));
    EXPECT_FALSE(is_job_id("j-"));
    EXPECT_FALSE(is_job_id("x-00000000000000000000000000"));
    EXPECT_FALSE(is_job_id("j-0000000000000000000000000"));    // 25
    EXPECT_FALSE(is_job_id("j-000000000000000000000000000"));  // 27
    EXPECT_FALSE(is_job_id("j-0000000000000000000000000I"));   // not Crockford
    EXPECT_FALSE(is_job_id("j-0000000000000000000000000a"));   // lower case
    EXPECT_FALSE(is_job_id("j-80000000000000000000000000"));   // more than 48 bits of time
    EXPECT_TRUE(is_job_id("j-7ZZZZZZZZZZZZZZZZZZZZZZZZZ"));
    EXPECT_FALSE(job_id_time_ms("j-nope"));
}

TEST(job_id, string_order_is_time_order_across_milliseconds) {
    std::array<std::uint8_t, 10> high;
    high.fill(0xff);
    std::array<std::uint8_t, 10> low{};
    for (std::uint64_t ms : {0ull, 1ull, 31ull, 32ull, 1700000000000ull, (1ull << 47)}) {
        EXPECT_LT(format_job_id(ms, high), format_job_id(ms + 1, low)) << ms;
    }
}

TEST(job_id, made_ids_carry_the_current_time) {
    auto before = std::chrono::duration_cast<std::chrono::milliseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count();
    auto t = job_id_time_ms(make_job_id());
    auto after = std::chrono::duration_cast<std::chrono::milliseconds>(
                     std::chrono::system_clock::now().time_since_epoch())
                     .count();
    ASSERT_TRUE(t);
    // The id may run ahead of the clock by a few ms only when many were made in one millisecond.
    EXPECT_GE(static_cast<std::int64_t>(*t), before);
    EXPECT_LE(static_cast<std::int64_t>(*t), after + 1000);
}

TEST(job_id, many_ids_are_unique_and_strictly_increasing) {
    std::vector<std::string> ids;
    ids.reserve(100000);
    for (int i = 0; i < 100000; ++i)
        ids.push_back(make_job_id());
    EXPECT_TRUE(std::is_sorted(ids.begin(), ids.end()));
    EXPECT_EQ(std::adjacent_find(ids.begin(), ids.end()), ids.end());
}

TEST(job_id, unique_across_threads) {
    std::vector<std::vector<std::string>> per(4);
    std::vector<std::thread> threads;
    for (auto& v : per)
        threads.emplace_back([&v] {
            for (int i = 0; i < 10000; ++i)
                v.push_back(make_job_id());
        });
    for (auto& t : threads)
        t.join();
    std::set<std::string> all;
    for (const auto& v : per) {
        EXPECT_TRUE(std::is_sorted(v.begin(), v.end()));
        all.insert(v.begin(), v.end());
    }
    EXPECT_EQ(all.size(), 40000u);
}

TEST(lease_id, format_and_uniqueness) {
    std::set<std::string> ids;
    for (int i = 0; i < 1000; ++i) {
        auto id = make_lease_id();
        ASSERT_EQ(id.size(), 34u);
        EXPECT_EQ(id.substr(0, 2), "l-");
        for (char c : id.substr(2))
            EXPECT_NE(std::string_view("0123456789abcdef").find(c), std::string_view::npos);
        ids.insert(id);
    }
    EXPECT_EQ(ids.size(), 1000u);
}

}  // namespace
}  // namespace gw::jobs
