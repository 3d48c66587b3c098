// The planner's motion model from the controller's snapshot, against an in-process simulator on a real
// pty: the driver reads SPEED/ACCEL/PC/BACKLASH/OVERSHOOT at identification and again after a command
// sets one ("S X=..", "AC X=..", "PC X=.."), so the model has the simulator's values without asking,
// and it predicts the simulator's busy time of real moves within 2 %. The busy time is read in
// SIMULATED time from the simulator's own state (each axis's motion start and settle times), so the
// check is about the model, not about wall-clock speed.
#include "gateway/jobs/snapshot_motion_model.hpp"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/use_future.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "devices/ms2000/reply.hpp"
#include "devices/serial/snapshot_update.hpp"
#include "devices/sim/sim_config.hpp"
#include "devices/sim/simulator.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "tests/support/io_thread.hpp"
#include "tests/support/sim_controller_settings.hpp"

namespace gw::jobs {
namespace {

namespace net = boost::asio;
namespace sim = devices::sim;
using namespace std::chrono_literals;
using test::io_thread;

class snapshot_motion_model_test : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = (std::filesystem::temp_directory_path() /
                ("gw-motion-probe-" + std::to_string(::getpid()) + "-" +
                 ::testing::UnitTest::GetInstance()->current_test_info()->name()))
                   .string();
        std::filesystem::create_directories(dir_);
    }

    void start(const std::string& preset = "plain", char screw = 'B', double time_scale = 20) {
        auto config = sim::preset(preset).value();
        config.name = "m1";
        config.lead_screw = screw;
        config.time_scale = time_scale;
        config.link_path = dir_ + "/m1/port";
        config.report_link_path = dir_ + "/m1/report";
        sim_ = std::make_shared<sim::simulator>(sim_io_.io.get_executor(), config);
        sim_->start();
        auto c = gw::test::sim_controller_settings("m1", *sim_, config.baud);
        c.command_timeout = 3000ms;
        registry_options options;
        options.controllers.push_back(c);
        registry_ = std::make_unique<controller_registry>(gw_io_.io.get_executor(), options);
        registry_->start();
        const auto deadline = std::chrono::steady_clock::now() + 30s;
        while (!registry_->ready() && std::chrono::steady_clock::now() < deadline)
            std::this_thread::sleep_for(10ms);
        ASSERT_TRUE(registry_->ready()) << "controller not ready";
        // The probe needs the counts per mm from the identification.
        while (std::chrono::steady_clock::now() < deadline) {
            const auto s = registry_->get("m1");
            if (s && s->axis('X') && s->axis('X')->counts_per_mm) break;
            std::this_thread::sleep_for(10ms);
        }
    }

    void TearDown() override {
        if (registry_) registry_->stop();
        gw_io_.join();
        registry_.reset();
        if (sim_) sim_->stop();
        sim_io_.join();
        std::error_code ec;
        std::filesystem::remove_all(dir_, ec);
    }

    // The model a submission would plan with now: from the snapshot, once it holds the motion settings
    // the controller answers to direct queries (a command that set one is read back after it).
    std::optional<motion_model> probe() {
        devices::controller_snapshot asked;
        if (auto s = registry_->get("m1")) asked = *s;
        for (const auto verb : devices::motion_setting_verbs) {
            auto reply = devices::ms2000::parse_reply(devices::ms2000::reply_shape::standard,
                                                      raw(std::string(verb) + " X? Y? Z?"));
            if (!reply) {
                ADD_FAILURE() << verb << ": no readable answer";
                return std::nullopt;
            }
            devices::apply_motion_setting(asked, verb, *reply);
        }
        const auto deadline = std::chrono::steady_clock::now() + 10s;
        while (std::chrono::steady_clock::now() < deadline) {
            const auto s = registry_->get("m1");
            if (s && same_motion_settings(*s, asked)) return motion_model_of(*s, 115200);
            std::this_thread::sleep_for(10ms);
        }
        ADD_FAILURE() << "the snapshot never held the controller's motion settings";
        return std::nullopt;
    }

    static bool same_motion_settings(const devices::controller_snapshot& a,
                                     const devices::controller_snapshot& b) {
        if (a.axes.size() != b.axes.size()) return false;
        for (std::size_t i = 0; i < a.axes.size(); ++i) {
            const auto& x = a.axes[i];
            const auto& y = b.axes[i];
            if (x.speed_mm_s != y.speed_mm_s || x.ramp_ms != y.ramp_ms ||
                x.finish_error_mm != y.finish_error_mm || x.backlash_mm != y.backlash_mm ||
                x.overshoot_mm != y.overshoot_mm)
                return false;
        }
        return true;
    }

