#include "api/auth.hpp"

#include <gtest/gtest.h>

namespace gw::api {
namespace {

auth_config tokens() {
    auth_config a;
    a.tokens = {{"dash", "viewer-token-0123456789", role::viewer},
                {"robot", "operator-token-0123456789", role::operator_},
                {"root", "admin-token-0123456789abc", role::admin}};
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
