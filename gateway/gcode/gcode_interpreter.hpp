#pragma once
// The modal state machine of the Tracer G-code subset (FANUC semantics): executes lexed blocks one
// at a time and appends their moves. Pure: no I/O. One per program; not thread-safe.
//
// Initial state: G17, G90, G15, G21, TTL off, no motion mode and no feed (axis words before a
// G00/G01/G02/G03 are an error, so is a feed move before the first F). Order inside a block: units,
// plane, G90/G91, G15/G16 and F apply first; then the analog output (Z in analog mode), then the TTL
// switch (M03/M05), then the dwell or the motion; M02/M30 end the program after the block.

#include <optional>
#include <vector>

#include "gateway/gcode/gcode_analog.hpp"
#include "gateway/gcode/gcode_error.hpp"
#include "gateway/gcode/gcode_lexer.hpp"
#include "gateway/gcode/gcode_move.hpp"
#include "gateway/gcode/gcode_options.hpp"
#include "gateway/gcode/gcode_warnings.hpp"

namespace gw::gcode {

class gcode_interpreter {
  public:
    // `options` must be valid (validate()); it is copied.
    explicit gcode_interpreter(const gcode_options& options);

    // Executes one block: appends 0 to 3 moves to `out`, or returns what is wrong (then nothing is
    // appended and the program must be abandoned).
    std::optional<gcode_error> execute(const gcode_block& block, std::vector<planned_move>& out);

    // End of the program (M02/M30, closing '%' or end of file) at `line`: a TTL still on is switched
    // off by an appended move, with a warning. Idempotent.
    void finish(int line, std::vector<planned_move>& out);

    bool ended() const { return ended_; }  // M02 or M30 executed
    const vec3& position() const { return position_; }
    bool ttl_on() const { return ttl_; }
    const gcode_warnings& warnings() const { return warnings_; }
    gcode_warnings& warnings() { return warnings_; }

  private:
    struct block_codes;
    std::optional<gcode_error> read_codes(const gcode_block& block, block_codes& codes);
    double length(const gcode_word& w);  // mm, after units and scale
    double angle(const gcode_word& w);   // degrees
    double plain_value(const gcode_word& w, double least_increment, const char* unit_name);
    std::optional<gcode_error> motion(const gcode_block& block, const block_codes& codes, int mode,
                                      std::vector<planned_move>& out);
    double feed_mm_s(int line);

    gcode_options options_;
    analog_mapping analog_;
    gcode_warnings warnings_;

    vec3 position_;
    std::optional<int> motion_mode_;  // 0, 1, 2, 3
    arc_plane plane_ = arc_plane::xy;
    bool absolute_ = true;
    bool polar_ = false;
    bool inches_ = false;
    std::optional<double> feed_mm_min_;  // as programmed, converted to mm/min when set
    bool ttl_ = false;
    double analog_z_mm_ = 0;          // analog mode: the programmed Z (mm, not scaled)
    std::optional<double> analog_v_;  // the last voltage set
    int line_ = 0;                    // the line of the block being executed
    bool moved_ = false;
    bool ended_ = false;
    bool finished_ = false;
};

}  // namespace gw::gcode
