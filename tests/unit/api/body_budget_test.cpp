#include "api/common/body_budget.hpp"

#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace gw::api {
namespace {

TEST(body_budget, refuses_what_it_cannot_cover_and_takes_back_what_is_released) {
    body_budget budget(1000);
    auto a = budget.try_reserve(600);
    ASSERT_TRUE(a);
    EXPECT_FALSE(budget.try_reserve(401));
    auto b = budget.try_reserve(400);
    ASSERT_TRUE(b);
    EXPECT_EQ(budget.in_use(), 1000u);
    a->reset();
    EXPECT_EQ(budget.in_use(), 400u);
    EXPECT_TRUE(budget.try_reserve(600));  // a temporary: given back at once
    EXPECT_EQ(budget.in_use(), 400u);
    EXPECT_FALSE(budget.try_reserve(5000));
}

TEST(body_budget, a_moved_reservation_is_released_once) {
    body_budget budget(100);
    auto r = budget.try_reserve(60);
    body_budget::reservation moved = std::move(*r);
    r.reset();
    EXPECT_EQ(budget.in_use(), 60u);
    body_budget::reservation other;
    other = std::move(moved);
    EXPECT_EQ(budget.in_use(), 60u);
    other.reset();
    EXPECT_EQ(budget.in_use(), 0u);
}

TEST(body_budget, never_overcommits_under_contention) {
    body_budget budget(1000);
    std::atomic<int> over{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
        threads.emplace_back([&] {
            for (int i = 0; i < 20000; ++i) {
                auto r = budget.try_reserve(300);
                if (budget.in_use() > 1000) ++over;
            }
        });
    for (auto& t : threads)
        t.join();
    EXPECT_EQ(over.load(), 0);
    EXPECT_EQ(budget.in_use(), 0u);
}

}  // namespace
}  // namespace gw::api
