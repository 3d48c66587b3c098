// Reply matching under faults: a reply is an answer only once it fits its command, and after any doubt
// the link is resynchronised before the next command. Against a pty that plays the controller.
#include <atomic>
#include <future>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>

#include "devices/ms2000/error.hpp"
#include "devices/ms2000/reply_check.hpp"
#include "devices/serial/controller.hpp"
#include "tests/support/drv_command_call.hpp"
#include "tests/support/drv_pty_controller.hpp"
#include "tests/support/drv_recording_observer.hpp"

namespace gw::devices {
namespace {

namespace net = boost::asio;
using namespace std::chrono_literals;
using kind = link_fault::kind;

// The identification replies of an XYZ stage (the fake's default is an XY one).
std::vector<std::string> xyz_reply(const std::string& c) {
    if (c == "BU X") return {"STD_XYZ\rMotor Axes: X Y Z\rAxis Addr: 1 2 3\r\n"};
    if (c == "CNTS X? Y? Z?") return {":A X=10000 Y=10000 Z=10000\r\n"};
    if (c == "SL X? Y? Z?") return {":A X=-50 Y=-25 Z=-5\r\n"};
    if (c == "SU X? Y? Z?") return {":A X=50 Y=25 Z=5\r\n"};
    if (c == "S X? Y? Z?") return {":A X=5.5 Y=5.5 Z=5.5\r\n"};
    if (c == "AC X? Y? Z?") return {":X=20 Y=20 Z=20 A\r\n"};
    if (c == "PC X? Y? Z?") return {":A X=0.000022 Y=0.000022 Z=0.000022\r\n"};
    if (c == "B X? Y? Z?") return {":X=0 Y=0 Z=0 A\r\n"};
    if (c == "OS X? Y? Z?") return {":A X=0 Y=0 Z=0\r\n"};
    if (c == "W X Y Z") return {":A 1.0 2.0 3.0 \r\n"};
    return test::drv_pty_controller::default_reply(c);
}

// An observer whose every callback throws: what a bug in an event encoder would do.
class throwing_observer : public controller_observer {
  public:
    void on_snapshot(const controller_snapshot&) override { fail(); }
    void on_trace(const command_trace&) override { fail(); }
    void on_link_fault(const link_fault&) override { fail(); }
    std::atomic<int> calls{0};

  private:
    void fail() {
        ++calls;
        throw std::runtime_error("encoder failed");
    }
};

class controller_sync_test : public ::testing::Test {
  protected:
    controller_settings settings() const {
        controller_settings s;
        s.id = "sync";
        s.port = fake_.link();
        s.baud = 115200;
        s.poll_interval = 0ms;
        s.command_timeout = 300ms;
        s.reconnect_min = 20ms;
        s.reconnect_max = 200ms;
        s.presence_check = 50ms;
        s.resync_delay = 50ms;
        return s;
    }

    void start(const controller_settings& s, std::shared_ptr<controller_observer> observer = {}) {
        observed_ = observer ? std::move(observer) : observer_;
        ctl_ = std::make_shared<controller>(io_.get_executor(), s, observed_);
        thread_ = std::thread([this] { io_.run(); });
        ctl_->start();
    }

    void TearDown() override {
        if (ctl_) {
            ctl_->stop();
            std::promise<void> stopped;
            ctl_->get_snapshot([&](const controller_snapshot&) { stopped.set_value(); });
            stopped.get_future().wait_for(5s);
        }
        work_.reset();
        if (thread_.joinable()) thread_.join();
    }

    test::command_result call(ms2000::command cmd) {
        return test::await_command(test::submit_command(*ctl_, std::move(cmd), "t"), 20s);
    }

    std::size_t count_of(kind k) {
        return observer_->locked(
            [&] { return std::count(observer_->faults.begin(), observer_->faults.end(), k); });
    }

