#include "devices/ms2000/reply.hpp"

#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "devices/ms2000/error.hpp"

namespace gw::devices::ms2000 {
namespace {

struct expected_axis {
    char axis;
    std::string text;
    std::optional<double> number;
};

struct reply_case {
    std::string name;
    reply_shape shape;
    std::string line;
    reply::kind what;
    std::vector<std::string> values = {};
    std::vector<expected_axis> axes = {};
    int error_code = 0;
    bool busy = false;
    std::vector<std::string> lines = {};
};

class parse_reply_test : public ::testing::TestWithParam<reply_case> {};

TEST_P(parse_reply_test, reads_the_shape) {
    const reply_case& c = GetParam();
    const auto r = parse_reply(c.shape, c.line);
    ASSERT_TRUE(r.has_value()) << c.line;
    EXPECT_EQ(r->what, c.what);
    EXPECT_EQ(r->raw, c.line);
    EXPECT_EQ(r->values, c.values);
    ASSERT_EQ(r->axes.size(), c.axes.size());
    for (std::size_t i = 0; i < c.axes.size(); ++i) {
        EXPECT_EQ(r->axes[i].axis, c.axes[i].axis);
        EXPECT_EQ(r->axes[i].text, c.axes[i].text);
        EXPECT_EQ(r->axes[i].number, c.axes[i].number);
    }
    EXPECT_EQ(r->error_code, c.error_code);
    EXPECT_EQ(r->busy, c.busy);
    EXPECT_EQ(r->lines, c.lines);
}

using k = reply::kind;
using s = reply_shape;

INSTANTIATE_TEST_SUITE_P(
    standard, parse_reply_test,
    ::testing::Values(
        reply_case{"ack", s::standard, ":A", k::ack}, reply_case{"ack_space", s::standard, ":A ", k::ack},
        reply_case{"ack_spaces", s::standard, ":A   ", k::ack},
        reply_case{"where", s::standard, ":A 1234.5 432.1 0 ", k::ack, {"1234.5", "432.1", "0"}},
        reply_case{"where_no_space", s::standard, ":A 1234.5", k::ack, {"1234.5"}},
        reply_case{"status_byte", s::standard, ":A 138", k::ack, {"138"}},
        reply_case{"lock_state", s::standard, ":A F", k::ack, {"F"}},
        reply_case{"ccb_enabled", s::standard, ":A Z", k::ack, {"Z"}},
        reply_case{"version", s::standard, ":A Version: USB-9.2p ", k::ack, {"Version:", "USB-9.2p"}},
        reply_case{"speed",
                   s::standard,
                   ":A X=7.500000 Y=7.5",
                   k::ack,
                   {},
                   {{'X', "7.500000", 7.5}, {'Y', "7.5", 7.5}}},
        reply_case{"ccb_value", s::standard, ":A Z=12345", k::ack, {}, {{'Z', "12345", 12345}}},
        reply_case{"axis_then_a", s::standard, ":A X=42 A", k::ack, {}, {{'X', "42", 42}}},
        reply_case{"empty_value",
                   s::standard,
                   ":A X= Y=N",
                   k::ack,
                   {},
                   {{'X', "", std::nullopt}, {'Y', "N", std::nullopt}}},
        reply_case{"lower_axis", s::standard, ":A x=1", k::ack, {}, {{'X', "1", 1}}},
        reply_case{"accel",
                   s::standard,
                   ":X=50 Y=50 Z=50 A",
                   k::ack,
                   {},
                   {{'X', "50", 50}, {'Y', "50", 50}, {'Z', "50", 50}}},
        reply_case{"accel_space", s::standard, ":X=50 A ", k::ack, {}, {{'X', "50", 50}}},
        reply_case{"led", s::standard, "X=10 :A", k::ack, {}, {{'X', "10", 10}}},
        reply_case{"tgled",
                   s::standard,
                   "X=10 Y=50 Z=50 F=0 :A",
                   k::ack,
                   {},
                   {{'X', "10", 10}, {'Y', "50", 50}, {'Z', "50", 50}, {'F', "0", 0}}},
        reply_case{"led_space", s::standard, "X=0 :A ", k::ack, {}, {{'X', "0", 0}}},
        reply_case{"negative", s::standard, ":A X=-1.5", k::ack, {}, {{'X', "-1.5", -1.5}}},
        reply_case{"nan_is_text", s::standard, ":A X=nan", k::ack, {}, {{'X', "nan", std::nullopt}}},
        reply_case{"error_1", s::standard, ":N-1", k::error, {}, {}, unknown_command},
        reply_case{"error_2", s::standard, ":N-2", k::error, {}, {}, unrecognized_axis},
        reply_case{"error_3", s::standard, ":N-3 ", k::error, {}, {}, missing_parameters},
        reply_case{"error_4", s::standard, ":N-4", k::error, {}, {}, parameter_out_of_range},
        reply_case{"error_5", s::standard, ":N-5", k::error, {}, {}, operation_failed},
        reply_case{"error_6", s::standard, ":N-6", k::error, {}, {}, undefined_error},
        reply_case{"error_21", s::standard, ":N-21", k::error, {}, {}, halted},
        reply_case{"error_unlisted", s::standard, ":N-87", k::error, {}, {}, -87},
        reply_case{"error_leading_zero", s::standard, ":N-007", k::error, {}, {}, -7}),
    [](const auto& info) { return info.param.name; });

INSTANTIATE_TEST_SUITE_P(
    other_shapes, parse_reply_test,
    ::testing::Values(reply_case{"idle", s::status, "N", k::status},
                      reply_case{"idle_space", s::status, "N ", k::status},
                      reply_case{"busy", s::status, "B", k::status, {}, {}, 0, true},
                      reply_case{"status_error", s::status, ":N-1", k::error, {}, {}, -1},
                      reply_case{"build",
                                 s::multiline,
                                 "STD_XYZ\rMotor Axes: X Y Z\rRING BUFFER 50",
                                 k::text,
                                 {},
                                 {},
                                 0,
                                 false,
                                 {"STD_XYZ", "Motor Axes: X Y Z", "RING BUFFER 50"}},
                      reply_case{"build_blank_lines",
                                 s::multiline,
                                 "\rSTD_XY\r\r  \rCRISP \r",
                                 k::text,
                                 {},
                                 {},
                                 0,
                                 false,
                                 {"STD_XY", "CRISP"}},
                      reply_case{
                          "bare_name", s::multiline, "STD_XYZ", k::text, {}, {}, 0, false, {"STD_XYZ"}},
                      reply_case{"info_columns",
                                 s::multiline,
                                 "Axis: X \r    Speed(S): 7.5\r   \r",
                                 k::text,
                                 {},
                                 {},
                                 0,
                                 false,
                                 {"Axis: X", "    Speed(S): 7.5"}},
                      reply_case{"multiline_indented_error", s::multiline, "  :N-2 ", k::error, {}, {}, -2},
                      reply_case{"multiline_error", s::multiline, ":N-1", k::error, {}, {}, -1},
                      reply_case{"multiline_error_cr", s::multiline, ":N-1\r", k::error, {}, {}, -1},
                      reply_case{"multiline_ack", s::multiline, ":A 0 ", k::ack, {"0"}},
                      reply_case{"saveset_ack", s::two_phase, ":A", k::ack},
                      reply_case{"saveset_a", s::two_phase, "A", k::ack},
                      reply_case{"saveset_a_space", s::two_phase, ":A ", k::ack},
                      reply_case{"saveset_error", s::two_phase, ":N-5", k::error, {}, {}, -5}),
    [](const auto& info) { return info.param.name; });

struct bad_case {
    reply_shape shape;
    std::string line;
};

class unrecognized_test : public ::testing::TestWithParam<bad_case> {};

TEST_P(unrecognized_test, is_refused) {
    const auto r = parse_reply(GetParam().shape, GetParam().line);
    ASSERT_FALSE(r.has_value()) << GetParam().line;
    EXPECT_EQ(r.error(), make_error_code(error::unrecognized_reply));
}

INSTANTIATE_TEST_SUITE_P(
    table, unrecognized_test,
    ::testing::Values(
        bad_case{s::standard, ""}, bad_case{s::standard, "   "}, bad_case{s::standard, ":N"},
        bad_case{s::standard, ":N "}, bad_case{s::standard, ":N-"}, bad_case{s::standard, ":N-x"},
        bad_case{s::standard, ":N-1x"}, bad_case{s::standard, ":N-1 2"},
        bad_case{s::standard, ":N-99999999999"}, bad_case{s::standard, ":AB"}, bad_case{s::standard, ":A1"},
        bad_case{s::standard, "N"}, bad_case{s::standard, "B"}, bad_case{s::standard, "A"},
        bad_case{s::standard, ":"}, bad_case{s::standard, ":X=50"}, bad_case{s::standard, ":X=50 Y"},
        bad_case{s::standard, ":50 A"}, bad_case{s::standard, "X=10"}, bad_case{s::standard, "10 :A"},
        bad_case{s::standard, "I    0    0"}, bad_case{s::standard, ":E-1"}, bad_case{s::status, ""},
        bad_case{s::status, ":A"}, bad_case{s::status, "NB"}, bad_case{s::status, "n"},
        bad_case{s::status, "X"}, bad_case{s::multiline, ""}, bad_case{s::multiline, "\r\r  \r"},
        bad_case{s::multiline, ":N"}, bad_case{s::multiline, ":garbage"}, bad_case{s::two_phase, ""},
        bad_case{s::two_phase, ":"}, bad_case{s::two_phase, "AA"}, bad_case{s::two_phase, ":A 1"}));

TEST(reply, number_and_axis_accessors) {
    const auto r = parse_reply(reply_shape::standard, ":A 1234.5 x 0 ");
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->number(0), 1234.5);
    EXPECT_EQ(r->number(1), std::nullopt);
    EXPECT_EQ(r->number(2), 0.0);
    EXPECT_EQ(r->number(3), std::nullopt);

