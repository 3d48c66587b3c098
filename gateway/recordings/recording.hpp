#pragma once
// A recording: the encoder positions a controller reports on its report port (the TTL_REPORT module
// latches every axis at each trigger edge on IN0), one frame per trigger, counted from 0 and stored.
// Where frames were lost, a marker says so, so that frame N is provably the N-th frame received since
// the start or provably after an unknown loss. Pure.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace gw::recordings {

enum class recording_state : std::uint8_t {
    recording,
    stopped,  // by a client, or a limit (max_frames, max_s) was reached
    failed,   // the store refused its frames, or the trigger input could not be armed or put back
};
std::string_view to_string(recording_state s);
std::optional<recording_state> parse_recording_state(std::string_view text);

// What a client asks for (POST /api/v1/controllers/{id}/recordings).
struct recording_request {
    std::string controller;
    std::string name;
    int ttl_in_mode = 1;  // TTL X=<mode> while it records: any non-zero mode triggers a report
    // false: the caller has set the trigger input (a job's run, which puts it back itself): the
    // recording neither sets it nor puts it back.
    bool arm = true;
    std::optional<std::uint64_t> max_frames;  // stops after this many frames
    std::optional<double> max_s;              // stops after this long
    nlohmann::json metadata = nlohmann::json::object();
    std::optional<std::string> job;  // the job whose run records (spec.record)
};

struct recording_record {
    std::string id;  // "r-..."
    std::string controller;
    std::string name;
    recording_state state = recording_state::recording;
    std::string reason;  // why it stopped or failed
    std::int64_t started_ms = 0;
    std::optional<std::int64_t> stopped_ms;
    std::uint64_t frames = 0;  // frames stored
    std::uint64_t losses = 0;  // markers stored: places where frames were lost
    std::string axes;          // the axes of its frames, in frame order ("XYZ"); empty before the first
    int ttl_in_mode = 1;
    std::optional<int> previous_in_mode;  // the IN0 mode put back when it ends
    std::optional<std::uint64_t> max_frames;
    std::optional<double> max_s;
    nlohmann::json metadata = nlohmann::json::object();
    std::optional<std::string> job;  // the job whose run made it
};

// Why frames are missing before a marker.
enum class loss_kind : std::uint8_t {
    none,          // a frame, not a marker
    garbled,       // bytes on the report port that fit no frame (a frame damaged or cut)
    disconnected,  // the controller (or its report port) was away: triggers meanwhile are unknown
    // The controller reported a trigger that came faster than it could send (error 87): one marker per
    // trigger. The error log is read at the poll after, so the marker's index is where the gateway
    // learned of it, at or after the place of the loss.
    overrun,
};
std::string_view to_string(loss_kind k);

// One row of a recording: a frame, or a marker of a loss before the frame of the same index.
struct recorded_frame {
    std::uint64_t index = 0;   // frames received before this one since the start (markers count none)
    std::int64_t time_us = 0;  // the gateway's receive time, microseconds since the epoch
    loss_kind loss = loss_kind::none;
    std::vector<std::int32_t> counts;       // per axis of the recording's `axes`, as the controller sent
    std::vector<std::optional<double>> um;  // counts as micrometres, where the axis's CNTS is known
};

nlohmann::json to_json(const recording_record& r);

}  // namespace gw::recordings
