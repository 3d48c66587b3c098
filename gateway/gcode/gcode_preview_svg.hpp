#pragma once
// A picture of a planned program, like the Tracer Console's graph pane: the path projected on one
// plane (XY by default, +Y up), feed moves solid, rapid moves dashed, stretches with the TTL output on
// in their own colour. Pure: reads a std::istream, writes SVG text to a std::ostream.
//
//   <svg xmlns=... width="800" height="412" viewBox="0 0 800 412">
//     <desc>moves 1204, segments 9300, drawn points 2411 (every 1st), estimated 93.2 s</desc>
//     <style>.feed{...} .rapid{...stroke-dasharray...} .ttl{...}</style>
//     <path class="rapid" d="M10 402L10 10"/><path class="ttl" d="M10 10L790 10..."/> ...
//   </svg>
//
// Bounded output whatever the program's size: coordinates are pixels (2 decimals); arcs are drawn
// with their own chord tolerance (half a pixel), not the machine's; points closer than half a pixel to
// the last drawn one are dropped; and when the plan has more straight segments than `max_points`,
// only every n-th point of a run is drawn (runs keep their ends, so style changes stay exact). A hard
// cap of 2 * max_points stops drawing (the <desc> says "truncated").

#include <cstddef>
#include <istream>
#include <optional>
#include <ostream>
#include <string>

#include "gateway/gcode/gcode_error.hpp"
#include "gateway/gcode/gcode_geometry.hpp"
#include "gateway/gcode/gcode_options.hpp"
#include "gateway/gcode/gcode_planner.hpp"

namespace gw::gcode {

struct preview_options {
    arc_plane view = arc_plane::xy;  // xy: X right, Y up; zx: Z right, X up; yz: Y right, Z up
    double width_px = 800;           // the longer side of the drawing, margins included
    std::size_t max_points = 100'000;
};

// Sets one preview option from text: "view" (XY|ZX|YZ), "width_px" (50..10000), "max_points"
// (100..1000000). `known` is false for other names (they may be gcode_options names); `error` says
// what is wrong with the value.
struct preview_option_result {
    bool known = false;
    std::optional<std::string> error;
};
preview_option_result set_preview_option(preview_options& options, const std::string& name,
                                         const std::string& value);

// Draws the moves it receives; needs the plan's summary (bounds, segment count) up front, so a program
// is planned twice (write_preview_svg does that).
class preview_svg_writer final : public move_sink {
  public:
    preview_svg_writer(std::ostream& out, const plan_summary& summary, const preview_options& options);
    void on_move(const planned_move& move) override;
    void finish();

    std::size_t points_drawn() const { return points_; }
    bool truncated() const { return truncated_; }

  private:
    enum class style : std::uint8_t { none, feed, rapid, ttl };
    struct pixel {
        double x = 0;
        double y = 0;
    };
    pixel to_pixel(const vec3& p) const;
    void draw_to(const vec3& p, style s);
    void close_path();
    void write_point(char command, const pixel& p);

    std::ostream& out_;
    preview_options options_;
    plan_summary summary_;
    double scale_ = 1;     // pixels per mm
    double origin_h_ = 0;  // the bounds' minimum of the horizontal axis (mm)
    double top_v_ = 0;     // the bounds' maximum of the vertical axis (mm)
    double margin_px_ = 10;
    double min_step_px_ = 0.5;
    std::uint64_t stride_ = 1;
    std::uint64_t since_drawn_ = 0;
    std::size_t points_ = 0;
    std::size_t path_points_ = 0;
    bool truncated_ = false;
    bool ttl_on_ = false;
    style current_ = style::none;
    pixel last_;
    pixel pending_;  // the last point of the run not drawn yet (decimated)
    bool has_pending_ = false;
};

// Plans `in` (twice: it must seek, as a file or a string stream does) and writes the SVG; the error
// when the program (or the options) are wrong, and then nothing is written.
std::optional<gcode_error> write_preview_svg(std::istream& in, const gcode_options& options,
                                             const preview_options& view, std::ostream& out);

}  // namespace gw::gcode
