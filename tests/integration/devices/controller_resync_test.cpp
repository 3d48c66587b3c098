// Reply matching against the simulator's fault injection: late, split, echoed and corrupted replies
// and noise. Every answer a command gets must be its own; the snapshot never shows another
// command's value.
#include <chrono>
#include <cmath>
#include <map>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "devices/ms2000/error.hpp"
#include "devices/ms2000/reply_check.hpp"
#include "tests/support/drv_sim_fixture.hpp"

namespace gw::devices {
namespace {

using namespace std::chrono_literals;
using controller_resync_test = test::drv_sim_fixture;

void tight_timeouts(controller_settings& s) {
    s.command_timeout = 500ms;
    s.resync_delay = 50ms;
    s.idle_poll_interval = 0ms;  // polls while idle too: they are what the faults hit
}

// Moves the stage to positions no two axes share and returns WHERE's answer for each axis.
std::map<char, double> park_at_distinct_positions(test::simulated_controller& c) {
    const auto move = ms2000::move({{'X', 1234.5}, {'Y', -555.1}, {'Z', 77.7}}).value();
    EXPECT_FALSE(c.call(move).first);
    for (int i = 0; i < 500; ++i) {
        const auto [ec, status] = c.call(ms2000::status());
        if (!ec && !status.busy) break;
        std::this_thread::sleep_for(10ms);
    }
    const auto [ec, where] = c.call(ms2000::where("XYZ"));
    EXPECT_FALSE(ec) << ec.message();
    std::map<char, double> truth;
    for (std::size_t i = 0; i < 3; ++i)
        truth["XYZ"[i]] = where.number(i).value_or(NAN);
    return truth;
}

TEST_F(controller_resync_test, a_late_reply_is_never_taken_for_a_later_commands_answer) {
    auto c = make("full", 10, 0ms, tight_timeouts);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    const auto truth = park_at_distinct_positions(c);

    // X's reply comes 3 s late: after W X, W Y and more have timed out or been sent.
    c.sim->delay_next_reply(3000ms);
    EXPECT_EQ(c.call(ms2000::where("X")).first, ms2000::error::timeout);
    const auto until = std::chrono::steady_clock::now() + 5s;
    int answered = 0;
    for (int i = 0; std::chrono::steady_clock::now() < until; ++i) {
        const char axis = "YZX"[i % 3];
        const auto [ec, reply] = c.call(ms2000::where(std::string(1, axis)));
        if (ec) continue;  // timeouts and refusals are fine; a wrong answer is not
        ++answered;
        ASSERT_EQ(reply.values.size(), 1u);
        EXPECT_DOUBLE_EQ(reply.number(0).value(), truth.at(axis)) << "W " << axis << " got " << reply.raw;
        const auto [vec, version] = c.call(ms2000::version());
        if (!vec) {
            EXPECT_TRUE(ms2000::parse_version(version).has_value()) << version.raw;
        }
    }
    EXPECT_GT(answered, 3);
}

TEST_F(controller_resync_test, polls_never_put_another_commands_value_into_the_snapshot) {
    auto c = make("full", 10, 20ms, tight_timeouts);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    const auto truth = park_at_distinct_positions(c);
    const auto first = c.observer->locked([&] { return c.observer->snapshots.size(); });

    // Faults on whatever reply comes next, mostly the poll's W X Y Z, / and RS.
    for (int round = 0; round < 12; ++round) {
        switch (round % 4) {
            case 0:
                c.sim->delay_next_reply(900ms);
                break;
            case 1:
                c.sim->echo_next_reply();
                break;
            case 2:
                c.sim->high_bit_next_reply();
                break;
            case 3:
                c.sim->split_next_reply(700ms);
                break;
        }
        std::this_thread::sleep_for(400ms);
    }
    std::this_thread::sleep_for(1500ms);
    const auto snapshots = c.observer->locked([&] { return c.observer->snapshots; });
    for (std::size_t i = first; i < snapshots.size(); ++i) {
        for (const auto& a : snapshots[i].axes) {
            if (!a.position_um) continue;
            EXPECT_NEAR(*a.position_um, truth.at(a.axis) / 10.0, 0.01)
                << "axis " << a.axis << " snapshot " << i;
        }
    }
    const auto faults = c.observer->locked([&] { return c.observer->faults; });
    EXPECT_GT(std::count(faults.begin(), faults.end(), link_fault::kind::resynced), 0);
    EXPECT_EQ(c.observer->latest().state, connection_state::connected);
}

TEST_F(controller_resync_test, a_split_reply_within_the_deadline_is_its_commands_answer) {
    auto c = make("full", 10, 0ms);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    const auto truth = park_at_distinct_positions(c);
    c.sim->split_next_reply(300ms);
    const auto [ec, reply] = c.call(ms2000::where("XYZ"));
    ASSERT_FALSE(ec) << ec.message();
    EXPECT_DOUBLE_EQ(reply.number(2).value(), truth.at('Z'));
}

TEST_F(controller_resync_test, an_echoed_reply_is_drained_not_handed_to_the_next_command) {
    auto c = make("full", 10, 0ms, tight_timeouts);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    const auto truth = park_at_distinct_positions(c);
    c.sim->echo_next_reply();
    const auto [ec, x] = c.call(ms2000::where("X"));
    ASSERT_FALSE(ec) << ec.message();
    EXPECT_DOUBLE_EQ(x.number(0).value(), truth.at('X'));
    for (int i = 0; i < 5; ++i) {
        const auto [ecy, y] = c.call(ms2000::where("Y"));
        if (ecy) continue;
        EXPECT_DOUBLE_EQ(y.number(0).value(), truth.at('Y')) << y.raw;
    }
}

TEST_F(controller_resync_test, noise_with_high_bytes_leaves_only_ascii_in_replies_and_snapshots) {
    auto c = make("full", 10, 20ms, tight_timeouts);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    for (int round = 0; round < 5; ++round) {
        c.sim->emit_garbage(500);
        for (const char* line : {"BU", "WHO", "BU X", "V"}) {
            const auto [ec, reply] = c.call(ms2000::raw_command(line).value());
            EXPECT_TRUE(ms2000::is_reply_text(reply.raw)) << line << ": " << reply.raw;
            for (const auto& l : reply.lines)
                EXPECT_TRUE(ms2000::is_reply_text(l));
            for (const auto& v : reply.values)
                EXPECT_TRUE(ms2000::is_reply_text(v));
        }
    }
    // It comes back to a proven, working link with its identity intact.
    test::command_result result;
    for (int i = 0; i < 50; ++i) {
        result = c.call(ms2000::where("XYZ"));
        if (!result.first) break;
        std::this_thread::sleep_for(50ms);
    }
    ASSERT_FALSE(result.first) << result.first.message();
    EXPECT_EQ(result.second.values.size(), 3u);
    const auto snapshots = c.observer->locked([&] { return c.observer->snapshots; });
    for (const auto& s : snapshots) {
        if (!s.identity) continue;
        EXPECT_TRUE(ms2000::is_reply_text(s.identity->version_raw));
        EXPECT_TRUE(ms2000::is_reply_text(s.identity->build.name));
        if (s.state == connection_state::connected) {
            EXPECT_EQ(s.identity->build.motor_axes, "XYZ");
        }
        if (s.last_error) {
            EXPECT_TRUE(ms2000::is_reply_text(s.last_error->text));
        }
    }
}

}  // namespace
}  // namespace gw::devices
