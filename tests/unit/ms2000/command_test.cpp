#include "devices/ms2000/command.hpp"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "devices/ms2000/error.hpp"

namespace gw::devices::ms2000 {
namespace {

struct number_case {
    double value;
    int decimals;
    std::string expected;
};

class format_number_test : public ::testing::TestWithParam<number_case> {};

TEST_P(format_number_test, formats_like_the_controller_reads) {
    const number_case& c = GetParam();
    EXPECT_EQ(format_number(c.value, c.decimals), c.expected);
}

INSTANTIATE_TEST_SUITE_P(table, format_number_test,
                         ::testing::Values(number_case{0, 4, "0"}, number_case{-0.0, 4, "0"},
                                           number_case{-0.00001, 4, "0"}, number_case{1.5, 4, "1.5"},
                                           number_case{1234.5, 1, "1234.5"}, number_case{-10, 4, "-10"},
                                           number_case{100, 0, "100"}, number_case{0.25, 1, "0.2"},
                                           number_case{7.5, 6, "7.5"}, number_case{1.23456789, 4, "1.2346"},
                                           number_case{-1.23456789, 2, "-1.23"},
                                           number_case{1e6, 3, "1000000"}, number_case{10.0, 3, "10"},
                                           number_case{2.0000001, 4, "2"}));

TEST(format_number, clamps_decimals) {
    EXPECT_EQ(format_number(1.123456789123, 50), "1.123456789");
    EXPECT_EQ(format_number(1.5, -3), "2");
    EXPECT_EQ(format_number(-2.5, 0), "-2");  // to_chars rounds half to even
}

TEST(format_number, refuses_non_finite) {
    EXPECT_EQ(format_number(std::numeric_limits<double>::quiet_NaN(), 4), "");
    EXPECT_EQ(format_number(std::numeric_limits<double>::infinity(), 4), "");
    EXPECT_EQ(format_number(-std::numeric_limits<double>::infinity(), 4), "");
}

TEST(format_number, never_uses_exponent) {
    const std::string text = format_number(1e20, 2);
    EXPECT_EQ(text, "100000000000000000000");
    EXPECT_EQ(format_number(1e-20, 4), "0");
}

struct builder_case {
    std::string name;
    command cmd;
    std::string wire;
    std::string verb;
    reply_shape expect;
    bool is_halt;
    bool long_reply;
};

class typed_builder_test : public ::testing::TestWithParam<builder_case> {};

TEST_P(typed_builder_test, builds_the_documented_wire_form) {
    const builder_case& c = GetParam();
    EXPECT_EQ(c.cmd.wire, c.wire);
    EXPECT_EQ(c.cmd.verb, c.verb);
    EXPECT_EQ(c.cmd.expect, c.expect);
    EXPECT_EQ(c.cmd.is_halt, c.is_halt);
    EXPECT_EQ(c.cmd.long_reply, c.long_reply);
}

INSTANTIATE_TEST_SUITE_P(
    table, typed_builder_test,
    ::testing::Values(
        builder_case{"status", status(), "/\r", "/", reply_shape::status, false, false},
        builder_case{"halt", halt(), "\\\r", "\\", reply_shape::standard, true, false},
        builder_case{"where", where("XYZ"), "W X Y Z\r", "W", reply_shape::standard, false, false},
        builder_case{"where_spaced_lower", where("x y"), "W X Y\r", "W", reply_shape::standard, false, false},
        builder_case{"where_injection", where("X\rM Y=2"), "W X M Y\r", "W", reply_shape::standard, false,
                     false},
        builder_case{"version", version(), "V\r", "V", reply_shape::standard, false, false},
        builder_case{"build_x", build_x(), "BU X\r", "BU", reply_shape::multiline, false, true},
        builder_case{"who", who(), "WHO\r", "WHO", reply_shape::multiline, false, true},
        builder_case{"query", query("CNTS", "XY"), "CNTS X? Y?\r", "CNTS", reply_shape::standard, false,
                     false},
        builder_case{"query_lower", query("speed", "z"), "SPEED Z?\r", "SPEED", reply_shape::standard, false,
                     false},
        builder_case{"query_injection", query("S\rM", "X"), "SM X?\r", "SM", reply_shape::standard, false,
                     false},
        builder_case{"zero", zero(), "Z\r", "Z", reply_shape::standard, false, false},
        builder_case{"home", home("XY"), "! X Y\r", "!", reply_shape::standard, false, false},
        builder_case{"save_settings", save_settings(), "SS Z\r", "SS", reply_shape::two_phase, false, true}),
    [](const auto& info) { return info.param.name; });

TEST(move, converts_micrometres_to_tenths_of_a_micron) {
    const std::vector<axis_position> to{{'X', 123.45}, {'y', -1}};
    const auto c = ms2000::move(to);
    ASSERT_TRUE(c.has_value());
    EXPECT_EQ(c->wire, "M X=1234.5 Y=-10\r");
    EXPECT_EQ(c->verb, "M");
    EXPECT_EQ(c->expect, reply_shape::standard);
    EXPECT_FALSE(c->long_reply);
}

TEST(move, braced_list) {
    const auto c = move({{'Z', -0.05}, {'F', 1e-9}});
    ASSERT_TRUE(c.has_value());
    EXPECT_EQ(c->wire, "M Z=-0.5 F=0\r");
    EXPECT_FALSE(move({}).has_value());
    EXPECT_EQ(move_relative({{'X', 2.5}})->wire, "R X=25\r");
    EXPECT_EQ(here({{'Y', 0}})->wire, "H Y=0\r");
}

TEST(move, relative_and_here) {
    const std::vector<axis_position> by{{'X', 1}};
    const auto r = move_relative(by);
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->wire, "R X=10\r");
    const std::vector<axis_position> at{{'X', 0}, {'Y', -0.0}};
    const auto h = here(at);
    ASSERT_TRUE(h.has_value());
    EXPECT_EQ(h->wire, "H X=0 Y=0\r");
}

TEST(move, refuses_bad_positions) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    const std::vector<std::vector<axis_position>> bad{
        {},                    // nothing to move
        {{'X', nan}},          // not a number
        {{'X', inf}},          // infinite
        {{'X', -inf}},         // infinite
        {{'\r', 1}},           // control byte as an axis
        {{'1', 1}},            // digit as an axis
        {{'=', 1}},            // punctuation as an axis
        {{'X', 1}, {'x', 2}},  // the same axis twice
        {{'X', 1e300}},        // absurdly far
    };
    for (const auto& list : bad) {
        const auto m = ms2000::move(list);
        ASSERT_FALSE(m.has_value());
        EXPECT_EQ(m.error(), make_error_code(error::invalid_argument));
        EXPECT_FALSE(move_relative(list).has_value());
        EXPECT_FALSE(here(list).has_value());
    }
}

