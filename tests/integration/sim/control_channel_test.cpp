// The control channel on a real Unix socket, acting on a simulator on a real pty.
#include "devices/sim/control_channel.hpp"

#include <filesystem>
#include <sys/socket.h>
#include <sys/un.h>
#include <thread>
#include <unistd.h>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/sim_serial_client.hpp"

namespace gw::devices::sim {
namespace {

using namespace std::chrono_literals;

// Blocking line client for the control socket.
class control_client {
  public:
    explicit control_client(const std::string& path) {
        fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        path.copy(addr.sun_path, sizeof addr.sun_path - 1);
        if (::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
            ::close(fd_);
            fd_ = -1;
        }
        timeval tv{10, 0};
        ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    }
    ~control_client() {
        if (fd_ >= 0) ::close(fd_);
    }
    bool connected() const { return fd_ >= 0; }
    std::string ask(const std::string& line) {
        const auto out = line + "\n";
        if (::write(fd_, out.data(), out.size()) != static_cast<ssize_t>(out.size())) return "<write failed>";
        std::string answer;
        char c = 0;
        while (::read(fd_, &c, 1) == 1 && c != '\n')
            answer.push_back(c);
        return answer;
    }

  private:
    int fd_ = -1;
};

TEST(control_channel, commands_act_on_the_simulator) {
    boost::asio::io_context io;
    auto work = boost::asio::make_work_guard(io);
    const auto dir = "/tmp/ms2000-sim-ctl-" + std::to_string(::getpid());
    auto config = preset("full").value();
    config.name = "ctl";
    config.link_path = dir + "/port";
    config.report_link_path = dir + "/report";
    auto sim = std::make_shared<simulator>(io.get_executor(), config);
    sim->start();
    auto channel = std::make_shared<control_channel>(io.get_executor(), dir + "/control.sock",
                                                     std::vector<std::shared_ptr<simulator>>{sim});
    channel->start();
    std::thread runner([&io] { io.run(); });

    {
        control_client ctl(dir + "/control.sock");
        ASSERT_TRUE(ctl.connected());
        gw::tests::sim_serial_client port(sim->port_path());
        EXPECT_NE(ctl.ask("help").find("pulse N RATE_HZ"), std::string::npos);
        EXPECT_EQ(ctl.ask("list"), "ctl");
        EXPECT_EQ(ctl.ask("frobnicate").rfind("error:", 0), 0u);
        EXPECT_EQ(ctl.ask("pulse 3"), "error: usage: pulse [N RATE_HZ]");
        EXPECT_EQ(ctl.ask("drop-next"), "ok");
        EXPECT_EQ(port.command("/", 500ms), std::nullopt);
        EXPECT_EQ(ctl.ask("garbage 7"), "ok");
        EXPECT_EQ(port.drain(300ms).size(), 7u);
        EXPECT_EQ(port.command("TTL X=1"), ":A\r\n");
        EXPECT_EQ(ctl.ask("pulse 2 50"), "ok");
        nlohmann::json state;
        for (int i = 0; i < 100; ++i) {
            state = nlohmann::json::parse(ctl.ask("state"));
            if (state["reports_sent"].get<int>() == 2) break;
            std::this_thread::sleep_for(20ms);
        }
        EXPECT_EQ(state["reports_sent"].get<int>(), 2);
        EXPECT_EQ(state["ttl"]["in0_mode"].get<int>(), 1);
        EXPECT_EQ(ctl.ask("unplug"), "ok");
        EXPECT_TRUE(port.wait_for_hangup(5s));
        EXPECT_EQ(ctl.ask("replug"), "ok");
        for (int i = 0; i < 100; ++i) {
            state = nlohmann::json::parse(ctl.ask("state"));
            if (state["port"]["plugged"].get<bool>()) break;
            std::this_thread::sleep_for(20ms);
        }
        EXPECT_TRUE(state["port"]["plugged"].get<bool>());
    }
    channel->stop();
    sim->stop();
    work.reset();
    io.stop();
    runner.join();
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace gw::devices::sim
