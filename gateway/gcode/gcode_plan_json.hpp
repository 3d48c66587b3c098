#pragma once
// The plan as JSON, written move by move so a program of millions of lines needs bounded memory:
//   {"units":"mm","moves":[{"line":N,"kind":"rapid|linear|arc|dwell|ttl|analog","end":[x,y,z],
//     "center":[x,y,z],"plane":"XY|ZX|YZ","direction":"cw|ccw","feed_mm_s":F,"dwell_ms":D,
//     "ttl":"on|off","analog_v":V}, ...],
//    "segments":S,"estimated_s":T,"bounds":{"min":[..],"max":[..]},"warnings":[...]}
// Each move carries only its kind's fields: rapid/linear: end, feed_mm_s; arc: end, center, plane,
// direction, feed_mm_s (before segmentation); dwell: dwell_ms; ttl: ttl; analog: analog_v.
// Errors: {"error":{"line":N,"column":C,"message":"..."}}.
// Numbers: at most 6 decimals (1 nm, 1 us), trailing zeros dropped.

#include <istream>
#include <ostream>

#include "gateway/gcode/gcode_error.hpp"
#include "gateway/gcode/gcode_move.hpp"
#include "gateway/gcode/gcode_options.hpp"
#include "gateway/gcode/gcode_planner.hpp"

namespace gw::gcode {

// A move_sink that writes the JSON document: construct (writes the head), feed moves, then finish().
class plan_json_writer final : public move_sink {
  public:
    explicit plan_json_writer(std::ostream& out);
    void on_move(const planned_move& move) override;
    void finish(const plan_summary& summary);

  private:
    std::ostream& out_;
    bool first_ = true;
};

void write_error_json(std::ostream& out, const gcode_error& error);

// Plans `in` and writes the plan (or the error) to `out`. The program is checked first, so an
// erroneous program writes only the error: this needs a stream that can seek back to its start
// (a file or a string); other streams are planned once and must be error-free (on a late error
// the document written so far is incomplete). Returns false on error.
bool write_plan_json(std::istream& in, const gcode_options& options, std::ostream& out);

// A JSON string literal (quotes included).
std::string json_string(std::string_view text);
// A JSON number as the plan writes it ("12.5", "0", "-0.001").
std::string json_number(double value);
// `value` with at most `decimals` decimals, trailing zeros dropped, never "-0" (json_number uses 6).
std::string trimmed_fixed(double value, int decimals);

}  // namespace gw::gcode
