#pragma once
// The spec of a `gcode` job, parsed strictly (errors name "spec.<field>"), and the names of its plan
// steps. Pure.
//
//   {"program": "G21 G90\nG01 X1 F60\n"}                      the program text, or
//   {"file": "g-01J..."}                                      an uploaded program (gcode_file_store)
//   "options": {"arc_tolerance_mm": 0.0005, "z_mode": "analog"}  gcode_options by their set_option()
//                                                             names; numbers or strings
//
// Steps: one per program line that moves, dwells or switches the TTL/analog output ("line 42"). A
// program with more such lines than max_gcode_steps gets steps of several consecutive lines
// ("lines 41-48"), so that the step list (and the per-step bookkeeping of the job manager) stays
// bounded whatever the program's length.

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "gateway/common/operation_error.hpp"
#include "gateway/gcode/gcode_options.hpp"

namespace gw::jobs {

// Inline programs larger than this must be uploaded and referenced by "file".
inline constexpr std::size_t max_inline_gcode_bytes = std::size_t{4} * 1024 * 1024;
inline constexpr std::size_t max_gcode_steps = 5000;

struct gcode_spec {
    std::optional<std::string> program;  // exactly one of program and file
    std::optional<std::string> file;
    gcode::gcode_options options;
};

operation_result<gcode_spec> parse_gcode_spec(const nlohmann::json& spec);

// "spec.program" or "spec.file": where a program error points.
std::string gcode_source_field(const gcode_spec& spec);

// "line 42" (first == last) or "lines 41-48".
std::string gcode_step_name(int first_line, int last_line);
// The last program line of a step name made by gcode_step_name(); nullopt for any other text.
std::optional<int> gcode_step_last_line(std::string_view name);

}  // namespace gw::jobs
