#pragma once
// The job types: for each, a pure planner (spec JSON -> plan, or a 422 naming the field) and a run()
// coroutine that executes the plan through a job_context. The manager dispatches on job_type.
//
// Spec validation is strict: unknown fields, wrong types and out-of-range values are invalid_value
// errors whose `field` is the JSON path inside the spec ("spec.wells[3]", "spec.dwell_ms").

#include <boost/asio/awaitable.hpp>
#include <nlohmann/json.hpp>

#include "gateway/common/operation_error.hpp"
#include "gateway/jobs/job_context.hpp"
#include "gateway/jobs/job_plan.hpp"

namespace gw::jobs {

// array_job.cpp: plate presets or explicit grids, firmware ARRAY module or host-driven MOVEs.
operation_result<job_plan> plan_array(const nlohmann::json& spec, const plan_context& ctx);
boost::asio::awaitable<void> run_array(job_context& ctx);

// scan_job.cpp: SCAN module raster/serpentine (SCANR/SCANV/SCAN), host-driven fallback.
operation_result<job_plan> plan_scan(const nlohmann::json& spec, const plan_context& ctx);
boost::asio::awaitable<void> run_scan(job_context& ctx);

// ring_buffer_job.cpp: LOAD + RBMODE tours, TTL-triggered or autoplay.
operation_result<job_plan> plan_ring_buffer(const nlohmann::json& spec, const plan_context& ctx);
boost::asio::awaitable<void> run_ring_buffer(job_context& ctx);

// planar_correction_job.cpp: CCB three points, enable/disable/clear.
operation_result<job_plan> plan_planar_correction(const nlohmann::json& spec, const plan_context& ctx);
boost::asio::awaitable<void> run_planar_correction(job_context& ctx);

// gcode_job.cpp: a G-code program traced as coordinated straight segments, TTL/analog switches between
// them.
operation_result<job_plan> plan_gcode(const nlohmann::json& spec, const plan_context& ctx);
boost::asio::awaitable<void> run_gcode(job_context& ctx);

// Dispatch on the type.
operation_result<job_plan> plan_job(job_type type, const nlohmann::json& spec, const plan_context& ctx);
boost::asio::awaitable<void> run_job(job_context& ctx);

}  // namespace gw::jobs
