#pragma once
// Plans a G-code program from a stream: reads it line by line, interprets it, and hands out the moves
// one at a time with their estimated duration, in bounded memory (a move never holds its segment
// points; see segment_end()). Pure apart from reading the stream; one per program; not thread-safe.
//
//   std::ifstream in(path);
//   gcode_planner planner(in, options);
//   while (const planned_move* m = planner.next()) execute(*m);
//   if (planner.error()) ...            // moves handed out before an error must not be executed:
//                                      // check_program() first when the stream can be read twice
//
// Duration model (the one gw::jobs::motion_model and the `gcode` job use): every straight segment is
// one coordinated move whose axes all arrive together, taking the MS-2000 trapezoid time
// (devices/ms2000/motion_profile) at the segment's vector speed with `ramp_ms`, then `settle_ms`,
// plus the host's overhead per segment (devices/ms2000/host_step_timing: a SPEED and a MOVE over the
// serial line at `host.baud`, and the STATUS polling that notices the stop). Arc segments run at the
// feed along the arc in its plane (FANUC helical feed: the third axis follows), so a helical segment's
// vector speed is F * 3-D length / in-plane length. Dwells last their P; TTL and analog switches take
// one command each. The program is taken to start where its first move starts; the job adds the move
// from wherever the stage is.

#include <cstdint>
#include <istream>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "gateway/gcode/gcode_error.hpp"
#include "gateway/gcode/gcode_interpreter.hpp"
#include "gateway/gcode/gcode_lexer.hpp"
#include "gateway/gcode/gcode_line_reader.hpp"
#include "gateway/gcode/gcode_move.hpp"
#include "gateway/gcode/gcode_options.hpp"

namespace gw::gcode {

struct plan_summary {
    std::uint64_t moves = 0;     // planned moves of every kind
    std::uint64_t segments = 0;  // straight segments after arc segmentation
    double estimated_s = 0;
    vec3 min;  // bounds of the path (the arcs' true extent), the start point (0, 0, 0) included
    vec3 max;
    int lines = 0;  // lines read
    std::vector<std::string> warnings;
};

// Receives the moves of plan_program() in program order.
class move_sink {
  public:
    virtual ~move_sink() = default;
    virtual void on_move(const planned_move& move) = 0;
};

class gcode_planner {
  public:
    gcode_planner(std::istream& in, const gcode_options& options);

    // The next move (valid until the next call), or nullptr at the end of the program or on error.
    const planned_move* next();
    const std::optional<gcode_error>& error() const { return error_; }
    // Totals of the moves handed out so far; complete once next() has returned nullptr.
    plan_summary summary() const;

  private:
    bool read_block();
    void account(planned_move& move);
    void include(const vec3& p);

    gcode_options options_;
    gcode_line_reader reader_;
    gcode_interpreter interpreter_;
    gcode_block block_;
    std::vector<planned_move> pending_;
    std::size_t pending_at_ = 0;
    planned_move current_;
    std::optional<gcode_error> error_;
    bool done_ = false;
    bool percent_open_ = false;
    bool seen_block_ = false;
    plan_summary totals_;
};

// Plans the whole program into `sink`. On error the moves already given to the sink are void.
std::variant<plan_summary, gcode_error> plan_program(std::istream& in, const gcode_options& options,
                                                     move_sink& sink);

// Plans without handing out moves: the summary, or the first error.
std::variant<plan_summary, gcode_error> check_program(std::istream& in, const gcode_options& options);

// The duration of one move under the model above.
double estimate_seconds(const planned_move& move, const gcode_options& options);
// One straight segment of `length_mm` at vector speed `speed_mm_s`: motion, settle and the host's
// overhead (a SPEED before the MOVE when `with_speed`). 0 for a zero length.
double straight_segment_seconds(double length_mm, double speed_mm_s, const gcode_options& options,
                                bool with_speed);

}  // namespace gw::gcode
