#pragma once
// The G-code check call (gcode_check_call, api/calls/calls.hpp) and what it shares with the HTTP
// G-code routes (api/http/gcode_requests.hpp): the query of G-code options, the invalid-gcode and
// planner-busy problems.

#include <cstdint>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "api/calls/job_requests.hpp"
#include "api/common/api_context.hpp"
#include "api/common/problem.hpp"
#include "gateway/common/operation_error.hpp"
#include "gateway/gcode/gcode_error.hpp"
#include "gateway/gcode/gcode_options.hpp"
#include "gateway/gcode/gcode_preview_svg.hpp"

namespace gw::api {

class gcode_worker;

// What the query string of a plan or preview asks for.
struct gcode_query {
    gcode::gcode_options options;
    gcode::preview_options preview;
    bool moves = true;  // plan: the move list (false: the summary only)
};
enum class gcode_output : std::uint8_t { plan, preview };

// Pure: the query's options, or invalid_value naming the parameter.
operation_result<gcode_query> parse_gcode_query(const query_params& q, gcode_output output);

// The summary of a stored program's plan, as POST /api/v1/gcode/files/{id}/plan?moves=false answers
// it, on the G-code thread. `options`: an object of G-code option names to strings, numbers or
// booleans (null: none); a bad one is invalid_value naming "options.<name>". `done` gets the outcome
// on its associated executor (default ctx.executor), never inline: unknown_file, invalid_gcode (with
// the line, column and message), planner_busy (503).
void check_stored_program(api_context& ctx, const std::string& file, const nlohmann::json& options,
                          const std::string& request_id, api_handler done);

// 422 invalid-gcode: the problem plus the program error's line, column and message.
problem invalid_gcode_problem(const gcode::gcode_error& e);
// 503 planner-busy: the G-code thread has as many requests waiting as it takes.
problem planner_busy(const gcode_worker& worker);

}  // namespace gw::api
