// worker_thread: work runs on its own thread, in order, and at most max_waiting pieces wait.
#include "gateway/common/worker_thread.hpp"

#include <chrono>
#include <future>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace gw {
namespace {

using namespace std::chrono_literals;

TEST(worker_thread, runs_work_in_order_on_its_own_thread) {
    worker_thread worker(8);
    std::vector<int> order;
    std::promise<std::thread::id> ran_on;
    for (int i = 0; i < 3; ++i)
        ASSERT_TRUE(worker.post([&order, i] { order.push_back(i); }));
    ASSERT_TRUE(worker.post([&ran_on] { ran_on.set_value(std::this_thread::get_id()); }));
    auto id = ran_on.get_future();
    ASSERT_EQ(id.wait_for(10s), std::future_status::ready);
    EXPECT_NE(id.get(), std::this_thread::get_id());
    EXPECT_EQ(order, (std::vector<int>{0, 1, 2}));
}

TEST(worker_thread, refuses_work_beyond_max_waiting_and_takes_it_again_after) {
    worker_thread worker(2);
    EXPECT_EQ(worker.max_waiting(), 2u);
    std::promise<void> release;
    auto released = release.get_future().share();
    std::promise<void> started;
    ASSERT_TRUE(worker.post([&started, released] {
        started.set_value();
        released.wait();
    }));
    started.get_future().wait();
    // The running piece no longer waits: two more may.
    ASSERT_TRUE(worker.post([] {}));
    std::promise<void> third_ran;
    ASSERT_TRUE(worker.post([&third_ran] { third_ran.set_value(); }));
    EXPECT_FALSE(worker.post([] { ADD_FAILURE() << "refused work ran"; }));
    release.set_value();
    auto second = third_ran.get_future();
    ASSERT_EQ(second.wait_for(10s), std::future_status::ready);
    std::promise<void> later;
    EXPECT_TRUE(worker.post([&later] { later.set_value(); }));
    EXPECT_EQ(later.get_future().wait_for(10s), std::future_status::ready);
}

}  // namespace
}  // namespace gw
