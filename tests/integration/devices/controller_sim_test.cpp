// The serial driver against the in-process simulator: a real pty, the simulated firmware behind it.
#include <algorithm>
#include <cmath>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "devices/ms2000/error.hpp"
#include "devices/ms2000/error_log.hpp"
#include "devices/serial/controller.hpp"
#include "devices/sim/sim_config.hpp"
#include "devices/sim/simulator.hpp"
#include "tests/support/drv_sim_fixture.hpp"

namespace gw::devices {
namespace {

namespace net = boost::asio;
using namespace std::chrono_literals;
using boost::system::error_code;
using result_pair = test::command_result;

using controller_sim_test = test::drv_sim_fixture;

TEST_F(controller_sim_test, identifies_a_full_and_a_plain_controller) {
    auto full = make("full");
    auto plain = make("plain");
    ASSERT_TRUE(full.observer->wait_state(connection_state::connected));
    ASSERT_TRUE(plain.observer->wait_state(connection_state::connected));

    const auto f = full.observer->latest();
    ASSERT_TRUE(f.identity);
    EXPECT_EQ(f.identity->version, full.sim->config().version);
    EXPECT_EQ(f.identity->build.name, "STD_XYZ_SCAN");
    EXPECT_EQ(f.identity->build.motor_axes, "XYZ");
    EXPECT_TRUE(f.identity->build.has(ms2000::module::ttl_report));
    EXPECT_TRUE(f.identity->build.has(ms2000::module::ring_buffer));
    ASSERT_EQ(f.axes.size(), 3u);
    const auto screw = sim::lead_screw_for(full.sim->config().lead_screw).value();
    ASSERT_TRUE(f.axes[0].counts_per_mm);
    EXPECT_NEAR(*f.axes[0].counts_per_mm, screw.counts_per_mm, 0.01);
    EXPECT_TRUE(f.axes[2].upper_limit_mm.has_value());
    EXPECT_TRUE(f.ttl_in0_mode.has_value());
    EXPECT_EQ(f.report, report_port_state::open);

    const auto p = plain.observer->latest();
    ASSERT_TRUE(p.identity);
    EXPECT_EQ(p.identity->build.name, "STD_XYZ");
    EXPECT_FALSE(p.identity->build.has(ms2000::module::ttl_report));
    EXPECT_FALSE(p.identity->build.has(ms2000::module::ring_buffer));
    EXPECT_EQ(p.report, report_port_state::none);
}

TEST_F(controller_sim_test, a_move_shows_in_snapshots_until_arrival) {
    auto c = make("plain", 4);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    ASSERT_TRUE(
        c.observer->wait([&] { return c.observer->snapshots.back().axes.at(0).position_um.has_value(); }));
    const double start_um = *c.observer->latest().axes[0].position_um;
    const double target_um = start_um + 20000;  // 20 mm: a few seconds of simulated travel

    auto move = ms2000::move(std::vector<ms2000::axis_position>{{'X', target_um}}).value();
    auto [ec, reply] = c.call(move);
    ASSERT_FALSE(ec) << ec.message();

    // Busy with X busy, somewhere between start and target, then idle at the target.
    EXPECT_TRUE(c.observer->wait([&] {
        const auto& s = c.observer->snapshots.back();
        return s.busy && s.axes[0].busy;
    }));
    EXPECT_TRUE(c.observer->wait([&] {
        const auto& x = c.observer->snapshots.back().axes[0];
        return x.position_um && *x.position_um > start_um + 1 && *x.position_um < target_um - 1;
    }));
    ASSERT_TRUE(c.observer->wait(
        [&] {
            const auto& s = c.observer->snapshots.back();
            return !s.busy && s.axes[0].position_um && std::abs(*s.axes[0].position_um - target_um) < 1.0;
        },
        60s));
    EXPECT_FALSE(c.observer->latest().axes[0].busy);

    // The snapshot that first says the move ended already says where: the target.
    const auto ended = c.observer->locked([&]() -> std::optional<controller_snapshot> {
        const auto& all = c.observer->snapshots;
        for (std::size_t i = 1; i < all.size(); ++i)
            if (all[i - 1].busy && !all[i].busy) return all[i];
        return std::nullopt;
    });
    ASSERT_TRUE(ended);
    ASSERT_TRUE(ended->axes[0].position_um);
    EXPECT_NEAR(*ended->axes[0].position_um, target_um, 1.0);

    // Each snapshot says when its positions were read: new positions come with a newer time, a change
    // of the busy flags alone keeps the time of the positions it carries.
    const auto snapshots = c.observer->locked([&] { return c.observer->snapshots; });
    for (std::size_t i = 1; i < snapshots.size(); ++i) {
        const auto& before = snapshots[i - 1];
        const auto& now = snapshots[i];
        if (now.state != connection_state::connected || before.state != connection_state::connected) continue;
        EXPECT_LE(now.positions_read, now.updated) << "snapshot " << i;
        const bool moved = !std::equal(
            now.axes.begin(), now.axes.end(), before.axes.begin(), before.axes.end(),
            [](const axis_state& a, const axis_state& b) { return a.position_um == b.position_um; });
        if (moved)
            EXPECT_GT(now.positions_read, before.positions_read) << "snapshot " << i;
        else
            EXPECT_GE(now.positions_read, before.positions_read) << "snapshot " << i;
    }
}

// A round that read the positions and then saw the stage stop would show it idle where it still
// moved. Back-to-back rounds (1 ms ticks) make the stop fall inside a round most of the time.
TEST_F(controller_sim_test, a_stopped_move_is_shown_idle_only_with_the_position_it_stopped_at) {
    auto c = make("plain", 4, 1ms);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    ASSERT_TRUE(
        c.observer->wait([&] { return c.observer->snapshots.back().axes.at(0).position_um.has_value(); }));
    const auto simulated_x_um = [&] {
        // The simulator speaks the controller's units: tenths of a micrometre.
        return nlohmann::json::parse(c.sim->state_json())["axes"]["X"]["position"].get<double>() / 10.0;
    };
    // Under the observer's lock: inside wait(), or through locked().
    const auto first_idle_after = [&](std::size_t from) -> std::optional<controller_snapshot> {
        const auto& all = c.observer->snapshots;
        for (std::size_t i = std::max<std::size_t>(from, 1); i < all.size(); ++i)
            if (all[i - 1].busy && !all[i].busy) return all[i];
        return std::nullopt;
    };
    for (int round = 0; round < 8; ++round) {
        SCOPED_TRACE("round " + std::to_string(round));
        // A short move that ends by itself.
        double start_um = *c.observer->latest().axes[0].position_um;
        std::size_t from = c.observer->locked([&] { return c.observer->snapshots.size(); });
        const double target_um = start_um + 500 + 100 * round;
        ASSERT_FALSE(
            c.call(ms2000::move(std::vector<ms2000::axis_position>{{'X', target_um}}).value()).first);
        ASSERT_TRUE(c.observer->wait([&] { return first_idle_after(from).has_value(); }, 20s));
        auto ended = c.observer->locked([&] { return first_idle_after(from); });
        ASSERT_TRUE(ended->axes[0].position_um);
        EXPECT_NEAR(*ended->axes[0].position_um, target_um, 1.0) << "shown idle before it arrived";

        // A long move, halted on the way.
        start_um = target_um;
        from = c.observer->locked([&] { return c.observer->snapshots.size(); });
        const double far_um = start_um + 50000;
        ASSERT_FALSE(c.call(ms2000::move(std::vector<ms2000::axis_position>{{'X', far_um}}).value()).first);
        ASSERT_TRUE(c.observer->wait([&] {
            const auto& x = c.observer->snapshots.back().axes[0];
            return x.position_um && *x.position_um > start_um + 200 + 150 * round;
        }));
        // Waiting on a snapshot lines the HALT up with the poll round; a varying pause does not.
        std::this_thread::sleep_for(std::chrono::microseconds(900 * round));
        c.call(ms2000::halt());  // answered :A or :N-21; either way the stage stops
        ASSERT_TRUE(c.observer->wait([&] { return first_idle_after(from).has_value(); }, 20s));
        ended = c.observer->locked([&] { return first_idle_after(from); });
        const double stopped_um = simulated_x_um();
        EXPECT_LT(stopped_um, far_um - 1000) << "the halt did not stop the move";
        ASSERT_TRUE(ended->axes[0].position_um);
        EXPECT_NEAR(*ended->axes[0].position_um, stopped_um, 1.0) << "shown idle before it stopped";
    }
}

// A job's run sends guarded commands (async_guarded_command): none may reach the controller after a
// HALT its caller did not see, whether it was submitted after the HALT or waited in the queue before it.
TEST_F(controller_sim_test, a_guarded_command_never_follows_a_halt_its_caller_did_not_see) {
    auto c = make("plain", 4);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    const auto simulated_x_um = [&] {
        return nlohmann::json::parse(c.sim->state_json())["axes"]["X"]["position"].get<double>() / 10.0;
    };
    const auto guarded = [&](ms2000::command cmd, std::uint64_t seen) {
        auto promise = std::make_shared<std::promise<result_pair>>();
        auto future = promise->get_future();
        c.ctl->async_guarded_command(std::move(cmd), "job", seen, [promise](error_code ec, ms2000::reply r) {
            promise->set_value({ec, std::move(r)});
        });
        return future;
    };
    const auto move_to = [](double um) {
        return ms2000::move(std::vector<ms2000::axis_position>{{'X', um}}).value();
    };

    const auto seen = c.ctl->halts_accepted();
    auto [ec, reply] = test::await_command(guarded(ms2000::where("X"), seen), 30s);
    EXPECT_FALSE(ec) << "no HALT since: the guarded command goes through";

    // Queued behind a slow one (WHERE in flight), then a HALT: the queued moves are dropped. The next
    // reply is held back 300 ms, so that the moves are still queued when the HALT comes, however slowly
    // this thread runs (a loaded machine once let both moves reach the wire first). Whatever takes the
    // held reply (the WHERE or a poll before it), the link stays busy until the HALT is submitted.
    const double start_um = simulated_x_um();
    c.sim->delay_next_reply(300ms);
    auto first = guarded(ms2000::where("X"), seen);
    auto second = guarded(move_to(start_um + 30000), seen);
    auto third = guarded(move_to(start_um + 40000), seen);
    auto halt = c.submit(ms2000::halt());
    EXPECT_EQ(test::await_command(std::move(second), 30s).first, ms2000::error::halted);
    EXPECT_EQ(test::await_command(std::move(third), 30s).first, ms2000::error::halted);
    EXPECT_FALSE(test::await_command(std::move(halt), 30s).first);
    test::await_command(std::move(first), 30s);  // in flight before the HALT: answered either way
    EXPECT_EQ(c.ctl->halts_accepted(), seen + 1);

    // After the HALT, with the count read before it: refused before the wire. With a fresh count: sent.
    EXPECT_EQ(test::await_command(guarded(move_to(start_um + 50000), seen), 30s).first,
              ms2000::error::halted);
    std::this_thread::sleep_for(300ms);
    EXPECT_LT(std::abs(simulated_x_um() - start_um), 1.0) << "a move refused by its guard moved the stage";
    EXPECT_FALSE(test::await_command(guarded(move_to(start_um + 100), c.ctl->halts_accepted()), 30s).first);
    ASSERT_TRUE(c.observer->wait([&] { return std::abs(simulated_x_um() - (start_um + 100)) < 1.0; }, 20s));
}

TEST_F(controller_sim_test, polls_rest_while_the_stage_is_idle_and_clients_only_read) {
    // An idle interval longer than the test: only a command that may move the stage starts a round.
    auto c =
        make("plain", 4, 20ms, [](controller_settings& s) { s.idle_poll_interval = std::chrono::hours(1); });
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    ASSERT_TRUE(
        c.observer->wait([&] { return c.observer->snapshots.back().axes.at(0).position_um.has_value(); }));
    ASSERT_TRUE(c.observer->wait([&] { return !c.observer->snapshots.back().busy; }));
    std::this_thread::sleep_for(100ms);  // a round that was running has ended
    const auto idle_read = c.observer->latest().positions_read;

    // Reads only: no poll round for as long as they go on.
    for (int i = 0; i < 20; ++i) {
        auto [ec, reply] = c.call(ms2000::where("X"));
        ASSERT_FALSE(ec) << ec.message();
        std::this_thread::sleep_for(20ms);
    }
    EXPECT_EQ(c.observer->latest().positions_read, idle_read) << "a poll round ran while idle";

    // A move brings the rounds back: the snapshots follow it to the target.
    const double start_um = *c.observer->latest().axes[0].position_um;
    auto move = ms2000::move(std::vector<ms2000::axis_position>{{'X', start_um + 5000}}).value();
    ASSERT_FALSE(c.call(move).first);
    EXPECT_TRUE(c.observer->wait([&] { return c.observer->snapshots.back().busy; }));
    ASSERT_TRUE(c.observer->wait(
        [&] {
            const auto& s = c.observer->snapshots.back();
            return !s.busy && s.axes[0].position_um &&
                   std::abs(*s.axes[0].position_um - (start_um + 5000)) < 1.0;
        },
        60s));
    EXPECT_GT(c.observer->latest().positions_read, idle_read);
}

// The poll rounds (their first command, "/") seen while `client` runs: the times between them.
template <typename Client>
std::vector<std::chrono::milliseconds> round_spacing_while(test::drv_recording_observer& o, Client client) {
    const auto first = o.locked([&] { return o.traces.size(); });
    client();
    std::vector<std::chrono::steady_clock::time_point> rounds;
    o.locked([&] {
        for (std::size_t i = first; i < o.traces.size(); ++i)
            if (o.traces[i].request_id == "poll" && o.traces[i].wire.starts_with("/"))
                rounds.push_back(o.trace_times[i]);
    });
    std::vector<std::chrono::milliseconds> spacing;
    for (std::size_t i = 1; i < rounds.size(); ++i)
        spacing.push_back(std::chrono::duration_cast<std::chrono::milliseconds>(rounds[i] - rounds[i - 1]));
    return spacing;
}

TEST_F(controller_sim_test, idle_rounds_yield_to_a_client_in_a_loop_but_at_most_twice_the_idle_interval) {
    // Every answer counts as a busy client here (a pause of 10 s): idle rounds then come only at the
    // limit, twice the idle interval apart, however the loop's own timing goes.
    auto c = make("plain", 4, 10ms, [](controller_settings& s) {
        s.idle_poll_interval = 150ms;
        s.client_pause = 10s;
    });
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    ASSERT_TRUE(c.observer->wait([&] { return !c.observer->snapshots.back().busy; }));
    std::this_thread::sleep_for(200ms);
    const auto spacing = round_spacing_while(*c.observer, [&] {
        const auto end = std::chrono::steady_clock::now() + 1600ms;
        while (std::chrono::steady_clock::now() < end)
            ASSERT_FALSE(c.call(ms2000::where("X")).first);
    });
    ASSERT_GE(spacing.size(), 2u) << "the snapshot went stale while the client read";
    for (const auto gap : spacing)
        EXPECT_GE(gap, 300ms - 30ms) << "an idle round went between a client's commands";
}

TEST_F(controller_sim_test, idle_rounds_keep_their_pace_when_a_client_pauses_between_commands) {
    auto c = make("plain", 4, 10ms, [](controller_settings& s) { s.idle_poll_interval = 150ms; });
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    ASSERT_TRUE(c.observer->wait([&] { return !c.observer->snapshots.back().busy; }));
    std::this_thread::sleep_for(200ms);
    // 30 ms between commands is longer than the default client pause (5 ms): rounds every 150 ms.
    const auto spacing = round_spacing_while(*c.observer, [&] {
        const auto end = std::chrono::steady_clock::now() + 1500ms;
        while (std::chrono::steady_clock::now() < end) {
            ASSERT_FALSE(c.call(ms2000::where("X")).first);
            std::this_thread::sleep_for(30ms);
        }
    });
    EXPECT_GE(spacing.size(), 6u) << "rounds waited for a client that was pausing";
}

TEST_F(controller_sim_test, unplug_fails_commands_then_replug_reconnects_and_reidentifies) {
    auto c = make("plain", 4);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    auto move = ms2000::move(std::vector<ms2000::axis_position>{{'X', 30000}}).value();
    ASSERT_FALSE(c.call(move).first);

    // A command in flight when the cable goes.
    c.sim->delay_next_reply(3000ms);
    auto in_flight = c.submit(ms2000::where("XYZ"));
    std::this_thread::sleep_for(100ms);  // let it reach the wire (not an assertion)
    const auto unplugged_at = std::chrono::steady_clock::now();
    c.sim->unplug();
    ASSERT_EQ(in_flight.wait_for(30s), std::future_status::ready);
    const auto failed_after = std::chrono::steady_clock::now() - unplugged_at;
    const auto ec = in_flight.get().first;
    EXPECT_TRUE(ec == ms2000::error::disconnected) << ec.message();
    EXPECT_TRUE(c.observer->wait_state(connection_state::disconnected));
    // Detection is meant to take well under a second; the bound here is loose for a loaded machine.
    EXPECT_LT(failed_after, 5s);
    const auto later = c.call(ms2000::where("XYZ")).first;
    EXPECT_TRUE(later == ms2000::error::not_connected || later == ms2000::error::disconnected)
        << later.message();

    c.sim->replug();
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected, 30s));
    EXPECT_TRUE(c.observer->latest().identity.has_value());
    auto [ec2, reply] = c.call(ms2000::where("XYZ"));
    EXPECT_FALSE(ec2) << ec2.message();
    EXPECT_EQ(reply.values.size(), 3u);
}

