#include "devices/ms2000/line_framer.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "devices/ms2000/error.hpp"
#include "devices/ms2000/reply.hpp"

namespace gw::devices::ms2000 {
namespace {

using lines_t = std::vector<std::string>;

struct framing_case {
    std::string name;
    std::string input;
    lines_t lines;
    std::string partial;
    std::uint64_t discarded;
};

class framing_test : public ::testing::TestWithParam<framing_case> {};

TEST_P(framing_test, in_one_feed) {
    const framing_case& c = GetParam();
    line_framer framer;
    lines_t lines;
    EXPECT_FALSE(framer.feed(c.input, lines));
    EXPECT_EQ(lines, c.lines);
    EXPECT_EQ(framer.partial(), c.partial);
    EXPECT_EQ(framer.discarded_bytes(), c.discarded);
}

TEST_P(framing_test, byte_by_byte) {
    const framing_case& c = GetParam();
    line_framer framer;
    lines_t lines;
    for (char byte : c.input)
        EXPECT_FALSE(framer.feed(std::string_view(&byte, 1), lines));
    EXPECT_EQ(lines, c.lines);
    EXPECT_EQ(framer.partial(), c.partial);
    EXPECT_EQ(framer.discarded_bytes(), c.discarded);
}

TEST_P(framing_test, at_every_split_point) {
    const framing_case& c = GetParam();
    for (std::size_t cut = 0; cut <= c.input.size(); ++cut) {
        line_framer framer;
        lines_t lines;
        const std::string_view input = c.input;
        framer.feed(input.substr(0, cut), lines);
        framer.feed(input.substr(cut), lines);
        EXPECT_EQ(lines, c.lines) << "cut at " << cut;
        EXPECT_EQ(framer.partial(), c.partial);
    }
}

INSTANTIATE_TEST_SUITE_P(table, framing_test,
                         ::testing::Values(framing_case{"ack", ":A\r\n", {":A"}, "", 0},
                                           framing_case{"ack_space", ":A \r\n", {":A "}, "", 0},
                                           framing_case{"two", ":A\r\n:N-1\r\n", {":A", ":N-1"}, "", 0},
                                           framing_case{"multiline",
                                                        "STD_XYZ\rMotor Axes: X Y Z\rCRISP\r\n",
                                                        {"STD_XYZ\rMotor Axes: X Y Z\rCRISP"},
                                                        "",
                                                        0},
                                           framing_case{"partial", ":A\r\n:", {":A"}, ":", 0},
                                           framing_case{"saveset", ":A\r\n", {":A"}, "", 0},
                                           framing_case{"pending_cr", "N\r", {}, "N\r", 0},
                                           framing_case{"stray_lf", "\n:A\r\n\nB\r\n", {":A", "B"}, "", 2},
                                           framing_case{"lf_only_line", "X=1\n", {}, "X=1", 1},
                                           framing_case{"empty_line", "\r\n", {""}, "", 0},
                                           framing_case{"double_cr", ":A\r\r\n", {":A\r"}, "", 0},
                                           framing_case{"nothing", "", {}, "", 0}),
                         [](const auto& info) { return info.param.name; });

TEST(line_framer, too_long_line_is_dropped_and_framing_goes_on) {
    line_framer framer(8);
    lines_t lines;
    EXPECT_FALSE(framer.feed("12345678\r\n", lines));  // exactly the bound
    EXPECT_EQ(lines, lines_t{"12345678"});
    const auto ec = framer.feed("123456789abc\r\n:A\r\n", lines);
    EXPECT_EQ(ec, make_error_code(error::line_too_long));
    EXPECT_EQ(lines, (lines_t{"12345678", ":A"}));
    EXPECT_EQ(framer.discarded_bytes(), 14u);
    EXPECT_EQ(framer.partial(), "");
}

TEST(line_framer, overflow_across_feeds) {
    line_framer framer(4);
    lines_t lines;
    EXPECT_FALSE(framer.feed("abcd", lines));
    EXPECT_EQ(framer.feed("e", lines), make_error_code(error::line_too_long));
    EXPECT_EQ(framer.partial(), "");
    EXPECT_FALSE(framer.feed("fgh\r", lines));  // still inside the long line: no new error
    EXPECT_FALSE(framer.feed("x\r", lines));    // a lone CR does not end the line either
    EXPECT_FALSE(framer.feed("\n", lines));
    EXPECT_TRUE(lines.empty());
    EXPECT_FALSE(framer.feed("N\r\n", lines));
    EXPECT_EQ(lines, lines_t{"N"});
    EXPECT_EQ(framer.discarded_bytes(), 12u);
}

TEST(line_framer, overflow_when_the_cr_is_the_last_byte_before_lf) {
    line_framer framer(3);
    lines_t lines;
    EXPECT_EQ(framer.feed("abcd\r", lines), make_error_code(error::line_too_long));
    EXPECT_FALSE(framer.feed("\nok\r\n", lines));
    EXPECT_EQ(lines, lines_t{"ok"});
}

TEST(line_framer, default_bound_holds_info) {
    line_framer framer;
    lines_t lines;
    std::string info;
    for (int i = 0; i < 60; ++i)
        info += "Max Speed(S):   7.50 mm/s       Ramp Time(AC):  50 ms  \r";
    ASSERT_GT(info.size(), 1023u);
    ASSERT_LT(info.size(), line_framer::default_max_line_bytes);
    EXPECT_FALSE(framer.feed(info + "\r\n", lines));
    ASSERT_EQ(lines.size(), 1u);
    EXPECT_EQ(lines[0], info);
}

// SAVESET: ":" when the flash write starts, "A" + CR LF when it is done.
TEST(line_framer, saveset_two_phase_reply) {
    line_framer framer;
    lines_t lines;
    framer.feed(":", lines);
    EXPECT_TRUE(lines.empty());
    EXPECT_EQ(framer.partial(), ":");
    framer.feed("A\r\n", lines);
    ASSERT_EQ(lines, lines_t{":A"});
    const auto r = parse_reply(reply_shape::two_phase, lines[0]);
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->what, reply::kind::ack);
}

// RDSBYTE: ":" then one raw status byte per axis, which may be CR or LF, then CR LF.
TEST(line_framer, status_bytes_hold_cr_and_lf) {
    struct row {
        std::size_t count;
        std::string input;
        lines_t lines;
    };
    const row rows[] = {
        {1, ":\n\r\n", {":\n"}},                        // 10: enabled, joystick on
        {1, ":\r\r\n", {":\r"}},                        // 13
        {2, ":\n\r\r\n", {":\n\r"}},                    // a CR LF inside, then its own
        {2, ":\x8a\x0a\r\nN\r\n", {":\x8a\x0a", "N"}},  // then ordinary lines again
        {1, ":N-2\r\n", {":N-2"}},                      // the controller refused it
        {4, ":N-21\r\n", {":N-21"}},                    // shorter than 4 bytes would be
        {2, ":N-\r\n", {":N-"}},                        // bytes 'N' and '-', not an error
        {1, "T: 1 2\r\n:\n\r\n", {"T: 1 2", ":\n"}},    // a report line first is framed as usual
        {1, ":AB\r\n", {":AB"}},                        // too long: ordinary framing takes it
    };
    for (const auto& r : rows) {
        // In one feed and byte by byte: the same lines.
        for (const bool bytewise : {false, true}) {
            line_framer framer;
            framer.expect_status_bytes(r.count);
            lines_t lines;
            if (bytewise) {
                for (char c : r.input)
                    framer.feed(std::string_view(&c, 1), lines);
            } else {
                framer.feed(r.input, lines);
            }
            EXPECT_EQ(lines, r.lines) << r.count << " bytes, input of " << r.input.size();
            EXPECT_EQ(framer.partial(), "");
        }
    }
}

TEST(line_framer, status_bytes_end_with_the_answer_or_a_reset) {
    line_framer framer;
    lines_t lines;
    framer.expect_status_bytes(1);
    framer.feed(":\n\r\n:\n\r\n", lines);  // only the first line is RDSBYTE's answer
    EXPECT_EQ(lines, (lines_t{":\n", ":"}));
    EXPECT_EQ(framer.discarded_bytes(), 1u);  // the second one's first LF was a stray
    lines.clear();
    framer.expect_status_bytes(1);
    framer.reset();
    framer.feed(":\n\r\n", lines);
    EXPECT_EQ(lines, lines_t{":"});
}

TEST(line_framer, reset_drops_the_partial_line) {
    line_framer framer;
    lines_t lines;
    framer.feed(":A 12", lines);
    EXPECT_EQ(framer.partial(), ":A 12");
    framer.reset();
    EXPECT_EQ(framer.partial(), "");
    EXPECT_EQ(framer.discarded_bytes(), 5u);
    framer.feed("N\r\n", lines);
    EXPECT_EQ(lines, lines_t{"N"});
}

TEST(line_framer, reset_ends_an_overflow) {
    line_framer framer(2);
    lines_t lines;
    EXPECT_TRUE(framer.feed("abc", lines));
    framer.reset();
    EXPECT_FALSE(framer.feed("B\r\n", lines));
    EXPECT_EQ(lines, lines_t{"B"});
}

}  // namespace
}  // namespace gw::devices::ms2000
