#include "devices/ms2000/error.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gw::devices::ms2000 {
namespace {

struct code_case {
    int code;
    std::string name;
    std::string description;
};

class controller_error_test : public ::testing::TestWithParam<code_case> {};

TEST_P(controller_error_test, has_a_stable_name) {
    EXPECT_EQ(controller_error_name(GetParam().code), GetParam().name);
    EXPECT_EQ(controller_error_description(GetParam().code), GetParam().description);
}

INSTANTIATE_TEST_SUITE_P(
    table, controller_error_test,
    ::testing::Values(code_case{-1, "unknown_command", "Unknown Command (Not Issued in MS-2000)"},
                      code_case{-2, "unrecognized_axis", "Unrecognized Axis Parameter"},
                      code_case{-3, "missing_parameters", "Missing parameters"},
                      code_case{-4, "parameter_out_of_range", "Parameter Out of Range"},
                      code_case{-5, "operation_failed", "Operation failed"},
                      code_case{-6, "undefined_error", "Undefined Error"},
                      code_case{-21, "halted", "Serial Command halted by the HALT command"},
                      code_case{-7, "controller_error", "Unlisted controller error"},
                      code_case{0, "controller_error", "Unlisted controller error"},
                      code_case{1, "controller_error", "Unlisted controller error"},
                      code_case{-87, "controller_error", "Unlisted controller error"}));

TEST(error_code, every_value_has_a_message_in_the_ms2000_category) {
    const std::vector<error> all{
        error::timeout,          error::unrecognized_reply, error::line_too_long, error::controller_rejected,
        error::invalid_argument, error::queue_full,         error::not_connected, error::disconnected,
        error::cancelled};
    std::vector<std::string> messages;
    for (error e : all) {
        const boost::system::error_code ec = e;  // is_error_code_enum
        EXPECT_TRUE(ec.failed());
        EXPECT_EQ(&ec.category(), &error_category());
        EXPECT_STREQ(ec.category().name(), "ms2000");
        EXPECT_EQ(ec, make_error_code(e));
        EXPECT_NE(ec.message(), "unknown ms2000 error");
        for (const std::string& m : messages)
            EXPECT_NE(m, ec.message());
        messages.push_back(ec.message());
    }
    EXPECT_EQ(make_error_code(error::timeout).message(), "controller did not reply in time");
    EXPECT_EQ(error_category().message(0), "unknown ms2000 error");
}

}  // namespace
}  // namespace gw::devices::ms2000
