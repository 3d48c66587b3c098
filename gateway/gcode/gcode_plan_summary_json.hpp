#pragma once
// The plan without its moves, for programs whose move list would be too big to send ("moves=false"
// over HTTP, --summary on the command line):
//   {"units":"mm","move_count":N,"lines":L,"segments":S,"estimated_s":T,
//    "bounds":{"min":[x,y,z],"max":[x,y,z]},"warnings":[...]}
// Same numbers and formatting as write_plan_json (gcode_plan_json.hpp).

#include <istream>
#include <ostream>

#include "gateway/gcode/gcode_options.hpp"
#include "gateway/gcode/gcode_planner.hpp"

namespace gw::gcode {

void write_plan_summary_json(std::ostream& out, const plan_summary& summary);

// Plans `in` once (no moves kept) and writes the summary or the error document; false on error.
bool write_plan_summary_json(std::istream& in, const gcode_options& options, std::ostream& out);

}  // namespace gw::gcode
