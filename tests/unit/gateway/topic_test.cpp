#include "gateway/events/topic.hpp"

#include <string>
#include <string_view>
#include <vector>

#include <gtest/gtest.h>

namespace {

using gw::topic_error;

struct validation_case {
    std::string topic;
    topic_error expected_filter;  // {} = valid
    topic_error expected_name;
};

constexpr topic_error ok{};

TEST(topic, validation_table) {
    const validation_case cases[] = {
        {"controllers/stage1/position", ok, ok},
        {"jobs/42", ok, ok},
        {"a", ok, ok},
        {"controllers/+/position", ok, topic_error::wildcard_in_name},
        {"controllers/stage1/#", ok, topic_error::wildcard_in_name},
        {"#", ok, topic_error::wildcard_in_name},
        {"+", ok, topic_error::wildcard_in_name},
        {"+/+/+", ok, topic_error::wildcard_in_name},
        {"jobs/#", ok, topic_error::wildcard_in_name},
        {"", topic_error::empty, topic_error::empty},
        {"a//b", topic_error::empty_level, topic_error::empty_level},
        {"/a", topic_error::empty_level, topic_error::empty_level},
        {"a/", topic_error::empty_level, topic_error::empty_level},
        {"/", topic_error::empty_level, topic_error::empty_level},
        {"#/a", topic_error::hash_not_last, topic_error::wildcard_in_name},
        {"a/#/b", topic_error::hash_not_last, topic_error::wildcard_in_name},
        {"+x", topic_error::wildcard_in_level, topic_error::wildcard_in_name},
        {"a/x+/b", topic_error::wildcard_in_level, topic_error::wildcard_in_name},
        {"a#", topic_error::wildcard_in_level, topic_error::wildcard_in_name},
        {"a/##", topic_error::wildcard_in_level, topic_error::wildcard_in_name},
        {"a b", topic_error::invalid_character, topic_error::invalid_character},
        {"a\tb", topic_error::invalid_character, topic_error::invalid_character},
        {"caf\xc3\xa9", topic_error::invalid_character, topic_error::invalid_character},
        {std::string(gw::max_topic_bytes, 'a'), ok, ok},
        {std::string(gw::max_topic_bytes + 1, 'a'), topic_error::too_long, topic_error::too_long},
        {"a/b/c/d/e/f/g/h/i/j/k/l/m/n/o/p", ok, ok},
        {"a/b/c/d/e/f/g/h/i/j/k/l/m/n/o/p/q", topic_error::too_many_levels, topic_error::too_many_levels},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE("topic: \"" + c.topic + "\"");
        auto filter = gw::validate_topic_filter(c.topic);
        auto name = gw::validate_topic_name(c.topic);
        if (c.expected_filter == ok)
            EXPECT_FALSE(filter) << filter.message();
        else
            EXPECT_EQ(filter, gw::make_error_code(c.expected_filter)) << filter.message();
        if (c.expected_name == ok)
            EXPECT_FALSE(name) << name.message();
        else
            EXPECT_EQ(name, gw::make_error_code(c.expected_name)) << name.message();
    }
}

TEST(topic, errors_have_messages_and_a_category) {
    boost::system::error_code ec = topic_error::hash_not_last;
    EXPECT_EQ(ec.category().name(), std::string("gw.topic"));
    EXPECT_EQ(ec.message(), "'#' is only allowed as the last level");
}

struct match_case {
    const char* filter;
    const char* name;
    bool matches;
};

TEST(topic, levels) {
    using levels = std::vector<std::string_view>;
    EXPECT_EQ(gw::topic_levels("controllers/sim1/state"), (levels{"controllers", "sim1", "state"}));
    EXPECT_EQ(gw::topic_levels("jobs"), (levels{"jobs"}));
    EXPECT_EQ(gw::topic_levels("a//b/"), (levels{"a", "", "b", ""}));
    EXPECT_EQ(gw::topic_levels(""), (levels{""}));
}

TEST(topic, matching_table) {
    const match_case cases[] = {
        {"controllers/stage1/position", "controllers/stage1/position", true},
        {"controllers/stage1/position", "controllers/stage2/position", false},
        {"controllers/stage1/position", "controllers/stage1", false},
        {"controllers/stage1", "controllers/stage1/position", false},
        {"controllers/+/position", "controllers/stage1/position", true},
        {"controllers/+/position", "controllers/stage1/state", false},
        {"controllers/+/position", "controllers/position", false},
        {"controllers/+/position", "controllers/a/b/position", false},
        {"controllers/+", "controllers/stage1", true},
        {"controllers/+", "controllers/stage1/state", false},
        {"+/+/ttl", "controllers/s/ttl", true},
        {"+", "jobs", true},
        {"+", "jobs/1", false},
        {"#", "jobs/1", true},
        {"#", "controllers/stage1/reports", true},
        {"jobs/#", "jobs/1", true},
        {"jobs/#", "jobs/1/steps", true},
        {"jobs/#", "jobs", true},  // MQTT: "a/#" also matches the parent "a"
        {"jobs/#", "jobsx/1", false},
        {"jobs/#", "controllers/jobs/1", false},
        {"controllers/+/#", "controllers/stage1/reports", true},
        {"controllers/+/#", "controllers/stage1", true},
        {"controllers/+/#", "controllers", false},
        {"controllers/stage1/#", "controllers/stage2/state", false},
        {"Jobs/#", "jobs/1", false},  // case-sensitive
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(std::string(c.filter) + " vs " + c.name);
        ASSERT_FALSE(gw::validate_topic_filter(c.filter));
        ASSERT_FALSE(gw::validate_topic_name(c.name));
        EXPECT_EQ(gw::topic_matches(c.filter, c.name), c.matches);
    }
}

TEST(topic, classification) {
    using gw::topic_class;
    EXPECT_EQ(gw::classify_topic("controllers/stage1/position"), topic_class::latest_value);
    EXPECT_EQ(gw::classify_topic("controllers/stage1/state"), topic_class::latest_value);
    EXPECT_EQ(gw::classify_topic("controllers/stage1/reports"), topic_class::stream);
    EXPECT_EQ(gw::classify_topic("controllers/stage1/ttl"), topic_class::stream);
    EXPECT_EQ(gw::classify_topic("jobs/7"), topic_class::stream);
    EXPECT_EQ(gw::classify_topic("jobs/state"), topic_class::stream);
    EXPECT_EQ(gw::classify_topic("controllers/state"), topic_class::stream);
    EXPECT_EQ(gw::classify_topic("controllers/a/b/state"), topic_class::stream);
}

TEST(topic, address_names_the_kind_and_where_the_key_is) {
    using gw::topic_kind;
    struct address_case {
        const char* name;
        topic_kind kind;
        const char* key;
    };
    const address_case cases[] = {
        {"controllers/stage1/state", topic_kind::controller_state, "stage1"},
        {"controllers/stage1/position", topic_kind::controller_position, "stage1"},
        {"controllers/s-2/reports", topic_kind::controller_reports, "s-2"},
        {"controllers/s-2/ttl", topic_kind::controller_ttl, "s-2"},
        {"controllers/s-2/errors", topic_kind::controller_errors, "s-2"},
        {"jobs/j-01M8", topic_kind::job, "j-01M8"},
        {"recordings/r-01M9", topic_kind::recording, "r-01M9"},
        {"recordings", topic_kind::other, ""},
        {"recordings/r-1/rows", topic_kind::other, ""},
        {"controllers/stage1/cmd", topic_kind::other, ""},
        {"controllers/stage1", topic_kind::other, ""},
        {"controllers/stage1/state/x", topic_kind::other, ""},
        {"controllers//state", topic_kind::other, ""},
        {"jobs", topic_kind::other, ""},
        {"jobs/j-1/x", topic_kind::other, ""},
        {"other/stage1/state", topic_kind::other, ""},
    };
    for (const auto& c : cases) {
        const auto a = gw::address_of(c.name);
        EXPECT_EQ(a.kind, c.kind) << c.name;
        EXPECT_EQ(std::string_view(c.name).substr(a.key_at, a.key_size), c.key) << c.name;
    }
    EXPECT_EQ(gw::controller_leaf(topic_kind::controller_errors), "errors");
    EXPECT_EQ(gw::controller_leaf(topic_kind::job), "");
    EXPECT_TRUE(gw::carries_document(topic_kind::controller_state));
    EXPECT_TRUE(gw::carries_document(topic_kind::job));
    EXPECT_FALSE(gw::carries_document(topic_kind::controller_reports));
    EXPECT_FALSE(gw::carries_document(topic_kind::controller_position));
    EXPECT_FALSE(gw::carries_document(topic_kind::recording));
    EXPECT_EQ(gw::classify_topic("recordings/r-1"), gw::topic_class::stream);
}

}  // namespace
