#pragma once
// Position recordings (gateway/recordings) without the transport: bodies and queries become recorder
// requests, its answers JSON results or problems.
//
//   POST   /api/v1/controllers/{id}/recordings   operator   {"name", "arm": {"ttl_in_mode"}, "max_frames",
//                                                           "max_s", "metadata"}  201 + Location
//   POST   /api/v1/recordings/{id}/stop          operator   the recording (as it ended)
//   DELETE /api/v1/recordings/{id}               operator   204 (refused while it records)
//   GET    /api/v1/recordings?controller=&state=&since=&until=&limit=   viewer   {"recordings": [...]}
//   GET    /api/v1/recordings/{id}               viewer     the recording
//   GET    /api/v1/recordings/{id}/frames?format=csv|jsonl|hdf5   viewer   its rows, streamed
// A start is refused (409) while the controller is leased to someone else or a job holds it: the
// recording changes the trigger input's mode. No recorder (no storage directory): 503.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "api/calls/call_outcome.hpp"
#include "api/calls/job_requests.hpp"
#include "api/common/api_context.hpp"
#include "api/common/caller.hpp"
#include "api/common/streamed_body.hpp"
#include "gateway/common/operation_error.hpp"
#include "gateway/recordings/frame_text.hpp"
#include "gateway/recordings/recorder.hpp"
#include "gateway/recordings/recording.hpp"
#include "gateway/recordings/recording_store.hpp"

namespace gw::api {

// {"name": "...", "arm": {"ttl_in_mode": 1}, "max_frames": N, "max_s": S, "metadata": {...}}: name is
// required; the rest optional. Unknown fields, wrong types, values out of range: invalid_value naming
// the field.
operation_result<recordings::recording_request> parse_recording_request(const std::string& controller,
                                                                        const nlohmann::json& body);
// GET /api/v1/recordings: controller, state, since and until (milliseconds since the epoch: started at
// or after, before), limit (1..500, default 100).
operation_result<recordings::recording_filter> parse_recording_filter(const query_params& q);
// GET /api/v1/recordings/{id}/frames: format csv (the default), jsonl or hdf5.
operation_result<recordings::frame_format> parse_frame_format(const query_params& q);

// The calls (dispatch_call runs them after the role check).
void start_recording(api_context& ctx, const caller& who, const std::string& controller,
                     const nlohmann::json& body, api_handler done);
void stop_recording(api_context& ctx, const std::string& id, const std::string& request_id, api_handler done);
void delete_recording(api_context& ctx, const std::string& id, const std::string& request_id,
                      api_handler done);

// The reads.
void get_recording(api_context& ctx, const std::string& id, const std::string& request_id, api_handler done);
void list_recordings(api_context& ctx, recordings::recording_filter filter, const std::string& request_id,
                     api_handler done);

// The rows of `record` as stored when it was read (its counters), as text pieces: the CSV header first,
// then a page of rows per piece.
std::shared_ptr<streamed_body> recording_frames_body(api_context& ctx, recordings::recording_record record,
                                                     recordings::frame_format format);
// An export file (hdf5), in pieces; the file is removed when the body is done with (sent or not).
std::shared_ptr<streamed_body> recording_export_body(api_context& ctx, recordings::export_file file);

}  // namespace gw::api
