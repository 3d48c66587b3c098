// The simulator on real pseudo-terminals, driven like a real client: raw termios, CR-terminated
// commands, replies read with generous timeouts.
#include <chrono>
#include <filesystem>
#include <thread>
#include <unistd.h>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "devices/ms2000/report_frame.hpp"
#include "devices/sim/simulator.hpp"
#include "tests/support/sim_serial_client.hpp"

namespace gw::devices::sim {
namespace {

using namespace std::chrono_literals;
using gw::tests::sim_serial_client;

class simulator_pty : public ::testing::Test {
  protected:
    void TearDown() override {
        if (sim_) sim_->stop();
        work_.reset();
        io_.stop();
        if (thread_.joinable()) thread_.join();
        if (!dir_.empty()) std::filesystem::remove_all(dir_);
    }

    std::shared_ptr<simulator> make(const char* preset_name, double time_scale = 1.0,
                                    unsigned baud = 115200) {
        auto config = preset(preset_name).value();
        const auto dir = "/tmp/ms2000-sim-test-" + std::to_string(::getpid()) + "-" +
                         ::testing::UnitTest::GetInstance()->current_test_info()->name();
        dir_ = dir;
        config.name = "t";
        config.link_path = dir + "/port";
        config.report_link_path = dir + "/report";
        config.time_scale = time_scale;
        config.baud = baud;
        sim_ = std::make_shared<simulator>(io_.get_executor(), config);
        sim_->start();
        thread_ = std::thread([this] { io_.run(); });
        return sim_;
    }