    const auto q = parse_reply(reply_shape::standard, ":X=50 Y=-2 A");
    ASSERT_TRUE(q.has_value());
    ASSERT_NE(q->axis('y'), nullptr);
    EXPECT_EQ(q->axis('Y')->number, -2.0);
    EXPECT_EQ(q->axis('Z'), nullptr);
}

TEST(parse_version, reads_both_forms) {
    const std::vector<std::pair<std::string, std::optional<std::string>>> cases{
        {":A Version: USB-9.50 ", "9.50"},
        {":A Version: USB-9.2p ", "9.2p"},
        {":A v9.54", "9.54"},
        {":A Version: 9.52", "9.52"},
        {":A", std::nullopt},
        {":A Version:", std::nullopt},
        {":A Version: USB-", std::nullopt},
        {":A vX", std::nullopt},
        {":A 12", std::nullopt},
        {":N-1", std::nullopt}};
    for (const auto& [line, version] : cases) {
        const auto r = parse_reply(reply_shape::standard, line);
        ASSERT_TRUE(r.has_value()) << line;
        EXPECT_EQ(parse_version(*r), version) << line;
    }
}

TEST(parse_position_report, reads_time_and_positions) {
    const auto p = parse_position_report("T:   400    0.0    0.1");
    ASSERT_TRUE(p.has_value());
    EXPECT_EQ(p->milliseconds, 400);
    EXPECT_EQ(p->positions, (std::vector<double>{0.0, 0.1}));

    const auto q = parse_position_report("T:200 -12.5 ");
    ASSERT_TRUE(q.has_value());
    EXPECT_EQ(q->milliseconds, 200);
    EXPECT_EQ(q->positions, (std::vector<double>{-12.5}));

    for (const std::string bad :
         {"", "T:", "T:  ", ":A 400 0.0", "T: x 1", "T: 400 1 y", "t: 400", "T: nan"}) {
        EXPECT_FALSE(parse_position_report(bad).has_value()) << bad;
    }
}

}  // namespace
}  // namespace gw::devices::ms2000