TEST_F(controller_sim_test, a_report_train_yields_one_event_per_pulse) {
    auto c = make("full", 10);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    ASSERT_EQ(c.observer->latest().report, report_port_state::open);

    auto move = ms2000::move(std::vector<ms2000::axis_position>{{'X', 1000}, {'Y', -500}}).value();
    ASSERT_FALSE(c.call(move).first);
    ASSERT_TRUE(c.observer->wait(
        [&] {
            const auto& s = c.observer->snapshots.back();
            return !s.busy && s.axes[0].position_um && std::abs(*s.axes[0].position_um - 1000) < 1.0;
        },
        20s));

    const ms2000::argument ttl_on{'X', ms2000::argument::op::set, 1};
    ASSERT_FALSE(c.call(ms2000::make_command("TTL", std::span(&ttl_on, 1)).value()).first);

    constexpr std::size_t pulses = 25;
    // 5 Hz of simulated time is 50 Hz real at time_scale 10: far from the frame time (about 1.4 ms at
    // 115200 baud, paced in real time), so no trigger meets a frame still going out (error 87).
    c.sim->ttl_pulse_train(pulses, 5);
    ASSERT_TRUE(c.observer->wait([&] { return c.observer->reports.size() >= pulses; }, 60s))
        << "reports: " << c.observer->locked([&] { return c.observer->reports.size(); })
        << ", simulator: " << c.sim->state_json();
    std::this_thread::sleep_for(200ms);  // a stray extra frame would show up here (not an assertion)
    const auto reports = c.observer->locked([&] { return c.observer->reports; });
    EXPECT_EQ(reports.size(), pulses);
    for (std::size_t i = 0; i < reports.size(); ++i) {
        EXPECT_EQ(reports[i].sequence, i + 1);
        ASSERT_EQ(reports[i].axes.size(), 3u);
        ASSERT_TRUE(reports[i].axes[0].position_um);
        EXPECT_NEAR(*reports[i].axes[0].position_um, 1000, 1.0);
        EXPECT_NEAR(*reports[i].axes[1].position_um, -500, 1.0);
        if (i > 0) {
            EXPECT_GE(reports[i].steady_time, reports[i - 1].steady_time);
        }
    }
    EXPECT_EQ(reports.back().bytes_skipped, 0u);
}

