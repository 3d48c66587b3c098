// Reply shapes and error codes of the pure model, one command at a time on a fresh controller.
#include <gtest/gtest.h>

#include "tests/unit/sim/model_test_util.hpp"

namespace gw::devices::sim {
namespace {

using namespace test;

struct reply_case {
    const char* preset;
    const char* line;
    const char* reply;
};

void PrintTo(const reply_case& c, std::ostream* os) {
    *os << c.preset << ": " << c.line;
}

class model_reply : public ::testing::TestWithParam<reply_case> {};

TEST_P(model_reply, matches) {
    const auto& c = GetParam();
    ms2000_model m(config_for(c.preset));
    EXPECT_EQ(send(m, c.line, sim_time{0}), c.reply);
}

INSTANTIATE_TEST_SUITE_P(
    shapes, model_reply,
    ::testing::Values(
        // STATUS: no colon (doc §2.3); QUDI's "/ " with a trailing space.
        reply_case{"plain", "/", "N\r\n"}, reply_case{"plain", "/ ", "N\r\n"},
        reply_case{"plain", "STATUS", "N\r\n"}, reply_case{"plain", "\\", ":A\r\n"},
        reply_case{"plain", "HALT", ":A\r\n"},
        // ":A X=.." shape (S, PC, CNTS, SU, SL, HM, ...)
        reply_case{"plain", "S X?", ":A X=5.500000 \r\n"},
        reply_case{"plain", "speed x? y?", ":A X=5.500000 Y=5.500000 \r\n"},
        reply_case{"plain", "PC X?", ":A X=0.000022 \r\n"},
        reply_case{"plain", "CNTS X?", ":A X=45397.6 \r\n"}, reply_case{"plain", "SU X?", ":A X=110 \r\n"},
        reply_case{"plain", "SL Y?", ":A Y=-110 \r\n"}, reply_case{"plain", "HM X?", ":A X=1000.000 \r\n"},
        reply_case{"plain", "UM X?", ":A X=10000 \r\n"},
        // ":X=.. A" shape (AC, B, WT, E)
        reply_case{"plain", "AC X? Y? Z?", ":X=20 Y=20 Z=20 A\r\n"},
        reply_case{"plain", "B X?", ":X=0 A\r\n"}, reply_case{"plain", "WT X?", ":X=0 A\r\n"},
        reply_case{"plain", "E X?", ":X=0.0004 A\r\n"},
        // "X=.. :A" shape (LED), also for QUDI's set-and-query "LED X=50?"
        reply_case{"planar", "LED X?", "X=0 :A\r\n"}, reply_case{"planar", "LED X=50?", "X=50 :A\r\n"},
        reply_case{"planar", "LED X=50", ":A\r\n"}, reply_case{"planar", "LED X=100", ":N-4\r\n"},
        // WHERE: hardware order, one decimal
        reply_case{"plain", "W X Y Z", ":A 0.0 0.0 0.0 \r\n"},
        reply_case{"plain", "W Z X", ":A 0.0 0.0 \r\n"}, reply_case{"plain", "W F", ":N-2\r\n"},
        // RDSTAT
        reply_case{"plain", "RS X?", ":A N\r\n"}, reply_case{"plain", "RS X? Y?", ":A NN\r\n"},
        reply_case{"plain", "RS X", ":A 10 \r\n"}, reply_case{"plain", "RS X+", ":A  \r\n"},
        // RDSBYTE: the same byte, raw (10 = enabled, joystick on)
        reply_case{"plain", "RB X", ":\x0a\r\n"}, reply_case{"plain", "RB X Y", ":\x0a\x0a\r\n"},
        reply_case{"plain", "RB Q", ":N-2\r\n"},
        // servo settings INFO lists: overshoot as O (INFO's name) and OS, Kv, the joystick input
        reply_case{"plain", "O X?", ":A X=0 \r\n"}, reply_case{"plain", "OS X=0.01?", ":A X=0.01 \r\n"},
        reply_case{"plain", "KV X?", ":A X=15 \r\n"}, reply_case{"plain", "KV X=20 Y?", ":A Y=15 \r\n"},
        reply_case{"plain", "J X? Y? Z?", ":A X=2 Y=3 Z=22 \r\n"}, reply_case{"plain", "J X=100", ":N-4\r\n"},
        // the error log: DU Y reads it, DU X? reads without clearing
        reply_case{"plain", "DU Y", ":A \r\n"}, reply_case{"plain", "DU X?", ":A \r\n"},
        // identity
        reply_case{"plain", "V", ":A Version: USB-9.50 \r\n"}, reply_case{"plain", "BU", "STD_XYZ\r\n"},
        reply_case{"plain", "BU X", "STD_XYZ\rMotor Axes: X Y Z\rCMDs: XYZFTR\rBootLdr V:1\rHdwr REV.E\r\n"},
        reply_case{"plain", "bu z?", ":A 0 \r\n"}, reply_case{"plain", "WHO", ":A ASI-MS2000 STD_XYZ \r\n"},
        // errors
        reply_case{"plain", "XYZZY", ":N-1\r\n"}, reply_case{"plain", "M Q=5", ":N-2\r\n"},
        reply_case{"plain", "M", ":N-3\r\n"}, reply_case{"plain", "AA X=120", ":N-4\r\n"},
        reply_case{"plain", "M X=abc", ":N-6\r\n"}, reply_case{"plain", "SU X=-200", ":N-4\r\n"},
        // commands of modules the build lacks -> ":N-1" (MM-Stage HasCommand)
        reply_case{"plain", "LD X=1", ":N-1\r\n"}, reply_case{"plain", "ARRAY", ":N-1\r\n"},
        reply_case{"plain", "SCANR X=0 Y=1 Z=24", ":N-1\r\n"}, reply_case{"plain", "WRDAC X=1", ":N-1\r\n"},
        reply_case{"plain", "LED X?", ":N-1\r\n"}, reply_case{"plain", "CCB Z=1", ":N-1\r\n"},
        reply_case{"plain", "LK X?", ":N-1\r\n"},
        // DAC OUT (seed: "WRDAC X=20 OR -1 -> :N-4")
        reply_case{"planar", "WRDAC X=1.1", ":A\r\n"}, reply_case{"planar", "WRDAC X=20", ":N-4\r\n"},
        reply_case{"planar", "WRDAC X=-1", ":N-4\r\n"},
        // SCAN limits: divide and pixels below 32768
        reply_case{"full", "SCANR X=0 Y=1 Z=24", ":A\r\n"},
        reply_case{"full", "SCANR X=0 Y=1 Z=32768", ":N-4\r\n"},
        reply_case{"full", "SCANR X=0 Y=1 Z=1", ":N-4\r\n"},
        reply_case{"full", "SCANR X=0 F=40000 Z=2", ":N-4\r\n"},
        // CRISP
        reply_case{"crisp", "LK X?", ":A I\r\n"},
        // SAVESET first phase
        reply_case{"plain", "SS Z", ":"}, reply_case{"plain", "SS X", ":A\r\n"},
        // planar correction needs three points first
        reply_case{"planar", "CCB Z=4", ":N-5\r\n"}, reply_case{"planar", "CCB Z=8", ":A 1 \r\n"},
        reply_case{"planar", "CCB Z=10", ":N-4\r\n"}, reply_case{"planar", "CCB Z=6", ":A Z=0 \r\n"}));

TEST(model_framing, cr_ends_commands_lf_ignored_del_flushes) {
    ms2000_model m(config_for("plain"));
    EXPECT_EQ(m.feed("W X\r\nW Y\r", sim_time{0}), ":A 0.0 \r\n:A 0.0 \r\n");
    EXPECT_EQ(m.feed("W", sim_time{0}), "");
    EXPECT_EQ(m.feed(" X\r", sim_time{0}), ":A 0.0 \r\n");
    EXPECT_EQ(m.feed("garbage\x7fW X\r", sim_time{0}), ":A 0.0 \r\n");
    EXPECT_EQ(m.feed("junk\bV\r", sim_time{0}), ":A Version: USB-9.50 \r\n");
    EXPECT_EQ(m.feed("\xff"
                     "AW X\r",
                     sim_time{0}),
              ":A 0.0 \r\n");  // low-level setup swallowed
}

TEST(model_framing, a_backslash_halts_at_once_with_or_without_cr) {
    ms2000_model m(config_for("plain"));
    EXPECT_EQ(m.feed("M X=100000\r", sim_time{0}), ":A\r\n");
    EXPECT_EQ(m.feed("\\", sim_time{1000}), ":N-21\r\n");      // no CR: answered at once
    EXPECT_EQ(m.feed("\r", sim_time{2000}), "");               // its CR is no second command
    EXPECT_EQ(m.feed("\\\r", sim_time{3000}), ":A\r\n");       // the usual form: one answer
    EXPECT_EQ(m.feed("W X\\\r", sim_time{4000}), ":N-6\r\n");  // inside a line it is no HALT
    EXPECT_EQ(m.feed("W XYZ\r", sim_time{5000}).substr(0, 3), ":A ");
}

TEST(model_framing, empty_line_is_configurable) {
    auto config = config_for("plain");
    ms2000_model quiet(config);
    EXPECT_EQ(quiet.feed("\r\r", sim_time{0}), "");
    config.empty_line = empty_line_reply::unknown_command;
    ms2000_model loud(config);
    EXPECT_EQ(loud.feed("\r", sim_time{0}), ":N-1\r\n");
}

TEST(model_framing, trailing_spaces_are_configurable) {
    auto config = config_for("plain");
    config.ack_trailing_space = true;
    config.value_trailing_space = false;
    ms2000_model m(config);
    EXPECT_EQ(send(m, "M X=1", sim_time{0}), ":A \r\n");
    EXPECT_EQ(send(m, "W Y", sim_time{0}), ":A 0.0\r\n");
}

// Clients build their settings from INFO (PYM sends "<CMD> X?" for every "[CMD]" it prints): each
// one must answer, not ":N-1".
TEST(model_info, every_command_info_names_answers_a_query) {
    for (const char* preset_name : {"plain", "full", "crisp"}) {
        ms2000_model m(config_for(preset_name));
        const auto info = send(m, "INFO X", sim_time{0});
        int commands = 0;
        for (std::size_t open = info.find('['); open != std::string::npos; open = info.find('[', open + 1)) {
            const auto close = info.find(']', open);
            ASSERT_NE(close, std::string::npos);
            const auto verb = info.substr(open + 1, close - open - 1);
            const auto reply = send(m, verb + " X?", sim_time{0});
            ++commands;
            EXPECT_FALSE(reply.starts_with(":N")) << preset_name << ": " << verb << " X? -> " << reply;
            EXPECT_TRUE(reply.ends_with("\r\n")) << preset_name << ": " << verb << " X? -> " << reply;
        }
        EXPECT_GE(commands, 20) << preset_name;
        // Reading did not change the controller: the same screen again (the error count included).
        EXPECT_EQ(send(m, "INFO X", sim_time{0}), info) << preset_name;
    }
}

TEST(model_info, names_the_input_that_drives_each_axis) {
    ms2000_model m(config_for("plain"));
    EXPECT_NE(send(m, "INFO Y", sim_time{0}).find("Input Device : JS_Y [J]"), std::string::npos);
    send(m, "J Y=0", sim_time{0});
    EXPECT_NE(send(m, "INFO Y", sim_time{0}).find("Input Device : NONE [J]"), std::string::npos);
}

TEST(model_info, two_columns_over_1023_characters) {
    ms2000_model m(config_for("plain"));
    const auto info = send(m, "INFO X", sim_time{0});
    EXPECT_GT(info.size(), 1023u);
    ASSERT_EQ(info.substr(info.size() - 2), "\r\n");
    EXPECT_EQ(info.find('\n'), info.size() - 1);
    std::size_t start = 0;
    while (start < info.size() - 2) {
        const auto end = info.find('\r', start);
        EXPECT_EQ(end - start, 66u);
        start = end + 1;
    }
    EXPECT_EQ(send(m, "INFO F", sim_time{0}), "");  // absent axis: no reply at all
}

}  // namespace
}  // namespace gw::devices::sim
