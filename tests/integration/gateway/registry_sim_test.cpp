// The controller registry and its typed operations against in-process simulators on real ptys.
#include <atomic>
#include <filesystem>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/use_future.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "devices/sim/sim_config.hpp"
#include "devices/sim/simulator.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "tests/support/drv_recording_observer.hpp"
#include "tests/support/io_thread.hpp"
#include "tests/support/sim_controller_settings.hpp"

namespace gw {
namespace {

namespace net = boost::asio;
namespace sim = devices::sim;
using namespace std::chrono_literals;
using devices::connection_state;
using kind = operation_error_kind;
using test::await;
using test::io_thread;

class registry_sim_test : public ::testing::Test {
  protected:
    std::shared_ptr<sim::simulator> add_sim(const std::string& id, const std::string& preset,
                                            double time_scale = 20) {
        auto config = sim::preset(preset).value();
        config.name = id;
        config.time_scale = time_scale;
        config.link_path = dir_ + "/" + id + "/port";
        config.report_link_path = dir_ + "/" + id + "/report";
        auto s = std::make_shared<sim::simulator>(sim_io_.io.get_executor(), config);
        s->start();
        sims_.push_back(s);
        options_.controllers.push_back(gw::test::sim_controller_settings(id, *s, config.baud));
        return s;
    }

    void start() {
        registry_ = std::make_unique<controller_registry>(gw_io_.io.get_executor(), options_);
        registry_->add_observer(std::weak_ptr<devices::controller_observer>(observer_));
        registry_->start();
        ASSERT_TRUE(wait_until([&] { return registry_->ready(); })) << "controllers not ready";
    }

    // Polls the registry's copy (never the serial line) until `pred` holds.
    template <typename Pred>
    bool wait_until(Pred pred, std::chrono::milliseconds timeout = 30s) {
        const auto deadline = std::chrono::steady_clock::now() + timeout;
        while (std::chrono::steady_clock::now() < deadline) {
            if (pred()) return true;
            std::this_thread::sleep_for(10ms);
        }
        return pred();
    }

    std::optional<double> position(const std::string& id, char axis) {
        auto s = registry_->get(id);
        if (!s) return std::nullopt;
        const auto* a = s->axis(axis);
        return a ? a->position_um : std::nullopt;
    }

    static nlohmann::json state(const std::shared_ptr<sim::simulator>& s) {
        return nlohmann::json::parse(s->state_json());
    }

    std::vector<devices::command_trace> traces_of(const std::string& id) {
        return observer_->locked([&] {
            std::vector<devices::command_trace> out;
            for (const auto& t : observer_->traces)
                if (t.controller_id == id) out.push_back(t);
            return out;
        });
    }

    void TearDown() override {
        if (registry_) registry_->stop();
        gw_io_.join();  // every completion has run before the registry goes
        registry_.reset();
        for (auto& s : sims_)
            s->stop();
        sim_io_.join();
        std::filesystem::remove_all(dir_);
    }