TEST_F(controller_sim_test, recovers_from_dropped_corrupted_and_noisy_replies) {
    auto c = make("plain", 10, 0ms);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));

    c.sim->drop_next_reply();
    EXPECT_EQ(c.call(ms2000::where("XYZ")).first, ms2000::error::timeout);
    auto [ec, reply] = c.call(ms2000::where("XYZ"));
    EXPECT_FALSE(ec) << ec.message();
    EXPECT_EQ(reply.values.size(), 3u);

    c.sim->corrupt_next_reply();
    EXPECT_TRUE(c.call(ms2000::status()).first);  // whatever the corruption made of it, not success
    EXPECT_FALSE(c.call(ms2000::status()).first);

    // Noise while idle (no CR or LF, so it would prefix the next reply if it were not discarded).
    // The simulator counts it when queued and paces it out at the baud rate; noise that races a
    // command on the wire cannot be told apart from the reply, so one failed command is tolerated.
    const auto bytes_out = [&] {
        return nlohmann::json::parse(c.sim->state_json())["port"]["bytes_out"].get<long>();
    };
    const auto before = bytes_out();
    c.sim->emit_garbage(64);
    for (int i = 0; i < 1000 && bytes_out() < before + 64; ++i)
        std::this_thread::sleep_for(5ms);
    ASSERT_GE(bytes_out(), before + 64);
    std::this_thread::sleep_for(50ms);  // about ten times the 64 bytes' time on the wire
    auto [ec2, reply2] = c.call(ms2000::where("XYZ"));
    if (ec2) {
        EXPECT_EQ(ec2, ms2000::error::unrecognized_reply);
        std::tie(ec2, reply2) = c.call(ms2000::where("XYZ"));
    }
    EXPECT_FALSE(ec2) << ec2.message();
    EXPECT_EQ(reply2.values.size(), 3u);
}

