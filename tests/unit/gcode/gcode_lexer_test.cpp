#include "gateway/gcode/gcode_lexer.hpp"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gw::gcode {
namespace {

struct word_expect {
    char letter;
    double value;
    bool decimal_point;
    int column;
};

struct lex_case {
    std::string name;
    std::string text;
    std::vector<word_expect> words;
    bool block_delete = false;
    bool percent = false;
    bool words_after_semicolon = false;
};

class lex_ok_test : public ::testing::TestWithParam<lex_case> {};

TEST_P(lex_ok_test, splits_words) {
    const auto& c = GetParam();
    gcode_block b;
    const auto e = lex_line(c.text, 7, b);
    ASSERT_FALSE(e.has_value()) << e->message;
    EXPECT_EQ(b.line, 7);
    ASSERT_EQ(b.words.size(), c.words.size());
    for (std::size_t i = 0; i < c.words.size(); ++i) {
        EXPECT_EQ(b.words[i].letter, c.words[i].letter) << i;
        EXPECT_DOUBLE_EQ(b.words[i].value, c.words[i].value) << i;
        EXPECT_EQ(b.words[i].decimal_point, c.words[i].decimal_point) << i;
        EXPECT_EQ(b.words[i].column, c.words[i].column) << i;
    }
    EXPECT_EQ(b.block_delete, c.block_delete);
    EXPECT_EQ(b.percent, c.percent);
    EXPECT_EQ(b.words_after_semicolon, c.words_after_semicolon);
}

INSTANTIATE_TEST_SUITE_P(
    lexer, lex_ok_test,
    ::testing::Values(
        lex_case{"several_codes",
                 "N10 G01 X1.5 Y-.5 F300",
                 {{'N', 10, false, 1},
                  {'G', 1, false, 5},
                  {'X', 1.5, true, 9},
                  {'Y', -0.5, true, 14},
                  {'F', 300, false, 19}}},
        // #5 case
        lex_case{"lower_case_packed", "g1x1y2", {{'G', 1, false, 1}, {'X', 1, false, 3}, {'Y', 2, false, 5}}},
        // #6 blanks after the letter and the sign: the vendor's sample file writes "Z- .1"
        lex_case{"vendor_z_minus_blank", "Z- .1", {{'Z', -0.1, true, 1}}},
        lex_case{"blank_after_letter", "X  +2.", {{'X', 2, true, 1}}},
        lex_case{"tabs", "\tG0\tX1", {{'G', 0, false, 2}, {'X', 1, false, 5}}},
        // #11 number forms
        lex_case{"number_forms",
                 "X.5 Y-.5 Z+1 I1.",
                 {{'X', 0.5, true, 1}, {'Y', -0.5, true, 5}, {'Z', 1, false, 10}, {'I', 1, true, 14}}},
        // #13 leading zeros are just digits
        lex_case{"leading_zeros", "G021 M005", {{'G', 21, false, 1}, {'M', 5, false, 6}}},
        // #4 comments between words, ';' inside a comment is literal, #3 ';' ends the block
        lex_case{"comments",
                 "G0 (move) X1 (a;b) Y2",
                 {{'G', 0, false, 1}, {'X', 1, false, 11}, {'Y', 2, false, 20}}},
        lex_case{"semicolon_comment", "G0 X1 ; to the start", {{'G', 0, false, 1}, {'X', 1, false, 4}}},
        lex_case{
            "semicolon_words", "G0 X1 ; G0 X5", {{'G', 0, false, 1}, {'X', 1, false, 4}}, false, false, true},
        lex_case{"semicolon_only", ";", {}},
        // #7 blank and comment-only lines
        lex_case{"empty", "", {}}, lex_case{"blank", "   \t ", {}},
        lex_case{"comment_only", "(just a comment)", {}},
        // #10 block delete, #1 percent
        lex_case{"block_delete", "/G0 X5", {{'G', 0, false, 2}, {'X', 5, false, 5}}, true},
        lex_case{"percent", "%", {}, false, true}, lex_case{"percent_title", "  % TITLE (x", {}, false, true},
        lex_case{"big_n", "N123456789 G0", {{'N', 123456789, false, 1}, {'G', 0, false, 12}}}),
    [](const auto& info) { return info.param.name; });

struct lex_error_case {
    std::string name;
    std::string text;
    int column;
    std::string message_part;
};

class lex_error_test : public ::testing::TestWithParam<lex_error_case> {};

TEST_P(lex_error_test, names_line_and_column) {
    const auto& c = GetParam();
    gcode_block b;
    const auto e = lex_line(c.text, 3, b);
    ASSERT_TRUE(e.has_value()) << c.text;
    EXPECT_EQ(e->line, 3);
    EXPECT_EQ(e->column, c.column) << e->message;
    EXPECT_NE(e->message.find(c.message_part), std::string::npos) << e->message;
}

INSTANTIATE_TEST_SUITE_P(lexer, lex_error_test,
                         ::testing::Values(
                             // #4 nested and unclosed comments
                             lex_error_case{"nested_comment", "(a (b) c)", 4, "nested comment"},
                             lex_error_case{"unclosed_comment", "G0 (abc", 4, "unclosed comment"},
                             lex_error_case{"stray_close", "G0 X1 )", 7, "')' without '('"},
                             // #4 a comment inside a word
                             lex_error_case{"comment_in_word", "S(x)100", 1, "S needs a number, found '('"},
                             // #6 a blank between digits
                             lex_error_case{"blank_in_number", "G0 X1 000", 7, "blank inside a number"},
                             // #11 bad numbers
                             lex_error_case{"comma", "X1,5", 3, "unexpected character ','"},
                             lex_error_case{"letter_without_number", "G1 X F1", 4,
                                            "X needs a number, found 'F'"},
                             lex_error_case{"letter_at_end", "G1 X", 4, "X needs a number"},
                             lex_error_case{"sign_only", "X-", 1, "X needs a number"},
                             lex_error_case{"dot_only", "X.", 1, "X needs a number"},
                             lex_error_case{"two_dots", "X1.2.3", 5, "second '.'"},
                             lex_error_case{"number_first", "12 G0", 1, "number without a letter"},
                             lex_error_case{"control_byte", std::string("G0\x01X1", 5), 3, "byte 0x01"},
                             lex_error_case{"high_byte", "G0 \xc3\xa9", 4, "byte 0xC3"},
                             lex_error_case{"percent_inside", "G0 X1 %", 7, "unexpected character '%'"},
                             lex_error_case{"slash_inside", "G0 /X1", 4, "unexpected character '/'"},
                             // #8 N after other words
                             lex_error_case{"n_not_first", "G0 N10 X1", 4, "N must be the first word"},
                             lex_error_case{"long_number", "X" + std::string(60, '1'), 1, "too long"}),
                         [](const auto& info) { return info.param.name; });

TEST(lexer, reuses_the_block) {
    gcode_block b;
    ASSERT_FALSE(lex_line("/G0 X1 ; Y2", 1, b));
    ASSERT_FALSE(lex_line("G1", 2, b));
    EXPECT_EQ(b.line, 2);
    EXPECT_EQ(b.words.size(), 1u);
    EXPECT_FALSE(b.block_delete);
    EXPECT_FALSE(b.words_after_semicolon);
    EXPECT_EQ(b.semicolon_column, 0);
}

TEST(lexer, negative_zero_is_zero) {
    gcode_block b;
    ASSERT_FALSE(lex_line("X-0", 1, b));
    EXPECT_FALSE(std::signbit(b.words[0].value));
}

}  // namespace
}  // namespace gw::gcode
