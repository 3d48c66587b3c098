#pragma once
// The /api/v1/jobs routes without the transport: query strings and bodies become job_manager
// requests, its answers become JSON results or problems. REST (router.cpp) and the WebSocket
// ({"op":"job", ...}) both call these, so validation, roles, leases and shapes are the same.
//
//   POST /api/v1/jobs[?dry_run=true]   operator   {"controller","type","spec"} (strict top level; the
//                                                 spec is the job type's to validate)
//        201 job + Location | 200 job + Idempotency-Replayed: true | 200 dry run {"dry_run":true,...}
//   GET  /api/v1/jobs?controller=&type=&state=&limit=&before=   viewer   {"jobs":[...],"next":id|null}
//   GET  /api/v1/jobs/{id}                    viewer   the job
//   GET  /api/v1/jobs/{id}/events?limit=      viewer   {"events":[...]} (stored, oldest first)
//   POST /api/v1/jobs/{id}/{cancel|pause|resume|next}   operator   the job
// Headers: Idempotency-Key (submission), Lease-Id (submission and control). No job manager
// (ctx.jobs null): 503 storage_unavailable. Shapes: openapi/openapi.yaml, gateway/jobs/job_json.hpp.

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <boost/asio/any_completion_handler.hpp>
#include <nlohmann/json.hpp>

#include "api/calls/call_outcome.hpp"
#include "api/common/api_context.hpp"
#include "api/common/problem.hpp"
#include "gateway/common/operation_error.hpp"
#include "gateway/jobs/job.hpp"
#include "gateway/jobs/manager/job_manager.hpp"

namespace gw::api {

// ---- pure parsing ----

// Decoded "name=value" pairs of a target's query string, in order ("/p?a=1&b=%2F" -> a=1, b=/).
// A parameter without '=' has an empty value; '+' stays '+'. A malformed escape or a parameter given
// twice is invalid_value naming it.
using query_params = std::vector<std::pair<std::string, std::string>>;
operation_result<query_params> parse_query(std::string_view target);

// invalid_value naming the first parameter not in `known` ("(this route takes none)" when empty).
operation_result<void> check_known_parameters(const query_params& q,
                                              std::initializer_list<std::string_view> known);

// The value of a parameter, if given.
std::optional<std::string> query_value(const query_params& q, std::string_view name);
// A decimal count ("25"): digits only; nullopt otherwise.
std::optional<std::size_t> parse_count(std::string_view s);

// "true"/"1"/"" (present without value) -> true, "false"/"0" -> false, absent -> `fallback`.
operation_result<bool> query_flag(const query_params& q, std::string_view name, bool fallback);

// GET /api/v1/jobs parameters: controller, type (job type name), state (job state name), limit
// (1..500, default 50), before (a job id). Anything else, or a bad value: invalid_value naming it.
operation_result<jobs::job_filter> parse_job_filter(const query_params& q);

inline constexpr std::size_t default_event_limit = 1000;
inline constexpr std::size_t max_event_limit = 10000;
// GET /api/v1/jobs/{id}/events?limit= (1..max_event_limit, default default_event_limit).
operation_result<std::size_t> parse_event_limit(const query_params& q);

struct job_submission {
    std::string controller;
    jobs::job_type type = jobs::job_type::array;
    nlohmann::json spec;
};

// {"controller": "<id>", "type": "array"|"scan"|"ring_buffer"|"planar_correction"|"gcode", "spec": {...}}.
// Unknown top-level fields, wrong types, a missing field: invalid_value naming it. "spec" must be an
// object; its content is the job type's to validate (when planning).
operation_result<job_submission> parse_job_submission(const nlohmann::json& body);

// Idempotency-Key / Lease-Id header values: 1..128 printable ASCII characters without spaces.
inline constexpr std::size_t max_key_bytes = 128;
bool is_valid_key(std::string_view key);

enum class job_command : std::uint8_t { cancel, pause, resume, next };
std::optional<job_command> parse_job_command(std::string_view name);
std::string_view to_string(job_command c);

// A job id as it may appear in a path: 1..64 characters of [A-Za-z0-9_-].
bool is_plausible_job_id(std::string_view id);

// ---- against the job manager ----

struct submit_options {
    bool dry_run = false;
    std::optional<std::string> idempotency_key;
    std::optional<std::string> lease_id;
    std::string principal = "anonymous";
    std::string request_id;
};

// Parses `body` (null counts as {}), submits, calls `handler` once on its associated executor
// (default ctx.executor), never inline. 201 + location; 200 + replayed; 200 dry-run body.
void submit_job(api_context& ctx, const nlohmann::json& body, submit_options options, api_handler handler);

// cancel / pause / resume / next: 200 with the job. The same calling rules as submit_job.
void control_job(api_context& ctx, job_command command, jobs::job_action action, api_handler handler);

// The reads of the job history (the store is read off the I/O thread). The same calling rules as
// submit_job.
void get_job(api_context& ctx, std::string id, const std::string& request_id, api_handler handler);
void list_jobs(api_context& ctx, jobs::job_filter filter, const std::string& request_id, api_handler handler);
void job_events(api_context& ctx, std::string id, std::size_t limit, const std::string& request_id,
                api_handler handler);

}  // namespace gw::api