TEST_F(controller_sim_test, a_replugged_controller_is_connected_again_without_waiting_out_the_backoff) {
    // A backoff far longer than the test: only watching for the device node can reconnect in time.
    auto c = make("plain", 10, 20ms, [](controller_settings& s) {
        s.reconnect_min = 60s;
        s.reconnect_max = 60s;
        s.presence_check = 100ms;
    });
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    for (int cycle = 0; cycle < 3; ++cycle) {
        c.sim->unplug();
        ASSERT_TRUE(c.observer->wait_state(connection_state::disconnected));
        std::this_thread::sleep_for(300ms);  // unplugged for a while (not an assertion)
        c.sim->replug();
        ASSERT_TRUE(c.observer->wait_state(connection_state::connected, 20s)) << "cycle " << cycle;
    }
}

TEST_F(controller_sim_test, an_unplugged_controller_does_not_stop_the_other) {
    auto a = make("plain", 10);
    auto b = make("plain", 10);
    ASSERT_TRUE(a.observer->wait_state(connection_state::connected));
    ASSERT_TRUE(b.observer->wait_state(connection_state::connected));

    a.sim->unplug();
    ASSERT_TRUE(a.observer->wait_state(connection_state::disconnected));
    for (int i = 0; i < 20; ++i) {
        auto [ec, reply] = b.call(ms2000::where("XYZ"));
        ASSERT_FALSE(ec) << ec.message();
    }
    EXPECT_EQ(b.observer->latest().state, connection_state::connected);
    // A keeps trying in the background and comes back when replugged.
    a.sim->replug();
    EXPECT_TRUE(a.observer->wait_state(connection_state::connected, 30s));
}

}  // namespace
}  // namespace gw::devices