    net::io_context io_;
    net::executor_work_guard<net::io_context::executor_type> work_ = net::make_work_guard(io_);
    std::thread thread_;
    test::drv_pty_controller fake_;
    std::shared_ptr<test::drv_recording_observer> observer_ =
        std::make_shared<test::drv_recording_observer>();
    std::shared_ptr<controller_observer> observed_;
    std::shared_ptr<controller> ctl_;
};

TEST_F(controller_sync_test, a_reply_that_does_not_fit_its_command_is_refused_and_the_link_resynchronised) {
    start(settings());
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    std::atomic<int> wheres{0};
    fake_.set_responder([&](const std::string& c) -> std::vector<std::string> {
        // The first WHERE of two axes gets one number: the late answer of a "W X", not its own.
        if (c == "W X Y" && wheres++ == 0) return {":A 12344.9\r\n"};
        return test::drv_pty_controller::default_reply(c);
    });
    fake_.clear_commands();
    const auto resynced_at_connect = count_of(kind::resynced);
    auto [ec, reply] = call(ms2000::where("XY"));
    EXPECT_EQ(ec, ms2000::error::unrecognized_reply);
    EXPECT_TRUE(reply.values.empty()) << "a refused reply hands out no values";

    auto [ec2, reply2] = call(ms2000::where("XY"));
    ASSERT_FALSE(ec2) << ec2.message();
    EXPECT_EQ(reply2.number(0), 100.0);
    // Between the two: the probe, and nothing else was let through.
    const std::vector<std::string> expected{"W X Y", "V", "W X Y"};
    EXPECT_EQ(fake_.commands(), expected);
    EXPECT_EQ(count_of(kind::mismatch), 1u);
    EXPECT_EQ(count_of(kind::resynced), resynced_at_connect + 1);
}

TEST_F(controller_sync_test, a_move_answered_with_values_is_not_acknowledged) {
    start(settings());
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    fake_.set_responder([](const std::string& c) -> std::vector<std::string> {
        if (c == "M X=10") return {":A 555.1 0\r\n"};
        return test::drv_pty_controller::default_reply(c);
    });
    EXPECT_EQ(call(test::raw_line("M X=10")).first, ms2000::error::unrecognized_reply);
    EXPECT_FALSE(call(ms2000::where("XY")).first);
}

TEST_F(controller_sync_test, bytes_that_are_not_ascii_never_reach_a_reply) {
    start(settings());
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    fake_.set_responder([](const std::string& c) -> std::vector<std::string> {
        if (c == "WHO") return {std::string(":A ASI\xFF\xC3(\r\n")};
        return test::drv_pty_controller::default_reply(c);
    });
    auto [ec, reply] = call(ms2000::who());
    EXPECT_EQ(ec, ms2000::error::unrecognized_reply);
    EXPECT_EQ(reply.raw, ":A ASI\\xFF\\xC3(") << "escaped, never the raw bytes";
    EXPECT_TRUE(ms2000::is_reply_text(reply.raw));
    const auto traces = observer_->locked([&] { return observer_->traces; });
    for (const auto& t : traces)
        EXPECT_TRUE(ms2000::is_reply_text(t.raw_reply)) << t.raw_reply;
    EXPECT_EQ(count_of(kind::noise), 1u);
    EXPECT_FALSE(call(ms2000::where("XY")).first);
}

TEST_F(controller_sync_test, a_late_reply_after_the_probe_starts_the_resynchronisation_over) {
    auto s = settings();
    start(s);
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    std::atomic<int> versions{0};
    fake_.set_responder([&](const std::string& c) -> std::vector<std::string> {
        if (c == "DROP") return {};
        // The first probe is answered twice: as if an earlier V's answer had been late.
        if (c == "V" && versions++ == 0) return {":A Version: USB-9.50 \r\n", ":A Version: USB-9.50 \r\n"};
        return test::drv_pty_controller::default_reply(c);
    });
    fake_.clear_commands();
    EXPECT_EQ(call(test::raw_line("DROP")).first, ms2000::error::timeout);
    EXPECT_FALSE(call(ms2000::where("XY")).first);
    const std::vector<std::string> expected{"DROP", "V", "V", "W X Y"};
    EXPECT_EQ(fake_.commands(), expected);
}

TEST_F(controller_sync_test, a_halt_goes_out_at_once_while_the_link_is_out_of_step) {
    start(settings());
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    fake_.set_responder([](const std::string& c) -> std::vector<std::string> {
        if (c == "DROP") return {};
        return test::drv_pty_controller::default_reply(c);
    });
    fake_.clear_commands();
    auto dropped = test::submit_command(*ctl_, test::raw_line("DROP"), "t");
    auto halt = test::submit_command(*ctl_, ms2000::halt(), "t");  // waits behind DROP's deadline only
    EXPECT_EQ(test::await_command(std::move(dropped), 20s).first, ms2000::error::timeout);
    EXPECT_FALSE(test::await_command(std::move(halt), 20s).first);
    const auto commands = fake_.commands();
    ASSERT_GE(commands.size(), 2u);
    EXPECT_EQ(commands[1], "\\") << "the HALT went before the resynchronisation's probe";
}

TEST_F(controller_sync_test, a_halt_whose_answer_is_in_doubt_is_sent_again_once_in_step) {
    start(settings());
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    std::atomic<int> halts{0};
    fake_.set_responder([&](const std::string& c) -> std::vector<std::string> {
        if (c == "\\" && halts++ == 0) return {":A 12 34\r\n"};  // another command's late reply
        return test::drv_pty_controller::default_reply(c);
    });
    fake_.clear_commands();
    EXPECT_FALSE(call(ms2000::halt()).first);
    const std::vector<std::string> expected{"\\", "V", "\\"};
    EXPECT_EQ(fake_.commands(), expected);
}

TEST_F(controller_sync_test, a_line_read_with_an_answer_is_not_taken_for_the_next_commands_answer) {
    // W X's answer and a stray line arrive in one read, with a HALT waiting behind W X. The HALT goes
    // out only once the whole read is handled: the stray line finds no command and the HALT waits for
    // its own answer (held back by the fake here) instead of taking the stray line for it.
    // The fake holds W X's answer until this thread has queued the HALT: however long the scheduler
    // keeps it from getting there (it took more than the 300 ms of settings() in a loaded CI run),
    // W X must still be waiting then, so its timeout is far beyond any such stall.
    auto s = settings();
    s.command_timeout = 20s;
    start(s);
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    fake_.set_responder([](const std::string& c) -> std::vector<std::string> {
        if (c == "W X") return {":A 1.0 \r\n:A \r\n"};
        return test::drv_pty_controller::default_reply(c);
    });
    fake_.clear_commands();
    fake_.hold();
    auto where = test::submit_command(*ctl_, ms2000::where("X"), "t");
    ASSERT_TRUE(fake_.wait_deferred(1));
    auto halt = test::submit_command(*ctl_, ms2000::halt(), "t");
    std::promise<void> queued;  // the strand took the HALT before W X's answer is released
    ctl_->get_snapshot([&](const controller_snapshot&) { queued.set_value(); });
    ASSERT_EQ(queued.get_future().wait_for(5s), std::future_status::ready);
    const auto unexpected_before = count_of(kind::unexpected);
    fake_.hold_on("\\");
    fake_.release();

    const auto [ecw, rw] = test::await_command(std::move(where), 20s);
    ASSERT_FALSE(ecw) << ecw.message();
    EXPECT_EQ(rw.number(0), 1.0);
    ASSERT_TRUE(fake_.wait_deferred(1));  // the HALT arrived; its answer is held
    EXPECT_EQ(count_of(kind::unexpected), unexpected_before + 1) << "the stray line found no command";
    EXPECT_EQ(halt.wait_for(200ms), std::future_status::timeout) << "the HALT took the stray line";
    fake_.release();
    EXPECT_FALSE(test::await_command(std::move(halt), 20s).first);
    const std::vector<std::string> first{"W X", "\\"};
    const auto commands = fake_.commands();
    ASSERT_GE(commands.size(), 2u);
    EXPECT_EQ(std::vector<std::string>(commands.begin(), commands.begin() + 2), first);
}

TEST_F(controller_sync_test, noise_during_identification_starts_it_over_instead_of_guessing_the_axes) {
    std::atomic<int> builds{0};
    fake_.set_responder([&](const std::string& c) -> std::vector<std::string> {
        if (c == "BU X" && builds++ == 0) return {std::string("\xC3(\xFF\r\n")};
        return xyz_reply(c);
    });
    start(settings());
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    const auto s = observer_->latest();
    ASSERT_TRUE(s.identity);
    EXPECT_EQ(s.identity->build.motor_axes, "XYZ") << "not the XY a firmware without BU X is taken for";
    EXPECT_EQ(s.axes.size(), 3u);
    EXPECT_GE(builds.load(), 2);
}

TEST_F(controller_sync_test, a_ttl_mode_set_by_a_command_is_read_back_into_the_snapshot) {
    std::atomic<int> in0{0};
    fake_.set_responder([&](const std::string& c) -> std::vector<std::string> {
        if (c == "TTL X=7") {
            in0 = 7;
            return {":A\r\n"};
        }
        if (c == "TTL X? Y?") return {":A X=" + std::to_string(in0.load()) + " Y=2\r\n"};
        return test::drv_pty_controller::default_reply(c);
    });
    start(settings());
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    EXPECT_EQ(observer_->latest().ttl_in0_mode, 0);
    EXPECT_FALSE(call(test::raw_line("TTL X=7")).first);
    EXPECT_TRUE(observer_->wait([&] { return observer_->snapshots.back().ttl_in0_mode == 7; }));
}

TEST_F(controller_sync_test, an_observer_that_throws_is_contained_and_the_controller_goes_on) {
    auto thrower = std::make_shared<throwing_observer>();
    start(settings(), thrower);
    // Identification and commands go on although every event handler throws.
    test::command_result result;
    for (int i = 0; i < 100; ++i) {
        result = call(ms2000::where("XY"));
        if (!result.first) break;
        std::this_thread::sleep_for(20ms);  // not connected yet
    }
    ASSERT_FALSE(result.first) << result.first.message();
    EXPECT_EQ(result.second.number(1), -20.0);
    EXPECT_GT(thrower->calls.load(), 0);
}

TEST_F(controller_sync_test, a_reply_repeated_after_the_guard_is_not_the_next_commands_answer) {
    // An adapter that sends a buffer twice, the copy a few milliseconds late (a later USB packet): it
    // lands while the next command waits and has that command's shape. It must not be its answer.
    // The fake answers W X with the copy first and W X's own answer 3 ms later, so the order does not
    // depend on how soon this thread is scheduled (a sleeping test thread raced W X's deadline here).
    auto s = settings();
    s.repeated_reply_window = 10s;  // the copy's lateness is up to the scheduler here; 50 ms in use
    s.resync_delay = 1s;            // the drain outlasts the 3 ms until W X's own answer
    start(s);
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    std::atomic<int> xs{0};
    fake_.set_responder([&](const std::string& c) -> std::vector<std::string> {
        if (c == "W Z") return {":A 776.9 \r\n"};
        if (c == "W X" && xs++ == 0) return {":A 776.9 \r\n", ":A 12344.9 \r\n"};
        if (c == "W X") return {":A 12344.9 \r\n"};
        return test::drv_pty_controller::default_reply(c);
    });
    fake_.clear_commands();
    const auto mismatches_before = count_of(kind::mismatch);
    const auto [ecz, rz] = call(ms2000::where("Z"));
    ASSERT_FALSE(ecz) << ecz.message();
    EXPECT_EQ(rz.number(0), 776.9);
    const auto [ecx, rx] = call(ms2000::where("X"));
    EXPECT_EQ(ecx, ms2000::error::unrecognized_reply) << "W X got " << rx.raw;
    EXPECT_TRUE(rx.values.empty());
    EXPECT_EQ(count_of(kind::mismatch), mismatches_before + 1);

    // In step again: W X gets its own answer, and the same reply to the same command is no repeat.
    for (int i = 0; i < 3; ++i) {
        const auto [ec, r] = call(ms2000::where("X"));
        ASSERT_FALSE(ec) << ec.message();
        EXPECT_EQ(r.number(0), 12344.9);
    }
    EXPECT_EQ(count_of(kind::mismatch), mismatches_before + 1);
}

TEST_F(controller_sync_test, identical_answers_to_different_commands_are_each_their_own) {
    // Different queries may share an answer (two axes at the same place): each is held for the
    // repeated-reply window and, with nothing after it, taken. One-character answers (two idle axes)
    // are not held at all. No refusal, no resynchronisation.
    start(settings());
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    fake_.set_responder([&](const std::string& c) -> std::vector<std::string> {
        if (c == "RS X?" || c == "RS Y?") return {":A N\r\n"};
        if (c == "W X" || c == "W Y") return {":A 12.5\r\n"};
        return test::drv_pty_controller::default_reply(c);
    });
    const auto resynced_before = count_of(kind::resynced);
    for (const char* line : {"RS X?", "RS Y?", "W X", "W Y", "RS X?"}) {
        const auto [ec, r] = call(test::raw_line(line));
        ASSERT_FALSE(ec) << line << ": " << ec.message();
        EXPECT_EQ(r.raw, line[0] == 'R' ? ":A N" : ":A 12.5") << line;
    }
    EXPECT_EQ(count_of(kind::mismatch), 0u);
    EXPECT_EQ(count_of(kind::resynced), resynced_before);
}

TEST_F(controller_sync_test, a_moving_stage_is_polled_without_link_faults) {
    // While the stage is busy every poll round asks each axis "RS <axis>?", and the axes answer
    // alike, one right after the other.
    fake_.set_responder([&](const std::string& c) -> std::vector<std::string> {
        if (c == "/") return {"B\r\n"};
        if (c == "RS X?" || c == "RS Y?") return {":A B\r\n"};
        return test::drv_pty_controller::default_reply(c);
    });
    auto s = settings();
    s.poll_interval = 10ms;
    start(s);
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    const auto resynced_at_connect = count_of(kind::resynced);
    fake_.clear_commands();
    const auto rounds = [&] {
        const auto sent = fake_.commands();
        return std::count(sent.begin(), sent.end(), "RS Y?");
    };
    for (int i = 0; i < 500 && rounds() < 5; ++i)
        std::this_thread::sleep_for(20ms);
    ASSERT_GE(rounds(), 5) << "the poll never asked every axis";
    const auto snapshot = observer_->latest();
    EXPECT_TRUE(snapshot.busy);
    ASSERT_EQ(snapshot.axes.size(), 2u);
    EXPECT_TRUE(snapshot.axes[0].busy && snapshot.axes[1].busy);
    EXPECT_EQ(count_of(kind::mismatch), 0u);
    EXPECT_EQ(count_of(kind::resynced), resynced_at_connect);
}

TEST_F(controller_sync_test, identical_acks_of_different_moves_are_each_their_own) {
    start(settings());
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    for (double x : {1.0, 2.0, 3.0}) {
        const auto [ec, r] = call(ms2000::move({{'X', x}}).value());
        EXPECT_FALSE(ec) << ec.message();
    }
    EXPECT_EQ(count_of(kind::mismatch), 0u);
}

TEST_F(controller_sync_test, a_handler_that_throws_loses_none_of_the_answers_handed_over_with_its_own) {
    // The I/O thread goes on after an exception, as the application's does (it logs and runs again).
    std::atomic<int> thrown{0};
    ctl_ = std::make_shared<controller>(io_.get_executor(), settings(), observer_);
    thread_ = std::thread([&] {
        for (;;) {
            try {
                io_.run();
                return;
            } catch (const std::runtime_error&) {
                ++thrown;
            }
        }
    });
    ctl_->start();
    ASSERT_TRUE(observer_->wait_state(connection_state::connected));
    fake_.clear_commands();
    fake_.hold();
    // One command in flight and two queued behind it; the port then fails while it is read, so the
    // three end in that one read and are handed over together, the throwing one first.
    ctl_->async_command(test::raw_line("W X"), "throws",
                        [](boost::system::error_code, ms2000::reply) { throw std::runtime_error("a bug"); });
    auto second = test::submit_command(*ctl_, test::raw_line("W Y"), "second");
    auto third = test::submit_command(*ctl_, test::raw_line("W Z"), "third");
    ASSERT_TRUE(fake_.wait_for_commands(1));
    fake_.unplug();
    EXPECT_TRUE(test::await_command(std::move(second), 10s).first) << "the second command's end was lost";
    EXPECT_TRUE(test::await_command(std::move(third), 10s).first) << "the third command's end was lost";
    EXPECT_EQ(thrown.load(), 1);
}

}  // namespace
}  // namespace gw::devices
