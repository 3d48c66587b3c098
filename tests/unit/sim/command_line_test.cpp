#include "devices/sim/command_line.hpp"

#include <gtest/gtest.h>

namespace gw::devices::sim {
namespace {

using op = line_argument::op;

struct arg_case {
    char letter;
    op kind;
    double value;
    bool also_query = false;
};

struct line_case {
    const char* line;
    const char* verb;
    std::vector<arg_case> args;
};

class command_line_table : public ::testing::TestWithParam<line_case> {};

TEST_P(command_line_table, parses) {
    const auto& c = GetParam();
    const auto parsed = parse_command_line(c.line);
    ASSERT_TRUE(parsed) << c.line;
    EXPECT_EQ(parsed->verb, c.verb) << c.line;
    ASSERT_EQ(parsed->args.size(), c.args.size()) << c.line;
    for (std::size_t i = 0; i < c.args.size(); ++i) {
        EXPECT_EQ(parsed->args[i].letter, c.args[i].letter) << c.line;
        EXPECT_EQ(parsed->args[i].kind, c.args[i].kind) << c.line;
        EXPECT_DOUBLE_EQ(parsed->args[i].value, c.args[i].value) << c.line;
        EXPECT_EQ(parsed->args[i].also_query, c.args[i].also_query) << c.line;
    }
}

INSTANTIATE_TEST_SUITE_P(
    lines, command_line_table,
    ::testing::Values(
        line_case{"M X=1.5 Y", "MOVE", {{'X', op::set, 1.5}, {'Y', op::bare, 0}}},
        line_case{"move x=-10 y=+2.25", "MOVE", {{'X', op::set, -10}, {'Y', op::set, 2.25}}},
        line_case{"SCANR X=0 Y=1 Z=24", "SCANR", {{'X', op::set, 0}, {'Y', op::set, 1}, {'Z', op::set, 24}}},
        line_case{"nr x=0 y=1 z=24", "SCANR", {{'X', op::set, 0}, {'Y', op::set, 1}, {'Z', op::set, 24}}},
        line_case{"RS X?", "RDSTAT", {{'X', op::query, 0}}},
        line_case{"LED X=50?", "LED", {{'X', op::set, 50, true}}},
        line_case{"RT M+", "RTIME", {{'M', op::plus, 0}}},
        line_case{"J X- Y-", "JOYSTICK", {{'X', op::minus, 0}, {'Y', op::minus, 0}}},
        line_case{"/", "STATUS", {}}, line_case{"/ ", "STATUS", {}}, line_case{"\\", "HALT", {}},
        line_case{"!X Y", "HOME", {{'X', op::bare, 0}, {'Y', op::bare, 0}}},
        line_case{"H X", "HERE", {{'X', op::bare, 0}}},
        line_case{"  W   X  Y ", "WHERE", {{'X', op::bare, 0}, {'Y', op::bare, 0}}},
        line_case{"s x?", "SPEED", {{'X', op::query, 0}}}, line_case{"AC X=", "ACCEL", {{'X', op::set, 0}}},
        line_case{"BU X", "BUILD", {{'X', op::bare, 0}}}, line_case{"SS Z", "SAVESET", {{'Z', op::bare, 0}}},
        line_case{"CCB Z=6", "CUSTOMB", {{'Z', op::set, 6}}},
        line_case{"ld x=1e3", "LOAD", {{'X', op::set, 1000}}},
        line_case{"WRDAC X=1.1", "WRDAC", {{'X', op::set, 1.1}}},
        line_case{"FOO X=1", "FOO", {{'X', op::set, 1}}},
        line_case{"W XYZ", "WHERE", {{'X', op::bare, 0}, {'Y', op::bare, 0}, {'Z', op::bare, 0}}},
        line_case{"w xy", "WHERE", {{'X', op::bare, 0}, {'Y', op::bare, 0}}}));

TEST(command_line, rejects_malformed_arguments) {
    for (const char* bad : {"M X=abc", "M 12", "M X=1.5.5", "M X*", "M =5", "M X==1"})
        EXPECT_FALSE(parse_command_line(bad)) << bad;
}

TEST(command_line, blank_line_is_its_own_error) {
    const auto parsed = parse_command_line("   ");
    ASSERT_FALSE(parsed);
    EXPECT_EQ(parsed.error(), boost::system::errc::no_message);
}

TEST(command_line, canonical_verbs) {
    EXPECT_EQ(canonical_verb("R"), "MOVREL");
    EXPECT_EQ(canonical_verb("RM"), "RBMODE");
    EXPECT_EQ(canonical_verb("AH"), "AHOME");
    EXPECT_EQ(canonical_verb("LK"), "LOCK");
    EXPECT_EQ(canonical_verb("TTL"), "TTL");
}

}  // namespace
}  // namespace gw::devices::sim
