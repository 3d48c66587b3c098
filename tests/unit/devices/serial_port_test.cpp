#include "devices/serial/serial_port.hpp"

#include <fcntl.h>
#include <stdlib.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>

namespace gw::devices {
namespace {

// A pty pair whose slave the port under test opens.
struct pty_pair {
    int master = -1;
    std::string slave;
    pty_pair() {
        master = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
        EXPECT_GE(master, 0);
        EXPECT_EQ(::grantpt(master), 0);
        EXPECT_EQ(::unlockpt(master), 0);
        char name[128];
        EXPECT_EQ(::ptsname_r(master, name, sizeof name), 0);
        slave = name;
    }
    ~pty_pair() { ::close(master); }
};

struct baud_case {
    unsigned baud;
    speed_t constant;  // 0: not a Bxxx rate (set through termios2)
};

class serial_port_baud_test : public ::testing::TestWithParam<baud_case> {};

TEST_P(serial_port_baud_test, opens_raw_8n1_without_flow_control) {
    boost::asio::io_context io;
    pty_pair pty;
    serial_port port(io.get_executor());
    ASSERT_FALSE(port.open(pty.slave, GetParam().baud));
    ASSERT_TRUE(port.is_open());

    termios tio{};
    ASSERT_EQ(::tcgetattr(port.stream().native_handle(), &tio), 0);
    EXPECT_EQ(tio.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
    EXPECT_EQ(tio.c_cflag & (PARENB | CSTOPB | CRTSCTS), 0u);
    EXPECT_EQ(tio.c_cflag & (CLOCAL | CREAD), static_cast<tcflag_t>(CLOCAL | CREAD));
    EXPECT_EQ(tio.c_iflag & (IXON | IXOFF | ICRNL), 0u);
    EXPECT_EQ(tio.c_lflag & (ICANON | ECHO), 0u);
    EXPECT_EQ(tio.c_oflag & OPOST, 0u);
    if (GetParam().constant != 0) {
        EXPECT_EQ(::cfgetospeed(&tio), GetParam().constant);
    }
    const int flags = ::fcntl(port.stream().native_handle(), F_GETFL);
    EXPECT_TRUE(flags & O_NONBLOCK);
    EXPECT_TRUE(port.still_present(pty.slave));
}

INSTANTIATE_TEST_SUITE_P(rates, serial_port_baud_test,
                         ::testing::Values(baud_case{9600, B9600}, baud_case{19200, B19200},
                                           baud_case{28800, 0}, baud_case{38400, B38400},
                                           baud_case{57600, B57600}, baud_case{115200, B115200}));

TEST(serial_port, refuses_an_unsupported_baud_and_a_missing_node) {
    boost::asio::io_context io;
    pty_pair pty;
    serial_port port(io.get_executor());
    EXPECT_TRUE(port.open(pty.slave, 12345));
    EXPECT_FALSE(port.is_open());
    EXPECT_TRUE(port.open("/nonexistent/tty", 9600));
    EXPECT_FALSE(port.still_present("/nonexistent/tty"));
}

TEST(serial_port, flush_input_drops_unread_bytes) {
    boost::asio::io_context io;
    pty_pair pty;
    serial_port port(io.get_executor());
    ASSERT_FALSE(port.open(pty.slave, 115200));
    ASSERT_EQ(::write(pty.master, "stale", 5), 5);
    // The pty hands bytes to the slave asynchronously: wait until all five are readable.
    for (int i = 0, available = 0; i < 400 && available < 5; ++i) {
        ::ioctl(port.stream().native_handle(), FIONREAD, &available);
        if (available < 5) ::usleep(5000);
    }
    port.flush_input();
    ASSERT_EQ(::write(pty.master, "new\r\n", 5), 5);
    char buf[32] = {};
    std::size_t got = 0;
    for (int i = 0; i < 200 && got < 5; ++i) {
        const auto n = ::read(port.stream().native_handle(), buf + got, sizeof buf - 1 - got);
        if (n > 0)
            got += static_cast<std::size_t>(n);
        else
            ::usleep(5000);  // non-blocking descriptor: poll until the bytes arrive
    }
    EXPECT_EQ(std::string(buf, got), "new\r\n");
}

}  // namespace
}  // namespace gw::devices