TEST(make_command, all_argument_kinds) {
    const std::vector<argument> args{{'x', argument::op::bare},  {'Y', argument::op::set, 1.25, 4},
                                     {'Z', argument::op::query}, {'F', argument::op::plus},
                                     {'T', argument::op::minus}, {'R', argument::op::set, -3.14159, 2}};
    const auto c = make_command("ttl", args);
    ASSERT_TRUE(c.has_value());
    EXPECT_EQ(c->wire, "TTL X Y=1.25 Z? F+ T- R=-3.14\r");
    EXPECT_EQ(c->verb, "TTL");
}

TEST(make_command, explicit_shape_sets_long_reply) {
    const auto c = make_command("INFO", std::vector<argument>{{'X'}}, reply_shape::multiline);
    ASSERT_TRUE(c.has_value());
    EXPECT_EQ(c->wire, "INFO X\r");
    EXPECT_TRUE(c->long_reply);
    EXPECT_EQ(c->expect, reply_shape::multiline);
}

TEST(make_command, single_character_verbs) {
    for (const std::string verb : {"/", "\\", "!", "@", "~"}) {
        const auto c = make_command(verb, {});
        ASSERT_TRUE(c.has_value()) << verb;
        EXPECT_EQ(c->wire, verb + "\r");
    }
    EXPECT_TRUE(make_command("HALT", {})->is_halt);
    EXPECT_TRUE(make_command("\\", {})->is_halt);
    EXPECT_FALSE(make_command("H", {})->is_halt);
}

