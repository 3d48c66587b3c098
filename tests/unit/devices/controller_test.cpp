#include "devices/serial/controller.hpp"

#include <atomic>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <boost/asio/use_future.hpp>
#include <gtest/gtest.h>

#include "devices/ms2000/error.hpp"
#include "devices/ms2000/report_frame.hpp"
#include "tests/support/drv_command_call.hpp"
#include "tests/support/drv_pty_controller.hpp"
#include "tests/support/drv_recording_observer.hpp"

namespace gw::devices {
namespace {

namespace net = boost::asio;
using namespace std::chrono_literals;
using boost::system::error_code;
using result_pair = test::command_result;

class controller_test : public ::testing::Test {
  protected:
    controller_settings settings() const {
        controller_settings s;
        s.id = "unit";
        s.port = fake_.link();
        s.baud = 115200;
        s.poll_interval = 0ms;  // tests that want polling turn it on
        s.command_timeout = 2000ms;
        s.queue_limit = 256;
        s.reconnect_min = 20ms;
        s.reconnect_max = 200ms;
        s.presence_check = 50ms;
        return s;
    }

    void start(const controller_settings& s, int threads = 1) {
        ctl_ = std::make_shared<controller>(io_.get_executor(), s, observer_);
        for (int i = 0; i < threads; ++i)
            threads_.emplace_back([this] { io_.run(); });
        ctl_->start();
        ASSERT_TRUE(observer_->wait_state(connection_state::connected)) << "not identified";
    }

    // The probe and the identification, its last step the error log read.
    static constexpr std::size_t identification_commands = 7;

    void TearDown() override {
        if (ctl_) {
            ctl_->stop();
            EXPECT_TRUE(observer_->wait_state(connection_state::stopped));
        }
        work_.reset();
        for (auto& t : threads_)
            t.join();
    }

    // Submits and returns a future of (error, reply); the callback runs on the controller's strand.
    std::future<result_pair> submit(ms2000::command cmd, std::string id = "test") {
        return test::submit_command(*ctl_, std::move(cmd), std::move(id));
    }

    result_pair call(ms2000::command cmd) { return test::await_command(submit(std::move(cmd)), 20s); }

