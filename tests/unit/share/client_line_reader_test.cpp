#include "devices/share/client_line_reader.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gw::devices::share {
namespace {

using kind = client_line::kind;

struct row {
    std::string bytes;
    std::vector<client_line> lines;
};

std::vector<client_line> read_all(const std::string& bytes, bool one_at_a_time) {
    client_line_reader reader(16);
    std::vector<client_line> lines;
    if (one_at_a_time) {
        for (char c : bytes)
            reader.feed(std::string_view(&c, 1), lines);
    } else {
        reader.feed(bytes, lines);
    }
    return lines;
}

TEST(client_line_reader, frames_lines_as_the_controller_does) {
    const row rows[] = {
        {"W X\r", {{kind::command, "W X"}}},
        {"W X\r\nW Y\r\n", {{kind::command, "W X"}, {kind::command, "W Y"}}},  // CR LF: LF ignored
        {"\nW X\r", {{kind::command, "W X"}}},                                 // a lone LF between lines
        {"W X", {}},                                                           // no CR yet
        {"\r\r  \r", {}},                                                      // empty lines are no command
        {"w x \r", {{kind::command, "w x "}}},                                 // verbatim, spaces kept
        {"W\x01X\rW Y\r",
         {{kind::unreadable, ""}, {kind::command, "W Y"}}},  // a control byte spoils the line
        {"W \xC3\xA9\r", {{kind::unreadable, ""}}},          // outside ASCII
        {std::string(17, 'A') + "\rV\r", {{kind::unreadable, ""}, {kind::command, "V"}}},  // over 16 bytes
        {std::string(16, 'A') + "\r", {{kind::command, std::string(16, 'A')}}},            // exactly 16
        {"\\", {{kind::command, "\\"}}},                                   // HALT at once, no CR needed
        {"\\\r\nW X\r", {{kind::command, "\\"}, {kind::command, "W X"}}},  // its CR is no second line
        {"\\rW X\r", {{kind::command, "\\"}, {kind::command, "rW X"}}},    // mesoSPIM's "\\r"
        {"W \\\r", {{kind::command, "W \\"}}},                             // inside a line: no HALT
    };
    for (const auto& r : rows) {
        for (bool one_at_a_time : {false, true}) {
            const auto lines = read_all(r.bytes, one_at_a_time);
            ASSERT_EQ(lines.size(), r.lines.size()) << testing::PrintToString(r.bytes);
            for (std::size_t i = 0; i < lines.size(); ++i) {
                EXPECT_EQ(lines[i].what, r.lines[i].what) << testing::PrintToString(r.bytes);
                EXPECT_EQ(lines[i].text, r.lines[i].text) << testing::PrintToString(r.bytes);
            }
        }
    }
}

TEST(client_line_reader, keeps_no_more_than_one_line_of_a_flood_without_cr) {
    client_line_reader reader(16);
    std::vector<client_line> lines;
    reader.feed(std::string(100000, 'W'), lines);
    EXPECT_TRUE(lines.empty());
    EXPECT_LE(reader.pending_bytes(), 16U);
    reader.feed("\r", lines);
    ASSERT_EQ(lines.size(), 1U);
    EXPECT_EQ(lines[0].what, kind::unreadable);
}

}  // namespace
}  // namespace gw::devices::share
