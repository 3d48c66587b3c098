// The ms2000-sim executable as users run it: --help, then a run with a control socket, SIGTERM.
// Skipped when the executable has not been built next to this test (it is a separate target).
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

#include <gtest/gtest.h>

#include "tests/support/sim_serial_client.hpp"

extern char** environ;

namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

fs::path executable() {
    const auto self = fs::read_symlink("/proc/self/exe");
    return self.parent_path().parent_path() / "devices" / "sim" / "ms2000-sim";
}

std::string run_and_capture(const std::string& command) {
    std::string out;
    FILE* pipe = ::popen(command.c_str(), "r");
    if (!pipe) return out;
    std::array<char, 4096> buffer{};
    while (const auto n = std::fread(buffer.data(), 1, buffer.size(), pipe))
        out.append(buffer.data(), n);
    ::pclose(pipe);
    return out;
}

TEST(ms2000_sim_executable, help_documents_options_and_control_commands) {
    if (!fs::exists(executable())) GTEST_SKIP() << "ms2000-sim not built";
    const auto help = run_and_capture(executable().string() + " --help");
    for (const char* word : {"--preset", "--link", "--report-link", "--axes", "--modules", "--lead-screw",
                             "--baud", "--time-scale", "--control", "pulse N RATE_HZ", "unplug", "replug",
                             "drop-next", "corrupt-next", "delay-next MS", "garbage N", "state"})
        EXPECT_NE(help.find(word), std::string::npos) << word;
}

TEST(ms2000_sim_executable, runs_until_sigterm_and_cleans_up) {
    if (!fs::exists(executable())) GTEST_SKIP() << "ms2000-sim not built";
    const auto dir = "/tmp/ms2000-sim-exe-" + std::to_string(::getpid());
    const auto link = dir + "/port";
    const auto control = dir + "/control.sock";
    fs::create_directories(dir);
    const std::string exe = executable().string();
    std::vector<std::string> args{exe,      "--preset", "plain",     "--name", "exe",
                                  "--link", link,       "--control", control};
    std::vector<char*> argv;
    for (auto& a : args)
        argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = 0;
    ASSERT_EQ(::posix_spawn(&pid, exe.c_str(), nullptr, nullptr, argv.data(), environ), 0);
    for (int i = 0; i < 500 && !(fs::exists(link) && fs::exists(control)); ++i)
        std::this_thread::sleep_for(20ms);
    ASSERT_TRUE(fs::exists(link));
    {
        gw::tests::sim_serial_client port(link);
        EXPECT_EQ(port.command("V"), ":A Version: USB-9.50 \r\n");
        EXPECT_EQ(port.command("BU"), "STD_XYZ\r\n");
    }
    ::kill(pid, SIGTERM);
    int status = 0;
    bool exited = false;
    for (int i = 0; i < 500 && !exited; ++i) {
        exited = ::waitpid(pid, &status, WNOHANG) == pid;
        if (!exited) std::this_thread::sleep_for(20ms);
    }
    if (!exited) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, &status, 0);
    }
    ASSERT_TRUE(exited);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    EXPECT_FALSE(fs::exists(link));
    fs::remove_all(dir);
}

}  // namespace