TEST(make_command, refuses_bad_verbs) {
    for (const std::string& verb :
         std::vector<std::string>{"", "M X", "M\r", "M\n", "W\x7f", "ABCDEFGHIJKLM", "?", "//",
                                  "M=", "\xc3\xa9", std::string("M\0", 2)}) {
        const auto c = make_command(verb, {});
        ASSERT_FALSE(c.has_value()) << verb;
        EXPECT_EQ(c.error(), make_error_code(error::invalid_argument));
    }
    EXPECT_TRUE(make_command("ABCDEFGHIJKL", {}).has_value());  // 12 characters
}

TEST(make_command, refuses_bad_arguments) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const std::vector<argument> bad{{'\r', argument::op::bare},         {'\n', argument::op::set, 1},
                                    {' ', argument::op::query},         {'X', argument::op::set, nan},
                                    {'X', argument::op::set, 1, -1},    {'X', argument::op::set, 1, 50},
                                    {'X', static_cast<argument::op>(9)}};
    for (const argument& a : bad) {
        const auto c = make_command("S", std::vector<argument>{a});
        ASSERT_FALSE(c.has_value());
        EXPECT_EQ(c.error(), make_error_code(error::invalid_argument));
    }
}

struct raw_case {
    std::string line;
    std::string wire;
    std::string verb;
    reply_shape expect;
    bool is_halt;
};

class raw_command_test : public ::testing::TestWithParam<raw_case> {};

TEST_P(raw_command_test, infers_the_reply_shape) {
    const raw_case& c = GetParam();
    const auto cmd = raw_command(c.line);
    ASSERT_TRUE(cmd.has_value()) << c.line;
    EXPECT_EQ(cmd->wire, c.wire);
    EXPECT_EQ(cmd->verb, c.verb);
    EXPECT_EQ(cmd->expect, c.expect);
    EXPECT_EQ(cmd->is_halt, c.is_halt);
    EXPECT_EQ(cmd->long_reply, c.expect == reply_shape::multiline || c.expect == reply_shape::two_phase);
}

INSTANTIATE_TEST_SUITE_P(
    table, raw_command_test,
    ::testing::Values(raw_case{"W X Y", "W X Y\r", "W", reply_shape::standard, false},
                      raw_case{"where x y", "WHERE x y\r", "WHERE", reply_shape::standard, false},
                      raw_case{"move X=10", "MOVE X=10\r", "MOVE", reply_shape::standard, false},
                      raw_case{"  M X=1  ", "M X=1\r", "M", reply_shape::standard, false},
                      raw_case{"/", "/\r", "/", reply_shape::status, false},
                      raw_case{"/ ", "/\r", "/", reply_shape::status, false},
                      raw_case{"status", "STATUS\r", "STATUS", reply_shape::status, false},
                      raw_case{"BU X", "BU X\r", "BU", reply_shape::multiline, false},
                      raw_case{"build x", "BUILD x\r", "BUILD", reply_shape::multiline, false},
                      raw_case{"BU", "BU\r", "BU", reply_shape::multiline, false},
                      raw_case{"BU Y?", "BU Y?\r", "BU", reply_shape::standard, false},
                      raw_case{"INFO X", "INFO X\r", "INFO", reply_shape::multiline, false},
                      raw_case{"I Y", "I Y\r", "I", reply_shape::multiline, false},
                      raw_case{"WHO", "WHO\r", "WHO", reply_shape::multiline, false},
                      raw_case{"N", "N\r", "N", reply_shape::multiline, false},
                      raw_case{"SS Z", "SS Z\r", "SS", reply_shape::two_phase, false},
                      raw_case{"saveset z", "SAVESET z\r", "SAVESET", reply_shape::two_phase, false},
                      raw_case{"SS X", "SS X\r", "SS", reply_shape::standard, false},
                      raw_case{"HALT", "HALT\r", "HALT", reply_shape::standard, true},
                      raw_case{"\\", "\\\r", "\\", reply_shape::standard, true},
                      raw_case{"halt", "HALT\r", "HALT", reply_shape::standard, true},
                      raw_case{"LK X?", "LK X?\r", "LK", reply_shape::standard, false},
                      raw_case{"! X Y", "! X Y\r", "!", reply_shape::standard, false}));

