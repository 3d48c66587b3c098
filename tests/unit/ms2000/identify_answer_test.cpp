#include "devices/ms2000/identify_answer.hpp"

#include <string>
#include <string_view>

#include <gtest/gtest.h>

namespace gw::devices::ms2000 {
namespace {

using kind = version_answer::kind;

struct version_case {
    std::string_view name;
    std::string bytes;
    kind expected;
    std::string_view version;
    bool complete;
};

TEST(IdentifyAnswer, ClassifiesVersionAnswers) {
    const version_case cases[] = {
        {"nothing", "", kind::silent, "", false},
        {"ms2000 with trailing space", ":A Version: USB-9.52 \r\n", kind::ms2000, "9.52", true},
        {"ms2000 letter revision", ":A Version: USB-9.2p\r\n", kind::ms2000, "9.2p", true},
        {"tiger answers v", ":A v3.45\r\n", kind::tiger, "3.45", true},
        {"a stray LF before the answer", "\n:A Version: USB-9.50\r\n", kind::ms2000, "9.50", true},
        {"line not ended yet", ":A Version: USB-9.5", kind::other, "", false},
        {"an error reply", ":N-1\r\n", kind::other, "", true},
        {"another device's text", "OK\r\n", kind::other, "", true},
        {"an ack without a version", ":A\r\n", kind::other, "", true},
        {"version with no digits", ":A Version: USB-x\r\n", kind::other, "", true},
        {"noise at a wrong baud rate", std::string("\x8f\xfe\x00\x7f\xe0", 5), kind::other, "", false},
        {"noise ending CR LF", std::string("\xf0\x0f\r\n", 4), kind::other, "", true},
        {"high bit inside a version line", ":A Version: USB-9.52\xb0\r\n", kind::other, "", true},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(std::string(c.name));
        const auto a = classify_version_answer(c.bytes);
        EXPECT_EQ(a.what, c.expected);
        EXPECT_EQ(a.version, c.version);
        EXPECT_EQ(a.complete, c.complete);
        EXPECT_EQ(has_complete_line(c.bytes), c.complete);
        if (c.expected == kind::ms2000 || c.expected == kind::tiger) {
            EXPECT_FALSE(a.line.empty());
        }
    }
}

TEST(IdentifyAnswer, ParsesBuildAnswers) {
    const auto full = parse_build_answer("STD_XYZ\rMotor Axes: X Y Z\rRING BUFFER 50\rARRAY MODULE\r\n");
    ASSERT_TRUE(full.has_value());
    EXPECT_EQ(full->name, "STD_XYZ");
    EXPECT_EQ(full->motor_axes, "XYZ");
    EXPECT_TRUE(full->has(module::ring_buffer));
    EXPECT_TRUE(full->has(module::array));
    EXPECT_FALSE(full->has(module::scan));

    const auto name_only = parse_build_answer("STD_XY\r\n");
    ASSERT_TRUE(name_only.has_value());
    EXPECT_EQ(name_only->name, "STD_XY");

    // Old firmware refuses BU X; noise, an incomplete or empty answer are no build either.
    EXPECT_FALSE(parse_build_answer(":N-1\r\n"));
    EXPECT_FALSE(parse_build_answer(":A\r\n"));
    EXPECT_FALSE(parse_build_answer("STD_XYZ\rMotor Axes: X"));
    EXPECT_FALSE(parse_build_answer(""));
    EXPECT_FALSE(parse_build_answer(std::string("STD\xff\r\n", 6)));
}

}  // namespace
}  // namespace gw::devices::ms2000
