#pragma once
// A test fixture with the serial driver against in-process simulators: each simulator serves a real
// pty on its own io_context thread, the drivers run on another. Header-only, like the other drv_*.

#include <chrono>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>

#include "devices/serial/controller.hpp"
#include "devices/sim/sim_config.hpp"
#include "devices/sim/simulator.hpp"
#include "tests/support/drv_command_call.hpp"
#include "tests/support/drv_recording_observer.hpp"
#include "tests/support/io_thread.hpp"

namespace gw::test {

struct simulated_controller {
    std::shared_ptr<devices::sim::simulator> sim;
    std::shared_ptr<drv_recording_observer> observer = std::make_shared<drv_recording_observer>();
    std::shared_ptr<devices::controller> ctl;

    std::future<command_result> submit(devices::ms2000::command cmd) {
        return submit_command(*ctl, std::move(cmd), "it");
    }

    command_result call(devices::ms2000::command cmd) {
        return await_command(submit(std::move(cmd)), std::chrono::seconds(30));
    }
};

class drv_sim_fixture : public ::testing::Test {
  protected:
    // A simulator of `preset_name` and a started driver on it; `tune` may change the driver's settings.
    simulated_controller make(const std::string& preset_name, double time_scale = 10,
                              std::chrono::milliseconds poll = std::chrono::milliseconds(20),
                              const std::function<void(devices::controller_settings&)>& tune = {}) {
        using namespace std::chrono_literals;
        auto config = devices::sim::preset(preset_name).value();
        config.name = unique_name(preset_name + std::to_string(count_++));
        config.time_scale = time_scale;
        simulated_controller c;
        c.sim = std::make_shared<devices::sim::simulator>(sim_io_.io.get_executor(), config);
        c.sim->start();
        devices::controller_settings s;
        s.id = config.name;
        s.port = c.sim->port_path();
        s.report_port = c.sim->report_port_path();
        s.baud = config.baud;
        s.poll_interval = poll;
        s.command_timeout = 2000ms;
        s.reconnect_min = 50ms;
        s.reconnect_max = 500ms;
        if (tune) tune(s);
        c.ctl = std::make_shared<devices::controller>(drv_io_.io.get_executor(), s, c.observer);
        c.ctl->start();
        started_.push_back(c);
        return c;
    }

    void TearDown() override {
        for (auto& c : started_) {
            c.ctl->stop();
            EXPECT_TRUE(c.observer->wait_state(devices::connection_state::stopped));
            c.sim->stop();
        }
        started_.clear();
    }

    static std::string unique_name(const std::string& base) {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        return "drv-" + base + "-" + info->name() + "-" + std::to_string(::getpid());
    }

    io_thread sim_io_;
    io_thread drv_io_;
    std::vector<simulated_controller> started_;
    int count_ = 0;
};

}  // namespace gw::test