    io_thread sim_io_;
    io_thread gw_io_;
    std::string dir_ = "/tmp/gw-registry-" +
                       std::string(testing::UnitTest::GetInstance()->current_test_info()->name()) + "-" +
                       std::to_string(::getpid());
    registry_options options_;
    std::vector<std::shared_ptr<sim::simulator>> sims_;
    std::shared_ptr<test::drv_recording_observer> observer_ =
        std::make_shared<test::drv_recording_observer>();
    std::unique_ptr<controller_registry> registry_;
};

TEST_F(registry_sim_test, lists_controllers_in_order_and_knows_their_builds) {
    add_sim("p1", "plain");
    add_sim("q1", "planar");
    start();
    const auto all = registry_->list();
    ASSERT_EQ(all.size(), 2u);
    EXPECT_EQ(all[0].id, "p1");
    EXPECT_EQ(all[1].id, "q1");
    ASSERT_TRUE(all[1].identity);
    EXPECT_TRUE(all[1].identity->build.has(devices::ms2000::module::dac_out));
    EXPECT_FALSE(registry_->get("nope"));
    EXPECT_EQ(registry_->ids(), (std::vector<std::string>{"p1", "q1"}));
}

TEST_F(registry_sim_test, move_with_wait_arrives_and_the_snapshot_shows_the_position) {
    add_sim("p1", "plain");
    start();
    move_request r;
    r.axes = {{'X', 2000}, {'Y', -1500}};
    r.wait = true;
    r.wait_timeout = 30s;
    auto result = await(registry_->async_move("p1", r, "req-move-1", net::use_future));
    ASSERT_TRUE(result) << result.error().message;
    EXPECT_TRUE(result->waited);
    ASSERT_EQ(result->positions.size(), 2u);
    EXPECT_EQ(result->positions[0].axis, 'X');
    EXPECT_NEAR(result->positions[0].micrometres, 2000, 1.0);
    EXPECT_EQ(result->positions[1].axis, 'Y');
    EXPECT_NEAR(result->positions[1].micrometres, -1500, 1.0);

    EXPECT_TRUE(wait_until([&] {
        auto x = position("p1", 'X');
        auto y = position("p1", 'Y');
        return x && y && std::abs(*x - 2000) < 1.0 && std::abs(*y + 1500) < 1.0 &&
               !registry_->get("p1")->busy;
    })) << "snapshot never showed the target";

    // Every command of the operation carries its request id.
    bool saw_move = false;
    for (const auto& t : traces_of("p1")) {
        if (t.wire.starts_with("M ")) {
            saw_move = true;
            EXPECT_EQ(t.request_id, "req-move-1");
            EXPECT_NE(t.wire.find("X=20000 Y=-15000"), std::string::npos) << t.wire;
        }
    }
    EXPECT_TRUE(saw_move);
}

TEST_F(registry_sim_test, move_without_wait_completes_at_once_and_relative_moves_add_up) {
    add_sim("p1", "plain");
    start();
    move_request r;
    r.axes = {{'Z', 300}};
    auto first = await(registry_->async_move("p1", r, "m1", net::use_future));
    ASSERT_TRUE(first) << first.error().message;
    EXPECT_FALSE(first->waited);
    r.kind = move_request::mode::relative;
    r.axes = {{'Z', 200}};
    r.wait = true;
    auto second = await(registry_->async_move("p1", r, "m2", net::use_future));
    ASSERT_TRUE(second) << second.error().message;
    ASSERT_EQ(second->positions.size(), 1u);
    // The relative move started wherever the first one had got to; both targets add up once stopped.
    EXPECT_TRUE(wait_until([&] {
        auto z = position("p1", 'Z');
        return z && std::abs(*z - 500) < 1.0;
    })) << "Z at "
        << position("p1", 'Z').value_or(-1);
}

TEST_F(registry_sim_test, dac_on_a_plain_build_is_missing_module_and_nothing_is_written) {
    auto plain = add_sim("p1", "plain");
    auto planar = add_sim("q1", "planar");
    start();
    const auto errors_before = state(plain).at("errors");

    auto refused = await(registry_->async_dac("p1", dac_request{5}, "dac-1", net::use_future));
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, kind::missing_module);
    EXPECT_EQ(refused.error().field, "dac_out");
    auto led = await(registry_->async_led("p1", led_request{40}, "led-1", net::use_future));
    ASSERT_FALSE(led);
    EXPECT_EQ(led.error().kind, kind::missing_module);

    for (const auto& t : traces_of("p1")) {
        EXPECT_EQ(t.wire.find("WRDAC"), std::string::npos) << t.wire;
        EXPECT_EQ(t.wire.find("LED"), std::string::npos) << t.wire;
        EXPECT_NE(t.request_id, "dac-1");
    }
    EXPECT_EQ(state(plain).at("errors"), errors_before);  // no ":N-1" was provoked
    EXPECT_EQ(state(plain).at("dac_volts"), 0);

