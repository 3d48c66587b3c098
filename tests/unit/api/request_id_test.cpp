#include "api/common/request_id.hpp"

#include <set>

#include <gtest/gtest.h>

namespace gw::api {
namespace {

TEST(request_id, honours_sane_ids_and_replaces_others) {
    EXPECT_EQ(request_id_for("abc-123"), "abc-123");
    EXPECT_EQ(request_id_for(std::string(128, 'a')), std::string(128, 'a'));
    for (std::string bad : {std::string(), std::string("has space"), std::string(129, 'a'),
                            std::string("tab\t"), std::string("nl\n"), std::string("\x7f")}) {
        auto id = request_id_for(bad);
        EXPECT_NE(id, bad);
        EXPECT_TRUE(is_valid_request_id(id));
    }
}

TEST(request_id, made_ids_are_unique_hex) {
    std::set<std::string> seen;
    for (int i = 0; i < 10000; ++i) {
        auto id = make_request_id();
        ASSERT_EQ(id.size(), 16u);
        ASSERT_EQ(id.find_first_not_of("0123456789abcdef"), std::string::npos);
        ASSERT_TRUE(seen.insert(id).second) << id;
    }
}

}  // namespace
}  // namespace gw::api
