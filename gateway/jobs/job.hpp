#pragma once
// A job as the gateway keeps it: what was asked (type, spec), where it runs (controller), where it is
// (state, progress) and why it ended. A plain value; the job_store persists it (but for the live
// progress.waiting_for and progress.eta), the job_manager owns the live copies, job_json.hpp turns it
// into the API's JSON.
//
// States:  queued -> running -> succeeded | failed | cancelled
//                    running <-> paused (pause after the current step; a disconnect also pauses)
//          running | paused -> interrupted (the gateway stopped or died while the job was active)
//          queued -> cancelled;  paused | interrupted -> (resume) -> queued again, from steps_done
// Terminal: succeeded, failed, cancelled. An interrupted job is never restarted by itself: nothing is
// sent twice to a controller after a restart unless a client asks to resume.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace gw::jobs {

enum class job_type : std::uint8_t { array, scan, ring_buffer, planar_correction, gcode };
std::string_view to_string(job_type t);  // "array", "scan", "ring_buffer", "planar_correction", "gcode"
std::optional<job_type> parse_job_type(std::string_view s);

enum class job_state : std::uint8_t { queued, running, paused, succeeded, failed, cancelled, interrupted };
std::string_view to_string(job_state s);
std::optional<job_state> parse_job_state(std::string_view s);
bool is_terminal(job_state s);  // succeeded, failed, cancelled

using job_clock = std::chrono::system_clock;

// What a job waits for that is neither its own motion nor a client's pause (progress.waiting_for).
enum class job_wait : std::uint8_t {
    next,        // a `next` call (advance "next"; a planar correction point taken at the current position)
    ttl,         // a TTL IN0 edge (advance or trigger "ttl")
    timer,       // a planned dwell or delay of at least min_shown_timer (dwell_ms, delay_ms, G04)
    controller,  // its controller: held by another job (queued), or disconnected (paused)
    storage,     // the job store refuses its history (paused until it takes it again)
    halt,        // its controller was halted (HALT): until someone resumes or submits a job there
};
std::string_view to_string(job_wait w);  // "next", "ttl", "timer", "controller", "storage", "halt"
// Every wait but a timer: when it ends cannot be predicted, so neither can the job's end.
bool is_unbounded(job_wait w);

// Shorter dwells are not shown as waits: a page would only see them flicker (and each shown wait is an
// event on the job's topic).
inline constexpr std::chrono::milliseconds min_shown_timer{1000};

struct job_progress {
    std::size_t steps_done = 0;   // steps completed, in plan order; a resume starts at this index
    std::size_t steps_total = 0;  // the plan's step count
    std::string current_step;     // name of the step in progress or last done: "C7", "line 12", "point 2"
    // Seconds the plan still needs: the estimates of the steps not done yet (motion, settle, dwell),
    // without the waits for a trigger (TTL input, a `next` call) that no one can predict. Empty when
    // unknown (a job stored by an older gateway).
    std::optional<double> remaining_s;
    // Live only (the store keeps neither: after a restart no job waits or runs).
    std::optional<job_wait> waiting_for;
    // The expected end: the time remaining_s was estimated plus remaining_s, set at every step, start
    // and end of an unbounded wait. Empty unless running, and while an unbounded wait lasts.
    std::optional<job_clock::time_point> eta;
};

struct job_record {
    std::string id;  // "j-" + 26 characters, sortable by creation time
    std::string controller;
    job_type type = job_type::array;
    nlohmann::json spec;  // as accepted (validated), the source of the plan
    job_state state = job_state::queued;
    job_progress progress;
    double estimated_s = 0;  // whole plan, at submission
    std::string plan_path;   // "firmware" (the controller's module runs it) or "host" (step by step)
    std::optional<std::string> idempotency_key;
    std::string submitted_by;  // principal (token name, or "anonymous")
    std::string request_id;    // of the submission
    std::string reason;        // why it failed / was cancelled / paused / interrupted; empty otherwise
    job_clock::time_point created{};
    std::optional<job_clock::time_point> started;   // first time it ran
    std::optional<job_clock::time_point> finished;  // reached a terminal state
    job_clock::time_point updated{};                // last change of anything above
};

}  // namespace gw::jobs
