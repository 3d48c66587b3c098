#include "api/common/problem.hpp"

#include <iterator>

#include <gtest/gtest.h>

namespace gw::api {
namespace {

struct kind_case {
    operation_error_kind kind;
    unsigned status;
    const char* type;
};

TEST(problem, every_operation_error_kind_has_its_status_and_type) {
    const kind_case cases[] = {
        {operation_error_kind::unknown_controller, 404,
         "https://asi-gateway.dev/problems/unknown-controller"},
        {operation_error_kind::invalid_value, 422, "https://asi-gateway.dev/problems/invalid-value"},
        {operation_error_kind::missing_module, 409, "https://asi-gateway.dev/problems/missing-module"},
        {operation_error_kind::busy, 409, "https://asi-gateway.dev/problems/busy"},
        {operation_error_kind::leased, 409, "https://asi-gateway.dev/problems/leased"},
        {operation_error_kind::not_connected, 503, "https://asi-gateway.dev/problems/not-connected"},
        {operation_error_kind::timeout, 504, "https://asi-gateway.dev/problems/timeout"},
        {operation_error_kind::controller_error, 502, "https://asi-gateway.dev/problems/controller-error"},
        {operation_error_kind::queue_full, 503, "https://asi-gateway.dev/problems/queue-full"},
        {operation_error_kind::unknown_job, 404, "https://asi-gateway.dev/problems/unknown-job"},
        {operation_error_kind::invalid_state, 409, "https://asi-gateway.dev/problems/invalid-state"},
        {operation_error_kind::storage_unavailable, 503,
         "https://asi-gateway.dev/problems/storage-unavailable"},
        {operation_error_kind::unknown_file, 404, "https://asi-gateway.dev/problems/unknown-file"},
        {operation_error_kind::halted, 409, "https://asi-gateway.dev/problems/halted"},
        {operation_error_kind::job_active, 409, "https://asi-gateway.dev/problems/job-active"},
        {operation_error_kind::unknown_recording, 404, "https://asi-gateway.dev/problems/unknown-recording"},
        {operation_error_kind::stale_command, 408, "https://asi-gateway.dev/problems/stale-command"},
        {operation_error_kind::internal, 500, "https://asi-gateway.dev/problems/internal"},
    };
    // internal is the last kind: a kind added without a row here fails this.
    EXPECT_EQ(std::size(cases), static_cast<std::size_t>(operation_error_kind::internal) + 1);
    for (const auto& c : cases) {
        auto p = make_problem(make_error(c.kind, "why"));
        EXPECT_EQ(p.status, c.status) << to_string(c.kind);
        EXPECT_EQ(p.type(), c.type);
        EXPECT_EQ(p.detail, "why");
        EXPECT_FALSE(p.title.empty());
    }
}

struct http_case {
    http_error error;
    unsigned status;
    const char* type;
};

TEST(problem, every_http_error_has_its_status_and_type) {
    const http_case cases[] = {
        {http_error::malformed_json, 400, "https://asi-gateway.dev/problems/malformed-json"},
        {http_error::bad_request, 400, "https://asi-gateway.dev/problems/bad-request"},
        {http_error::unauthorized, 401, "https://asi-gateway.dev/problems/unauthorized"},
        {http_error::forbidden, 403, "https://asi-gateway.dev/problems/forbidden"},
        {http_error::not_found, 404, "https://asi-gateway.dev/problems/not-found"},
        {http_error::method_not_allowed, 405, "https://asi-gateway.dev/problems/method-not-allowed"},
        {http_error::payload_too_large, 413, "https://asi-gateway.dev/problems/payload-too-large"},
        {http_error::header_too_large, 431, "https://asi-gateway.dev/problems/header-too-large"},
        {http_error::not_implemented, 501, "https://asi-gateway.dev/problems/not-implemented"},
        {http_error::too_many_connections, 503, "https://asi-gateway.dev/problems/too-many-connections"},
        {http_error::body_budget_exhausted, 503, "https://asi-gateway.dev/problems/body-budget-exhausted"},
        {http_error::cross_origin, 403, "https://asi-gateway.dev/problems/cross-origin"},
        {http_error::unsupported_media_type, 415, "https://asi-gateway.dev/problems/unsupported-media-type"},
        {http_error::misdirected_request, 421, "https://asi-gateway.dev/problems/misdirected-request"},
    };
    for (const auto& c : cases) {
        auto p = make_problem(c.error, "d");
        EXPECT_EQ(p.status, c.status) << to_string(c.error);
        EXPECT_EQ(p.type(), c.type);
        EXPECT_EQ(p.retry_after_s, c.status == 503 ? 1u : 0u) << to_string(c.error);  // 503s pass soon
    }
}

TEST(problem, json_has_rfc9457_members_and_extensions_only_when_set) {
    auto p = make_problem(make_error(operation_error_kind::invalid_value, "X out of range", "axes.X"));
    p.instance = "/api/v1/controllers/sim1/move";
    p.request_id = "r1";
    auto j = p.to_json();
    EXPECT_EQ(j["type"], "https://asi-gateway.dev/problems/invalid-value");
    EXPECT_EQ(j["status"], 422);
    EXPECT_EQ(j["title"], "Invalid value");
    EXPECT_EQ(j["detail"], "X out of range");
    EXPECT_EQ(j["instance"], "/api/v1/controllers/sim1/move");
    EXPECT_EQ(j["request_id"], "r1");
    EXPECT_EQ(j["field"], "axes.X");
    EXPECT_FALSE(j.contains("controller_code"));

    operation_error e = make_error(operation_error_kind::controller_error, "answered :N-4");
    e.controller_code = -4;
    e.controller_code_name = "parameter_out_of_range";
    auto k = make_problem(e).to_json();
    EXPECT_EQ(k["controller_code"], -4);
    EXPECT_EQ(k["controller_code_name"], "parameter_out_of_range");
    EXPECT_FALSE(k.contains("field"));
    EXPECT_FALSE(k.contains("instance"));
}

}  // namespace
}  // namespace gw::api