TEST(raw_command, refuses_injection_and_non_printable) {
    const std::vector<std::string> bad{
        "",       "   ",     "X=1\rM Y=2",      "W X\r",
        "W X\n",  "W X\r\n", "M X=1\nM Y=2",    std::string("W\0X", 3),
        "W\tX",   "W X\x7f", "W \x1b[2J",       "W \xc3\xa9",
        "W \x80", "M=3 X",   "ABCDEFGHIJKLM X", std::string(max_raw_command_bytes + 1, 'W')};
    for (const std::string& line : bad) {
        const auto c = raw_command(line);
        ASSERT_FALSE(c.has_value()) << line;
        EXPECT_EQ(c.error(), make_error_code(error::invalid_argument));
    }
    // RDSBYTE answers raw bytes, which a JSON answer cannot carry.
    for (const std::string line : {"RB X", "rdsbyte X Y"})
        EXPECT_EQ(raw_command(line).error(), make_error_code(error::binary_reply)) << line;
}

TEST(raw_command, accepts_the_longest_line) {
    std::string line = "W";
    line.resize(max_raw_command_bytes, ' ');
    line.back() = 'X';
    const auto c = raw_command(line);
    ASSERT_TRUE(c.has_value());
    EXPECT_EQ(c->wire.back(), '\r');
}

TEST(command, only_reads_tells_reads_from_commands_that_may_change_something) {
    struct row {
        std::string line;
        bool reads;
    };
    const row rows[] = {
        {"W X Y", true},  {"WHERE X", true},      {"/", true},          {"STATUS", true},
        {"RS X", true},   {"RDSTAT X Y", true},   {"V", true},          {"BU X", true},
        {"WHO", true},    {"INFO X", true},       {"CNTS X? Y?", true}, {"SL X?", true},
        {"TTL X?", true}, {"M X=10", false},      {"R X=1", false},     {"! X", false},
        {"HALT", false},  {"Z", false},           {"SL X=-5", false},   {"TTL X=1", false},
        {"SS Z", false},  {"CNTS X? Y=2", false}, {"ARRAY", false},     {"SPIN X=1", false},
    };
    for (const auto& r : rows) {
        auto cmd = raw_command(r.line);
        ASSERT_TRUE(cmd) << r.line;
        EXPECT_EQ(only_reads(*cmd), r.reads) << r.line;
    }
    EXPECT_TRUE(only_reads(where("XY")));
    EXPECT_TRUE(only_reads(status()));
    EXPECT_TRUE(only_reads(query("CNTS", "XYZ")));
    EXPECT_FALSE(only_reads(halt()));
    EXPECT_FALSE(only_reads(zero()));
}

TEST(command, resets_or_recalibrates_names_what_a_caller_must_insist_on) {
    struct row {
        std::string line;
        bool resets;
    };
    const row rows[] = {
        {"~", true},        {"RESET", true},         {"SS X", true},       {"SAVESET X", true},
        {"ss x", true},     {"UM X=-10000", true},   {"UM X=1 Y=2", true}, {"CNTS X=1000", true},
        {"C X=1000", true}, {"BAUD X=115200", true}, {"SS Z", false},      {"SS Y", false},
        {"UM X?", false},   {"CNTS X? Y?", false},   {"C X?", false},      {"W X", false},
        {"M X=10", false},  {"SU X=50", false},      {"SPEED X=2", false}, {"UNITS", false},
    };
    for (const auto& r : rows) {
        auto cmd = raw_command(r.line);
        ASSERT_TRUE(cmd) << r.line;
        EXPECT_EQ(!resets_or_recalibrates(*cmd).empty(), r.resets) << r.line;
    }
    EXPECT_TRUE(resets_or_recalibrates(query("CNTS", "XYZ")).empty());
    EXPECT_TRUE(resets_or_recalibrates(halt()).empty());
}