namespace gw::devices {
namespace {

// Every code the error-log events carried, in order.
std::vector<int> logged_codes(test::drv_recording_observer& o) {
    return o.locked([&] {
        std::vector<int> codes;
        for (const auto& e : o.error_logs)
            codes.insert(codes.end(), e.codes.begin(), e.codes.end());
        return codes;
    });
}

using controller_error_log_test = test::drv_sim_fixture;

TEST_F(controller_error_log_test, a_move_clamped_at_a_soft_limit_comes_as_its_code_once) {
    auto c = make("plain", 20);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    EXPECT_TRUE(logged_codes(*c.observer).empty());  // read at identification: nothing logged yet

    // Beyond the lower soft limit (-110 mm): clamped and answered :A, logged as 35.
    auto below = ms2000::move(std::vector<ms2000::axis_position>{{'X', -2'000'000}}).value();
    ASSERT_FALSE(c.call(below).first);
    ASSERT_TRUE(c.observer->wait([&] { return !c.observer->error_logs.empty(); }, 60s))
        << "simulator: " << c.sim->state_json();
    EXPECT_EQ(logged_codes(*c.observer), std::vector<int>{35});
    ASSERT_TRUE(c.observer->wait([&] { return c.observer->snapshots.back().error_log_count == 1; }));
    EXPECT_EQ(c.observer->latest().error_log_recent, std::vector<int>{35});

    // Read while idle and quiet, so cleared: the next code is reported alone, 35 not again.
    ASSERT_TRUE(
        c.observer->wait([&] { return nlohmann::json::parse(c.sim->state_json())["errors"].empty(); }, 20s))
        << "the driver did not clear the log: " << c.sim->state_json();
    auto above = ms2000::move(std::vector<ms2000::axis_position>{{'Y', 2'000'000}}).value();
    ASSERT_FALSE(c.call(above).first);
    ASSERT_TRUE(c.observer->wait([&] { return c.observer->error_logs.size() >= 2; }, 60s));
    std::this_thread::sleep_for(300ms);  // a repeated 35 would show up here
    EXPECT_EQ(logged_codes(*c.observer), (std::vector<int>{35, 34}));
    EXPECT_EQ(c.observer->latest().error_log_count, 2u);
}

TEST_F(controller_error_log_test, report_frames_lost_in_the_controller_come_as_87_one_per_frame) {
    // Real time: the pulses' simulated times and the frames' pacing on the pty agree.
    auto c = make("full", 1);
    ASSERT_TRUE(c.observer->wait_state(connection_state::connected));
    ASSERT_EQ(c.observer->latest().report, report_port_state::open);
    const ms2000::argument ttl_on{'X', ms2000::argument::op::set, 1};
    ASSERT_FALSE(c.call(ms2000::make_command("TTL", std::span(&ttl_on, 1)).value()).first);

    // A frame takes about 1.6 ms to go out at 115200 baud; triggers every 0.5 ms meet most of them
    // still going out, and the controller drops those (seed 003).
    constexpr std::size_t pulses = 40;
    c.sim->ttl_pulse_train(pulses, 2000);
    const auto sim_state = [&] { return nlohmann::json::parse(c.sim->state_json()); };
    ASSERT_TRUE(c.observer->wait(
        [&] {
            const auto s = sim_state();
            return s["reports_sent"].get<std::size_t>() + s["reports_dropped"].get<std::size_t>() == pulses;
        },
        20s))
        << sim_state().dump();
    const auto s = sim_state();
    const auto sent = s["reports_sent"].get<std::size_t>();
    const auto dropped = s["reports_dropped"].get<std::size_t>();
    ASSERT_GT(dropped, 0u) << "the train was not faster than the report port";
    ASSERT_GT(sent, 0u);

    // Read once the stream is quiet: one 87 per frame the controller dropped, every other frame here.
    ASSERT_TRUE(c.observer->wait(
        [&] {
            std::size_t n = 0;
            for (const auto& e : c.observer->error_logs)
                n += std::count(e.codes.begin(), e.codes.end(), ms2000::ttl_report_buffer_overrun);
            return n >= dropped;
        },
        20s))
        << "codes: " << ::testing::PrintToString(logged_codes(*c.observer)) << ", simulator: " << s.dump();
    std::this_thread::sleep_for(300ms);  // one 87 too many would show up here
    const auto codes = logged_codes(*c.observer);
    EXPECT_EQ(
        static_cast<std::size_t>(std::count(codes.begin(), codes.end(), ms2000::ttl_report_buffer_overrun)),
        dropped);
    EXPECT_EQ(c.observer->locked([&] { return c.observer->reports.size(); }), sent);
}

}  // namespace
}  // namespace gw::devices
