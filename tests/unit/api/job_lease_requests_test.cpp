#include <chrono>
#include <string>
#include <string_view>

#include <gtest/gtest.h>

#include "api/calls/lease_requests.hpp"

namespace gw::api {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;

TEST(lease_body, defaults_when_empty_or_null) {
    for (const json& body : {json(), json::object()}) {
        auto b = parse_lease_body(body, true);
        ASSERT_TRUE(b.has_value());
        EXPECT_EQ(b->ttl, default_lease_ttl);
        EXPECT_FALSE(b->label);
    }
}

TEST(lease_body, ttl_and_holder) {
    auto b = parse_lease_body(json::parse(R"({"ttl_s":120,"holder":"notebook-3"})"), true);
    ASSERT_TRUE(b.has_value()) << b.error().message;
    EXPECT_EQ(b->ttl, 120s);
    EXPECT_EQ(b->label, "notebook-3");
    // The limits themselves are accepted.
    EXPECT_TRUE(parse_lease_body({{"ttl_s", min_lease_ttl.count()}}, false).has_value());
    EXPECT_TRUE(parse_lease_body({{"ttl_s", max_lease_ttl.count()}}, false).has_value());
}

struct bad_lease_case {
    std::string_view name;
    std::string body;
    bool allow_holder;
    std::string_view field;
};

class bad_lease_body : public ::testing::TestWithParam<bad_lease_case> {};

TEST_P(bad_lease_body, is_422_naming_the_field) {
    const auto& c = GetParam();
    auto b = parse_lease_body(json::parse(c.body), c.allow_holder);
    ASSERT_FALSE(b.has_value()) << c.body;
    EXPECT_EQ(b.error().kind, operation_error_kind::invalid_value);
    EXPECT_EQ(b.error().field, c.field);
}

INSTANTIATE_TEST_SUITE_P(
    all, bad_lease_body,
    ::testing::Values(bad_lease_case{"not_object", "[60]", true, ""},
                      bad_lease_case{"unknown", R"({"ttl":60})", true, "ttl"},
                      bad_lease_case{"holder_on_renew", R"({"holder":"x"})", false, "holder"},
                      bad_lease_case{"ttl_zero", R"({"ttl_s":0})", true, "ttl_s"},
                      bad_lease_case{"ttl_over_a_day", R"({"ttl_s":86401})", true, "ttl_s"},
                      bad_lease_case{"ttl_fraction", R"({"ttl_s":1.5})", true, "ttl_s"},
                      bad_lease_case{"ttl_string", R"({"ttl_s":"60"})", true, "ttl_s"},
                      bad_lease_case{"holder_empty", R"({"holder":""})", true, "holder"},
                      bad_lease_case{"holder_number", R"({"holder":7})", true, "holder"},
                      bad_lease_case{"holder_newline", R"({"holder":"a\nb"})", true, "holder"}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(lease_json, with_and_without_the_id) {
    const auto t0 = std::chrono::system_clock::time_point{} + 1'800'000'000s;
    lease l{.id = "l-abc", .controller = "sim1", .holder = "op/nb", .acquired = t0, .expires = t0 + 60s};
    auto j = lease_json(l, true, t0 + 20s);
    EXPECT_EQ(j["lease_id"], "l-abc");
    EXPECT_EQ(j["controller"], "sim1");
    EXPECT_EQ(j["holder"], "op/nb");
    EXPECT_EQ(j["acquired"], "2027-01-15T08:00:00.000Z");
    EXPECT_EQ(j["expires"], "2027-01-15T08:01:00.000Z");
    EXPECT_DOUBLE_EQ(j["expires_in_s"].get<double>(), 40.0);
    auto public_view = lease_json(l, false, t0 + 90s);
    EXPECT_FALSE(public_view.contains("lease_id"));
    EXPECT_DOUBLE_EQ(public_view["expires_in_s"].get<double>(), 0.0);  // never negative
}

}  // namespace
}  // namespace gw::api