    net::io_context io_;
    net::executor_work_guard<net::io_context::executor_type> work_ = net::make_work_guard(io_);
    std::vector<std::thread> threads_;
    test::drv_pty_controller fake_;
    std::shared_ptr<test::drv_recording_observer> observer_ =
        std::make_shared<test::drv_recording_observer>();
    std::shared_ptr<controller> ctl_;
};

TEST_F(controller_test, identifies_the_controller_on_connect) {
    start(settings());
    const auto s = observer_->latest();
    ASSERT_TRUE(s.identity.has_value());
    EXPECT_EQ(s.identity->version, "9.50");
    EXPECT_EQ(s.identity->build.name, "STD_XY");
    EXPECT_TRUE(s.identity->build.has(ms2000::module::ring_buffer));
    ASSERT_EQ(s.axes.size(), 2u);
    EXPECT_EQ(s.axes[0].axis, 'X');
    EXPECT_EQ(s.axes[1].counts_per_mm, 20000.0);
    EXPECT_EQ(s.axes[0].lower_limit_mm, -50.0);
    EXPECT_EQ(s.axes[1].upper_limit_mm, 25.0);
    EXPECT_EQ(s.ttl_in0_mode, 0);
    EXPECT_EQ(s.ttl_out0_mode, 2);
    EXPECT_EQ(s.axes[0].speed_mm_s, 5.5);
    EXPECT_EQ(s.axes[1].ramp_ms, 20.0);
    EXPECT_EQ(s.axes[0].finish_error_mm, 0.000022);
    EXPECT_DOUBLE_EQ(s.axes[0].finish_error_printed_step_mm, 0.0000005);
    EXPECT_EQ(s.axes[1].backlash_mm, 0.04);
    EXPECT_EQ(s.axes[1].overshoot_mm, 0.0);
    // The resynchronisation probe that proves a fresh port in step, then the identification.
    const std::vector<std::string> expected{"V",        "V",         "BU X",     "CNTS X? Y?", "SL X? Y?",
                                            "SU X? Y?", "S X? Y?",   "AC X? Y?", "PC X? Y?",   "B X? Y?",
                                            "OS X? Y?", "TTL X? Y?", "DU Y"};
    EXPECT_EQ(fake_.commands(), expected);
}

TEST_F(controller_test, an_error_log_answer_it_cannot_read_is_asked_for_three_times_then_left_alone) {
    // DU Y's reply format is unconfirmed: a firmware that answers in another shape must not cost a
    // resynchronisation every few seconds for ever.
    fake_.set_responder([](const std::string& c) -> std::vector<std::string> {
        if (c == "DU Y") return {":A X=1\r\n"};  // not a list of codes
        return test::drv_pty_controller::default_reply(c);
    });
    auto s = settings();
    s.poll_interval = 20ms;
    s.error_log_interval = 50ms;
    start(s);
    const auto deadline = std::chrono::steady_clock::now() + 20s;
    while (fake_.count("DU Y") < 3 && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(10ms);
    ASSERT_EQ(fake_.count("DU Y"), 3u);
    std::this_thread::sleep_for(600ms);  // a dozen more scheduled reads, were it still asking
    EXPECT_EQ(fake_.count("DU Y"), 3u);
    EXPECT_EQ(observer_->latest().state, connection_state::connected);
    EXPECT_TRUE(call(ms2000::where("XY")).first == error_code{}) << "the link is usable";
}

TEST_F(controller_test, reply_split_over_several_writes_is_reassembled) {
    start(settings());
    fake_.set_responder([](const std::string& c) -> std::vector<std::string> {
        if (c == "W X Y") return {":A 12", "34.5 -6", "7.0 \r", "\n"};
        return test::drv_pty_controller::default_reply(c);
    });
    auto [ec, reply] = call(ms2000::where("XY"));
    ASSERT_FALSE(ec) << ec.message();
    EXPECT_EQ(reply.number(0), 1234.5);
    EXPECT_EQ(reply.number(1), -67.0);
}

TEST_F(controller_test, stale_bytes_before_a_command_are_discarded) {
    start(settings());
    // Complete stale lines and a partial one arrive while nothing is in flight.
    fake_.write_raw(":A 999\r\n:N-3\r\n:A 12");
    auto [ec, reply] = call(test::raw_line("NUM X?"));
    ASSERT_FALSE(ec) << ec.message();
    EXPECT_EQ(reply.raw, ":A");
    fake_.set_responder([](const std::string& c) -> std::vector<std::string> {
        if (c == "NUM X?") return {":A 5\r\n"};
        return test::drv_pty_controller::default_reply(c);  // the resynchronisation probe's V
    });
    fake_.write_raw("junk without end");
    auto [ec2, reply2] = call(test::raw_line("NUM X?"));
    ASSERT_FALSE(ec2) << ec2.message();
    EXPECT_EQ(reply2.raw, ":A 5");
}

TEST_F(controller_test, timeout_fails_the_command_and_the_next_one_succeeds) {
    auto s = settings();
    s.command_timeout = 300ms;
    start(s);
    fake_.set_responder([](const std::string& c) -> std::vector<std::string> {
        if (c == "DROP") return {};
        if (c == "NUM 2") return {":A 2\r\n"};
        return test::drv_pty_controller::default_reply(c);
    });
    // Queued together: the second is written only after the first timed out.
    auto first = submit(test::raw_line("DROP"));
    auto second = submit(test::raw_line("NUM 2"));
    ASSERT_EQ(first.wait_for(20s), std::future_status::ready);
    EXPECT_EQ(first.get().first, ms2000::error::timeout);
    ASSERT_EQ(second.wait_for(20s), std::future_status::ready);
    auto [ec, reply] = second.get();
    ASSERT_FALSE(ec) << ec.message();
    EXPECT_EQ(reply.number(0), 2.0);

    // A late reply to a timed-out command is discarded, not taken for the next command's reply.
    auto third = submit(test::raw_line("DROP"));
    ASSERT_EQ(third.wait_for(20s), std::future_status::ready);
    EXPECT_EQ(third.get().first, ms2000::error::timeout);
    fake_.write_raw(":A 666\r\n");
    auto [ec4, reply4] = call(test::raw_line("NUM 2"));
    ASSERT_FALSE(ec4) << ec4.message();
    EXPECT_EQ(reply4.number(0), 2.0);
    EXPECT_TRUE(observer_->wait([&] {
        return observer_->snapshots.back().last_error &&
               observer_->snapshots.back().last_error->name ==
                   make_error_code(ms2000::error::timeout).message();
    }));
}

TEST_F(controller_test, queue_is_bounded) {
    auto s = settings();
    s.queue_limit = 3;
    // A1 is held on purpose while the queue fills: its deadline must outlast that on a loaded machine
    // (at 2 s it timed out once under ASan, a failure of the test, not of the queue).
    s.command_timeout = 30s;
    start(s);
    fake_.hold();
    auto in_flight = submit(test::raw_line("A1"));
    ASSERT_TRUE(fake_.wait_for_commands(identification_commands + 1));  // and A1: A1 is in flight
    std::vector<std::future<result_pair>> queued;
    for (int i = 0; i < 3; ++i)
        queued.push_back(submit(test::raw_line("Q" + std::to_string(i))));
    auto overflow = submit(test::raw_line("OVER"));
    ASSERT_EQ(overflow.wait_for(20s), std::future_status::ready);
    EXPECT_EQ(overflow.get().first, ms2000::error::queue_full);
    fake_.release();
    EXPECT_FALSE(in_flight.get().first);
    for (auto& f : queued)
        EXPECT_FALSE(f.get().first);
    EXPECT_EQ(fake_.count("OVER"), 0u);
}

TEST_F(controller_test, halt_jumps_the_queue_and_its_minus_21_is_success) {
    start(settings());
    fake_.set_responder([](const std::string& c) -> std::vector<std::string> {
        if (c == "\\") return {":N-21\r\n"};
        return {":A\r\n"};
    });
    fake_.hold();
    auto a = submit(test::raw_line("A1"));
    ASSERT_TRUE(fake_.wait_for_commands(identification_commands + 1));
    auto b = submit(test::raw_line("B1"));
    auto c = submit(test::raw_line("C1"));
    auto halt = submit(ms2000::halt());
    // Make sure all three are queued before the in-flight command completes.
    std::promise<void> queued;
    ctl_->get_snapshot([&](controller_snapshot) { queued.set_value(); });
    queued.get_future().wait();
    fake_.release();

    auto [ec, reply] = halt.get();
    EXPECT_FALSE(ec) << ec.message();
    EXPECT_EQ(reply.what, ms2000::reply::kind::error);
    EXPECT_EQ(reply.error_code, ms2000::halted);
    EXPECT_FALSE(a.get().first);
    EXPECT_FALSE(b.get().first);
    EXPECT_FALSE(c.get().first);
    const auto cmds = fake_.commands();
    const std::vector<std::string> tail(cmds.end() - 4, cmds.end());
    EXPECT_EQ(tail, (std::vector<std::string>{"A1", "\\", "B1", "C1"}));
}

TEST_F(controller_test, controller_error_completes_with_controller_rejected_and_signed_code) {
    start(settings());
    fake_.set_responder([](const std::string&) -> std::vector<std::string> { return {":N-4\r\n"}; });
    auto [ec, reply] = call(test::raw_line("S X=99999"));
    EXPECT_EQ(ec, ms2000::error::controller_rejected);
    EXPECT_EQ(reply.what, ms2000::reply::kind::error);
    EXPECT_EQ(reply.error_code, -4);
    ASSERT_TRUE(observer_->wait([&] {
        const auto& e = observer_->snapshots.back().last_error;
        return e && e->code == -4;
    }));
    EXPECT_EQ(observer_->latest().last_error->name, "parameter_out_of_range");
}

TEST_F(controller_test, halt_minus_21_is_success_but_other_commands_minus_21_are_not) {
    start(settings());
    fake_.set_responder([](const std::string&) -> std::vector<std::string> { return {":N-21\r\n"}; });
    EXPECT_FALSE(call(ms2000::halt()).first);
    EXPECT_EQ(call(test::raw_line("M X=1")).first, ms2000::error::controller_rejected);
}

TEST_F(controller_test, many_concurrent_submissions_from_several_threads_stay_in_order) {
    start(settings(), 2);
    // The fake answers "NUM <n>" with ":A <n>", so every reply says which command it belongs to.
    fake_.set_responder([](const std::string& c) -> std::vector<std::string> {
        if (c.rfind("NUM ", 0) == 0) return {":A " + c.substr(4) + " \r\n"};
        return {":A\r\n"};
    });
    constexpr int submitters = 4;
    constexpr int per_thread = 40;
    std::atomic<int> mismatches{0};
    std::atomic<int> done{0};
    std::vector<std::vector<int>> completion_order(submitters);
    std::mutex order_mu;
    std::promise<void> all_done;
    std::vector<std::thread> threads;
    for (int t = 0; t < submitters; ++t) {
        threads.emplace_back([&, t] {
            for (int i = 0; i < per_thread; ++i) {
                const int n = t * 1000 + i;
                ctl_->async_command(test::raw_line("NUM " + std::to_string(n)), "c",
                                    [&, n, t](error_code ec, ms2000::reply r) {
                                        if (ec || r.number(0) != static_cast<double>(n)) ++mismatches;
                                        {
                                            std::lock_guard lock(order_mu);
                                            completion_order[t].push_back(n);
                                        }
                                        if (++done == submitters * per_thread) all_done.set_value();
                                    });
            }
        });
    }
    for (auto& t : threads)
        t.join();
    ASSERT_EQ(all_done.get_future().wait_for(60s), std::future_status::ready);
    EXPECT_EQ(mismatches.load(), 0);
    // Each thread's commands reached the wire, and completed, in the order it submitted them.
    for (int t = 0; t < submitters; ++t) {
        EXPECT_TRUE(std::is_sorted(completion_order[t].begin(), completion_order[t].end())) << "thread " << t;
        EXPECT_EQ(completion_order[t].size(), static_cast<std::size_t>(per_thread));
    }
    std::vector<int> last(submitters, -1);
    for (const auto& c : fake_.commands()) {
        if (c.rfind("NUM ", 0) != 0) continue;
        const int n = std::stoi(c.substr(4));
        EXPECT_GT(n % 1000, last[n / 1000]);
        last[n / 1000] = n % 1000;
    }
}

TEST_F(controller_test, works_with_use_future_and_use_awaitable) {
    start(settings());
    auto f = ctl_->async_command(ms2000::where("XY"), "future", net::use_future);
    ASSERT_EQ(f.wait_for(20s), std::future_status::ready);
    EXPECT_EQ(f.get().number(0), 100.0);

    std::promise<double> value;
    net::co_spawn(
        io_,
        [&]() -> net::awaitable<void> {
            auto r = co_await ctl_->async_command(ms2000::where("XY"), "coro", net::use_awaitable);
            value.set_value(r.number(1).value_or(0));
        },
        net::detached);
    auto fv = value.get_future();
    ASSERT_EQ(fv.wait_for(20s), std::future_status::ready);
    EXPECT_EQ(fv.get(), -20.0);

    // An error reaches use_future as an exception carrying the error code.
    fake_.set_responder([](const std::string&) -> std::vector<std::string> { return {":N-1\r\n"}; });
    auto bad = ctl_->async_command(test::raw_line("NOPE"), "future", net::use_future);
    try {
        bad.get();
        ADD_FAILURE() << "no exception";
    } catch (const boost::system::system_error& e) {
        EXPECT_EQ(e.code(), ms2000::error::controller_rejected);
    }
}

TEST_F(controller_test, polls_positions_and_busy_state) {
    auto s = settings();
    s.poll_interval = 20ms;
    fake_.set_responder([](const std::string& c) -> std::vector<std::string> {
        if (c == "/") return {"B\r\n"};
        if (c == "RS X?") return {":A B\r\n"};
        if (c == "RS Y?") return {":A N\r\n"};
        return test::drv_pty_controller::default_reply(c);
    });
    start(s);
    ASSERT_TRUE(observer_->wait([&] {
        const auto& snap = observer_->snapshots.back();
        return snap.busy && snap.axes.size() == 2 && snap.axes[0].busy;
    }));
    const auto snap = observer_->latest();
    EXPECT_EQ(snap.axes[0].position_um, 10.0);
    EXPECT_EQ(snap.axes[1].position_um, -2.0);
    EXPECT_FALSE(snap.axes[1].busy);

    fake_.set_responder([](const std::string& c) { return test::drv_pty_controller::default_reply(c); });
    EXPECT_TRUE(observer_->wait([&] { return !observer_->snapshots.back().busy; }));
    EXPECT_FALSE(observer_->latest().axes[0].busy);
}

TEST_F(controller_test, user_command_goes_ahead_of_the_next_poll_step) {
    auto s = settings();
    s.poll_interval = 20ms;
    // The W is held on purpose: it must not time out meanwhile, or the resynchronisation's V would
    // come next (a loaded machine can take seconds between the hold and the release).
    s.command_timeout = 30s;
    start(s);
    ASSERT_TRUE(fake_.wait_for_commands(identification_commands + 1));
    // Catch a W in flight, queue a user command, and check it is written right after the W.
    fake_.hold_on("W X Y");
    ASSERT_TRUE(fake_.wait_deferred(1));
    const std::size_t w_index = fake_.commands().size() - 1;
    ASSERT_GT(w_index, 0u) << "never caught a W in flight";
    auto user = submit(test::raw_line("USER"));
    std::promise<void> queued;
    ctl_->get_snapshot([&](controller_snapshot) { queued.set_value(); });
    queued.get_future().wait();
    fake_.release();
    EXPECT_FALSE(user.get().first);
    const auto cmds = fake_.commands();
    ASSERT_GT(cmds.size(), w_index + 1);
    EXPECT_EQ(cmds[w_index + 1], "USER");
}

TEST_F(controller_test, unplug_fails_commands_with_disconnected_and_replug_reconnects) {
    start(settings());
    fake_.hold();
    auto pending = submit(test::raw_line("LONG"));
    ASSERT_TRUE(fake_.wait_for_commands(identification_commands + 1));
    fake_.unplug();
    ASSERT_EQ(pending.wait_for(20s), std::future_status::ready);
    EXPECT_EQ(pending.get().first, ms2000::error::disconnected);
    EXPECT_TRUE(observer_->wait_state(connection_state::disconnected));
    EXPECT_EQ(call(test::raw_line("NUM 1")).first, ms2000::error::not_connected);

    fake_.release();
    fake_.replug();
    EXPECT_TRUE(observer_->wait_state(connection_state::connected));
    EXPECT_GE(fake_.count("V"), 2u);
    EXPECT_FALSE(call(test::raw_line("NUM 1")).first);
}

TEST_F(controller_test, a_vanished_device_node_is_a_disconnect) {
    start(settings());
    fake_.remove_link();
    EXPECT_TRUE(observer_->wait_state(connection_state::disconnected));
    EXPECT_EQ(observer_->latest().last_error->name, "disconnected");
    fake_.replug();
    EXPECT_TRUE(observer_->wait_state(connection_state::connected));
}

TEST_F(controller_test, snapshots_are_published_only_on_change) {
    auto s = settings();
    s.poll_interval = 5ms;
    s.idle_poll_interval = 5ms;  // rounds while idle too: this test needs many identical ones
    start(s);
    const auto polls = [&] { return fake_.count("W X Y"); };
    ASSERT_TRUE(
        observer_->wait([&] { return observer_->snapshots.back().axes.at(0).position_um.has_value(); }));
    const auto before = observer_->locked([&] { return observer_->snapshots.size(); });
    const auto polled = polls();
    // Twenty more identical poll rounds.
    ASSERT_TRUE(fake_.wait_for_commands(fake_.commands().size() + 40));
    EXPECT_GE(polls(), polled + 10);
    EXPECT_EQ(observer_->locked([&] { return observer_->snapshots.size(); }), before);

    // A changed position is published.
    fake_.set_responder([](const std::string& c) -> std::vector<std::string> {
        if (c == "W X Y") return {":A 300.0 -20.0 \r\n"};
        return test::drv_pty_controller::default_reply(c);
    });
    EXPECT_TRUE(observer_->wait([&] { return observer_->snapshots.back().axes.at(0).position_um == 30.0; }));
}

TEST_F(controller_test, unsolicited_position_report_becomes_a_ttl_event) {
    start(settings());
    fake_.write_raw("T:   400    12.0    -3.5\r\n");
    ASSERT_TRUE(observer_->wait([&] { return !observer_->ttls.empty(); }));
    const auto e = observer_->locked([&] { return observer_->ttls.front(); });
    EXPECT_EQ(e.controller_ms, 400.0);
    ASSERT_EQ(e.axes.size(), 2u);
    EXPECT_EQ(e.axes[0].letter, 'X');
    EXPECT_DOUBLE_EQ(e.axes[0].position_um, 1.2);
    EXPECT_DOUBLE_EQ(e.axes[1].position_um, -0.35);
    EXPECT_FALSE(call(test::raw_line("NUM 1")).first);  // and the main port still works
}

TEST_F(controller_test, traces_carry_request_id_wire_reply_and_latency) {
    start(settings());
    EXPECT_FALSE(call(ms2000::where("XY")).first);
    ASSERT_TRUE(observer_->wait([&] {
        for (const auto& t : observer_->traces)
            if (t.request_id == "test") return true;
        return false;
    }));
    const auto t = observer_->locked([&] {
        for (const auto& t : observer_->traces)
            if (t.request_id == "test") return t;
        return command_trace{};
    });
    EXPECT_EQ(t.wire, "W X Y\\r");
    EXPECT_EQ(t.raw_reply, ":A 100.0 -20.0 ");
    EXPECT_FALSE(t.internal);
    EXPECT_FALSE(t.error);
    EXPECT_GE(t.latency.count(), 0);
}

TEST_F(controller_test, commands_before_start_and_after_stop_fail) {
    ctl_ = std::make_shared<controller>(io_.get_executor(), settings(), observer_);
    threads_.emplace_back([this] { io_.run(); });
    EXPECT_EQ(call(test::raw_line("NUM 1")).first, ms2000::error::not_connected);
    ctl_->start();
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    fake_.hold();
    auto pending = submit(test::raw_line("LONG"));
    ASSERT_TRUE(fake_.wait_for_commands(identification_commands + 1));
    ctl_->stop();
    EXPECT_EQ(pending.get().first, ms2000::error::cancelled);
    EXPECT_EQ(call(test::raw_line("NUM 1")).first, ms2000::error::cancelled);
    fake_.release();

    // And it can be started again.
    ctl_->start();
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    EXPECT_FALSE(call(test::raw_line("NUM 1")).first);
}

// The report port: a second pty on which the test sends binary encoder frames.
TEST_F(controller_test, report_port_frames_become_report_events) {
    test::drv_pty_controller report_side;
    auto s = settings();
    s.report_port = report_side.link();
    start(s);
    ASSERT_TRUE(
        observer_->wait([&] { return observer_->snapshots.back().report == report_port_state::open; }));
    ms2000::report_frame frame;
    frame.axes = {{'X', 10000}, {'Y', -40000}};
    const auto bytes = ms2000::encode_report(frame, ms2000::report_format::binary);
    std::string wire(bytes.begin(), bytes.end());
    report_side.write_raw("\x01\x02" + wire + wire);  // two junk bytes first
    ASSERT_TRUE(observer_->wait([&] { return observer_->reports.size() >= 2; }));
    const auto e = observer_->locked([&] { return observer_->reports[1]; });
    EXPECT_EQ(e.sequence, 2u);
    EXPECT_EQ(e.controller_id, "unit");
    ASSERT_EQ(e.axes.size(), 2u);
    EXPECT_EQ(e.axes[0].counts, 10000);
    EXPECT_EQ(e.axes[0].position_um, 1000.0);   // 10000 counts / 10000 per mm
    EXPECT_EQ(e.axes[1].position_um, -2000.0);  // -40000 / 20000 per mm
    EXPECT_GE(e.bytes_skipped, 2u);
}

}  // namespace
}  // namespace gw::devices
