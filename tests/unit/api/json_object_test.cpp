#include "api/common/json_object.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace {

using nlohmann::json;

TEST(json_object, every_known_key_passes) {
    EXPECT_FALSE(gw::api::find_unknown_field(json::object(), {}));
    EXPECT_FALSE(gw::api::find_unknown_field(json{{"speed", 1}, {"accel", 2}}, {"speed", "accel", "x"}));
    // Not an object: the caller says what it expected instead.
    EXPECT_FALSE(gw::api::find_unknown_field(json::array({1}), {"speed"}));
}

TEST(json_object, an_unknown_key_is_named_with_the_known_ones) {
    auto u = gw::api::find_unknown_field(json{{"speed", 1}, {"spd", 2}}, {"speed", "accel"});
    ASSERT_TRUE(u);
    EXPECT_EQ(u->field, "spd");
    EXPECT_EQ(u->message, "unknown field \"spd\" (known: speed, accel)");
}

TEST(json_object, a_receiver_that_takes_nothing_says_so) {
    auto u = gw::api::find_unknown_field(json{{"x", 1}}, {}, "this operation takes none");
    ASSERT_TRUE(u);
    EXPECT_EQ(u->message, "unknown field \"x\" (this operation takes none)");
}

TEST(json_object, a_key_that_is_not_a_short_printable_word_is_not_repeated) {
    for (const char* key : {"a\nb", "two words", "\x1b[2J"}) {
        auto u = gw::api::find_unknown_field(json{{key, 1}}, {"speed"});
        ASSERT_TRUE(u) << key;
        EXPECT_EQ(u->field, "...");
        EXPECT_EQ(u->message, "unknown field \"...\" (known: speed)");
    }
    auto long_key = gw::api::find_unknown_field(json{{std::string(200, 'k'), 1}}, {"speed"});
    ASSERT_TRUE(long_key);
    EXPECT_EQ(long_key->field, "...");
}

TEST(json_object, type_names_say_what_a_value_is) {
    EXPECT_EQ(gw::api::json_type_name(json(1)), "a number");
    EXPECT_EQ(gw::api::json_type_name(json(1.5)), "a number");
    EXPECT_EQ(gw::api::json_type_name(json("x")), "string");
    EXPECT_EQ(gw::api::json_type_name(json::array()), "array");
    EXPECT_EQ(gw::api::json_type_name(json()), "null");
}

}  // namespace