TEST(verbatim_command, sends_the_line_as_it_came) {
    struct row {
        std::string_view line;
        std::string_view verb;
        reply_shape expect;
        reply_form::kind form;
    };
    const row rows[] = {
        {"w x y", "W", reply_shape::standard, reply_form::kind::numbers},
        {"  W X", "W", reply_shape::standard, reply_form::kind::numbers},
        {"MOVE X=1 ", "MOVE", reply_shape::standard, reply_form::kind::bare_ack},
        {"/", "/", reply_shape::status, reply_form::kind::any},
        {"\\", "\\", reply_shape::standard, reply_form::kind::bare_ack},
        {"bu x", "BU", reply_shape::multiline, reply_form::kind::build_text},
        {"ss z", "SS", reply_shape::two_phase, reply_form::kind::any},
        {"s x?", "S", reply_shape::standard, reply_form::kind::axis_values},
        {"RB X", "RB", reply_shape::status_bytes, reply_form::kind::status_bytes},
        {"rdsbyte xy z", "RDSBYTE", reply_shape::status_bytes, reply_form::kind::status_bytes},
        {"RB X=1", "RB", reply_shape::standard, reply_form::kind::any},  // no byte count to expect
    };
    for (const auto& r : rows) {
        auto cmd = verbatim_command(r.line);
        ASSERT_TRUE(cmd) << r.line;
        EXPECT_EQ(cmd->wire, std::string(r.line) + "\r") << r.line;
        EXPECT_EQ(cmd->verb, r.verb) << r.line;
        EXPECT_EQ(cmd->expect, r.expect) << r.line;
        EXPECT_EQ(cmd->form.what, r.form) << r.line;
    }
    EXPECT_TRUE(verbatim_command("\\")->is_halt);
    EXPECT_TRUE(verbatim_command("halt")->is_halt);
    EXPECT_EQ(verbatim_command("rdsbyte xy z")->form.axes, "XYZ");
}

TEST(verbatim_command, refuses_what_cannot_be_one_line_of_ascii) {
    for (std::string_view line : {"", "   ", "W X\r", "W\nX", "W \x01", "M=X", "ABCDEFGHIJKLM X"})
        EXPECT_FALSE(verbatim_command(line)) << line;
    EXPECT_FALSE(verbatim_command(std::string(max_raw_command_bytes + 1, 'W')));
    const std::string high = "W \xC3\xA9";
    EXPECT_FALSE(verbatim_command(high));
}

TEST(command_effect, tells_what_a_line_may_do) {
    struct row {
        std::string_view line;
        command_effect effect;
    };
    const row rows[] = {
        {"W X", command_effect::reads},
        {"/", command_effect::reads},
        {"RB X Y", command_effect::reads},
        {"S X? Y?", command_effect::reads},
        {"BU X", command_effect::reads},
        {"\\", command_effect::halts},
        {"HALT", command_effect::halts},
        {"M X=10", command_effect::acts},
        {"r x=1", command_effect::acts},
        {"S X=2", command_effect::acts},
        {"UM X=-10000 Y=10000", command_effect::acts},
        {"TTL X=1", command_effect::acts},
        {"CCA Y", command_effect::acts},
        {"SS Z", command_effect::writes_flash},
        {"SAVESET X", command_effect::writes_flash},
        {"SP", command_effect::writes_flash},
        {"~", command_effect::breaks_link},
        {"RESET", command_effect::breaks_link},
        {"BAUD X=9600", command_effect::breaks_link},
        {"FOO X=1", command_effect::unknown},
        {"XYZZY", command_effect::unknown},
    };
    for (const auto& r : rows) {
        auto cmd = verbatim_command(r.line);
        ASSERT_TRUE(cmd) << r.line;
        EXPECT_EQ(effect_of(*cmd), r.effect) << r.line << ": " << to_string(effect_of(*cmd));
    }
}

}  // namespace
}  // namespace gw::devices::ms2000
