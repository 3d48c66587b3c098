#pragma once
// The plan of a job: checked before anything moves, shown by ?dry_run=true, and the step list the
// runner reports progress against. Planning is pure: a spec plus what the gateway knows of the
// controller (plan_context) gives a plan or an operation_error naming the offending field/step.

#include <array>
#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "devices/serial/controller_snapshot.hpp"
#include "gateway/common/operation_error.hpp"
#include "gateway/jobs/job.hpp"
#include "gateway/jobs/motion_model.hpp"

namespace gw::jobs {

// Axis letter -> position in micrometres (the units of the REST API).
using position_um = std::map<char, double>;

struct bounding_box {
    position_um min;
    position_um max;
    void include(const position_um& p);  // grows the box to hold p (per axis)
    bool empty() const { return min.empty(); }
};

struct plan_step {
    std::string name;                   // "C7", "line 12", "point 2", "load"
    std::optional<position_um> target;  // where the stage should be at the end of the step, when known
    double estimated_s = 0;             // motion + settle + dwell; 0 when unknown
    bool waits_for_trigger = false;     // advance on TTL or `next`: its duration is not predictable
};

struct job_plan {
    job_type type = job_type::array;
    std::string path = "host";  // "firmware" or "host"
    std::vector<plan_step> steps;
    // The serial commands the job would send, in order (for the dry run). Long plans keep the first
    // max_preview_commands and say how many were left out.
    std::vector<std::string> commands;
    std::size_t commands_omitted = 0;
    std::string summary;  // one line for humans: "96 wells, serpentine, host-driven, TTL advance"
    double estimated_s = 0;
    bounding_box bounds;
    std::vector<std::string> warnings;
    // spec.record: the run records the report port's frames (a recording of its own, started before
    // it moves and stopped after it ends).
    bool record = false;
};

inline constexpr std::size_t max_preview_commands = 200;

// Adds a command to the preview, or counts it as omitted past max_preview_commands.
void add_preview_command(job_plan& plan, std::string command);

// Seconds the steps from `first` on still need: their motion, settle and dwell estimates. A step that
// waits for a trigger counts without its wait, which no one can predict (waiting_for shows it).
double remaining_from(const job_plan& plan, std::size_t first);

// What planning may use: the controller's latest snapshot (identity and modules, axes, positions,
// soft limits) and its motion parameters.
struct plan_context {
    devices::controller_snapshot snapshot;
    motion_model motion;
    // Uploaded G-code programs (gcode_file_store's directory, <storage.path>/gcode); empty: none.
    std::filesystem::path gcode_files;
};

// invalid_value (422) naming the first step whose target lies outside the controller's soft limits
// (SL/SU in the snapshot, millimetres) or outside +-max_travel_um. `field` is "spec" + the step's
// spec path, `message` names the step ("well H12: X=112500 um is beyond the upper soft limit 110 mm").
operation_result<void> check_soft_limits(const job_plan& plan, const devices::controller_snapshot& s);

}  // namespace gw::jobs
