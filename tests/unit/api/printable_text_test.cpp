#include "api/common/printable_text.hpp"

#include <string>
#include <string_view>

#include <gtest/gtest.h>

namespace {

using namespace std::string_view_literals;

struct text_case {
    std::string_view text;
    bool word;
    bool label;
};

TEST(printable_text, words_have_no_spaces_labels_may) {
    const text_case cases[] = {
        {"", true, true},
        {"j-01M8V4QNY1H8EM830S09VBW6MW", true, true},
        {"~!\"#$%&'()*+,-./:;<=>?@[\\]^_`{|}", true, true},
        {"Alice at scope 3", false, true},
        {" ", false, true},
        {"tab\there", false, false},
        {"line\nbreak", false, false},
        {"nul\0byte"sv, false, false},
        {"del\x7f", false, false},
        {"caf\xc3\xa9", false, false},  // UTF-8 is not ASCII
        {"\x1b[31mred", false, false},
    };
    for (const auto& c : cases) {
        EXPECT_EQ(gw::api::is_printable_word(c.text), c.word) << c.text;
        EXPECT_EQ(gw::api::is_printable_label(c.text), c.label) << c.text;
    }
}

TEST(printable_text, messages_repeat_only_short_printable_text) {
    EXPECT_EQ(gw::api::shown_in_message("controler"), "controler");
    EXPECT_EQ(gw::api::shown_in_message("two words"), "...");
    EXPECT_EQ(gw::api::shown_in_message(std::string(64, 'a')), std::string(64, 'a'));
    EXPECT_EQ(gw::api::shown_in_message(std::string(65, 'a')), "...");
    EXPECT_EQ(gw::api::shown_in_message("new\nline"), "...");
    EXPECT_EQ(gw::api::shown_in_message("\xff"), "...");
}

}  // namespace
