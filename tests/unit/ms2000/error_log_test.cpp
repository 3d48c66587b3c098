#include "devices/ms2000/error_log.hpp"

#include <gtest/gtest.h>

#include "devices/ms2000/reply_check.hpp"

namespace gw::devices::ms2000 {
namespace {

struct log_case {
    const char* line;
    bool answer;  // accepted as the answer to DU Y
    std::optional<std::vector<int>> codes;
};

class error_log_reply : public ::testing::TestWithParam<log_case> {};

TEST_P(error_log_reply, reads_the_codes_of_an_answer) {
    const auto& c = GetParam();
    const auto r = accept_reply(read_error_log(), c.line);
    ASSERT_EQ(r.has_value(), c.answer) << c.line;
    if (r) {
        EXPECT_EQ(error_log_codes(*r), c.codes) << c.line;
    }
}

INSTANTIATE_TEST_SUITE_P(
    table, error_log_reply,
    ::testing::Values(log_case{":A", true, std::vector<int>{}}, log_case{":A ", true, std::vector<int>{}},
                      log_case{":A 34 ", true, std::vector<int>{34}},
                      log_case{":A 87 87 35", true, std::vector<int>{87, 87, 35}},
                      // a late answer of another command is not the log
                      log_case{":A 0.0 12.5 ", false, std::nullopt}, log_case{":A X=15", false, std::nullopt},
                      log_case{":A NB", false, std::nullopt}, log_case{"N", false, std::nullopt},
                      log_case{":A -4", false, std::nullopt}, log_case{":A 1e3", false, std::nullopt},
                      // the firmware refusing DU Y is an answer, not a log
                      log_case{":N-1", true, std::nullopt}));

TEST(error_log, codes_beyond_the_reference_list_are_refused_as_codes) {
    reply r;
    r.values = {"34", "123456"};
    EXPECT_EQ(error_log_codes(r), std::nullopt);
}

TEST(error_log, names_the_codes_of_the_reference_list) {
    EXPECT_EQ(error_log_name(87), "TTL_REPORT_BUFFER_OVERRUN");
    EXPECT_EQ(error_log_name(34), "UPPER_LIMIT");
    EXPECT_EQ(error_log_name(35), "LOWER_LIMIT");
    EXPECT_EQ(error_log_name(85), "SCAN_LOST_PULSES");
    EXPECT_EQ(error_log_name(86), "SCAN_INCOMPLETE");
    EXPECT_EQ(error_log_name(1), "OVERTIME");
    EXPECT_EQ(error_log_name(12), "OVERSHOT");
    EXPECT_EQ(error_log_name(21), "AXIS_DEAD");
    EXPECT_EQ(error_log_name(30), "EMERGENCY_STOP");
    EXPECT_EQ(error_log_name(33), "UNKNOWN");
    EXPECT_EQ(error_log_name(0), "UNKNOWN");
}

TEST(error_log, a_read_adds_what_follows_the_earlier_read) {
    EXPECT_EQ(new_error_log_codes({}, {87, 87}), (std::vector<int>{87, 87}));
    EXPECT_EQ(new_error_log_codes({87, 87}, {87, 87, 87, 34}), (std::vector<int>{87, 34}));
    EXPECT_EQ(new_error_log_codes({87, 34}, {87, 34}), std::vector<int>{});
    // cleared elsewhere (or power-cycled) and refilled: all of it is new
    EXPECT_EQ(new_error_log_codes({87, 34}, {35}), std::vector<int>{35});
    EXPECT_EQ(new_error_log_codes({87, 34}, {87}), std::vector<int>{87});
}

TEST(error_log, commands) {
    EXPECT_EQ(read_error_log().wire, "DU Y\r");
    EXPECT_EQ(read_error_log().form.what, reply_form::kind::integers);
    EXPECT_EQ(clear_error_log().wire, "DU X\r");
}

}  // namespace
}  // namespace gw::devices::ms2000
