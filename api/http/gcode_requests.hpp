#pragma once
// The /api/v1/gcode routes: planning and previewing programs without a controller, and the store of
// uploaded programs (gateway/storage/gcode_files.hpp). Planning, previews and uploads run on the gcode_worker
// thread, never on an I/O thread.
//
//   POST   /api/v1/gcode/plan[?moves=false&<option>=<value>...]   viewer    body: the program (text)
//   POST   /api/v1/gcode/preview.svg[?view=XY&<option>=...]        viewer    body: the program
//   GET    /api/v1/gcode/files                                     viewer    {"files":[GcodeFile...]}
//   POST   /api/v1/gcode/files?name=part.ngc                       operator  body: the program; 201
//   GET    /api/v1/gcode/files/{id}                                viewer    GcodeFile
//   DELETE /api/v1/gcode/files/{id}                                operator  204
//   POST   /api/v1/gcode/files/{id}/plan[?...]                     viewer    as /gcode/plan
//   GET    /api/v1/gcode/files/{id}/preview.svg[?...]              viewer    as /gcode/preview.svg
//
// Options are the names of gcode_options (set_option: xyz_scale, speed_scale, arc_tolerance_mm, ...),
// the same as the command line's --set. A program error is 422 invalid-gcode with line, column and
// message; a bad option is 422 invalid-value naming it. The plan JSON is the CLI's; a plan bigger
// than max_plan_response_bytes is refused (422, field "moves": ask for moves=false, the summary).
// Bodies of these POSTs may be as large as gcode.max_file_mb (http_session asks gcode_body_limit).
// A body that is a program (the route_body::program routes: POST plan, preview.svg, files) is never
// held in memory whole: from the header, before the body is read, the route table authorises the
// caller (refusal_from_header, with the browser rules) and admit_gcode_program checks the query and
// takes a planner slot (a refusal is answered at once, also to a client waiting with Expect:
// 100-continue); http_session then streams the body into the store's temporary file and has
// gcode_program_intake::finish plan, preview or store it.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "api/calls/gcode_check.hpp"
#include "api/calls/job_requests.hpp"
#include "api/common/api_context.hpp"
#include "api/common/net.hpp"
#include "api/http/route_table.hpp"
#include "api/http/router.hpp"
#include "gateway/common/operation_error.hpp"
#include "gateway/gcode/gcode_options.hpp"
#include "gateway/gcode/gcode_preview_svg.hpp"

namespace gw::api {

inline constexpr std::size_t max_plan_response_bytes = std::size_t{64} * 1024 * 1024;

// The body limit for a request whose header says `method` and `target`: the routes whose body is a
// program (route_body::program) may carry one up to the store's size cap; nullopt for everything else
// (the normal limit applies).
std::optional<std::uint64_t> gcode_body_limit(const api_context& ctx, http::verb method,
                                              std::string_view target);

// The largest of those limits (0 without a G-code store).
std::uint64_t max_gcode_body_bytes(const api_context& ctx);

// A program request accepted from its header: its planner slot and the upload its body goes to.
class gcode_program_intake {
  public:
    struct state;
    explicit gcode_program_intake(std::unique_ptr<state> s);
    ~gcode_program_intake();
    gcode_program_intake(const gcode_program_intake&) = delete;
    gcode_program_intake& operator=(const gcode_program_intake&) = delete;

    // The next bytes of the body, written to the upload's file: blocking, call it on
    // gcode_worker::post_io. A failure is the response to send instead (storage-unavailable).
    std::optional<string_response> append(std::string_view chunk);
    // Once the whole body is in: plans, previews or stores it on the planner thread, in the slot taken
    // from the header; `done` gets the response on `session_executor`.
    static void finish(std::shared_ptr<gcode_program_intake> self,
                       const net::any_io_executor& session_executor, response_handler done);
    const std::string& route() const;  // for metrics

  private:
    std::unique_ptr<state> s_;
};

struct gcode_program_admission {
    bool applies = false;  // false: not a program request (or no store): read the body as for any route
    std::optional<routed_response> refusal;        // send it without reading the body, then close
    std::shared_ptr<gcode_program_intake> intake;  // accepted: stream the body into it
};

gcode_program_admission admit_gcode_program(const std::shared_ptr<api_context>& ctx,
                                            const http::request<http::empty_body>& header,
                                            const std::string& request_id,
                                            const std::string& client_address = {});

// The /api/v1/gcode routes above, for the route table.
std::vector<route> gcode_routes();

}  // namespace gw::api
