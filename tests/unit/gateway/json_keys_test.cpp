// first_unknown_key: the one check of an object's keys that the config, the job specs and the API's
// strict reader share.
#include "gateway/common/json_keys.hpp"

#include <gtest/gtest.h>

namespace {

using nlohmann::json;

TEST(json_keys, the_first_key_not_known_in_the_objects_order) {
    EXPECT_EQ(gw::first_unknown_key(json{{"a", 1}, {"b", 2}}, {"a", "b"}), std::nullopt);
    EXPECT_EQ(gw::first_unknown_key(json::object(), {}), std::nullopt);
    EXPECT_EQ(gw::first_unknown_key(json{{"a", 1}, {"zz", 2}, {"zy", 3}}, {"a"}), "zy");  // keys are sorted
    EXPECT_EQ(gw::first_unknown_key(json{{"A", 1}}, {"a"}), "A");                         // case counts
    EXPECT_EQ(gw::first_unknown_key(json{{"x", 1}}, {}), "x");
}

TEST(json_keys, no_object_has_no_unknown_key) {
    EXPECT_EQ(gw::first_unknown_key(json::array({1, 2}), {"a"}), std::nullopt);
    EXPECT_EQ(gw::first_unknown_key(json(nullptr), {"a"}), std::nullopt);
    EXPECT_EQ(gw::first_unknown_key(json("a"), {"a"}), std::nullopt);
}

}  // namespace
