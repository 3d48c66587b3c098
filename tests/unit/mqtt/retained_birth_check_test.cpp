// Reading the retained birth back (api/mqtt/retained_birth_check.hpp): confirmed, stale, missing,
// given up on, and ended by a disconnect. Real timers on an io_context, with short waits.
#include "api/mqtt/retained_birth_check.hpp"

#include <chrono>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <boost/asio/strand.hpp>
#include <gtest/gtest.h>

#include "api/mqtt/mqtt_client.hpp"

namespace gw::api {
namespace {

using namespace std::chrono_literals;
namespace net = boost::asio;

struct check_rig {
    net::io_context io;
    std::vector<std::string> calls;  // "watch", "unwatch", "republish", in order
    retained_birth_check check{net::make_strand(net::any_io_executor(io.get_executor())),
                               "asi/gw/status",
                               {[this](const std::string&) { calls.emplace_back("watch"); },
                                [this](const std::string&) { calls.emplace_back("unwatch"); },
                                [this] { calls.emplace_back("republish"); }},
                               nullptr,
                               {.check_delay = 20ms, .answer_wait = 50ms, .max_rounds = 2}};

    // Runs the io_context until `calls` has `n` entries (or a second passed).
    void run_until(std::size_t n) {
        const auto deadline = std::chrono::steady_clock::now() + 1s;
        while (calls.size() < n && std::chrono::steady_clock::now() < deadline) {
            io.run_for(5ms);
            io.restart();
        }
    }
    bool retained(const std::string& payload, bool flag = true) {
        mqtt_message_in in;
        in.topic = "asi/gw/status";
        in.payload = payload;
        in.retained = flag;
        return check.on_message(in);
    }
};

TEST(retained_birth_check, the_birth_served_ends_the_check) {
    check_rig r;
    r.check.birth_published("birth-1");
    r.check.connected();
    r.run_until(1);
    ASSERT_EQ(r.calls, (std::vector<std::string>{"watch"}));
    EXPECT_TRUE(r.retained("birth-1", false)) << "a live birth is the check's message, but not the answer";
    EXPECT_EQ(r.calls.size(), 1u);
    EXPECT_TRUE(r.retained("birth-1"));
    EXPECT_EQ(r.calls, (std::vector<std::string>{"watch", "unwatch"}));
    r.run_until(3);  // nothing more comes: no answer timeout fires after the confirmation
    EXPECT_EQ(r.calls.size(), 2u);
}

TEST(retained_birth_check, an_older_birth_is_published_again_until_served) {
    check_rig r;
    r.check.birth_published("birth-1");
    r.check.connected();
    r.run_until(1);
    EXPECT_TRUE(r.retained("birth-0"));
    EXPECT_EQ(r.calls, (std::vector<std::string>{"watch", "unwatch", "republish"}));
    r.check.birth_published("birth-2");  // what the republish sent
    r.run_until(4);
    ASSERT_EQ(r.calls.back(), "watch");
    EXPECT_TRUE(r.retained("birth-2"));
    EXPECT_EQ(r.calls.back(), "unwatch");
    EXPECT_EQ(r.calls.size(), 5u);
}

TEST(retained_birth_check, no_retained_birth_at_all_counts_as_stale_and_it_gives_up_after_max_rounds) {
    check_rig r;
    r.check.birth_published("birth-1");
    r.check.connected();
    r.run_until(9);
    EXPECT_EQ(r.calls, (std::vector<std::string>{"watch", "unwatch", "republish", "watch", "unwatch",
                                                 "republish", "watch", "unwatch"}))
        << "two republishes (max_rounds), then it stops asking";
}

TEST(retained_birth_check, a_disconnect_ends_the_check_and_other_topics_are_not_its_own) {
    check_rig r;
    r.check.birth_published("birth-1");
    r.check.connected();
    r.check.disconnected();
    r.run_until(1);
    EXPECT_TRUE(r.calls.empty());
    mqtt_message_in command;
    command.topic = "asi/gw/controllers/sim1/cmd";
    EXPECT_FALSE(r.check.on_message(command));
}

}  // namespace
}  // namespace gw::api