    std::string raw(const std::string& line) {
        auto f = registry_->async_raw_command("m1", raw_command_request{line, std::nullopt}, "test-raw",
                                              net::use_future);
        if (f.wait_for(60s) != std::future_status::ready) {
            ADD_FAILURE() << line << ": no completion";
            return {};
        }
        auto r = f.get();
        if (!r) {
            ADD_FAILURE() << line << ": " << r.error().message;
            return {};
        }
        return r->raw_reply;
    }

    nlohmann::json state() const { return nlohmann::json::parse(sim_->state_json()); }

    // The snapshot's soft limits are read back after a command sets one: wait until they are the
    // simulator's.
    bool limits_in_the_snapshot() const {
        const auto deadline = std::chrono::steady_clock::now() + 10s;
        while (std::chrono::steady_clock::now() < deadline) {
            const auto sim = state();
            const auto s = registry_->get("m1");
            bool same = s.has_value();
            for (const auto& a : s ? s->axes : std::vector<devices::axis_state>{}) {
                const auto& expected = sim["axes"][std::string(1, a.axis)];
                same = same && a.lower_limit_mm == expected["lower_limit"].get<double>() &&
                       a.upper_limit_mm == expected["upper_limit"].get<double>();
            }
            if (same) return true;
            std::this_thread::sleep_for(10ms);
        }
        return false;
    }

    std::string dir_;
    io_thread sim_io_;
    io_thread gw_io_;
    std::shared_ptr<sim::simulator> sim_;
    std::unique_ptr<controller_registry> registry_;
};

TEST_F(snapshot_motion_model_test, reads_the_simulators_defaults) {
    start();
    const auto m = probe();
    ASSERT_TRUE(m);
    for (const char a : {'X', 'Y', 'Z'}) {
        ASSERT_TRUE(m->axes().count(a)) << a;
        const auto& p = m->axis(a);
        EXPECT_DOUBLE_EQ(p.speed_mm_s, 5.5) << a;
        EXPECT_DOUBLE_EQ(p.ramp_ms, 20) << a;
        EXPECT_NEAR(p.settle_ms, 14, 1e-6) << a;
        EXPECT_DOUBLE_EQ(p.max_speed_mm_s, 6.8) << a;
    }
}

TEST_F(snapshot_motion_model_test, reads_values_changed_on_the_controller) {
    start();
    EXPECT_EQ(raw("S X=2.5 Y=1.25"), ":A");
    EXPECT_EQ(raw("AC X=75 Z=150"), ":A");
    EXPECT_EQ(raw("PC X=0.000088 Z=0.1"), ":A");
    const auto m = probe();
    ASSERT_TRUE(m);
    EXPECT_DOUBLE_EQ(m->axis('X').speed_mm_s, 2.5);
    EXPECT_DOUBLE_EQ(m->axis('Y').speed_mm_s, 1.25);
    EXPECT_DOUBLE_EQ(m->axis('Z').speed_mm_s, 5.5);
    EXPECT_DOUBLE_EQ(m->axis('X').ramp_ms, 75);
    EXPECT_DOUBLE_EQ(m->axis('Y').ramp_ms, 20);
    EXPECT_DOUBLE_EQ(m->axis('Z').ramp_ms, 150);
    // settle = 14 ms * clamp(sqrt(0.000022 / PC), 0.1, 3)
    EXPECT_NEAR(m->axis('X').settle_ms, 7, 1e-6);
    EXPECT_NEAR(m->axis('Y').settle_ms, 14, 1e-6);
    EXPECT_NEAR(m->axis('Z').settle_ms, 1.4, 1e-6);
}

TEST_F(snapshot_motion_model_test, picks_the_lead_screw_from_counts_per_mm) {
    start("plain", 'A');
    const auto m = probe();
    ASSERT_TRUE(m);
    EXPECT_DOUBLE_EQ(m->axis('X').speed_mm_s, 1.361);
    EXPECT_NEAR(m->axis('X').settle_ms, 68, 1e-6);
    EXPECT_DOUBLE_EQ(m->axis('X').max_speed_mm_s, 1.7);
}