    boost::asio::io_context io_;
    std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_{
        boost::asio::make_work_guard(io_)};
    std::thread thread_;
    std::shared_ptr<simulator> sim_;
    std::string dir_;
};

TEST_F(simulator_pty, answers_like_a_controller) {
    auto sim = make("full");
    ASSERT_TRUE(std::filesystem::is_symlink(sim->port_path()));
    EXPECT_EQ(std::filesystem::read_symlink(sim->port_path()).string(), sim->device_path());
    sim_serial_client client(sim->port_path());
    EXPECT_EQ(client.command("/"), "N\r\n");
    EXPECT_EQ(client.command("V"), ":A Version: USB-9.50 \r\n");
    EXPECT_EQ(client.command("w x y z"), ":A 0.0 0.0 0.0 \r\n");
    EXPECT_EQ(client.command("FOO"), ":N-1\r\n");
    EXPECT_EQ(client.command("WRDAC X=1"), ":N-1\r\n");  // DAC OUT not in this build
    // Doubled CR (NAV) gives one reply; LF is ignored.
    client.write("WHERE X\r\r\n");
    EXPECT_EQ(client.read_until("\r\n"), ":A 0.0 \r\n");
    EXPECT_EQ(client.drain(200ms), "");
    const auto build = client.command("BU X");
    ASSERT_TRUE(build);
    EXPECT_NE(build->find("Motor Axes: X Y Z\r"), std::string::npos);
    EXPECT_NE(build->find("TTL_REPORT_INT"), std::string::npos);
}

TEST_F(simulator_pty, move_is_busy_then_done) {
    auto sim = make("plain", 10.0);  // 10x: a 1 mm move takes about 20 ms of real time
    sim_serial_client client(sim->port_path());
    EXPECT_EQ(client.command("M X=10000"), ":A\r\n");
    EXPECT_EQ(client.command("/"), "B\r\n");
    bool done = false;
    for (int i = 0; i < 500 && !done; ++i) {
        done = client.command("/") == "N\r\n";
        if (!done) std::this_thread::sleep_for(10ms);
    }
    ASSERT_TRUE(done);
    // Targets are quantised to encoder counts: 1 mm = 45398 counts = 10000.1 tenths of a micron.
    EXPECT_EQ(client.command("W X"), ":A 10000.1 \r\n");
    const auto state = nlohmann::json::parse(sim->state_json());
    EXPECT_NEAR(state["axes"]["X"]["position"].get<double>(), 10000.0, 0.25);
    EXPECT_FALSE(state["busy"].get<bool>());
}

TEST_F(simulator_pty, saveset_answers_in_two_phases) {
    auto sim = make("plain", 1.0);
    sim_serial_client client(sim->port_path());
    client.write("SS Z\r");
    const auto first = client.read_until(":", 5s);
    ASSERT_TRUE(first);
    EXPECT_EQ(*first, ":");
    EXPECT_EQ(client.read_until("\r\n", 10s), "A\r\n");
}

TEST_F(simulator_pty, output_is_paced_at_the_baud_rate) {
    auto sim = make("plain", 1.0, 1200);  // 120 bytes/s: the INFO reply (> 1023 bytes) needs > 8 s
    sim_serial_client client(sim->port_path());
    const auto start = std::chrono::steady_clock::now();
    client.write("W X Y Z\r");  // ":A 0.0 0.0 0.0 \r\n" = 17 bytes -> at least 140 ms
    ASSERT_EQ(client.read_until("\r\n", 10s), ":A 0.0 0.0 0.0 \r\n");
    EXPECT_GE(std::chrono::steady_clock::now() - start, 120ms);
}

TEST_F(simulator_pty, unplug_gives_the_client_a_hangup_and_replug_a_new_port) {
    auto sim = make("plain");
    const auto first_device = sim->device_path();
    {
        sim_serial_client client(sim->port_path());
        ASSERT_EQ(client.command("/"), "N\r\n");
        sim->unplug();
        EXPECT_TRUE(client.wait_for_hangup(5s));
    }
    for (int i = 0; i < 200 && std::filesystem::exists(sim->port_path()); ++i)
        std::this_thread::sleep_for(10ms);
    EXPECT_FALSE(std::filesystem::exists(sim->port_path()));
    sim->replug();
    for (int i = 0; i < 200 && !std::filesystem::exists(sim->port_path()); ++i)
        std::this_thread::sleep_for(10ms);
    ASSERT_TRUE(std::filesystem::exists(sim->port_path()));
    sim_serial_client again(sim->port_path());
    EXPECT_EQ(again.command("/"), "N\r\n");
    (void)first_device;
}

TEST_F(simulator_pty, fault_injection) {
    auto sim = make("plain");
    sim_serial_client client(sim->port_path());
    sim->drop_next_reply();
    EXPECT_EQ(client.command("/", 500ms), std::nullopt);
    EXPECT_EQ(client.command("/"), "N\r\n");
    sim->corrupt_next_reply();
    const auto corrupted = client.command("W X");
    ASSERT_TRUE(corrupted);
    EXPECT_NE(corrupted->substr(0, 2), ":A");
    EXPECT_EQ(corrupted->substr(corrupted->size() - 2), "\r\n");
    sim->delay_next_reply(300ms);
    const auto start = std::chrono::steady_clock::now();
    EXPECT_EQ(client.command("/"), "N\r\n");
    EXPECT_GE(std::chrono::steady_clock::now() - start, 250ms);
    sim->emit_garbage(20);
    const auto garbage = client.drain(500ms);
    EXPECT_EQ(garbage.size(), 20u);
    EXPECT_EQ(garbage.find_first_of("\r\n"), std::string::npos);
}

TEST_F(simulator_pty, report_port_delivers_decodable_frames) {
    auto sim = make("full");
    ASSERT_FALSE(sim->report_port_path().empty());
    sim_serial_client client(sim->port_path());
    sim_serial_client report(sim->report_port_path());
    ASSERT_EQ(client.command("H X=1000 Y=-20"), ":A\r\n");
    ASSERT_EQ(client.command("TTL X=1"), ":A\r\n");
    ms2000::report_decoder decoder(ms2000::report_format::binary, 3);
    std::vector<ms2000::report_frame> frames;
    const auto collect = [&](std::size_t want) {
        const auto deadline = std::chrono::steady_clock::now() + 10s;
        while (frames.size() < want && std::chrono::steady_clock::now() < deadline) {
            const auto bytes = report.drain(100ms);
            decoder.feed(std::span(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()),
                         frames);
        }
    };
    sim->ttl_pulse_train(3, 50);  // 20 ms apart: slower than the 1.7 ms re-trigger time
    collect(3);
    ASSERT_EQ(frames.size(), 3u);
    EXPECT_TRUE(nlohmann::json::parse(sim->state_json())["errors"].empty());
    // Two edges at once: the second comes before the first frame is out -> error 87, no frame.
    sim->ttl_pulse();
    sim->ttl_pulse();
    collect(4);
    const auto rest = report.drain(300ms);  // no fifth frame follows
    decoder.feed(std::span(reinterpret_cast<const std::uint8_t*>(rest.data()), rest.size()), frames);
    EXPECT_EQ(frames.size(), 4u);
    const auto errors = nlohmann::json::parse(sim->state_json())["errors"];
    ASSERT_EQ(errors.size(), 1u);
    EXPECT_EQ(errors[0].get<int>(), 87);
    ASSERT_EQ(frames[0].axes.size(), 3u);
    EXPECT_EQ(frames[0].axes[0].axis, 'X');
    // 0.1 mm at 45397.6 counts/mm
    EXPECT_NEAR(frames[0].axes[0].count, 4540, 1);
    EXPECT_NEAR(frames[0].axes[1].count, -91, 1);
}

}  // namespace
}  // namespace gw::devices::sim
