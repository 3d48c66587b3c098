// The WebSocket's G-code messages ({"op":"gcode"}), which MQTT's <base>/gcode/check shares.
#include <string>
#include <variant>

#include <gtest/gtest.h>

#include "api/ws/websocket_protocol.hpp"

namespace gw::api {
namespace {

TEST(gcode_message, check_with_options) {
    auto r = parse_client_message(
        R"({"op":"gcode","id":"g1","action":"check","file":"g-01JD0000000000000000000000",)"
        R"("options":{"xyz_scale":0.5,"decimal_point":"always"}})");
    ASSERT_TRUE(r.has_value()) << r.error().error.detail;
    const auto* g = std::get_if<gcode_message>(&*r);
    ASSERT_NE(g, nullptr);
    EXPECT_EQ(g->id, "g1");
    EXPECT_EQ(g->file, "g-01JD0000000000000000000000");
    EXPECT_EQ(g->options["xyz_scale"], 0.5);
    auto c = to_call(*g);
    const auto* check = std::get_if<gcode_check_call>(&c);
    ASSERT_NE(check, nullptr);
    EXPECT_EQ(check->file, g->file);
    EXPECT_EQ(role_for(c), gw::role::viewer);
}

TEST(gcode_message, options_may_be_left_out) {
    auto r = parse_client_message(
        R"({"op":"gcode","id":2,"action":"check","file":"g-01JD0000000000000000000000"})");
    ASSERT_TRUE(r.has_value()) << r.error().error.detail;
    EXPECT_TRUE(std::get<gcode_message>(*r).options.is_null());
}

struct refusal {
    std::string text;
    std::string field;
};

class refused_gcode : public ::testing::TestWithParam<refusal> {};

TEST_P(refused_gcode, is_422_naming_the_field) {
    auto r = parse_client_message(GetParam().text);
    ASSERT_FALSE(r.has_value()) << GetParam().text;
    EXPECT_EQ(r.error().error.status, 422u);
    EXPECT_EQ(r.error().error.field, GetParam().field) << r.error().error.detail;
}

INSTANTIATE_TEST_SUITE_P(
    all, refused_gcode,
    ::testing::Values(
        refusal{R"({"op":"gcode","action":"check","file":"g-01JD0000000000000000000000"})", "id"},
        refusal{R"({"op":"gcode","id":1,"file":"g-01JD0000000000000000000000"})", "action"},
        refusal{R"({"op":"gcode","id":1,"action":"plan","file":"g-01JD0000000000000000000000"})", "action"},
        refusal{R"({"op":"gcode","id":1,"action":"check"})", "file"},
        refusal{R"({"op":"gcode","id":1,"action":"check","file":"../etc/passwd"})", "file"},
        refusal{R"({"op":"gcode","id":1,"action":"check","file":"j-01JD0000000000000000000000"})", "file"},
        refusal{
            R"({"op":"gcode","id":1,"action":"check","file":"g-01JD0000000000000000000000","options":[1]})",
            "options"},
        refusal{
            R"({"op":"gcode","id":1,"action":"check","file":"g-01JD0000000000000000000000","lease":"l-1"})",
            "lease"}));

}  // namespace
}  // namespace gw::api
