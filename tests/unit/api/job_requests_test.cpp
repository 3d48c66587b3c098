#include "api/calls/job_requests.hpp"

#include <string>
#include <string_view>

#include <gtest/gtest.h>

namespace gw::api {
namespace {

using nlohmann::json;

// ---- query strings ----

TEST(job_query, decodes_pairs_in_order) {
    auto q = parse_query("/api/v1/jobs?controller=sim1&state=running&before=j-01%2DAB&flag");
    ASSERT_TRUE(q.has_value());
    ASSERT_EQ(q->size(), 4u);
    EXPECT_EQ((*q)[0], (std::pair<std::string, std::string>{"controller", "sim1"}));
    EXPECT_EQ((*q)[2].second, "j-01-AB");
    EXPECT_EQ((*q)[3], (std::pair<std::string, std::string>{"flag", ""}));
    EXPECT_EQ(query_value(*q, "state"), "running");
    EXPECT_FALSE(query_value(*q, "type"));
}

TEST(job_query, no_query_string_is_empty) {
    auto q = parse_query("/api/v1/jobs");
    ASSERT_TRUE(q.has_value());
    EXPECT_TRUE(q->empty());
    q = parse_query("/api/v1/jobs?");
    ASSERT_TRUE(q.has_value());
    EXPECT_TRUE(q->empty());
    q = parse_query("/api/v1/jobs?&&limit=2&");
    ASSERT_TRUE(q.has_value());
    EXPECT_EQ(q->size(), 1u);
}

struct bad_query_case {
    std::string_view name;
    std::string_view target;
    std::string_view field;
};

class bad_query : public ::testing::TestWithParam<bad_query_case> {};

TEST_P(bad_query, names_the_parameter) {
    auto q = parse_query(GetParam().target);
    ASSERT_FALSE(q.has_value());
    EXPECT_EQ(q.error().kind, operation_error_kind::invalid_value);
    EXPECT_EQ(q.error().field, GetParam().field);
}

INSTANTIATE_TEST_SUITE_P(all, bad_query,
                         ::testing::Values(bad_query_case{"truncated_escape", "/j?limit=%4", "limit"},
                                           bad_query_case{"escape_at_end", "/j?limit=5%", "limit"},
                                           bad_query_case{"not_hex", "/j?state=%zz", "state"},
                                           bad_query_case{"twice", "/j?limit=1&limit=2", "limit"}),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(job_query, flags) {
    auto q = *parse_query("/j?a=true&b=false&c=1&d=0&e&f=yes");
    EXPECT_EQ(*query_flag(q, "a", false), true);
    EXPECT_EQ(*query_flag(q, "b", true), false);
    EXPECT_EQ(*query_flag(q, "c", false), true);
    EXPECT_EQ(*query_flag(q, "d", true), false);
    EXPECT_EQ(*query_flag(q, "e", false), true);
    EXPECT_EQ(*query_flag(q, "absent", true), true);
    auto bad = query_flag(q, "f", false);
    ASSERT_FALSE(bad.has_value());
    EXPECT_EQ(bad.error().field, "f");
}

// ---- GET /api/v1/jobs filters ----

TEST(job_filter, defaults) {
    auto f = parse_job_filter({});
    ASSERT_TRUE(f.has_value());
    EXPECT_EQ(f->limit, 50u);
    EXPECT_FALSE(f->controller || f->type || f->state || f->before);
}

TEST(job_filter, every_parameter) {
    auto f = parse_job_filter(
        *parse_query("/j?controller=sim2&type=ring_buffer&state=interrupted&limit=500&before=j-01ABC"));
    ASSERT_TRUE(f.has_value()) << f.error().message;
    EXPECT_EQ(f->controller, "sim2");
    EXPECT_EQ(f->type, jobs::job_type::ring_buffer);
    EXPECT_EQ(f->state, jobs::job_state::interrupted);
    EXPECT_EQ(f->limit, 500u);
    EXPECT_EQ(f->before, "j-01ABC");
}

struct bad_filter_case {
    std::string_view name;
    std::string_view target;
    std::string_view field;
};

class bad_filter : public ::testing::TestWithParam<bad_filter_case> {};

TEST_P(bad_filter, is_422_naming_the_parameter) {
    auto q = parse_query(GetParam().target);
    ASSERT_TRUE(q.has_value());
    auto f = parse_job_filter(*q);
    ASSERT_FALSE(f.has_value()) << GetParam().target;
    EXPECT_EQ(f.error().kind, operation_error_kind::invalid_value);
    EXPECT_EQ(f.error().field, GetParam().field);
    EXPECT_FALSE(f.error().message.empty());
}

INSTANTIATE_TEST_SUITE_P(all, bad_filter,
                         ::testing::Values(bad_filter_case{"unknown_parameter", "/j?page=2", "page"},
                                           bad_filter_case{"limit_zero", "/j?limit=0", "limit"},
                                           bad_filter_case{"limit_too_big", "/j?limit=501", "limit"},
                                           bad_filter_case{"limit_negative", "/j?limit=-1", "limit"},
                                           bad_filter_case{"limit_text", "/j?limit=ten", "limit"},
                                           bad_filter_case{"limit_trailing", "/j?limit=5x", "limit"},
                                           bad_filter_case{"limit_empty", "/j?limit=", "limit"},
                                           bad_filter_case{"type_unknown", "/j?type=tour", "type"},
                                           bad_filter_case{"state_unknown", "/j?state=done", "state"},
                                           bad_filter_case{"state_case", "/j?state=Running", "state"},
                                           bad_filter_case{"before_not_an_id", "/j?before=a%20b", "before"},
                                           bad_filter_case{"controller_empty",
                                                           "/j?controller=", "controller"}),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(job_events_limit, default_range_and_errors) {
    EXPECT_EQ(*parse_event_limit({}), default_event_limit);
    EXPECT_EQ(*parse_event_limit(*parse_query("/e?limit=10000")), 10000u);
    EXPECT_EQ(parse_event_limit(*parse_query("/e?limit=10001")).error().field, "limit");
    EXPECT_EQ(parse_event_limit(*parse_query("/e?limit=0")).error().field, "limit");
    EXPECT_EQ(parse_event_limit(*parse_query("/e?since=3")).error().field, "since");
}

// ---- POST /api/v1/jobs bodies ----

TEST(job_submission, accepts_the_three_fields) {
    auto s = parse_job_submission(json::parse(R"({"controller":"sim1","type":"scan","spec":{"fast":{}}})"));
    ASSERT_TRUE(s.has_value()) << s.error().message;
    EXPECT_EQ(s->controller, "sim1");
    EXPECT_EQ(s->type, jobs::job_type::scan);
    EXPECT_EQ(s->spec, json::parse(R"({"fast":{}})"));
}

TEST(job_submission, every_type_name) {
    for (auto [name, type] :
         {std::pair{"array", jobs::job_type::array}, std::pair{"scan", jobs::job_type::scan},
          std::pair{"ring_buffer", jobs::job_type::ring_buffer},
          std::pair{"planar_correction", jobs::job_type::planar_correction}}) {
        auto s = parse_job_submission({{"controller", "c"}, {"type", name}, {"spec", json::object()}});
        ASSERT_TRUE(s.has_value()) << name;
        EXPECT_EQ(s->type, type);
    }
}

struct bad_body_case {
    std::string_view name;
    std::string body;
    std::string_view field;
};

class bad_body : public ::testing::TestWithParam<bad_body_case> {};

TEST_P(bad_body, is_422_naming_the_field) {
    auto s = parse_job_submission(json::parse(GetParam().body));
    ASSERT_FALSE(s.has_value()) << GetParam().body;
    EXPECT_EQ(s.error().kind, operation_error_kind::invalid_value);
    EXPECT_EQ(s.error().field, GetParam().field);
    EXPECT_FALSE(s.error().message.empty());
}

INSTANTIATE_TEST_SUITE_P(
    all, bad_body,
    ::testing::Values(
        bad_body_case{"null_is_empty", "null", "controller"}, bad_body_case{"empty", "{}", "controller"},
        bad_body_case{"array", "[1]", ""},
        bad_body_case{"unknown_field", R"({"controller":"sim1","type":"scan","spec":{},"priority":1})",
                      "priority"},
        bad_body_case{"controller_number", R"({"controller":1,"type":"scan","spec":{}})", "controller"},
        bad_body_case{"controller_empty", R"({"controller":"","type":"scan","spec":{}})", "controller"},
        bad_body_case{"type_missing", R"({"controller":"sim1","spec":{}})", "type"},
        bad_body_case{"type_unknown", R"({"controller":"sim1","type":"tour","spec":{}})", "type"},
        bad_body_case{"type_number", R"({"controller":"sim1","type":3,"spec":{}})", "type"},
        bad_body_case{"spec_missing", R"({"controller":"sim1","type":"scan"})", "spec"},
        bad_body_case{"spec_array", R"({"controller":"sim1","type":"scan","spec":[]})", "spec"},
        bad_body_case{"spec_string", R"({"controller":"sim1","type":"scan","spec":"x"})", "spec"}),
    [](const auto& info) { return std::string(info.param.name); });

// ---- small grammars ----

TEST(job_keys, idempotency_and_lease_keys) {
    EXPECT_TRUE(is_valid_key("plate-7"));
    EXPECT_TRUE(is_valid_key(std::string(128, 'k')));
    EXPECT_FALSE(is_valid_key(""));
    EXPECT_FALSE(is_valid_key(std::string(129, 'k')));
    EXPECT_FALSE(is_valid_key("a b"));
    EXPECT_FALSE(is_valid_key("a\tb"));
    EXPECT_FALSE(is_valid_key("\xc3\xa9"));
}

TEST(job_commands, names_round_trip) {
    for (std::string_view n : {"cancel", "pause", "resume", "next"}) {
        auto c = parse_job_command(n);
        ASSERT_TRUE(c) << n;
        EXPECT_EQ(to_string(*c), n);
    }
    EXPECT_FALSE(parse_job_command("events"));
    EXPECT_FALSE(parse_job_command("Cancel"));
}

TEST(job_ids, plausible_path_segments) {
    EXPECT_TRUE(is_plausible_job_id("j-01JD3Q5W8Z0000000000000000"));
    EXPECT_FALSE(is_plausible_job_id(""));
    EXPECT_FALSE(is_plausible_job_id("j.1"));
    EXPECT_FALSE(is_plausible_job_id(std::string(65, 'j')));
}

// ---- without a job manager ----

TEST(job_outcome, failed_carries_the_status_and_request_id) {
    auto o = failed(make_error(operation_error_kind::unknown_job, "no job \"j-1\""), "rid-9");
    ASSERT_TRUE(o.error);
    EXPECT_EQ(o.status, 404u);
    EXPECT_EQ(o.error->kind, "unknown_job");
    EXPECT_EQ(o.error->request_id, "rid-9");
    EXPECT_EQ(o.error->type(), "https://asi-gateway.dev/problems/unknown-job");
}

}  // namespace
}  // namespace gw::api