TEST_F(snapshot_motion_model_test, the_identification_reads_the_motion_settings) {
    start();
    const auto s = registry_->get("m1");
    ASSERT_TRUE(s);
    for (const auto& a : s->axes) {
        EXPECT_EQ(a.speed_mm_s, 5.5) << a.axis;
        EXPECT_EQ(a.ramp_ms, 20) << a.axis;
        EXPECT_TRUE(a.finish_error_mm) << a.axis;
        EXPECT_TRUE(a.backlash_mm) << a.axis;
        EXPECT_TRUE(a.overshoot_mm) << a.axis;
    }
}

// A move in micrometres; the expected busy time comes from the probed model.
struct move_row {
    const char* name;
    std::vector<std::string> settings;  // raw commands before probing
    std::vector<axis_value_um> targets;
};

TEST_F(snapshot_motion_model_test, estimate_agrees_with_the_simulated_busy_time) {
    start();
    const move_row table[] = {
        {"nine_mm", {}, {{'X', 9000}}},
        {"back_and_diagonal", {}, {{'X', 0}, {'Y', -27000}}},
        {"fifth_mm", {}, {{'Y', -26800}}},
        {"triangle_30um", {}, {{'X', 30}}},
        {"three_axes", {}, {{'X', 12000}, {'Y', 0}, {'Z', 500}}},
        {"slow_long_ramp", {"S X=1.25 Y=1.25", "AC X=150 Y=150"}, {{'X', 7000}, {'Y', 100}}},
        {"wide_finish_error", {"PC X=0.0002 Y=0.0002"}, {{'X', 16000}}},
        {"tight_finish_error", {"PC X=0.000005"}, {{'X', 15800}}},
        {"short_under_tight_error", {}, {{'X', 15805}}},
        // The probe reads B and OS: a move down runs past its target and back.
        {"backlash_down", {"PC X=0.000022", "B X=0.4 Y=0.4"}, {{'X', 2000}, {'Y', -28000}}},
        {"overshoot", {"B X=0 Y=0", "OS X=0.2"}, {{'X', 9000}}},
        // A move's leg ends at the soft limit: 0.15 mm of the 0.4 just above it, none onto it.
        {"backlash_near_the_lower_limit", {"B Y=0.4", "SL Y=-30"}, {{'Y', -29850}}},
        {"backlash_onto_the_lower_limit", {}, {{'Y', -30000}}},
    };
    for (const auto& row : table) {
        SCOPED_TRACE(row.name);
        for (const auto& s : row.settings)
            EXPECT_EQ(raw(s), ":A") << s;
        ASSERT_TRUE(limits_in_the_snapshot());
        const auto m = probe();
        ASSERT_TRUE(m);
        const auto before = state();
        std::vector<axis_delta_mm> deltas;
        for (const auto& t : row.targets) {
            const double from_units = before["axes"][std::string(1, t.axis)]["position"].get<double>();
            deltas.push_back({t.axis, (t.micrometres * 10 - from_units) / 10000.0, t.micrometres / 1000.0});
        }
        const double estimate_s = m->move_seconds(deltas);

        move_request r;
        r.axes = row.targets;
        r.wait = true;
        auto f = registry_->async_move("m1", r, "test-move", net::use_future);
        ASSERT_EQ(f.wait_for(60s), std::future_status::ready);
        const auto moved = f.get();
        ASSERT_TRUE(moved) << moved.error().message;

        // Simulated busy time: from the start of the command's motion to the last axis settled.
        const auto after = state();
        EXPECT_FALSE(after["busy"].get<bool>());
        long long start_us = -1, settled_us = 0;
        for (const auto& t : row.targets) {
            const auto& a = after["axes"][std::string(1, t.axis)];
            const auto s = a["motion_start_us"].get<long long>();
            start_us = start_us < 0 ? s : std::min(start_us, s);
            settled_us = std::max(settled_us, a["settled_us"].get<long long>());
            EXPECT_EQ(s, start_us) << "axes of one command start together";
        }
        EXPECT_GE(after["time_us"].get<long long>(), settled_us);
        const double simulated_s = static_cast<double>(settled_us - start_us) / 1e6;
        ASSERT_GT(simulated_s, 0);
        EXPECT_NEAR(estimate_s, simulated_s, 0.02 * simulated_s)
            << "estimate " << estimate_s << " s, simulated " << simulated_s << " s";
    }
}

}  // namespace
}  // namespace gw::jobs
