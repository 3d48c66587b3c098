#include "devices/serial/port_candidates.hpp"

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>

#include "devices/serial/connection_problem.hpp"

namespace gw::devices {
namespace {

namespace fs = std::filesystem;

// A fake /dev: plain files stand in for the nodes (listing only resolves paths, it opens nothing).
class fake_dev : public ::testing::Test {
  protected:
    void SetUp() override {
        root_ = fs::temp_directory_path() / ("gw-fake-dev-" + std::to_string(::getpid()));
        fs::remove_all(root_);
        fs::create_directories(root_ / "serial" / "by-id");
        for (const char* n : {"ttyUSB0", "ttyUSB1", "ttyACM0", "ttyS10", "ttyS2", "ttyUSBx", "tty0", "null"})
            std::ofstream(root_ / n) << "";
        fs::create_symlink("../../ttyUSB1",
                           root_ / "serial" / "by-id" / "usb-Silicon_Labs_CP2102_0001-if00-port0");
        fs::create_symlink("../../gone", root_ / "serial" / "by-id" / "usb-dangling");
    }
    void TearDown() override { fs::remove_all(root_); }
    std::string path(const std::string& name) const { return (root_ / name).string(); }

    fs::path root_;
};

TEST_F(fake_dev, by_id_first_then_usb_acm_then_builtin_naturally_sorted) {
    const auto extra = path("elsewhere/port");
    const auto list = list_candidate_ports({extra, path("ttyUSB0")}, true, root_.string());
    std::vector<std::string> paths;
    for (const auto& c : list)
        paths.push_back(c.path);
    const std::vector<std::string> expected = {
        path("serial/by-id/usb-Silicon_Labs_CP2102_0001-if00-port0"),  // ttyUSB1 under its stable name
        path("ttyACM0"),
        path("ttyUSB0"),
        path("ttyS2"),
        path("ttyS10"),
        extra,  // asked for: listed although missing; ttyUSB0 asked again: not twice
    };
    EXPECT_EQ(paths, expected);
    EXPECT_TRUE(list.front().by_id);
    EXPECT_EQ(list.front().device, fs::canonical(root_ / "ttyUSB1").string());
    EXPECT_TRUE(list.back().device.empty());
}

TEST_F(fake_dev, only_the_paths_asked_for) {
    const auto list = list_candidate_ports({path("ttyS2")}, false, root_.string());
    ASSERT_EQ(list.size(), 1u);
    EXPECT_EQ(list[0].path, path("ttyS2"));
}

TEST(connection_problem, names_the_path_the_errno_text_and_a_hint) {
    struct expectation {
        int err;
        const char* name;
        const char* errno_text;
        const char* hint_part;
    };
    const expectation cases[] = {
        {ENOENT, "port_not_found", "No such file or directory", "/dev/serial/by-id/"},
        {EACCES, "permission_denied", "Permission denied", "dialout"},
        {EBUSY, "port_busy", "Device or resource busy", "another program"},
        {ENOTTY, "not_a_tty", "Inappropriate ioctl for device", "not a serial port"},
        {EIO, "open_failed", "Input/output error", "dmesg"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.name);
        const auto p = open_problem("/dev/ttyUSB7", c.err);
        EXPECT_EQ(p.name, c.name);
        EXPECT_EQ(p.text, std::string("cannot open /dev/ttyUSB7: ") + c.errno_text);
        EXPECT_NE(p.hint.find(c.hint_part), std::string::npos) << p.hint;
    }
    const auto unplugged = open_problem("/dev/serial/by-id/usb-FTDI_0001-if00-port0", ENOENT);
    EXPECT_EQ(unplugged.name, "port_not_found");
    EXPECT_NE(unplugged.hint.find("unplugged"), std::string::npos) << unplugged.hint;
    EXPECT_EQ(unplugged.hint.find("name the port"), std::string::npos) << unplugged.hint;

    const auto silent = no_reply_problem("/dev/ttyUSB7", "9600");
    EXPECT_EQ(silent.name, "no_reply");
    EXPECT_EQ(silent.text, "no reply on /dev/ttyUSB7 at 9600 baud");
    EXPECT_NE(silent.hint.find("DIP switches 4 and 5"), std::string::npos);
    const auto other = not_ms2000_problem("/dev/ttyUSB7", 115200, "\\x8F\\xFE", "an ASI Tiger controller");
    EXPECT_EQ(other.name, "not_ms2000");
    EXPECT_EQ(
        other.text,
        "the device on /dev/ttyUSB7 answers at 115200 baud, but not as an MS-2000 (an ASI Tiger controller): "
        "\"\\x8F\\xFE\"");
    EXPECT_NE(other.hint.find("another device"), std::string::npos);
}

}  // namespace
}  // namespace gw::devices
