#include "api/app/startup_summary.hpp"

#include <gtest/gtest.h>

namespace gw {
namespace {

namespace ip = boost::asio::ip;

devices::controller_snapshot controller(std::string id, std::string port) {
    devices::controller_snapshot s;
    s.id = std::move(id);
    s.port = std::move(port);
    return s;
}

TEST(startup_summary, names_the_url_the_storage_and_every_controller) {
    const ip::tcp::endpoint http(ip::make_address("127.0.0.1"), 8080);
    EXPECT_EQ(
        startup_summary(http_url(http), "/var/lib/asi-gateway",
                        {controller("sim1", "/tmp/gw/sim1/port"), controller("stage1", "/dev/ttyUSB0")}, {}),
        "serving http://127.0.0.1:8080/ (storage /var/lib/asi-gateway; controllers: sim1 on "
        "/tmp/gw/sim1/port, stage1 on /dev/ttyUSB0)");
    EXPECT_EQ(startup_summary(http_url(http), "/s", {}, {"mqtt://broker:1883", "mqtts://b2:8883"}),
              "serving http://127.0.0.1:8080/ (storage /s; controllers: none; MQTT to mqtt://broker:1883, "
              "mqtts://b2:8883)");
}

TEST(startup_summary, names_where_a_controller_is_shared) {
    const ip::tcp::endpoint http(ip::make_address("127.0.0.1"), 8080);
    EXPECT_EQ(
        startup_summary(http_url(http), "/s",
                        {controller("sim1", "/tmp/gw/sim1/port"), controller("s2", "/dev/ttyS0")}, {},
                        {{"sim1", "pty /tmp/gw/sim1/share, tcp 127.0.0.1:7001"}}),
        "serving http://127.0.0.1:8080/ (storage /s; controllers: sim1 on /tmp/gw/sim1/port shared at pty "
        "/tmp/gw/sim1/share, tcp 127.0.0.1:7001, s2 on /dev/ttyS0)");
}

TEST(startup_summary, ipv6_hosts_are_bracketed) {
    EXPECT_EQ(http_url(ip::tcp::endpoint(ip::make_address("::1"), 9000)), "http://[::1]:9000/");
    EXPECT_EQ(http_url(ip::tcp::endpoint(ip::make_address("0.0.0.0"), 80)), "http://0.0.0.0:80/");
    EXPECT_EQ(http_url(ip::tcp::endpoint(ip::make_address("::1"), 8443), true), "https://[::1]:8443/");
}

}  // namespace
}  // namespace gw
