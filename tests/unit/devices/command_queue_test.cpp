// The order in which a controller's commands are served, and what a HALT does to the ones waiting.
#include "devices/serial/command_queue.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gw::devices {
namespace {

queued_command client(const std::string& id, std::optional<std::uint64_t> halts_seen = std::nullopt) {
    return queued_command{.cmd = ms2000::where("X"), .request_id = id, .halts_seen = halts_seen};
}

queued_command internal(const std::string& id) {
    return queued_command{.cmd = ms2000::version(),
                          .request_id = id,
                          .internal = [](boost::system::error_code, const ms2000::reply&) {}};
}

queued_command halt(const std::string& id) {
    return queued_command{.cmd = ms2000::halt(), .request_id = id};
}

void push(command_queue& q, queued_command job) {
    ASSERT_TRUE(q.push(job)) << job.request_id;
}

std::vector<std::string> served(command_queue& q) {
    std::vector<std::string> ids;
    while (auto job = q.pop())
        ids.push_back(job->request_id);
    return ids;
}

TEST(command_queue, halts_then_the_drivers_own_then_clients_each_in_arrival_order) {
    command_queue q(8);
    push(q, client("c1"));
    push(q, halt("h1"));
    push(q, client("c2"));
    push(q, halt("h2"));
    q.push_internal(internal("i1"));
    q.push_internal(internal("i2"));
    EXPECT_EQ(served(q), (std::vector<std::string>{"h1", "h2", "i1", "i2", "c1", "c2"}));
}

TEST(command_queue, a_full_queue_refuses_and_leaves_the_command_to_its_caller) {
    command_queue q(2);
    auto a = client("a");
    auto b = client("b");
    auto c = client("c");
    ASSERT_TRUE(q.push(a));
    ASSERT_TRUE(q.push(b));
    EXPECT_FALSE(q.push(c));
    EXPECT_EQ(c.request_id, "c");
    auto h = halt("h");
    EXPECT_TRUE(q.push(h)) << "HALTs have a queue of their own";
}

TEST(command_queue, a_halt_drops_the_guarded_commands_waiting_and_refuses_those_that_missed_it) {
    command_queue q(8);
    const auto seen = q.halts_accepted();
    push(q, client("guarded1", seen));
    push(q, client("plain"));
    push(q, client("guarded2", seen));
    std::vector<std::string> dropped;
    for (const auto& job : q.accept_halt())
        dropped.push_back(job.request_id);
    EXPECT_EQ(dropped, (std::vector<std::string>{"guarded1", "guarded2"}));
    EXPECT_EQ(q.halts_accepted(), seen + 1);
    EXPECT_TRUE(q.missed_halt(client("late", seen)));
    EXPECT_FALSE(q.missed_halt(client("fresh", seen + 1)));
    EXPECT_FALSE(q.missed_halt(client("unguarded")));
    EXPECT_EQ(served(q), (std::vector<std::string>{"plain"}));
}

TEST(command_queue, a_command_put_back_is_first_of_its_kind_and_take_all_empties_it) {
    command_queue q(8);
    push(q, client("c1"));
    q.push_internal(internal("i1"));
    q.push_front(client("held"));
    q.push_front(internal("i0"));
    auto resent = halt("resent");
    resent.resent = true;
    q.push_front(std::move(resent));
    EXPECT_FALSE(q.unsent_halt_waiting()) << "a HALT already written once waits for the link";
    std::vector<std::string> all;
    for (const auto& job : q.take_all())
        all.push_back(job.request_id);
    EXPECT_EQ(all, (std::vector<std::string>{"resent", "i0", "i1", "held", "c1"}));
    EXPECT_FALSE(q.pop());
}

}  // namespace
}  // namespace gw::devices