    // The planar build has both modules.
    auto dac = await(registry_->async_dac("q1", dac_request{2.5}, "dac-2", net::use_future));
    ASSERT_TRUE(dac) << dac.error().message;
    EXPECT_DOUBLE_EQ(state(planar).at("dac_volts").get<double>(), 2.5);
    auto led_ok = await(registry_->async_led("q1", led_request{40}, "led-2", net::use_future));
    ASSERT_TRUE(led_ok) << led_ok.error().message;
    // The model's LED map comes out as [[letter, percent], ...].
    double led_x = -1;
    const auto planar_state = state(planar);
    for (const auto& pair : planar_state.at("led"))
        if (pair.at(0).get<int>() == 'X') led_x = pair.at(1).get<double>();
    EXPECT_EQ(led_x, 40) << planar_state.at("led").dump();
}

TEST_F(registry_sim_test, speed_ttl_here_zero_and_home_reach_the_controller) {
    auto s = add_sim("p1", "plain");
    start();
    auto speed = await(registry_->async_speed("p1", speed_request{{{'X', 2.5}}}, "s", net::use_future));
    ASSERT_TRUE(speed) << speed.error().message;
    EXPECT_NEAR(state(s).at("axes").at("X").at("speed").get<double>(), 2.5, 1e-6);

    auto ttl = await(registry_->async_ttl("p1", ttl_request{5, 2, {}}, "t", net::use_future));
    ASSERT_TRUE(ttl) << ttl.error().message;
    EXPECT_EQ(state(s).at("ttl").at("in0_mode"), 5);
    EXPECT_EQ(state(s).at("ttl").at("out0_mode"), 2);
    auto ttl_bad = await(registry_->async_ttl("p1", ttl_request{1, {}, {}}, "t2", net::use_future));
    ASSERT_FALSE(ttl_bad);
    EXPECT_EQ(ttl_bad.error().kind, kind::missing_module);

    auto here = await(registry_->async_here("p1", here_request{{{'Y', 1234.5}}}, "h", net::use_future));
    ASSERT_TRUE(here) << here.error().message;
    EXPECT_TRUE(wait_until([&] {
        auto y = position("p1", 'Y');
        return y && std::abs(*y - 1234.5) < 0.2;
    }));
    auto zero = await(registry_->async_zero("p1", "z", net::use_future));
    ASSERT_TRUE(zero) << zero.error().message;
    EXPECT_TRUE(wait_until([&] {
        auto y = position("p1", 'Y');
        return y && std::abs(*y) < 0.2;
    }));
    auto home = await(registry_->async_home("p1", home_request{"X"}, "hm", net::use_future));
    ASSERT_TRUE(home) << home.error().message;
}

TEST_F(registry_sim_test, halt_during_a_move_stops_the_stage_and_ends_the_wait) {
    add_sim("p1", "plain", 2);  // a 100 mm move takes about 9 s real time
    start();
    move_request r;
    r.axes = {{'X', 100000}};
    r.wait = true;
    r.wait_timeout = 120s;
    auto moving = registry_->async_move("p1", r, "long-move", net::use_future);
    ASSERT_TRUE(wait_until([&] {
        auto x = position("p1", 'X');
        return registry_->get("p1")->busy && x && *x > 100;
    })) << "never seen moving";

    auto halted = await(registry_->async_halt("p1", "halt-1", net::use_future));
    ASSERT_TRUE(halted) << halted.error().message;
    auto result = await(std::move(moving));
    ASSERT_TRUE(result) << result.error().message;
    ASSERT_EQ(result->positions.size(), 1u);
    EXPECT_LT(result->positions[0].micrometres, 90000);  // stopped well short of the target
    EXPECT_GT(result->positions[0].micrometres, 100);
    EXPECT_TRUE(wait_until([&] { return !registry_->get("p1")->busy; }));
}

TEST_F(registry_sim_test, wait_timeout_is_reported_as_timeout) {
    add_sim("p1", "plain", 1);  // real time: 50 mm takes about 9 s
    start();
    move_request r;
    r.axes = {{'X', 50000}};
    r.wait = true;
    r.wait_timeout = 200ms;
    auto result = await(registry_->async_move("p1", r, "slow", net::use_future));
    ASSERT_FALSE(result);
    EXPECT_EQ(result.error().kind, kind::timeout);
    EXPECT_EQ(result.error().field, "wait_timeout");
    auto halted = await(registry_->async_halt("p1", "stop-it", net::use_future));
    EXPECT_TRUE(halted);
}

TEST_F(registry_sim_test, a_raw_soft_limit_command_refreshes_the_limits_jobs_check_against) {
    add_sim("p1", "plain");
    start();
    const auto limit = [&](char axis,
                           std::optional<double> devices::axis_state::*which) -> std::optional<double> {
        const auto s = registry_->get("p1");
        if (!s) return std::nullopt;
        for (const auto& a : s->axes)
            if (a.axis == axis) return a.*which;
        return std::nullopt;
    };
    ASSERT_TRUE(wait_until([&] { return limit('X', &devices::axis_state::lower_limit_mm).has_value(); }));
    EXPECT_DOUBLE_EQ(*limit('X', &devices::axis_state::lower_limit_mm), -110);
    auto set = await(
        registry_->async_raw_command("p1", raw_command_request{"SL X=-30 Y=-40"}, "sl", net::use_future));
    ASSERT_TRUE(set) << set.error().message;
    EXPECT_TRUE(wait_until([&] {
        return limit('X', &devices::axis_state::lower_limit_mm) == -30.0 &&
               limit('Y', &devices::axis_state::lower_limit_mm) == -40.0;
    })) << "the snapshot kept the limits read at identification";
    // The long name, and SU; a refused value (SU below SL) leaves what the controller has.
    set = await(registry_->async_raw_command("p1", raw_command_request{"SETUP X=55"}, "su", net::use_future));
    ASSERT_TRUE(set) << set.error().message;
    EXPECT_TRUE(wait_until([&] { return limit('X', &devices::axis_state::upper_limit_mm) == 55.0; }));
    set = await(registry_->async_raw_command("p1", raw_command_request{"SU Y=-50"}, "su2", net::use_future));
    ASSERT_TRUE(set) << set.error().message;
    EXPECT_EQ(set->reply.what, devices::ms2000::reply::kind::error) << set->raw_reply;
    EXPECT_EQ(limit('Y', &devices::axis_state::upper_limit_mm), 110.0);
}

TEST_F(registry_sim_test, raw_command_round_trip) {
    add_sim("p1", "plain");
    start();
    auto where =
        await(registry_->async_raw_command("p1", raw_command_request{"W X"}, "raw-1", net::use_future));
    ASSERT_TRUE(where) << where.error().message;
    EXPECT_TRUE(where->raw_reply.starts_with(":A")) << where->raw_reply;
    EXPECT_EQ(where->reply.what, devices::ms2000::reply::kind::ack);
    ASSERT_EQ(where->reply.values.size(), 1u);
    EXPECT_GT(where->latency.count(), 0);

    auto version =
        await(registry_->async_raw_command("p1", raw_command_request{"V"}, "raw-2", net::use_future));
    ASSERT_TRUE(version);
    EXPECT_NE(version->raw_reply.find("Version"), std::string::npos) << version->raw_reply;

    auto build =
        await(registry_->async_raw_command("p1", raw_command_request{"BU X"}, "raw-3", net::use_future));
    ASSERT_TRUE(build);
    EXPECT_EQ(build->reply.what, devices::ms2000::reply::kind::text);
    ASSERT_FALSE(build->reply.lines.empty());
    EXPECT_EQ(build->reply.lines[0], "STD_XYZ");

    // A controller error is an answer, shown as such.
    auto unknown =
        await(registry_->async_raw_command("p1", raw_command_request{"XYZZY"}, "raw-4", net::use_future));
    ASSERT_TRUE(unknown) << unknown.error().message;
    EXPECT_EQ(unknown->reply.what, devices::ms2000::reply::kind::error);
    EXPECT_EQ(unknown->reply.error_code, -1);
    EXPECT_EQ(unknown->raw_reply, ":N-1");

    auto bad =
        await(registry_->async_raw_command("p1", raw_command_request{"W X\nW Y"}, "raw-5", net::use_future));
    ASSERT_FALSE(bad);
    EXPECT_EQ(bad.error().kind, kind::invalid_value);
    EXPECT_EQ(bad.error().field, "command");
}

TEST_F(registry_sim_test, unknown_controller_for_every_operation) {
    add_sim("p1", "plain");
    start();
    auto expect_unknown = [](auto result) {
        ASSERT_FALSE(result);
        EXPECT_EQ(result.error().kind, kind::unknown_controller);
        EXPECT_NE(result.error().message.find("ghost"), std::string::npos);
    };
    expect_unknown(await(registry_->async_move("ghost", move_request{}, "u", net::use_future)));
    expect_unknown(await(registry_->async_halt("ghost", "u", net::use_future)));
    expect_unknown(await(registry_->async_home("ghost", home_request{}, "u", net::use_future)));
    expect_unknown(await(registry_->async_zero("ghost", "u", net::use_future)));
    expect_unknown(await(registry_->async_here("ghost", here_request{}, "u", net::use_future)));
    expect_unknown(await(registry_->async_speed("ghost", speed_request{}, "u", net::use_future)));
    expect_unknown(await(registry_->async_ttl("ghost", ttl_request{}, "u", net::use_future)));
    expect_unknown(await(registry_->async_dac("ghost", dac_request{}, "u", net::use_future)));
    expect_unknown(await(registry_->async_led("ghost", led_request{}, "u", net::use_future)));
    expect_unknown(
        await(registry_->async_raw_command("ghost", raw_command_request{"V"}, "u", net::use_future)));
}

TEST_F(registry_sim_test, unplugged_controller_is_not_connected_and_comes_back) {
    auto s = add_sim("p1", "plain");
    add_sim("p2", "plain");
    start();
    s->unplug();
    ASSERT_TRUE(wait_until([&] { return registry_->get("p1")->state != connection_state::connected; }));
    EXPECT_FALSE(registry_->ready());

    move_request r;
    r.axes = {{'X', 10}};
    auto moved = await(registry_->async_move("p1", r, "u1", net::use_future));
    ASSERT_FALSE(moved);
    EXPECT_EQ(moved.error().kind, kind::not_connected);
    auto raw = await(registry_->async_raw_command("p1", raw_command_request{"V"}, "u2", net::use_future));
    ASSERT_FALSE(raw);
    EXPECT_EQ(raw.error().kind, kind::not_connected);
    for (const auto& t : traces_of("p1"))
        EXPECT_NE(t.request_id, "u1");  // refused before the wire

    // The other controller is unaffected.
    auto other = await(registry_->async_move("p2", r, "u3", net::use_future));
    EXPECT_TRUE(other) << other.error().message;

    s->replug();
    ASSERT_TRUE(wait_until([&] { return registry_->ready(); })) << "did not reconnect";
    auto again = await(registry_->async_move("p1", r, "u4", net::use_future));
    EXPECT_TRUE(again) << again.error().message;
}

TEST_F(registry_sim_test, shutdown_halts_a_moving_stage) {
    auto s = add_sim("p1", "plain", 2);
    start();
    move_request r;
    r.axes = {{'X', 100000}};
    ASSERT_TRUE(await(registry_->async_move("p1", r, "m", net::use_future)));
    ASSERT_TRUE(wait_until([&] { return state(s).at("busy").get<bool>(); }));

    std::promise<void> done;
    registry_->async_shutdown([&done] { done.set_value(); });
    ASSERT_EQ(done.get_future().wait_for(30s), std::future_status::ready);
    EXPECT_TRUE(wait_until([&] { return !state(s).at("busy").get<bool>(); }, 10s)) << "still moving";
    EXPECT_LT(state(s).at("axes").at("X").at("position").get<double>(), 900000);  // tenths of a micron
    EXPECT_TRUE(wait_until([&] { return registry_->get("p1")->state == connection_state::stopped; }));
}

TEST_F(registry_sim_test, shutdown_leaves_stages_moving_when_configured) {
    auto s = add_sim("p1", "plain", 1);  // 100 mm take about 18 s
    options_.halt_on_exit = false;
    start();
    move_request r;
    r.axes = {{'X', 100000}};
    ASSERT_TRUE(await(registry_->async_move("p1", r, "m", net::use_future)));
    ASSERT_TRUE(wait_until([&] { return state(s).at("busy").get<bool>(); }));

    std::promise<void> done;
    registry_->async_shutdown([&done] { done.set_value(); });
    ASSERT_EQ(done.get_future().wait_for(30s), std::future_status::ready);
    EXPECT_TRUE(state(s).at("busy").get<bool>());
    for (const auto& t : traces_of("p1"))
        EXPECT_NE(t.request_id, "shutdown");
}

TEST_F(registry_sim_test, completions_never_run_inside_the_initiating_call) {
    add_sim("p1", "plain");
    start();
    // Initiated on the registry's own (single) io thread: an inline completion would run before the
    // initiating lambda returns, a posted one only after it.
    std::promise<operation_result<operation_done>> p;
    std::atomic<bool> returned{false};
    std::atomic<bool> ran_before_return{false};
    net::post(gw_io_.io, [&] {
        registry_->async_halt("ghost", "x", [&](operation_result<operation_done> r) {
            if (!returned) ran_before_return = true;
            p.set_value(std::move(r));
        });
        returned = true;
    });
    auto r = await(p.get_future());
    EXPECT_FALSE(ran_before_return.load());
    EXPECT_FALSE(r);
}

}  // namespace
}  // namespace gw
