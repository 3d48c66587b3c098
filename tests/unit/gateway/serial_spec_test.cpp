#include "gateway/config/serial_spec.hpp"

#include <gtest/gtest.h>

namespace {

struct good_case {
    const char* spec;
    const char* id;
    const char* port;
    unsigned baud;
    const char* report;
};

TEST(serial_spec, accepts_well_formed_specs) {
    const good_case cases[] = {
        {"stage1=/dev/ttyUSB0", "stage1", "/dev/ttyUSB0", 9600, ""},
        {"stage1=/dev/ttyUSB0@115200", "stage1", "/dev/ttyUSB0", 115200, ""},
        {"a-b_c=/dev/serial/by-id/usb-Silicon_Labs@x@28800", "a-b_c", "/dev/serial/by-id/usb-Silicon_Labs@x",
         28800, ""},
        {"s=/dev/ttyUSB0@19200,report=/dev/ttyUSB1", "s", "/dev/ttyUSB0", 19200, "/dev/ttyUSB1"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.spec);
        auto r = gw::parse_serial_spec(c.spec);
        ASSERT_TRUE(r.has_value()) << r.error();
        EXPECT_EQ(r->id, c.id);
        EXPECT_EQ(r->port, c.port);
        EXPECT_EQ(r->baud, c.baud);
        EXPECT_EQ(r->report_port, c.report);
    }
}

TEST(serial_spec, refuses_malformed_specs_with_a_reason) {
    const char* cases[] = {"",
                           "/dev/ttyUSB0",
                           "=/dev/ttyUSB0",
                           "id=",
                           "id=@9600",
                           "id=/dev/tty@12345",
                           "id=/dev/tty@fast",
                           "bad id=/dev/tty",
                           "id=/dev/tty,speed=3",
                           "id=/dev/tty,report="};
    for (const char* spec : cases) {
        SCOPED_TRACE(spec);
        auto r = gw::parse_serial_spec(spec);
        ASSERT_FALSE(r.has_value());
        EXPECT_FALSE(r.error().empty());
    }
}

}  // namespace
