#include "api/common/auth.hpp"

#include <optional>
#include <string>

#include <gtest/gtest.h>

namespace gw::api {
namespace {

auth_config tokens() {
    auth_config a;
    a.tokens = {{"dash", hash_token("viewer-token-0123456789"), role::viewer},
                {"robot", hash_token("operator-token-0123456789"), role::operator_},
                // As a config's "token_sha256" gives it: the hash of admin-token-0123456789abc.
                {"root", *parse_token_digest(to_hex(hash_token("admin-token-0123456789abc"))), role::admin}};
    return a;
}

TEST(auth, without_tokens_everyone_is_admin) {
    problem p;
    auto who = authenticate(auth_config{}, "", p);
    ASSERT_TRUE(who);
    EXPECT_EQ(who->role, role::admin);
    EXPECT_EQ(who->name, "anonymous");
}

TEST(auth, bearer_tokens_map_to_their_roles) {
    struct row {
        const char* header;
        bool ok;
        role expected;
    };
    const row rows[] = {
        {"Bearer viewer-token-0123456789", true, role::viewer},
        {"bearer operator-token-0123456789", true, role::operator_},
        {"Bearer   admin-token-0123456789abc  ", true, role::admin},
        {"", false, role::viewer},
        {"Bearer ", false, role::viewer},
        {"Bearer viewer-token-012345678", false, role::viewer},  // a prefix is not the token
        {"Bearer viewer-token-01234567890", false, role::viewer},
        {"Basic dmlld2VyOg==", false, role::viewer},
        {"viewer-token-0123456789", false, role::viewer},
    };
    for (const auto& r : rows) {
        problem p;
        auto who = authenticate(tokens(), r.header, p);
        EXPECT_EQ(bool(who), r.ok) << r.header;
        if (who) {
            EXPECT_EQ(who->role, r.expected) << r.header;
        } else {
            EXPECT_EQ(p.status, 401u) << r.header;
        }
    }
}

TEST(auth, bare_tokens_from_the_websocket_query) {
    problem p;
    auto who = authenticate_token(tokens(), "viewer-token-0123456789", p);
    ASSERT_TRUE(who);
    EXPECT_EQ(who->role, role::viewer);
    EXPECT_EQ(who->name, "dash");
    for (const char* bad : {"", "viewer-token-012345678", "nope"}) {
        problem e;
        EXPECT_FALSE(authenticate_token(tokens(), bad, e)) << bad;
        EXPECT_EQ(e.status, 401) << bad;
    }
}

TEST(auth, access_token_query_parameter) {
    struct row {
        const char* target;
        std::optional<std::string> expected;
    };
    const row rows[] = {
        {"/api/v1/ws", std::nullopt},
        {"/api/v1/ws?", std::nullopt},
        {"/api/v1/ws?other=1", std::nullopt},
        {"/api/v1/ws?my_access_token=x", std::nullopt},
        {"/api/v1/ws?access_token=abc", "abc"},
        {"/api/v1/ws?a=1&access_token=abc&b=2", "abc"},
        {"/api/v1/ws?access_token=", ""},
        {"/api/v1/ws?access_token=a%2Bb%2fc+d", "a+b/c+d"},  // '+' stays '+'
        {"/api/v1/ws?access_token=abc%2", ""},               // malformed escapes match nothing
        {"/api/v1/ws?access_token=abc%zz", ""},
    };
    for (const auto& r : rows)
        EXPECT_EQ(access_token_parameter(r.target), r.expected) << r.target;
}

TEST(auth, access_tokens_are_redacted) {
    struct row {
        const char* target;
        const char* expected;
    };
    const row rows[] = {
        {"/api/v1/ws", "/api/v1/ws"},
        {"/api/v1/ws?access_token=secret", "/api/v1/ws?access_token=REDACTED"},
        {"/api/v1/ws?a=1&access_token=secret&b=2", "/api/v1/ws?a=1&access_token=REDACTED&b=2"},
        {"/api/v1/ws?a=1&", "/api/v1/ws?a=1&"},
    };
    for (const auto& r : rows)
        EXPECT_EQ(redact_access_token(r.target), r.expected) << r.target;
}

TEST(auth, roles_are_ordered) {
    auth_identity viewer{"v", role::viewer}, op{"o", role::operator_}, admin{"a", role::admin};
    EXPECT_TRUE(has_role(viewer, role::viewer));
    EXPECT_FALSE(has_role(viewer, role::operator_));
    EXPECT_TRUE(has_role(op, role::operator_));
    EXPECT_FALSE(has_role(op, role::admin));
    EXPECT_TRUE(has_role(admin, role::viewer));
    EXPECT_TRUE(has_role(admin, role::admin));
    auto p = forbidden_problem(viewer, role::operator_);
    EXPECT_EQ(p.status, 403u);
    EXPECT_NE(p.detail.find("operator"), std::string::npos);
}

}  // namespace
}  // namespace gw::api
