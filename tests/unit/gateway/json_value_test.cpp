// read_number, read_integer, read_unsigned, read_text: the one reader of typed JSON values that the
// config file and the job specs share. Each says why it refused: the type, or the range.
#include "gateway/common/json_value.hpp"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace {

using gw::json_fault;
using nlohmann::json;

TEST(json_value, a_number_is_finite_and_in_its_range) {
    EXPECT_EQ(gw::read_number(json(1.5), 0, 2).value, 1.5);
    EXPECT_EQ(gw::read_number(json(2), 0, 2).value, 2.0);  // an integer is a number; bounds included
    EXPECT_EQ(gw::read_number(json(-0.5), 0, 2).fault, json_fault::out_of_range);
    EXPECT_EQ(gw::read_number(json(2.5), 0, 2).fault, json_fault::out_of_range);
    EXPECT_EQ(gw::read_number(json(std::nan("")), -1e300, 1e300).fault, json_fault::out_of_range);
    EXPECT_EQ(gw::read_number(json("1"), 0, 2).fault, json_fault::wrong_type);
    EXPECT_EQ(gw::read_number(json(true), 0, 2).fault, json_fault::wrong_type);
    EXPECT_EQ(gw::read_number(json(nullptr), 0, 2).fault, json_fault::wrong_type);
    EXPECT_FALSE(gw::read_number(json("1"), 0, 2));
}

TEST(json_value, an_integer_may_be_written_as_a_whole_float) {
    EXPECT_EQ(gw::read_integer(json(20), 1, 100).value, 20);
    EXPECT_EQ(gw::read_integer(json(20.0), 1, 100).value, 20);
    EXPECT_EQ(gw::read_integer(json(-3), -5, 5).value, -3);
    EXPECT_EQ(gw::read_integer(json(20.5), 1, 100).fault, json_fault::wrong_type);
    EXPECT_EQ(gw::read_integer(json(1e300), 1, 100).fault, json_fault::wrong_type);  // no longer exact
    EXPECT_EQ(gw::read_integer(json("20"), 1, 100).fault, json_fault::wrong_type);
    EXPECT_EQ(gw::read_integer(json(0), 1, 100).fault, json_fault::out_of_range);
    EXPECT_EQ(gw::read_integer(json(101.0), 1, 100).fault, json_fault::out_of_range);
    // Above the largest signed value: refused, not wrapped to a negative number inside the range.
    EXPECT_EQ(gw::read_integer(json(std::numeric_limits<std::uint64_t>::max()), -5, 5).fault,
              json_fault::out_of_range);
}

TEST(json_value, an_unsigned_is_written_without_sign_or_fraction) {
    EXPECT_EQ(gw::read_unsigned(json(8080), 0, 65535).value, 8080u);
    EXPECT_EQ(gw::read_unsigned(json::parse("8080"), 0, 65535).value, 8080u);
    EXPECT_EQ(gw::read_unsigned(json(8080.0), 0, 65535).fault, json_fault::wrong_type);
    EXPECT_EQ(gw::read_unsigned(json(-1), 0, 65535).fault, json_fault::wrong_type);
    EXPECT_EQ(gw::read_unsigned(json(65536), 0, 65535).fault, json_fault::out_of_range);
    EXPECT_EQ(gw::read_unsigned(json(0), 1, 10).fault, json_fault::out_of_range);
}

TEST(json_value, a_text_follows_its_rules) {
    EXPECT_EQ(gw::read_text(json("abc")).value, "abc");
    EXPECT_EQ(gw::read_text(json("")).value, "");  // by default anything goes
    EXPECT_EQ(gw::read_text(json("a\tb")).value, "a\tb");
    EXPECT_EQ(gw::read_text(json(1)).fault, json_fault::wrong_type);
    const gw::text_rules strict{.allow_empty = false, .allow_control = false};
    EXPECT_EQ(gw::read_text(json(""), strict).fault, json_fault::empty);
    EXPECT_EQ(gw::read_text(json("a\tb"), strict).fault, json_fault::control_character);
    EXPECT_EQ(gw::read_text(json("a\x7f"), strict).fault, json_fault::control_character);
    EXPECT_EQ(gw::read_text(json("caf\xc3\xa9"), strict).value, "caf\xc3\xa9");  // UTF-8 is text
}

}  // namespace
